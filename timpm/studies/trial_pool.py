"""Strength-reduction trials side by side: worker processes of one thread each.

A factor-of-safety study at a few thousand particles steps faster on one thread than on
two (a step of 4,800 particles is too short to pay for two threads' barriers: Griffiths &
Lane's trial 2.9 s on one, 4.3 s on two, 2026-12-03), so on a machine of two cores two
trials at once, each on one core, take the time of one.  :class:`TrialPool` starts
``workers`` processes (spawned, one Taichi thread each, ended with the caller), starts
Taichi in each as the caller runs it (precision, backend, fast math), gives each the
world once, and runs :func:`timpm.studies.factor_of_safety.trial` at the factors
it is handed; each worker compiles its program once and reuses it for every trial.
"""
import os
import pickle
import tempfile

from .sweep import WORKER_ENV, die_with_parent, environment, stop_workers

__all__ = ["TrialPool", "study"]

#: a worker that died: what to do about it
_DIED = ("a worker process of the study died {}; run it with --workers 1 (Python: "
         "workers=1) to see why.  A script that runs a study with workers must start it "
         "under `if __name__ == \"__main__\":` (the workers are spawned: each imports the "
         "script, whose top level would start the study again)")

#: the world and the trial's settings in a worker (set by its initializer)
_STUDY = {}


def _start(parent_pid, settings, world_file, t_end, creep, mode):
    from ..platform import runtime

    die_with_parent(parent_pid)
    runtime.init(**settings)  # the caller's precision, backend and fast math; one thread
    with open(world_file, "rb") as f:
        world = pickle.load(f)
    _STUDY.update(world=world, t_end=t_end, creep=creep, mode=mode)


def study() -> dict:
    """In a worker: its world and settings ("world", "t_end", "creep", "mode"), which the
    tasks the pool runs read."""
    return _STUDY


class TrialPool:
    """``workers`` processes running trials of ``world`` (see the module); use as a
    context manager, :meth:`run` a list of factors."""

    def __init__(self, world, t_end, creep, workers, mode="auto"):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        from ..platform import runtime

        self.workers = workers
        settings = dict(runtime.settings(), threads=1)
        # the world goes by a file, not through the pipe that starts a process: a worker
        # that dies as it starts (a script without a main guard) would leave a large
        # write to it blocked for ever
        fd, self.world_file = tempfile.mkstemp(prefix="timpm-world-", suffix=".pickle")
        with os.fdopen(fd, "wb") as f:
            pickle.dump(world, f, protocol=pickle.HIGHEST_PROTOCOL)
        with environment({**WORKER_ENV, "TIMPM_THREADS": "1"}):
            self.pool = ProcessPoolExecutor(
                max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_start,
                initargs=(os.getpid(), settings, self.world_file, t_end, creep, mode))
            # the processes start as work is submitted: start them all now, here, with
            # the environment above (each builds its world; the first trial compiles)
            try:
                self.wait([self.pool.submit(os.getpid) for _ in range(workers)])
            except BaseException:  # (a worker that died, an interrupt: nothing left over)
                self.close(wait=False)
                raise

    def wait(self, futures, first=False):
        """Wait for ``futures`` (``first``: for one of them; returns (done, pending)),
        watching the worker processes: one that died is a RuntimeError, not a wait
        without end (a worker that dies while it starts leaves the executor waiting)."""
        from concurrent.futures import FIRST_COMPLETED, ALL_COMPLETED
        from concurrent.futures import wait as wait_for
        from concurrent.futures.process import BrokenProcessPool

        pending = set(futures)
        while True:
            done, pending = wait_for(pending, timeout=0.5, return_when=FIRST_COMPLETED
                                     if first else ALL_COMPLETED)
            for f in done:
                if isinstance(f.exception(), BrokenProcessPool):
                    raise RuntimeError(_DIED.format(f"({f.exception()})")) from None
            if first and done or not pending:
                return done, pending
            dead = [p.exitcode for p in (getattr(self.pool, "_processes", None) or {}).values()
                    if p.exitcode is not None]
            if dead:
                raise RuntimeError(_DIED.format(f"(exit code {dead[0]})"))

    def submit(self, fn, *args):
        """``fn(*args)`` in a worker (a module-level function; it reads the worker's
        world and settings from ``_STUDY``): a Future."""
        return self.pool.submit(fn, *args)

    def map(self, fn, items) -> list:
        """``[fn(item) for item in items]`` in the workers (``fn`` a module-level function
        reading :func:`study`), in their order (the first that raised raises)."""
        futures = [self.pool.submit(fn, item) for item in items]
        self.wait(futures)
        return [f.result() for f in futures]

    def close(self, wait=True):
        if not wait:
            stop_workers(self.pool)
        self.pool.shutdown(wait=True, cancel_futures=True)
        try:
            os.unlink(self.world_file)
        except OSError:
            pass

    def __enter__(self):
        return self

    def __exit__(self, kind, value, tb):
        self.close(wait=kind is None)
