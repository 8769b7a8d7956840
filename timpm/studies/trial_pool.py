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

from .sweep import _WORKER_ENV, _environment, _stop_workers, die_with_parent

__all__ = ["TrialPool"]

#: the world and the trial's settings in a worker (set by its initializer)
_STUDY = {}


def _start(parent_pid, settings, world_bytes, t_end, creep, mode):
    from ..platform import runtime

    die_with_parent(parent_pid)
    runtime.init(**settings)  # the caller's precision, backend and fast math; one thread
    _STUDY.update(world=pickle.loads(world_bytes), t_end=t_end, creep=creep, mode=mode)


def _trial(F):
    from .factor_of_safety import trial

    return trial(_STUDY["world"], F, _STUDY["t_end"], _STUDY["creep"], _STUDY["mode"])


class TrialPool:
    """``workers`` processes running trials of ``world`` (see the module); use as a
    context manager, :meth:`run` a list of factors."""

    def __init__(self, world, t_end, creep, workers, mode="auto"):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        from ..platform import runtime

        self.workers = workers
        settings = dict(runtime.settings(), threads=1)
        with _environment({**_WORKER_ENV, "TIMPM_THREADS": "1"}):
            self.pool = ProcessPoolExecutor(
                max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_start,
                initargs=(os.getpid(), settings, pickle.dumps(world), t_end, creep, mode))
            # the processes start as work is submitted: start them all now, here, with
            # the environment above (each builds its world; the first trial compiles)
            for future in [self.pool.submit(os.getpid) for _ in range(workers)]:
                future.result()

    def run(self, factors) -> list:
        """The trials at ``factors``, in their order (the first failing one raises)."""
        from concurrent.futures.process import BrokenProcessPool

        futures = [self.pool.submit(_trial, F) for F in factors]
        try:
            return [f.result() for f in futures]
        except BrokenProcessPool as exc:
            raise RuntimeError(f"a trial's worker process died ({exc}); run the study with "
                               "--workers 1 to see why") from None

    def close(self, wait=True):
        if not wait:
            _stop_workers(self.pool)
        self.pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self):
        return self

    def __exit__(self, kind, value, tb):
        self.close(wait=kind is None)
