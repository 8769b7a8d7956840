"""The runtime: arguments checked before Taichi starts, no silent fallback from a GPU
backend to the CPU, and clear errors (not an abort or a hang) for use from another thread
or from a child forked after Taichi started; spawned worker processes work.

The test session's runtime (tests/conftest.py) is never restarted here: what would start
Taichi with other settings runs in a subprocess, under a timeout that also ends the
subprocess's own workers."""
import concurrent.futures
import importlib.util
import os
import textwrap

import pytest
from conftest import run_script
import taichi as ti
from taichi.lang import impl
from taichi.lang.misc import is_arch_supported

from timpm.platform import runtime, taichi_backend

#: seconds a subprocess may take (each needs ~2 s; a hang is what the limit catches)
TIMEOUT = 60

#: the start of every subprocess script: one worker thread, a tiny vibrating-string run
PRELUDE = '''
import os, sys
import numpy as np
import timpm
from timpm.platform import runtime
from timpm.problems import get_problem

def string_run(_=None):
    solver = timpm.Solver(get_problem("vibrating-string").scene(elements=4))
    solver.run(n_steps=10)
    return solver.positions()
'''


def _script(tmp_path, body, env=None):
    """Run PRELUDE + ``body`` as a script in a new process group (killed whole at the
    timeout: a hung pool worker must not outlive the test); returns (rc, stdout, stderr)."""
    path = tmp_path / "script.py"
    path.write_text(PRELUDE + textwrap.dedent(body))
    # the CPU's runtime, whatever backend the test session runs on (tests/test_gpu.py)
    return run_script(path, {**os.environ, "TIMPM_THREADS": "1", **(env or {})}, TIMEOUT)


# ---- arguments ------------------------------------------------------------------------

def test_unknown_arch_lists_the_choices():
    before = runtime.generation()
    with pytest.raises(ValueError, match=r"unknown arch 'gpu': choose one of cpu, cuda, "
                                         r"vulkan, metal"):
        runtime.init(arch="gpu")
    assert runtime.generation() == before  # checked before Taichi was touched


@pytest.mark.parametrize("threads", [0, -2, 2.5, True, "2"])
def test_threads_must_be_a_positive_integer(threads):
    before = runtime.generation()
    with pytest.raises(ValueError, match=f"threads must be a positive integer, got "
                                         f"{threads!r}"):
        runtime.init(threads=threads)
    assert runtime.generation() == before


def test_precision_is_checked():
    with pytest.raises(ValueError, match="precision must be 'f64' or 'f32', got 'f16'"):
        runtime.init(precision="f16")


THREADS_MESSAGE = "must be a positive integer (worker threads)"
OPTIMIZE_MESSAGE = "must be 1 (optimise the kernels fully) or 0 (compile faster)"


@pytest.mark.parametrize("variable, value, message", [
    *[("TIMPM_THREADS", v, THREADS_MESSAGE) for v in ("abc", "-2", "0", "2.5")],
    *[("TIMPM_OPTIMIZE", v, OPTIMIZE_MESSAGE) for v in ("yes", "2", "true")]])
def test_a_bad_environment_variable_is_named(tmp_path, variable, value, message):
    rc, _, err = _script(tmp_path, "timpm.init()\n", env={variable: value})
    assert rc != 0
    assert f"ValueError: the environment variable {variable} {message}, got {value!r}" in err


def test_taichi_opt_level_zero_is_refused(tmp_path):
    """TI_OPT_LEVEL=0 (read by Taichi itself) computes an integer times a float as 0.0 in
    taichi 1.7.4 on the CPU: refused by name before Taichi starts; other levels run."""
    rc, _, err = _script(tmp_path, "timpm.init()\n", env={"TI_OPT_LEVEL": "0"})
    assert rc != 0
    assert "ValueError: the environment variable TI_OPT_LEVEL=0 makes taichi" in err
    rc, _, err = _script(tmp_path, "timpm.init()\n", env={"TI_OPT_LEVEL": "1"})
    assert rc == 0, err


def test_TIMPM_THREADS_sets_the_default(tmp_path):
    rc, out, err = _script(tmp_path, "print('threads', runtime.cpu_threads())\n",
                           env={"TIMPM_THREADS": " 1 "})
    assert rc == 0, err
    assert "threads 1" in out


def test_optimize_reaches_taichi_and_keeps_the_run_bit_for_bit(tmp_path):
    """optimize=False turns Taichi's control-flow optimisation off (the test processes run
    so, TIMPM_OPTIMIZE=0); the string's run is the same to the last bit either way."""
    code = (
        "import sys\n"
        "from taichi.lang import impl\n"
        "from timpm.problems import get_problem\n"
        "flag = sys.argv[1] == '1'\n"
        "timpm.init(threads=1, optimize=flag)\n"
        "assert impl.current_cfg().cfg_optimization == flag\n"
        "s = timpm.Solver(get_problem('vibrating-string').scene(elements=8), energies=False)\n"
        "s.run(n_steps=300)\n"
        "print(repr(s.positions().tolist()))\n")
    outs = []
    for flag in ("1", "0"):
        rc, out, err = _script(tmp_path, code.replace("sys.argv[1]", repr(flag)))
        assert rc == 0, err
        outs.append(out.strip().splitlines()[-1])
    assert outs[0] == outs[1]
    with pytest.raises(ValueError, match="optimize must be True or False, got 'no'"):
        runtime.init(optimize="no")


def test_fast_math_reaches_taichi(strict_arithmetic):
    assert impl.current_cfg().fast_math is False
    assert runtime.settings()["fast_math"] is False and runtime.cpu_threads() == 1
    with pytest.raises(ValueError, match="fast_math must be True or False, got 0"):
        runtime.init(fast_math=0)


# ---- backends -------------------------------------------------------------------------

@pytest.mark.cpu_only("describes a CPU runtime")
def test_helpers_describe_the_session_runtime():
    cfg = impl.current_cfg()
    assert runtime.arch() == "cpu" and runtime.on_cpu()
    assert runtime.cpu_threads() == max(1, cfg.cpu_max_num_threads) >= 1
    assert runtime.static_cpu_blocks() == bool(cfg.make_cpu_multithreading_loop)
    assert runtime.precision() == "f64"


@pytest.mark.skipif(is_arch_supported(ti.cuda), reason="this machine has CUDA")
def test_missing_gpu_is_an_error_and_the_cpu_still_works(tmp_path):
    rc, out, err = _script(tmp_path, '''
        runtime.init(threads=1)
        first = string_run()
        generation = runtime.generation()
        try:
            timpm.init(arch="cuda")
        except runtime.BackendUnavailable as exc:
            print("error:", exc)
        assert runtime.generation() == generation  # the runtime was not even restarted
        assert runtime.arch() == "cpu"
        assert np.array_equal(string_run(), first)
        print("cpu ok")
        ''')
    assert rc == 0, err
    assert ("error: timpm cannot run on the cuda backend: it is not available on this "
            "machine (available: cpu") in out
    assert "does not fall back to the CPU silently: use timpm.init(arch='cpu')" in out
    assert "cpu ok" in out


@pytest.mark.skipif(is_arch_supported(ti.metal), reason="this machine has Metal")
def test_taichi_fallback_is_caught_and_the_last_settings_restored(tmp_path):
    """Should Taichi start the CPU where a backend was asked for (its fallback, e.g. when
    its check and timpm's disagree), timpm raises and restarts with the last settings."""
    rc, out, err = _script(tmp_path, '''
        import taichi as ti
        runtime.init(threads=1, precision="f32")
        settings = dict(runtime._state["settings"])
        real = runtime._supported
        runtime._supported = lambda a: a == ti.metal or real(a)  # timpm's check passes
        try:
            timpm.init(arch="metal")
        except runtime.BackendUnavailable as exc:
            print("error:", exc)
        assert runtime._state["settings"] == settings, runtime._state["settings"]
        assert runtime.arch() == "cpu" and runtime.precision() == "f32"
        assert string_run().size > 0
        print("cpu ok")
        ''')
    assert rc == 0, err
    assert "error: timpm cannot run on the metal backend: Taichi fell back to x64" in out \
        or "error: timpm cannot run on the metal backend: Taichi fell back to arm64" in out
    assert "cpu ok" in out


# ---- threads and processes ------------------------------------------------------------

def test_other_threads_get_a_clear_error():
    runtime.ensure_init()
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        for call in (runtime.check_caller, runtime.ensure_init, runtime.on_cpu,
                     lambda: runtime.init(threads=2)):
            exc = pool.submit(call).exception(timeout=TIMEOUT)
            assert isinstance(exc, runtime.WrongThread), exc
            assert isinstance(exc, RuntimeError)
            message = str(exc)
            assert "timpm runs in the thread that started it ('MainThread')" in message
            assert "process pool with the 'spawn' start method" in message
            assert "ProcessPoolExecutor(mp_context=multiprocessing.get_context('spawn'))" \
                in message
    runtime.check_caller()  # the owner thread goes on


def test_first_start_in_another_thread_makes_it_the_owner(tmp_path):
    rc, out, err = _script(tmp_path, '''
        import threading
        result = {}
        def work():
            result["positions"] = string_run()
        thread = threading.Thread(target=work, name="worker")
        thread.start(); thread.join()
        assert result["positions"].shape[0] > 0
        try:
            runtime.check_caller()
        except runtime.WrongThread as exc:
            print("error:", exc)
        ''')
    assert rc == 0, err
    assert "error: timpm runs in the thread that started it ('worker'), not in " \
           "'MainThread'" in out


def test_forked_worker_gets_a_clear_error_not_a_hang(tmp_path):
    rc, out, err = _script(tmp_path, '''
        import concurrent.futures, multiprocessing
        string_run()  # Taichi runs in this process now
        context = multiprocessing.get_context("fork")
        with concurrent.futures.ProcessPoolExecutor(1, mp_context=context) as pool:
            exc = pool.submit(string_run).exception(timeout=30)
        assert isinstance(exc, runtime.ForkedProcess), repr(exc)
        print("error:", exc)
        pid = os.fork()  # a child that leaves through the interpreter's normal exit
        if pid == 0:
            try:
                runtime.ensure_init()
            except runtime.ForkedProcess:
                sys.exit(7)
            sys.exit(1)
        assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 7
        assert string_run().shape[0] > 0  # the parent goes on
        print("parent ok")
        ''')
    assert rc == 0, err
    assert "error: Taichi was started in the parent process (pid " in out
    assert ("a forked child cannot use it (its first kernel would hang): start worker "
            "processes with the 'spawn' method") in out
    assert "parent ok" in out


def test_child_forked_before_the_start_works(tmp_path):
    rc, out, err = _script(tmp_path, '''
        read, write = os.pipe()
        pid = os.fork()
        if pid == 0:  # Taichi never ran in the parent: the child starts its own
            os.write(write, string_run().tobytes())
            os._exit(0)
        os.close(write)
        data = b""
        while chunk := os.read(read, 1 << 16):
            data += chunk
        assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 0
        child = np.frombuffer(data, dtype=np.float64)
        mine = string_run()
        assert np.array_equal(child, mine.ravel()), (child, mine)
        print("same", mine.size)
        ''')
    assert rc == 0, err
    assert "same" in out


def test_spawned_workers_compute_what_the_parent_does(tmp_path):
    rc, out, err = _script(tmp_path, '''
        import concurrent.futures, multiprocessing
        if __name__ == "__main__":
            mine = string_run()
            context = multiprocessing.get_context("spawn")
            with concurrent.futures.ProcessPoolExecutor(2, mp_context=context) as pool:
                theirs = list(pool.map(string_run, range(2), timeout=50))
            for positions in theirs:
                assert np.array_equal(positions, mine), (positions, mine)
            print("identical", len(theirs), mine.shape)
        ''')
    assert rc == 0, err
    assert "identical 2" in out


def test_the_fast_line_wrapper_wraps_as_textwrap_does():
    # Taichi's frontend wraps every source line it reports; the fast path for lines that
    # fit must give TextWrapper's lines exactly (they end up in the compiled IR's notes)
    import random
    import textwrap

    from timpm.platform.taichi_frontend import _FittingLineWrapper

    fast, reference = _FittingLineWrapper(width=80), textwrap.TextWrapper(width=80)
    rng = random.Random(1)
    alphabet = " \t\n\x0b\x1c\xa0ab^(),.=x_"
    texts = ["", " ", "    x = 1   ", " " * 8 + "^" * 10 + " " * 30, "y" * 80, "y" * 81]
    texts += ["".join(rng.choice(alphabet) for _ in range(rng.randint(0, 100)))
              for _ in range(20000)]
    for text in texts:
        assert fast.wrap(text) == reference.wrap(text), repr(text)
        assert fast.wrap(text) == reference.wrap(text), repr(text)  # a long line: remembered
    # the remembered lines depend on the settings too, not on the text alone
    narrow = _FittingLineWrapper(width=30)
    assert narrow.wrap(texts[-1]) == textwrap.TextWrapper(width=30).wrap(texts[-1])
    # and the memoized fill and dedent of each source line Taichi reads
    from timpm.platform.taichi_frontend import _MemoizedTextwrap

    for text in texts[:2000]:
        assert _MemoizedTextwrap.fill(text, tabsize=4, width=9999) == textwrap.fill(
            text, tabsize=4, width=9999), repr(text)
        assert _MemoizedTextwrap.dedent(text) == textwrap.dedent(text), repr(text)


def test_taichi_imported_by_timpm_has_the_fast_class_body_check_from_its_start(tmp_path):
    # installed while `import taichi` runs: Taichi's own modules decorate their functions
    # at import without inspect.getframeinfo (93 calls in taichi 1.7.4 otherwise); the
    # import hook gone after it, and the string runs
    path = tmp_path / "fresh.py"
    path.write_text(textwrap.dedent("""
        import inspect, sys
        calls = []
        frameinfo = inspect.getframeinfo
        inspect.getframeinfo = lambda *a, **k: calls.append(1) or frameinfo(*a, **k)
        import timpm
        from taichi.lang import kernel_impl
        from timpm.problems import get_problem
        assert kernel_impl._timpm_fast
        assert not any(type(f).__name__ == "FastDecoratorsOnLoad" for f in sys.meta_path)
        solver = timpm.Solver(get_problem("vibrating-string").scene(elements=4))
        solver.run(n_steps=10)
        print("getframeinfo calls", len(calls), "x", solver.positions().ravel()[:2])
        """))
    rc, out, err = run_script(path, {**os.environ, "TIMPM_THREADS": "1"}, TIMEOUT)
    assert rc == 0, err
    assert "getframeinfo calls 0 x [" in out


def test_the_class_body_check_reads_the_line_inspect_reads():
    # timpm answers Taichi's "is this decorator in a class body?" from linecache; it must
    # read the very line inspect.getframeinfo reads, in a class body, a function and a
    # decorated method alike (a wrong answer turns a ti.func into a method or back)
    import inspect
    import sys

    from taichi.lang import kernel_impl

    seen = []

    def check():
        # as Taichi asks: the frame that runs the class statement (or the function's)
        frame = sys._getframe(2)
        context = inspect.getframeinfo(frame)[3]
        expected = any(p.match(context[0].strip())
                       for p in kernel_impl._KERNEL_CLASS_STACKFRAME_STMT_RES)
        seen.append((kernel_impl._inside_class(3), expected))
        return lambda f: f

    class Plain:
        @check()
        def method(self):
            pass

    @ti.data_oriented
    class Oriented:
        @check()
        def method(self):
            pass

    @check()
    def function():
        pass

    assert [answer for answer, _ in seen] == [expected for _, expected in seen]
    assert [answer for answer, _ in seen] == [True, True, False]


def test_the_compile_clock_books_a_kernels_first_call_only():
    """The clock moves when a kernel instance is built (frontend and JIT), not when it
    runs again; a new template instance is a new build."""
    runtime.ensure_init()
    out = ti.field(ti.f64, shape=4)

    @ti.kernel
    def fill(value: ti.f64, shift: ti.template()):
        for i in out:
            out[i] = value + shift

    clock = runtime.compile_clock()
    fill(1.0, 0)
    built = runtime.compile_clock()
    assert built > clock
    fill(2.0, 0)
    assert runtime.compile_clock() == built
    assert out.to_numpy().tolist() == [2.0] * 4  # to_numpy builds its reader: booked
    read = runtime.compile_clock()
    # taichi-forge copies fields in and out without kernels of its own: nothing to book
    builds_readers = not taichi_backend.FORGE
    assert read > built if builds_readers else read == built
    fill(3.0, 1)  # another instance of the template
    instance = runtime.compile_clock()
    assert instance > read
    scalar = ti.field(ti.f64, shape=())
    scalar[None] = 4.0  # the first write builds the field's writer, the first read its reader
    written = runtime.compile_clock()
    assert written > instance if builds_readers else written == instance
    assert scalar[None] == 4.0
    first_read = runtime.compile_clock()
    assert first_read > written if builds_readers else first_read == written
    scalar[None] = 5.0
    assert scalar[None] == 5.0
    assert runtime.compile_clock() == first_read


@pytest.mark.parametrize("choice, message", [
    ("bogus", "TIMPM_TAICHI must be 'taichi' or 'forge' (taichi-forge), got 'bogus'"),
    ("taichi" if taichi_backend.FORGE else "forge",
     "but the taichi package is not installed" if taichi_backend.FORGE
     else "but taichi-forge is not installed"),
])
def test_the_taichi_choice_is_checked_at_import(tmp_path, choice, message):
    """TIMPM_TAICHI names the Taichi that runs timpm; a bad name, or one that is not
    installed, is refused when timpm is imported, naming the variable and the install."""
    if choice == "forge" and importlib.util.find_spec("taichi_forge") is not None:
        pytest.skip("taichi-forge is installed beside taichi here")
    script = tmp_path / "choose.py"
    script.write_text("import timpm\n")
    rc, _, err = run_script(script, dict(os.environ, TIMPM_TAICHI=choice), TIMEOUT)
    assert rc == 1
    assert message in err


def test_a_program_released_before_its_kernels_ran_leaves_later_builds_whole(tmp_path):
    """Taichi checks the fields made since its last kernel build at the next build, reading
    their trees: a program freed before any of its kernels ran (built, then grown or
    dropped) left that check reading freed memory (RuntimeError "Members of the following
    field have different shapes [(), (35, -536496646, ...)]", or a crash of the process).
    Program.release runs the check first."""
    rc, out, err = _script(tmp_path, """
        from timpm.engine.features import plan
        from timpm.engine.program import Program
        from timpm.engine.program_cache import Capacity
        world = timpm.World(domain=(1.0, 1.0), cells=8, transfer="apic", bodies=[
            timpm.Body(timpm.Box((0.25, 0.25), (0.5, 0.5)),
                       timpm.NeoHookean(E=1e4, nu=0.3, density=1000.0))])
        timpm.init()
        features, layout = plan(world)
        Program(features, Capacity.first(features, layout)).release()
        print("string", string_run()[-1])
        """)
    assert rc == 0, err
    assert "string" in out
