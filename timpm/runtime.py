"""Taichi start-up: one CPU runtime per process, started on first use."""

import os
import threading

import taichi as ti

__all__ = ["ensure_init", "init", "pin_workers"]

_state: dict = {}


def init(threads: int | None = None, debug: bool = False, precision: str = "f64",
         pin: bool = True) -> None:
    """Start Taichi on the CPU backend.

    ``threads`` caps the worker threads (default: ``TIMPM_THREADS`` or all cores);
    ``precision`` sets the default float type of literals and fields ("f64" or "f32");
    ``debug=True`` turns on Taichi's own bounds checks (slow); ``pin`` binds Taichi's
    worker threads one per core, round robin over the cores this process may use (Linux;
    like ``OMP_PROC_BIND=spread``; see :func:`pin_workers`).  Calling it again with other
    settings restarts Taichi, which frees the fields of every existing solver (using one
    then raises a RuntimeError; the study drivers build new ones).
    """
    if precision not in ("f64", "f32"):
        raise ValueError(f"precision must be 'f64' or 'f32', got {precision!r}")
    if threads is None and os.environ.get("TIMPM_THREADS"):
        threads = int(os.environ["TIMPM_THREADS"])
    settings = dict(threads=threads, debug=debug, precision=precision, pin=bool(pin))
    if _state.get("settings") == settings:
        return
    kwargs = dict(arch=ti.cpu, default_fp=ti.f64 if precision == "f64" else ti.f32,
                  debug=debug, log_level=ti.WARN)
    if threads:
        kwargs["cpu_max_num_threads"] = int(threads)
    ti.init(**kwargs)
    _state["settings"] = settings
    _state["generation"] = generation() + 1
    _state["pinned"] = pin_workers() if pin else []


def _cpu_time(tid: int) -> int:
    """Nanoseconds thread ``tid`` of this process has run (Linux schedstat)."""
    with open(f"/proc/self/task/{tid}/schedstat") as f:
        return int(f.read().split()[0])


def pin_workers() -> list:
    """Bind each of Taichi's CPU worker threads to its own core (round robin).

    Linux wakes a thread on the core of the thread that woke it when it judges the cache
    warm there, so the two workers of a short parallel task often share one core of a
    2-core machine and the task takes as long as on one thread: pinned, they run on two.
    The workers are found as the threads that gain CPU time during a parallel probe
    kernel.  Returns ``[(thread id, core), ...]``; empty where this is not possible (not
    Linux, one thread or one core allowed), which changes nothing but speed.
    """
    from taichi.lang import impl

    if not hasattr(os, "sched_setaffinity") or not os.path.isdir("/proc/self/task"):
        return []
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) < 2 or impl.current_cfg().cpu_max_num_threads < 2:
        return []
    probe = ti.field(ti.f64, shape=4096)

    @ti.kernel
    def busy(n: ti.i32):
        for i in range(4096):  # both workers take a block of the range
            acc = 0.0
            for k in range(n):
                acc = acc * 0.999 + 1.0
            probe[i] = acc

    busy(1)
    main = threading.get_native_id()
    try:
        tids = [int(t) for t in os.listdir("/proc/self/task") if int(t) != main]
        before = {t: _cpu_time(t) for t in tids}
        busy(20000)  # a few milliseconds of work shared by the workers
        gained = [t for t in tids if _cpu_time(t) - before[t] > 1_000_000]
        pinned = []
        for k, tid in enumerate(sorted(gained)):
            os.sched_setaffinity(tid, {cores[k % len(cores)]})
            pinned.append((tid, cores[k % len(cores)]))
    except (OSError, ValueError, KeyError):
        return []
    return pinned


def generation() -> int:
    """How many times timpm started Taichi: fields (solvers) of an earlier start are gone."""
    return _state.get("generation", 0)


def ensure_init() -> None:
    """Start Taichi with the defaults unless it was started already."""
    if "settings" not in _state:
        init()
