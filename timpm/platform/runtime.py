"""Taichi start-up: one runtime per process (the CPU unless asked), started on first use,
owned by the thread that started it and unusable in a child forked after it started."""

import atexit
import ctypes
import functools
import hashlib
import numbers
import os
import sys
import tempfile
import threading
import time

from . import taichi_backend, taichi_frontend


# Taichi prints its banner when imported: timpm imports it quietly and prints the banner
# when it starts Taichi (timpm --help, timpm list and refused arguments print none), unless
# Taichi was imported before or ENABLE_TAICHI_HEADER_PRINT says otherwise
_BANNER_VAR = "ENABLE_TAICHI_HEADER_PRINT"
_banner_deferred = "taichi" not in sys.modules and _BANNER_VAR not in os.environ
if _banner_deferred:
    os.environ[_BANNER_VAR] = "False"
_fast_decorators = None
if "taichi" not in sys.modules:
    _fast_decorators = taichi_frontend.FastDecoratorsOnLoad(
        "taichi_forge" if taichi_backend.FORGE else "taichi")
    sys.meta_path.insert(0, _fast_decorators)
try:
    import taichi as ti
finally:
    if _banner_deferred:
        del os.environ[_BANNER_VAR]
    if _fast_decorators in sys.meta_path:
        sys.meta_path.remove(_fast_decorators)
from taichi.lang import impl, kernel_impl
from taichi.lang.misc import is_arch_supported

taichi_frontend.read_decorator_line_once(kernel_impl)  # Taichi imported before timpm

__all__ = ["ARCHS", "BackendUnavailable", "ForkedProcess", "WrongThread", "arch",
           "check_caller", "compile_clock", "cpu_threads", "ensure_init", "generation",
           "init", "on_cpu", "exit_process", "pin_workers", "precision", "settings",
           "static_cpu_blocks", "stop"]

#: the backends ``init(arch=...)`` takes
ARCHS = {"cpu": ti.cpu, "cuda": ti.cuda, "vulkan": ti.vulkan, "metal": ti.metal}
_CPUS = (ti.x64, ti.arm64)
_SPAWN = ("concurrent.futures.ProcessPoolExecutor(mp_context=multiprocessing."
          "get_context('spawn'))")

_state: dict = {}


class BackendUnavailable(RuntimeError):
    """The backend asked for is not on this machine (Taichi would fall back to the CPU)."""


class WrongThread(RuntimeError):
    """timpm used from a thread other than the one that started Taichi."""


class ForkedProcess(RuntimeError):
    """timpm used in a child forked after the parent started Taichi."""


#: the most worker threads per core this process may use (more only share the cores, and
#: a thousand threads under a memory limit deadlocked Taichi's thread pool)
THREADS_PER_CORE = 16


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _threads(threads):
    """``threads`` checked, or ``TIMPM_THREADS`` when None (None if that is unset too); at
    most ``THREADS_PER_CORE`` times the cores this process may use."""
    what = "threads"
    if threads is None:
        text = os.environ.get("TIMPM_THREADS", "").strip()
        if not text:
            return None
        try:
            threads = int(text)
        except ValueError:
            threads = 0
        if threads < 1:
            raise ValueError(f"the environment variable TIMPM_THREADS must be a positive "
                             f"integer (worker threads), got {text!r}")
        what = "TIMPM_THREADS"
    elif isinstance(threads, bool) or not isinstance(threads, numbers.Integral) or threads < 1:
        raise ValueError(f"threads must be a positive integer, got {threads!r}")
    cores = _cores()
    if threads > THREADS_PER_CORE * cores:
        raise ValueError(f"{what} = {threads} is more than {THREADS_PER_CORE} times the "
                         f"{cores} core{'s' * (cores != 1)} this process may use (at most "
                         f"{THREADS_PER_CORE * cores}): more threads than cores only share "
                         "them")
    return int(threads)


def _arch(arch):
    """``arch`` checked, or ``TIMPM_ARCH`` when None ("cpu" if that is unset too)."""
    if arch is None:
        text = os.environ.get("TIMPM_ARCH", "").strip()
        if not text:
            return "cpu"
        if text.lower() not in ARCHS:
            raise ValueError(f"the environment variable TIMPM_ARCH must name a backend: "
                             f"{', '.join(ARCHS)}; got {text!r}")
        return text.lower()
    if arch not in ARCHS:
        raise ValueError(f"unknown arch {arch!r}: choose one of {', '.join(ARCHS)}")
    return arch


#: Taichi's names of the backends in ``TI_ARCH`` (its own variable, which ``ti.init`` puts
#: before its ``arch`` argument) as timpm's: "cpu" too, which Taichi itself aborts on
_TI_ARCH_NAMES = {"x64": "cpu", "arm64": "cpu", "cpu": "cpu", "cuda": "cuda",
                  "vulkan": "vulkan", "metal": "metal"}
#: Taichi's other backends, which timpm does not run on
_TI_ARCH_OTHERS = ("opengl", "gles", "dx11", "dx12", "amdgpu", "cc", "wasm")


def _check_ti_arch(arch: str, source: str) -> None:
    """Taichi's own ``TI_ARCH``, if set, checked against the backend timpm was asked for
    (``arch``, from ``source``): ``ti.init`` would put it before the backend timpm passes,
    silently (falling back to the CPU from a GPU it lacks, or running a CPU request on a
    GPU), and abort the process in C++ on a name it does not know.  One that agrees is
    kept from Taichi (timpm passes the backend itself); any other is refused."""
    text = os.environ.get("TI_ARCH")
    if text is None or not text.strip():
        return
    name = text.strip().lower()
    fix = "unset TI_ARCH (timpm's backend is --arch, TIMPM_ARCH or timpm.init(arch=...))"
    if name in _TI_ARCH_OTHERS:
        raise ValueError(f"the environment variable TI_ARCH={text!r} names Taichi's {name} "
                         f"backend, which timpm does not run on (it runs on "
                         f"{', '.join(ARCHS)}); {fix}")
    if name not in _TI_ARCH_NAMES:
        raise ValueError(f"the environment variable TI_ARCH={text!r} names no Taichi backend "
                         f"(Taichi would abort: it takes x64, arm64, cuda, vulkan, metal, "
                         f"...); {fix}")
    if _TI_ARCH_NAMES[name] != arch:
        wanted = _TI_ARCH_NAMES[name]
        raise ValueError(f"the environment variable TI_ARCH={text!r} asks Taichi for the "
                         f"{wanted} backend, but timpm was asked for {arch} ({source}), "
                         f"and Taichi would take TI_ARCH's silently: {fix}, or ask for "
                         f"{wanted} with --arch {wanted} (TIMPM_ARCH={wanted})")


def _optimize(optimize):
    """``optimize`` checked, or ``TIMPM_OPTIMIZE`` ("1" or "0") when None (False if unset:
    Taichi's control-flow optimisation doubles the compilation, and since the stencil
    loops run by rows the steps measure no faster with it beyond the machine's noise;
    benchmarks/optimize_ab.py)."""
    if optimize is None:
        text = os.environ.get("TIMPM_OPTIMIZE", "").strip()
        if text not in ("", "0", "1"):
            raise ValueError(f"the environment variable TIMPM_OPTIMIZE must be 1 (optimise "
                             f"the kernels fully) or 0 (compile faster), got {text!r}")
        return text == "1"
    if not isinstance(optimize, bool):
        raise ValueError(f"optimize must be True or False, got {optimize!r}")
    return optimize


def _check_opt_level():
    """Taichi reads ``TI_OPT_LEVEL`` (its LLVM optimisation level) from the environment; at
    0, taichi 1.7.4 on the CPU turns an integer times a float into 0.0 (``t = n dt`` is 0:
    Table 3.2 stopped after one step with a wrong error), so that setting is refused."""
    text = os.environ.get("TI_OPT_LEVEL", "").strip()
    if text == "0":
        raise ValueError("the environment variable TI_OPT_LEVEL=0 makes taichi 1.7.4 compute "
                         "integer-times-float products as 0.0 on the CPU (wrong results, no "
                         "error): unset it or set it to 1, 2 or 3")


def _settings(threads=None, debug=False, precision="f64", pin=True, arch=None,
              optimize=None, fast_math=True) -> dict:
    """The settings of a start, checked before Taichi is touched."""
    _check_opt_level()
    source = ("by --arch, the arch argument" if arch is not None else
              "by the environment variable TIMPM_ARCH"
              if os.environ.get("TIMPM_ARCH", "").strip() else
              "the default: no --arch, no TIMPM_ARCH")
    arch = _arch(arch)
    _check_ti_arch(arch, source)
    if precision not in ("f64", "f32"):
        raise ValueError(f"precision must be 'f64' or 'f32', got {precision!r}")
    if not isinstance(fast_math, bool):
        raise ValueError(f"fast_math must be True or False, got {fast_math!r}")
    return dict(threads=_threads(threads), debug=bool(debug), precision=precision,
                pin=bool(pin), arch=arch, optimize=_optimize(optimize), fast_math=fast_math)


def _supported(a) -> bool:
    """Whether Taichi finds backend ``a`` here (its test before falling back to the CPU)."""
    return bool(is_arch_supported(a))


def _unavailable(name: str, why: str = "it is not available on this machine") -> Exception:
    available = ", ".join(n for n, a in ARCHS.items() if _supported(a))
    return BackendUnavailable(f"timpm cannot run on the {name} backend: {why} (available: "
                              f"{available}); timpm does not fall back to the CPU silently: "
                              f"use timpm.init(arch='cpu') (on the command line: --arch cpu)")


def init(threads: int | None = None, debug: bool = False, precision: str = "f64",
         pin: bool = True, arch: str | None = None, optimize: bool | None = None,
         fast_math: bool = True) -> None:
    """Start Taichi, on the CPU unless ``arch`` names a GPU backend.

    ``arch``: "cpu", "cuda", "vulkan" or "metal" (default: ``TIMPM_ARCH``, else "cpu"; a
    GPU backend scatters with atomic adds, on one launch per step); a backend this machine lacks
    raises :class:`BackendUnavailable`, not Taichi's silent fallback to the CPU (the
    runtime stays as it was, or restarts with the last settings or the defaults).
    Taichi's own ``TI_ARCH`` must name the same backend or be unset (a ValueError before
    Taichi starts: ``ti.init`` would take it silently); the backend started is checked to
    be the one asked for, the CPU too.
    ``threads`` caps the CPU worker threads (a positive integer; default: ``TIMPM_THREADS``
    or all cores); ``precision`` sets the default float type of literals and fields ("f64"
    or "f32"); ``debug=True`` turns on Taichi's own bounds checks (slow); ``pin`` binds
    Taichi's CPU worker threads one per core, round robin over the cores this process may
    use (Linux; like ``OMP_PROC_BIND=spread``; see :func:`pin_workers`).
    ``optimize=True`` (default: ``TIMPM_OPTIMIZE``, else False) turns on Taichi's
    control-flow optimisation (store forwarding, dead-store elimination): kernels compile
    about 2x slower, and the steps measure no faster beyond the machine's noise since the
    stencil loops run by rows (``benchmarks/optimize_ab.py``, docs/performance.md).
    Every golden case (one thread) is bit for bit the same either way; a two-thread run
    can differ at round-off (Taichi contracts other multiply-adds).
    ``fast_math=False`` turns off Taichi's fast math: every operation rounds as written
    (no reassociation, no contraction into fused multiply-adds), so that two programs of
    the same arithmetic (the fused serial and the parallel mode, a team and the private
    scatter, a batch and its members alone) give the same bits on any CPU; with fast math
    LLVM may vectorise them apart (round-off).  The arguments are checked (ValueError)
    before Taichi is touched.  Calling it again with other
    settings restarts Taichi, which frees the fields of every existing solver (using one
    then raises a RuntimeError; the study drivers build new ones).  The calling thread
    owns the runtime (see :func:`check_caller`).
    """
    settings = _settings(threads, debug, precision, pin, arch, optimize, fast_math)
    check_caller()
    previous = _state.get("settings")
    if previous == settings:
        return
    arch = settings["arch"]
    if arch != "cpu" and threading.current_thread() is not threading.main_thread():
        # the interpreter's exit frees the runtime from the main thread, where the GPU
        # context started here is not current: CUDA aborts the process (seen on an H100)
        raise WrongThread(f"timpm starts a GPU backend ({arch}) from the main thread only, "
                          f"not from {threading.current_thread().name!r}: the runtime is "
                          f"freed from the main thread at exit, which another thread's GPU "
                          f"context would abort")
    if not _supported(ARCHS[arch]):
        raise _unavailable(arch)
    failure = None
    try:
        _start(settings)
    except Exception as exc:  # a GPU driver that fails to start: back to a usable runtime
        if arch == "cpu":
            raise
        failure = exc
    if failure is None and _started(arch):
        return
    started = ti._lib.core.arch_name(impl.current_cfg().arch)
    if arch == "cpu":  # not a fallback: the CPU was asked for and Taichi started another
        _state.pop("settings", None)
        raise BackendUnavailable(f"timpm asked Taichi for the CPU and it started on "
                                 f"{started}: check Taichi's environment variables (TI_*)")
    why = (f"Taichi failed to start it ({failure})" if failure else
           f"Taichi fell back to {started}")
    _start(previous or _settings())  # the last start again, or the defaults
    raise _unavailable(arch, why) from failure


def _started(arch: str) -> bool:
    """Whether the backend Taichi started is ``arch`` (timpm's name)."""
    current = impl.current_cfg().arch
    return current in _CPUS if arch == "cpu" else current == ARCHS[arch]


_compile_clock = [0.0]  # seconds in kernel calls that built a new kernel instance


def _time_compilation() -> None:
    """Book every call of a Taichi kernel that built a new instance of it (its frontend,
    its JIT or its load from the offline cache, and that first launch) on one process-wide
    clock, :func:`compile_clock`: Taichi's own kernels (``to_numpy``) and timpm's state
    transfers too, not only the step kernels a solver compiles on purpose; and the first
    read and write of each field element from Python (``field[None]``), where Taichi
    builds that field's reader or writer kernel."""
    from taichi.lang import kernel_impl

    kernel = kernel_impl.Kernel
    if getattr(kernel, "_timpm_timed", False):
        return
    call = kernel.__call__
    clock, now = _compile_clock, time.perf_counter
    accessor = getattr(sys.modules.get("taichi.lang.field"), "SNodeHostAccessor", None)
    if accessor is not None:
        build = accessor.__init__

        def timed_first(obj, name):
            # obj.name timed at its first call, then the plain function again
            plain = getattr(obj, name)

            def first(*args):
                start = now()
                try:
                    return plain(*args)
                finally:
                    clock[0] += now() - start
                    setattr(obj, name, plain)
            setattr(obj, name, first)

        @functools.wraps(build)
        def timed_build(self, snode):
            build(self, snode)
            timed_first(self, "getter")
            timed_first(self, "setter")

        accessor.__init__ = timed_build

    @functools.wraps(call)
    def timed_call(self, *args, **kwargs):
        built = len(self.compiled_kernels)
        start = now()
        try:
            return call(self, *args, **kwargs)
        finally:
            if len(self.compiled_kernels) != built:
                clock[0] += now() - start

    kernel.__call__ = timed_call
    kernel._timpm_timed = True


_time_compilation()


def compile_clock() -> float:
    """Seconds this process has spent in kernel calls that compiled (the frontend, the
    JIT or the load from Taichi's offline cache, and that first launch), all kernels and
    field readers counted.  Differences of two readings time the compilation a piece of
    work caused."""
    return _compile_clock[0]


def _print_banner() -> None:
    """Taichi's banner (version, LLVM, commit), once, at the first start."""
    global _banner_deferred
    if _banner_deferred:
        _banner_deferred = False
        try:
            from taichi._lib.utils import _print_taichi_header
        except ImportError:  # another Taichi version: no banner
            return
        _print_taichi_header()


def stop() -> None:
    """Stop Taichi, which writes the kernels it compiled to its offline cache: one process
    at a time per cache (a file lock beside Taichi's own).  Processes stopping together,
    as test and sweep workers do, met on Taichi's lock, which then leaves one's kernels
    out of the cache ("Lock .../ticache.lock failed").  Run at exit and before a restart."""
    if impl.get_runtime().prog is None or "forked" in _state:
        return
    cache = os.path.abspath(os.environ.get("TI_OFFLINE_CACHE_FILE_PATH", "default"))
    key = hashlib.sha1(cache.encode()).hexdigest()[:12]
    try:
        import fcntl

        lock = open(os.path.join(tempfile.gettempdir(), f"timpm-ticache-{key}.lock"), "w")
    except (ImportError, OSError):  # not POSIX, or no temporary folder: Taichi's lock alone
        ti.reset()
        return
    with lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        ti.reset()


atexit.register(stop)


def _start(settings: dict) -> None:
    """``ti.init`` with ``settings``; the calling thread becomes the owner."""
    _state.pop("settings", None)
    _state["generation"] = generation() + 1  # the fields of the last start are gone
    fp = ti.f64 if settings["precision"] == "f64" else ti.f32
    kwargs = dict(arch=ARCHS[settings.get("arch", "cpu")], debug=settings["debug"],
                  default_fp=fp, cfg_optimization=settings.get("optimize", True),
                  fast_math=settings.get("fast_math", True))
    if "TI_LOG_LEVEL" not in os.environ:  # Taichi's notes off; a level the user set stays
        kwargs["log_level"] = ti.WARN  # (given both, Taichi warns that it overrode it)
    if settings["threads"]:
        kwargs["cpu_max_num_threads"] = settings["threads"]
    if taichi_backend.FORGE and "TI_COMPILE_TIER" not in os.environ:
        # taichi-forge's default tier ("fast") skips Taichi's IR optimisations: the steps
        # ran 4-6x slower; "full" is taichi 1.7's pipeline (docs/performance.md)
        kwargs["compile_tier"] = "full"
    if taichi_backend.FORGE and "TI_UNROLLING_KERNEL_WARNING_LIMIT" not in os.environ:
        # taichi-forge warns (a SyntaxWarning at every compile of a step) when a kernel's
        # static loops expand past 1024 statements: timpm's stencils are unrolled on purpose
        kwargs["unrolling_kernel_warning_limit"] = 0
    _print_banner()
    stop()  # a restart: the last start's kernels written in turn
    # TI_ARCH, checked to agree (_check_ti_arch), kept from ti.init: it would take it
    # before the arch passed, and abort on timpm's own name "cpu"
    ti_arch = os.environ.pop("TI_ARCH", None)
    try:
        ti.init(**kwargs)
    finally:
        if ti_arch is not None:
            os.environ["TI_ARCH"] = ti_arch
    taichi_frontend.memoize_source_positions()
    _state.update(settings=settings, owner=threading.get_ident(),
                  owner_name=threading.current_thread().name)
    _state.pop("pinned", None)  # pinned at the first parallel launch (ensure_pinned)


def ensure_pinned() -> list:
    """Pin Taichi's workers (:func:`pin_workers`) once per start, if the settings ask for
    it: called before the first parallel launch (a serial run never wakes them)."""
    if "pinned" not in _state:
        settings = _state.get("settings") or {}
        _state["pinned"] = pin_workers() if settings.get("pin") and on_cpu() else []
    return _state["pinned"]


def check_caller() -> None:
    """Raise unless this thread of this process may use the runtime timpm started.

    Taichi aborts the interpreter when a thread other than the one that started it
    compiles a kernel (:class:`WrongThread`), and a child forked after the start hangs in
    its first kernel (:class:`ForkedProcess`).  Before any start every caller may go on.
    """
    if "forked" in _state:
        raise ForkedProcess(
            f"Taichi was started in the parent process (pid {_state['forked']}) before this "
            f"process was forked from it, and a forked child cannot use it (its first "
            f"kernel would hang): start worker processes with the 'spawn' method, e.g. "
            f"{_SPAWN}")
    owner = _state.get("owner")
    if owner is not None and owner != threading.get_ident():
        raise WrongThread(
            f"timpm runs in the thread that started it ({_state['owner_name']!r}), not in "
            f"{threading.current_thread().name!r}: Taichi aborts the process when another "
            f"thread launches a kernel.  Run parallel simulations in a process pool with "
            f"the 'spawn' start method, e.g. {_SPAWN}")


def _after_fork_in_child() -> None:
    """Mark a child forked from a process with a running Taichi, and keep its copy of the
    runtime alive: destroying it waits for worker threads that a forked child lacks, which
    would hang the child at exit."""
    prog = impl.get_runtime().prog
    if prog is not None:
        _state["forked"] = os.getppid()
        ctypes.pythonapi.Py_IncRef(ctypes.py_object(prog))  # never freed in the child


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def exit_process(code: int):
    """End the process with exit status ``code`` and no interpreter teardown: the standard
    streams flushed, the ``atexit`` handlers run (:func:`stop` among them: Taichi writes
    newly compiled kernels to the offline cache), then ``os._exit``.  The
    teardown it skips (freeing every module and Taichi's LLVM state) took 0.06-0.08 s of
    every command (docs/performance.md).  For the ``timpm`` command only: a caller in
    Python keeps its interpreter."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (timpm ... | head): nothing to save
            pass
    atexit._run_exitfuncs()
    os._exit(code)


def ensure_init() -> None:
    """Start Taichi with the defaults unless it was started already (in this thread)."""
    check_caller()
    if "settings" not in _state:
        init()


def arch() -> str:
    """The backend Taichi runs on: "cpu", "cuda", "vulkan", "metal" (or Taichi's name)."""
    ensure_init()
    current = impl.current_cfg().arch
    if current in _CPUS:
        return "cpu"
    return next((name for name, a in ARCHS.items() if a == current),
                ti._lib.core.arch_name(current))


def on_cpu() -> bool:
    """Whether Taichi runs on the CPU."""
    ensure_init()
    return impl.current_cfg().arch in _CPUS


def cpu_threads() -> int:
    """Taichi's CPU worker threads (its ``cpu_max_num_threads``), at least 1."""
    ensure_init()
    return max(1, int(impl.current_cfg().cpu_max_num_threads))


def static_cpu_blocks() -> bool:
    """Whether a CPU range-for hands each thread one contiguous block of the range
    (Taichi's ``make_cpu_multithreading_loop``), which the private scatter relies on."""
    ensure_init()
    return bool(getattr(impl.current_cfg(), "make_cpu_multithreading_loop", False))


def precision() -> str:
    """The default float type of the runtime: "f64" or "f32"."""
    ensure_init()
    return "f32" if impl.get_runtime().default_fp == ti.f32 else "f64"


def settings() -> dict:
    """The settings of the running start as :func:`init` takes them (``threads``: the
    worker threads Taichi runs, resolved): another process started with them runs every
    kernel as this one does (the sweeps' worker processes do)."""
    ensure_init()
    return dict(_state["settings"], threads=cpu_threads())


def generation() -> int:
    """How many times timpm started Taichi: fields (solvers) of an earlier start are gone."""
    return _state.get("generation", 0)


def _cpu_time(tid: int) -> int | None:
    """Nanoseconds thread ``tid`` of this process has run (Linux schedstat); None for a
    thread that has ended since it was listed."""
    try:
        with open(f"/proc/self/task/{tid}/schedstat") as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def pin_workers() -> list:
    """Bind each of Taichi's CPU worker threads to its own core (round robin).

    Linux wakes a thread on the core of the thread that woke it when it judges the cache
    warm there, so the two workers of a short parallel task often share one core of a
    2-core machine and the task takes as long as on one thread: pinned, they run on two.
    The workers are found as the threads that gain CPU time during a parallel probe
    kernel.  Returns ``[(thread id, core), ...]``; empty where this is not possible (not
    Linux, one thread or one core allowed), which changes nothing but speed.
    """
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
    except (OSError, ValueError):
        return []
    # (another library's thread may end at any moment: it is skipped, not a reason to pin
    # none)
    before = {t: c for t in tids if (c := _cpu_time(t)) is not None}
    busy(20000)  # a few milliseconds of work shared by the workers
    gained = [t for t, c in before.items()
              if (now := _cpu_time(t)) is not None and now - c > 1_000_000]
    pinned = []
    for tid in sorted(gained):
        core = cores[len(pinned) % len(cores)]
        try:
            os.sched_setaffinity(tid, {core})
        except OSError:  # ended since
            continue
        pinned.append((tid, core))
    return pinned
