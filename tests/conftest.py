import contextlib
import os

import pytest

# no banner or start-up notes from Taichi in the test processes: pytest-xdist's workers
# would print them after pytest's summary line
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "false")
os.environ.setdefault("TI_LOG_LEVEL", "warn")
# Taichi's control-flow optimisation off, as timpm's default (kernels compile ~2x faster;
# one-thread runs, every golden case among them, are bit for bit the optimised build's);
# TIMPM_OPTIMIZE=1 runs the whole suite on the optimised build
os.environ.setdefault("TIMPM_OPTIMIZE", "0")

import timpm  # noqa: E402


#: the backend the tests run on: the CPU unless TIMPM_ARCH names another (e.g. cuda on a
#: GPU machine: the whole suite then runs there)
ARCH = os.environ.get("TIMPM_ARCH", "").strip().lower() or "cpu"


def pytest_collection_modifyitems(config, items):
    """Off the CPU, skip the tests marked ``cpu_only``: the CPU's own strategies (private
    scatter, team, pinned workers) and runs compared bit for bit (a GPU's atomic adds
    add in another order each run)."""
    if ARCH == "cpu":
        return
    for item in items:
        marker = item.get_closest_marker("cpu_only")
        if marker is not None:
            reason = marker.args[0] if marker.args else "runs on the CPU only"
            item.add_marker(pytest.mark.skip(reason=f"{reason} (tests on {ARCH})"))


def assert_same_run(actual, desired):
    """Bit for bit on the CPU; on a GPU, to round-off of the largest value (atomic adds
    there add in another order)."""
    import numpy as np

    if ARCH == "cpu":
        np.testing.assert_array_equal(actual, desired)
    else:
        np.testing.assert_allclose(actual, desired, rtol=0,
                                   atol=1e-12 * max(1.0, float(np.abs(desired).max())))


#: scene-file overrides that write no output file (and no frames: a scene refuses frames
#: without an output written frame by frame)
NO_FILES = {"output.gif": None, "output.vtk": None, "output.npz": None, "output.json": None,
            "output.frames": None}

#: the environment of a ``timpm`` child process in a test: one thread, no banners
CHILD_ENV = dict(os.environ, TIMPM_THREADS="1", ENABLE_TAICHI_HEADER_PRINT="false",
                 TI_LOG_LEVEL="warn")


def default_signals():
    """In a child before it starts (``preexec_fn``): SIGINT, SIGTERM and SIGHUP at their
    defaults, as in a terminal.  A process inherits an ignored signal (Python then
    installs no handler, and Ctrl-C does nothing): a test worker may have been left
    ignoring one by a pool of an earlier test, and the child then ran on past the signal
    (2026-11-25, the full suite on two workers)."""
    import signal

    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def scene_file_error(path, text) -> str:
    """The message of the ValueError that loading the scene file ``text``, written to
    ``path``, raises (the tests of scene-file errors read its ``file:line: key``)."""
    from timpm.scenefile import load_scene

    path.write_text(text)
    with pytest.raises(ValueError) as err:
        load_scene(path)
    return str(err.value)


@contextlib.contextmanager
def killed_at_exit(process):
    """A failed wait leaves no run behind."""
    try:
        yield process
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()


def sigterm_after(command, prefix, count, timeout=240):
    """Run ``command`` (a timpm study), send it SIGTERM once ``count`` lines of its stderr
    start with ``prefix`` (its progress), wait for it: (returncode, stderr)."""
    import signal
    import subprocess
    import threading

    run = subprocess.Popen(command, env=CHILD_ENV, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, preexec_fn=default_signals)
    lines, enough = [], threading.Event()

    def read():
        for line in run.stderr:
            lines.append(line)
            if sum(line.startswith(prefix) for line in lines) >= count:
                enough.set()
    reader = threading.Thread(target=read, daemon=True)
    with killed_at_exit(run):
        reader.start()
        assert enough.wait(timeout=timeout), "".join(lines)
        run.send_signal(signal.SIGTERM)
        run.wait(timeout=120)
        reader.join(timeout=10)
    return run.returncode, "".join(lines)


def wait_until(process, ready, timeout=120):
    """Wait until ``ready()`` holds while ``process`` runs: it ending first, or the timeout
    (the process then killed, not waited for), is a test failure with its output."""
    import time

    deadline = time.monotonic() + timeout
    while not ready():
        if process.poll() is None and time.monotonic() > deadline:
            process.kill()
        if process.poll() is not None or time.monotonic() > deadline:
            pytest.fail(f"not ready within {timeout} s: {process.communicate()}")
        time.sleep(0.1)


def run_script(path, env, timeout):
    """Run the Python script ``path`` with ``env`` (TIMPM_ARCH dropped: the CPU unless the
    script says otherwise) in a new process group, killed whole at the ``timeout`` (a
    hung pool worker must not outlive the test); returns (rc, stdout, stderr)."""
    import signal
    import subprocess
    import sys

    env = {k: v for k, v in env.items() if k != "TIMPM_ARCH"}
    proc = subprocess.Popen([sys.executable, str(path)], env=env, cwd=path.parent,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"the subprocess did not end in {timeout} s (killed)\n{out}\n{err}")
    return proc.returncode, out, err


def pytest_configure(config):
    # the process that runs tests starts Taichi (with pytest-xdist, each worker does; the
    # controller only distributes the test files); two threads at most: CI machines have
    # two cores
    controller = getattr(config.option, "numprocesses", None) and \
        "PYTEST_XDIST_WORKER" not in os.environ
    if not controller:
        timpm.init(threads=int(os.environ.get("TIMPM_THREADS", "2")))


def pytest_sessionfinish(session):
    # each test process writes its kernels to the offline cache here, in turn with the
    # other worker (timpm.platform.runtime.stop; also run at exit)
    from timpm.platform import runtime

    runtime.stop()


@pytest.fixture
def exact_rounding():
    """Taichi restarted without fast math (threads kept) for one test, then back to the
    session's settings.  Two programs of the same arithmetic (the team against the
    parallel mode, a batch against its members alone, gravity against a body force) give
    the same bits only so: with fast math LLVM may reassociate and vectorise the stencil
    loops of each kernel its own way."""
    from timpm.platform import runtime

    before = runtime.settings()
    timpm.init(**dict(before, fast_math=False))
    yield
    timpm.init(**before)


@pytest.fixture
def strict_arithmetic():
    """Taichi restarted on one thread without fast math for one test (every operation
    rounds as written, whatever the CPU's vector width), then back to the session's
    settings: the fields of solvers built before are freed."""
    from timpm.platform import runtime

    before = runtime.settings()
    timpm.init(**dict(before, threads=1, fast_math=False))
    yield
    timpm.init(**before)


@pytest.fixture(scope="session")
def study_table_3_2():
    """Runs of the vibrating string with the study's Table 3.2 settings (defaults)."""
    from timpm.studies.study import convergence

    return convergence("vibrating-string", elements=(4, 8, 16, 32, 64))


@pytest.fixture
def kernel_calls(monkeypatch):
    """The names of the Taichi kernels called during the test (a refusal comes before any:
    nothing compiled, nothing run)."""
    from taichi.lang import kernel_impl

    calls, real = [], kernel_impl.Kernel.__call__

    def call(self, *args, **kwargs):
        calls.append(self.func.__qualname__)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(kernel_impl.Kernel, "__call__", call)
    return calls
