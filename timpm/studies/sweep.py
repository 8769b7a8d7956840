"""Sweeps of independent runs: in this process, in worker processes on this machine, or on
a Dask cluster; the results come back in the order of the runs, equal to a serial sweep's.

:func:`map_runs` calls ``task(*args)`` for each ``args`` of a list.  With ``workers=N``
the calls go to a pool of N processes started with the "spawn" method (a forked child of
a process running Taichi would hang: :mod:`timpm.platform.runtime`); with ``dask=ADDRESS`` to the
workers of a ``dask.distributed`` scheduler, or with ``dask="local"`` to a LocalCluster on
this machine, one single-threaded worker process per core.

Each worker process starts Taichi itself with the settings of this one
(:func:`timpm.platform.runtime.settings`: the same worker-thread count, precision, arch), so a
run's ``mode="auto"`` and its scatter resolve there as here and the run computes the same
numbers: serial (fused) runs are bit-reproducible on any thread count, and a parallel
run's particle state depends only on the thread count, which is the same (its recorded
energies, summed with atomic adds, vary in the last digits from run to run, serially too).  Tasks and their results
are plain data (NumPy scalars and arrays come back as Python numbers and lists); no Taichi
object crosses processes.  A task's own error (a ``ValueError`` or ``SimulationError`` of
a run) is raised here as it would be in a serial sweep, for the first failing run in
order; a worker that dies, a missing dask or an unreachable scheduler raise
:class:`SweepError`.
"""
from __future__ import annotations

import contextlib
import numbers
import os
import pickle
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..platform.argtypes import positive_int

__all__ = ["SweepError", "SweepInterrupted", "interruptible", "check_executor", "map_runs",
           "WORKER_ENV", "environment", "stop_workers", "die_with_parent",
           "add_arguments", "CONNECT_TIMEOUT", "DASK_INSTALL"]

#: seconds to wait for a Dask scheduler to answer, and for its first worker
CONNECT_TIMEOUT = 5.0
DASK_INSTALL = "pip install 'timpm[dask]'"
#: environment of the worker processes: no Taichi banner between the tables on stdout
WORKER_ENV = {"ENABLE_TAICHI_HEADER_PRINT": "false"}


class SweepError(RuntimeError):
    """The worker processes or the Dask cluster could not run the sweep (not a run's own
    error, which is raised as it is)."""


class SweepInterrupted(Exception):
    """Ctrl-C, SIGTERM or SIGHUP stopped a sweep: ``partial`` is its record of the runs
    that had finished (marked ``"interrupted": true``), ``done`` and ``planned`` count
    them."""

    def __init__(self, partial: dict, done: int, planned: int):
        super().__init__(f"interrupted after {done} of {planned} runs")
        self.partial, self.done, self.planned = partial, done, planned


@contextlib.contextmanager
def interruptible(partial, planned: int):
    """Turn an interruption of the sweep in the block (``KeyboardInterrupt``, or a run's
    own :class:`~timpm.platform.interrupt.RunInterrupted`) into :class:`SweepInterrupted`
    carrying ``partial()``, the record of the runs done so far, and how many they are
    (its ``"runs"``)."""
    from ..platform.interrupt import RunInterrupted

    try:
        yield
    except (KeyboardInterrupt, RunInterrupted) as stop:
        doc = partial()
        doc["interrupted"] = True
        raise SweepInterrupted(doc, len(doc.get("runs", ())), planned) from stop


def check_executor(workers=None, dask=None) -> None:
    """Raise ValueError unless ``workers`` (a positive integer) or ``dask`` (an address or
    "local") or neither is given."""
    if workers is not None and dask is not None:
        raise ValueError(f"give workers or dask, not both (workers={workers!r}, "
                         f"dask={dask!r}): worker processes on this machine or a Dask "
                         f"cluster")
    if workers is not None and (isinstance(workers, bool) or
                                not isinstance(workers, numbers.Integral) or workers < 1):
        raise ValueError(f"workers must be a positive integer (worker processes), got "
                         f"{workers!r}")
    if dask is not None and (not isinstance(dask, str) or not dask.strip()):
        raise ValueError(f"dask must be a scheduler address such as tcp://host:8786 or "
                         f"'local', got {dask!r}")


def add_arguments(parser) -> None:
    """``--workers N`` and ``--dask ADDRESS`` (one or the other) on an argparse parser."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--workers", type=positive_int, metavar="N",
                       help="run the sweep's runs in N worker processes on this machine, "
                            "each starting Taichi with this run's --threads and precision: "
                            "the serial results, in the serial order")
    group.add_argument("--dask", metavar="ADDRESS",
                       help="run them on a Dask cluster: its scheduler's address (e.g. "
                            "tcp://host:8786; every worker needs timpm installed) or 'local' "
                            f"(one single-threaded worker process per core); needs "
                            f"{DASK_INSTALL}")


def map_runs(task, calls, *, workers=None, dask=None, on_result=None, cost=None,
             connect_timeout=CONNECT_TIMEOUT) -> list:
    """``[task(*args) for args in calls]``: in this process, or with ``workers`` /
    ``dask`` in other processes (see the module).

    ``task`` is a module-level function (worker processes import it by name) and ``calls``
    plain, picklable arguments.  ``on_result(i, result)`` is called for each result in
    order, as soon as it and those before it are in.  ``cost``, a number per call (e.g.
    its particle count), starts the costliest calls first on workers, so that the largest
    run does not start last (the results keep the order of ``calls``).
    ``connect_timeout``: seconds to wait for a Dask scheduler and its first worker.
    """
    check_executor(workers, dask)
    calls = [tuple(args) for args in calls]
    if cost is not None and len(cost) != len(calls):
        raise ValueError(f"cost must give a number per call ({len(calls)}), got {len(cost)}")
    if workers is None and dask is None:
        results = []
        for i, args in enumerate(calls):
            results.append(task(*args))
            if on_result is not None:
                on_result(i, results[-1])
        return results
    if not calls:
        return []
    try:
        pickle.dumps((task, calls))
    except Exception as exc:
        raise ValueError(f"the runs cannot be sent to worker processes (their arguments "
                         f"must be plain, picklable data): {exc}") from None
    from ..platform.version import __version__
    from ..platform import runtime

    job = _Job(task, runtime.settings(), __version__, own_thread=dask is not None)
    # the order in which the calls start: costliest first (a stable sort: ties in order)
    start = sorted(range(len(calls)), key=lambda i: -cost[i]) if cost is not None else \
        list(range(len(calls)))
    if workers is not None:
        return _on_pool(job, calls, start, min(int(workers), len(calls)), on_result)
    return _on_dask(job, calls, start, dask.strip(), float(connect_timeout), on_result)


# ---- in a worker process ------------------------------------------------------------------

class _Job:
    """``task(*args)`` in a worker process: Taichi started there with this process's
    settings (in one thread of its own where the worker calls from several, as Dask's
    do), the result as plain data."""

    def __init__(self, task, settings, version, own_thread=False):
        self.task, self.settings, self.version = task, settings, version
        self.own_thread = own_thread

    def __call__(self, *args):
        if self.own_thread:
            return _taichi_thread().submit(self._run, args).result()
        return self._run(args)

    def _run(self, args):
        import socket

        from ..platform.version import __version__
        from ..platform import runtime

        if __version__ != self.version:
            raise ValueError(f"the worker on {socket.gethostname()} runs timpm {__version__}, "
                             f"the sweep was started with timpm {self.version}: install the "
                             f"same version on every worker")
        with open(os.devnull, "w") as quiet, contextlib.redirect_stdout(quiet):
            runtime.init(**self.settings)  # its start-up note is not the caller's output
        with contextlib.redirect_stdout(sys.stderr):  # stdout is the caller's table
            return _plain(self.task(*args))


_THREAD: dict = {}
_THREAD_LOCK = threading.Lock()


def _taichi_thread() -> ThreadPoolExecutor:
    """The one thread of this process that runs the tasks (Taichi runs in the thread
    that started it)."""
    with _THREAD_LOCK:
        if "pool" not in _THREAD:
            _THREAD["pool"] = ThreadPoolExecutor(1, thread_name_prefix="timpm")
        return _THREAD["pool"]


def _plain(value):
    """``value`` with NumPy scalars and arrays as Python numbers and lists (exact)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, tuple):
        return tuple(_plain(v) for v in value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


# ---- the executors --------------------------------------------------------------------------

@contextlib.contextmanager
def environment(values):
    """``os.environ`` with ``values`` while processes are started, restored after."""
    saved = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def die_with_parent(parent_pid):
    """In a worker: end when the process that started it ends, however it ends (SIGKILL
    too), so that no worker lives on holding its caller's output open.  Linux asks the
    kernel (PR_SET_PDEATHSIG: SIGKILL at the parent's death); elsewhere a thread watches
    the parent's pid."""
    import signal
    import sys
    import threading

    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            PR_SET_PDEATHSIG = 1
            if libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0:
                if os.getppid() != parent_pid:  # it died before the request was made
                    os._exit(1)
                return
        except (OSError, AttributeError):
            pass

    def watch():
        import time
        while True:
            time.sleep(1.0)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, daemon=True, name="timpm-parent-watch").start()


def _in_order(futures, on_result) -> list:
    """The futures' results in order (the first failing one raises)."""
    results = []
    for i, future in enumerate(futures):
        results.append(future.result())
        if on_result is not None:
            on_result(i, results[-1])
    return results


def _on_pool(job, calls, start, workers, on_result) -> list:
    # imported here: a serial sweep (every timpm convergence) does not pay for them
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    pool = ProcessPoolExecutor(max_workers=workers,
                               mp_context=multiprocessing.get_context("spawn"),
                               initializer=die_with_parent, initargs=(os.getpid(),))
    done = False
    try:
        with environment(WORKER_ENV):  # the processes start as the runs are submitted
            futures = [None] * len(calls)
            for i in start:
                futures[i] = pool.submit(job, *calls[i])
        try:
            results = _in_order(futures, on_result)
        except BrokenProcessPool as exc:
            raise SweepError(f"a worker process died before its run finished ({exc}); "
                             f"run the study without workers to see why (a script that "
                             f"starts workers must do so under if __name__ == '__main__':, "
                             f"as the spawned workers import it)") from None
        done = True
        return results
    finally:
        if not done:  # an error or an interrupt: the other runs are not waited for
            stop_workers(pool)
        pool.shutdown(wait=True, cancel_futures=True)


def stop_workers(pool) -> None:
    """Stop the pool's worker processes now (ours: started by this pool)."""
    terminate = getattr(pool, "terminate_workers", None)  # Python 3.14
    if terminate is not None:
        terminate()
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        if process.is_alive():
            process.terminate()


def _dask_client(distributed, stack, address, timeout, n_calls):
    """A client of the scheduler at ``address`` (or of a new local cluster) with at least
    one worker, entered into ``stack``."""
    import asyncio

    target = address
    if address == "local":
        # its worker processes start here; an interrupted sweep stops them, so their
        # own warnings then (a cancelled task, a lost heartbeat) are not shown
        with environment({**WORKER_ENV, "DASK_LOGGING__DISTRIBUTED": "critical"}):
            # (dashboard_address=None still serves the scheduler's HTTP routes on 8787: a
            # second local cluster at the same time, another study's, warned that the
            # port was taken; any free port instead)
            target = stack.enter_context(distributed.LocalCluster(
                n_workers=min(_cores(), n_calls), threads_per_worker=1,
                processes=True, dashboard_address=None,
                scheduler_kwargs={"dashboard_address": ":0"}))
    try:
        client = stack.enter_context(distributed.Client(
            target, timeout=f"{timeout}s", set_as_default=False))
    except OSError as exc:  # timed out, refused
        raise SweepError(f"cannot reach the Dask scheduler at {address} within "
                         f"{timeout:g} s: {exc}") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except (OSError, asyncio.TimeoutError):
        raise SweepError(f"the Dask scheduler at {address} has no workers (waited "
                         f"{timeout:g} s): start some with: dask worker {address} "
                         f"--nthreads 1") from None
    return client


class _QuietTeardown:
    """After :meth:`start`, until the block ends, no log lines from Dask: an interrupted
    local cluster closes without the nannies' warnings about the workers they stop (busy in
    a kernel, they are killed)."""

    def __init__(self):
        import logging

        self.logger, self.level = logging.getLogger("distributed"), None

    def start(self):
        import logging

        self.level = self.logger.level
        self.logger.setLevel(logging.CRITICAL)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.level is not None:
            self.logger.setLevel(self.level)


def _cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else \
        (os.cpu_count() or 1)


def _on_dask(job, calls, start, address, timeout, on_result) -> list:
    import uuid

    try:
        import distributed
        from distributed.scheduler import KilledWorker
    except ImportError:
        raise SweepError(f"dask={address!r} needs dask.distributed, which is not "
                         f"installed: {DASK_INSTALL}") from None
    if address != "local":
        try:
            distributed.comm.get_address_host_port(address)
        except ValueError as exc:
            raise SweepError(f"dask={address!r} is not a scheduler address such as "
                             f"tcp://host:8786 (or 'local'): {exc}") from None
    from ..platform import interrupt

    with contextlib.ExitStack() as stack:
        quiet = stack.enter_context(_QuietTeardown())  # entered first: it exits last
        # Ctrl-C or SIGTERM while the cluster starts is held until it is up (Dask cannot
        # close a cluster stopped half-way), then stops the sweep as at any other time
        with interrupt.deferred_sigint():
            client = _dask_client(distributed, stack, address, timeout, len(calls))
            stopped = interrupt.requested()
        if stopped:
            quiet.start()
            raise KeyboardInterrupt
        sweep = f"timpm-{getattr(job.task, '__name__', 'task')}-{uuid.uuid4().hex[:8]}"
        futures = [None] * len(calls)  # keys name the sweep and the call's place in it
        for rank, i in enumerate(start):
            futures[i] = client.submit(job, *calls[i], key=f"{sweep}-{i}",
                                       priority=len(calls) - rank)
        try:
            return _in_order(futures, on_result)
        except BaseException as exc:  # a failed run or an interrupt: drop the others
            client.cancel(futures)
            if address == "local" and isinstance(exc, KeyboardInterrupt):
                quiet.start()
            if isinstance(exc, KilledWorker):
                raise SweepError(f"a Dask worker died while running a task ({exc}); run "
                                 f"the study without dask to see why") from None
            raise
