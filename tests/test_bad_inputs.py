"""Every bad input refused clearly, before any work (issue 16).

A command exits with status 2 and ``timpm: error: ...`` (or argparse's ``timpm CMD:
error: ...``), never a traceback; a Python call raises a ValueError that names the value.
Sizes are refused before anything is allocated (against Taichi's 32-bit indices and the
memory available, fixed here at 8 GiB), runs of more than 1e8 steps unless allowed, and
every case is refused before a kernel is compiled.
"""
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import taichi as ti
from taichi.lang.misc import is_arch_supported

import timpm
from timpm.platform import checks, runtime
from timpm.cli.main import _parser, main

#: the memory the size checks see in these tests (the machine's varies)
MEMORY = 8 << 30
#: what the machine reports
AVAILABLE_MEMORY = checks.available_memory
VS = ["run", "vibrating-string"]
ROOT = Path(__file__).resolve().parent.parent
SE = ["study", "speed-error", "vibrating-string"]


@pytest.fixture(autouse=True)
def _fixed_machine(monkeypatch):
    monkeypatch.setattr(checks, "available_memory", lambda: MEMORY)
    # the commands start Taichi as the session did: nothing is restarted
    monkeypatch.setenv("TIMPM_THREADS", str(runtime.cpu_threads()))


def _available():
    return f"more than the {MEMORY / 1e9:.3g} GB of memory available"


def _steps(count):
    return f"takes {count} steps, more than the 1e+08 a run may take unless allowed"


#: the refusal of a run's step count, whatever the count
MANY_STEPS = "steps, more than the 1e+08 a run may take unless allowed"


INDEX = "more than the 2147483647 Taichi can index"

COMMANDS = [
    # sizes, before anything is allocated
    (VS + ["--elements", "1000000000000"], "4e+12 particles, " + INDEX),
    (VS + ["--ppc", "100000000"], "1.6e+09 particles and 17 grid nodes need at least 115 GB "
                                  "(72 B a particle, 24 B a node), " + _available()),
    (["run", "mms-2d", "--elements", "100000"], "4e+10 particles, " + INDEX),
    (["run", "mms-3d", "--elements", "500"], "(200 B a particle, 40 B a node), " + _available()),
    (["compare-ulfem", "--elements", "1000000000000"], "5e+13 particles, " + INDEX),
    (["demo", "disks", "--param", "cells=100000"],
     "a World of 100000 cells along x: 1.28e+10 particles, " + INDEX),
    (["demo", "disks", "--out", "{tmp}/d.gif", "--width", "100000"],
     "the movie width must be at most 8192 px, got 100000"),
    (["demo", "disks", "--out", "{tmp}/d.gif", "--width", "100"],
     "the movie width must be at least 320 px"),
    (SE + ["--ppc", "100000000"], "6.4e+09 particles, " + INDEX),
    (SE + ["--elements", "1000000000000"], "4e+12 particles, " + INDEX),
    # step counts
    (VS + ["--dt", "1e-300", "--t-end", "1e-290"], _steps("1e+10")),
    (VS + ["--dt", "1e-300", "--t-end", "1e-290"], "--allow-many-steps"),
    (["convergence", "vibrating-string", "--dt", "1e-300"], _steps("1e+299")),
    (["compare-ulfem", "--dt", "1e-300"], _steps("3e+300")),
    (["demo", "disks", "--param", "E=1e30", "--t-end", "1"], MANY_STEPS),
    (VS + ["--t-end", "1e-9"], "t_end = 1e-09 s is shorter than half a time step (dt = "
                               "0.0001 s): the run would take no step"),
    # times and steps that are no positive finite numbers
    (VS + ["--t-end", "inf"], "argument --t-end: must be a positive number, got inf"),
    (VS + ["--t-end", "nan"], "argument --t-end: must be a positive number, got nan"),
    (VS + ["--t-end", "0"], "argument --t-end: must be a positive number, got 0"),
    (VS + ["--dt", "-1e-4"], "argument --dt: must be a positive number, got -1e-4"),
    (VS + ["--dt", "-inf"], "argument --dt: must be a positive number, got -inf"),
    (["convergence", "vibrating-string", "--t-end", "inf"],
     "argument --t-end: must be a positive number, got inf"),
    (["compare-ulfem", "--t-end", "inf"], "argument --t-end: must be a positive number, got inf"),
    (["compare-ulfem", "--dt", "-1"], "argument --dt: must be a positive number, got -1"),
    (["demo", "disks", "--t-end", "nan"], "argument --t-end: must be a positive number, got nan"),
    # counts
    (VS + ["--elements", "2.5"], "argument --elements: '2.5' is not an integer"),
    (VS + ["--elements", "-4"], "argument --elements: must be a positive integer, got -4"),
    (VS + ["--ppc", "2.5"], "argument --ppc: '2.5' is not an integer"),
    (VS + ["--ppc", "0"], "argument --ppc: must be a positive integer, got 0"),
    (["convergence", "vibrating-string", "--elements", "8", "0"],
     "argument --elements: must be a positive integer, got 0"),
    (VS + ["--frames", "2.5"], "argument --frames: '2.5' is not an integer"),
    (VS + ["--threads", "-2"], "argument --threads: must be a positive integer, got -2"),
    (VS + ["--damping", "nan"], "damping factor alpha must lie in [0, 1), got nan"),
    (SE + ["--max-halvings", "-1"],
     "argument --max-halvings: must be a non-negative integer, got -1"),
    (["demo", "disks", "--fps", "0"], "argument --fps: must be a positive integer, got 0"),
    # bases: the B-spline degree bounded
    (VS + ["--basis", "bspline1000"],
     "basis 'bspline1000': B-spline degree must be an integer from 1 to 8, got 1000"),
    (VS + ["--basis", "bspline9"], "B-spline degree must be an integer from 1 to 8, got 9"),
    (VS + ["--basis", "uniform-bspline0"],
     "basis 'uniform-bspline0': B-spline degree must be an integer from 1 to 8, got 0"),
    (SE + ["--bases", "linear", "bspline1000"],
     "B-spline degree must be an integer from 1 to 8, got 1000"),
    # problem parameters: integers are whole numbers
    (VS + ["--param", "E=nan"], "vibrating-string: parameter E must be positive, got nan"),
    (VS + ["--param", "=3"], "argument --param: expected NAME=VALUE, got '=3'"),
    (["run", "soil-column", "--param", "n_terms=2.5"],
     "soil-column: parameter n_terms must be a positive integer, got 2.5"),
    (["run", "soil-column", "--param", "n_terms=1e12"],
     "soil-column: parameter n_terms must be at most 1000000"),
    (["run", "soil-column-2d", "--param", "width=2.5"],
     "soil-column-2d: width must be a positive number of cells, got 2.5"),
    (["run", "oedometer", "--param", "ramp=-1"],
     "oedometer: parameter ramp must be a duration >= 0 (0: a step load), got -1.0"),
    # demo parameters
    (["demo", "disks", "--param", "cells=2.5"], "disks: cells must be a positive integer, got 2.5"),
    (["demo", "column-collapse", "--param", "cells_per_width=0"],
     "column-collapse: cells_per_width must be a positive integer, got 0"),
    (["demo", "dam-break", "--param", "cells_per_a=2.5"],
     "dam-break: cells_per_a must be a positive integer, got 2.5"),
    # meshes of a study
    (["convergence", "vibrating-string", "--elements", "8", "16", "8"],
     "elements lists 8 more than once: give each mesh once"),
    (SE + ["--elements", "8", "8"], "elements lists 8 more than once"),
]


@pytest.mark.parametrize("argv, message", COMMANDS, ids=[" ".join(a) for a, _ in COMMANDS])
def test_a_bad_command_exits_2_with_the_message(argv, message, tmp_path, capsys):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's refusal
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2
    assert message in err
    assert err.startswith("usage: timpm") or err.startswith("timpm: error: ")
    assert not list(tmp_path.iterdir())  # nothing written


def _scene(**kw):
    x, vol = timpm.equidistant_particles(4, 2, 1.0, start=1.0)
    args = dict(grid=timpm.Grid1D(6, 1.0), material=timpm.Material(1.0, 1.0), positions=x,
                volume=vol, dt=0.1, fixed_nodes=(0,))
    args.update(kw)
    return timpm.Scene(**args)


def _solver(**kw):
    return timpm.Solver(_scene(), mode="serial", **kw)


def _world(cells=8, material="rubber", size=0.4):
    return timpm.World(domain=(1.0, 1.0), cells=cells, bodies=[timpm.Body(
        timpm.Box((0.1, 0.1), (0.1 + size, 0.1 + size)), material)])


def _run_problem(**kw):
    from timpm.studies.study import run_problem

    return run_problem("vibrating-string", **kw)


def _convergence(**kw):
    from timpm.studies.study import convergence

    return convergence("vibrating-string", **kw)


def _speed_error(**kw):
    from timpm.studies.speed_error import speed_error_study

    return speed_error_study("vibrating-string", progress=None, **kw)


def _problem(name, **params):
    from timpm.problems import get_problem

    return get_problem(name, **params)


def _demo(name, **params):
    from timpm.scenarios.demos import get_demo, run_demo

    return run_demo(name, **params) if "t_end" in params else get_demo(name, **params).world()


def _renderer(width):
    from timpm.output.render import Renderer

    return Renderer((0.0, 0.0), (1.0, 1.0), width=width)


def _affine(C):
    solver = timpm.Solver(_world(), mode="serial")
    solver.set_affine(C)


CALLS = [
    # sizes
    (lambda: _world(cells=100000), "a World of 100000 cells along x: 6.4e+09 particles, " + INDEX),
    (lambda: _world(cells=20000, size=1e-4), ("a World of 20000 cells along x: ",
                                              " grid nodes need at least", _available())),
    (lambda: timpm.World(domain=(1.0, 1.0), cells=10, bodies=[timpm.Body(
        timpm.Box((0.1, 0.1), (0.5, 0.5)), "rubber", ppc=100000)]), "1.6e+11 particles, " + INDEX),
    (lambda: timpm.equidistant_particles(10 ** 12, 4, 0.1),
     "1000000000000 elements of 4 particles: 4e+12 particles, " + INDEX),
    (lambda: _scene(grid=timpm.Grid1D(10 ** 12, 1.0)),
     "the model 'scene': 1e+12 grid nodes, " + INDEX),
    (lambda: _run_problem(elements=10 ** 12), "4e+12 particles, " + INDEX),
    (lambda: _run_problem(ppc=10 ** 8), "1.6e+09 particles and 17 grid nodes need at least"),
    (lambda: _problem("mms-2d").scene(elements=30000), "3.6e+09 particles, " + INDEX),
    # the MLS projection: the 1D study's, and the Gauss-point stress of 2D
    (lambda: _problem("mms-3d").scene(elements=4, basis="bspline2", projection="mls"),
     "the MLS projection is implemented in 1D and 2D, not 3D"),
    (lambda: _problem("mms-2d").scene(elements=4, basis="linear", projection="mls"),
     "in 2D the MLS projection reconstructs the stress only (Gauss-point forces): it takes "
     "a B-spline of degree 2 or more, not linear"),
    (lambda: _renderer(100000),
     "an image of 100000 x 100000 pixels has more than the 2147483647 pixels"),
    # step counts
    (lambda: _solver().run(n_steps=10 ** 12), "a run at dt = 0.1 s " + _steps("1e+12")),
    (lambda: _solver().run(t_end=1e12), _steps("1e+13")),
    (lambda: _run_problem(dt=1e-300, t_end=1e-290), _steps("1e+10")),
    (lambda: _run_problem(t_end=1e-9), "t_end = 1e-09 s is shorter than half a time step"),
    # times and counts that are no numbers of their kind
    (lambda: _solver().run(n_steps=-5), "n_steps must be a non-negative integer, got -5"),
    (lambda: _solver().run(n_steps=2.7), "n_steps must be a non-negative integer, got 2.7"),
    (lambda: _solver().run(n_steps="3"), "n_steps must be a non-negative integer, got '3'"),
    (lambda: _solver().run(t_end=float("inf")), "t_end must be a finite number, got inf"),
    (lambda: _solver().run(t_end="1"), "t_end must be a finite number, got '1'"),
    (lambda: _run_problem(t_end=float("inf")), "t_end must be a finite number, got inf"),
    (lambda: _run_problem(elements=4, record_every=2.5),
     "record_every must be a positive integer, got 2.5"),
    (lambda: timpm.init(threads=0), "threads must be a positive integer, got 0"),
    (lambda: _scene(fixed_nodes=(0.7,)), "fixed node 0.7 must be a whole number"),
    (lambda: _problem("soil-column", n_terms=2.5),
     "soil-column: parameter n_terms must be a positive integer, got 2.5"),
    (lambda: _problem("oedometer", ramp=-1), "oedometer: parameter ramp must be a duration >= 0"),
    (lambda: _demo("column-collapse", cells_per_width=0),
     "column-collapse: cells_per_width must be a positive integer, got 0"),
    (lambda: timpm.Traction(2.5, 1.0), "traction particle must be an integer >= 0, got 2.5"),
    (lambda: timpm.Sine(float("nan")), "Sine omega must be a finite number, got nan"),
    (lambda: _scene(gravity="down"), "gravity must be a finite number, got 'down'"),
    # the solver's options
    (lambda: _solver(energy_guard=-1), "energy_guard must be a finite number >= 1"),
    (lambda: _solver(energy_guard=float("nan")), "energy_guard must be a finite number >= 1"),
    (lambda: _solver(serial_threshold=-1),
     "serial_threshold must be a non-negative integer (particles), got -1"),
    (lambda: _solver(small_mass=float("nan")), "small_mass must be a finite number >= 0, got nan"),
    (lambda: _solver(energies="no"), "energies must be True or False, got 'no'"),
    (lambda: _solver(track=3), "track must be a sequence of particle indices, got 3"),
    (lambda: _affine(np.zeros((3, 3))), ("set_affine takes one 2x2 matrix or (",
                                         ", 2, 2) matrices, got an array of shape (3, 3)")),
    (lambda: _affine(np.full((2, 2), np.nan)), "set_affine takes finite values"),
    (lambda: _solver().write("x", np.zeros(3)), "write('x'): cannot reshape array of size 3"),
    # bases
    (lambda: timpm.get_basis("bspline1000"),
     "basis 'bspline1000': B-spline degree must be an integer from 1 to 8, got 1000"),
    (lambda: timpm.bases.bspline(9, clamped=False),
     "B-spline degree must be an integer from 1 to 8, got 9"),
    # studies
    (lambda: _convergence(elements=(8, 16, 8)),
     "elements lists 8 more than once: give each mesh once (a rate compares two"),
    (lambda: _speed_error(elements=(4, 4)), "elements lists 4 more than once"),
    (lambda: _speed_error(ppcs=(2, 2)), "ppcs lists 2 more than once"),
    (lambda: _speed_error(max_halvings=2.5), "max_halvings must be an integer >= 0, got 2.5"),
]


@pytest.mark.parametrize("call, message", CALLS, ids=[
    (m if isinstance(m, str) else m[0])[:48] for _, m in CALLS])
def test_a_bad_call_raises_a_named_error(call, message):
    """``message``: the text of the error, or its parts in order."""
    parts = (message,) if isinstance(message, str) else message
    with pytest.raises(ValueError, match=".*".join(map(re.escape, parts))):
        call()


def test_a_scene_whose_cfl_step_shrinks_is_refused_with_the_count():
    from timpm.scenarios.demos import get_demo, run_demo

    world = _world(material=timpm.NeoHookean(1e25, 0.3, 1e3))
    assert world.dt < 1e-11
    count = f"a run to t_end = 1 s at dt = {world.dt:g} s " + _steps(f"{1.0 / world.dt:.3g}")
    with pytest.raises(ValueError, match=re.escape(count)):
        timpm.Solver(world).run(t_end=1.0)
    dt = get_demo("disks", E=1e30).world().dt
    with pytest.raises(ValueError, match=re.escape(_steps(f"{1.0 / dt:.3g}"))):
        run_demo("disks", E=1e30, t_end=1.0)


def test_allowed_many_steps_are_counted_not_refused():
    assert checks.step_count(1e-290, 1e-300, allow_many_steps=True) == 10 ** 10
    assert checks.step_count(0.1, 1e-4) == 1000
    with pytest.raises(ValueError, match=re.escape(_steps("1e+10"))):
        checks.step_count(1e-290, 1e-300)


def test_whole_numbers_given_as_floats_are_taken():
    """What a command line gives as a float (--param width=8) is an integer when whole."""
    assert _problem("soil-column", n_terms=4000.0).n_terms == 4000
    assert type(_problem("soil-column", n_terms=4000.0).n_terms) is int
    assert _problem("soil-column-2d", width=8.0).width == 8
    from timpm.scenarios.demos import get_demo

    assert get_demo("dam-break", cells_per_a=20.0).cells_per_a == 20


def test_the_size_estimate_bounds_what_a_solver_takes():
    """The refusal's estimate is the least a scene needs: the state of real scenes, 1D to
    3D, takes at least that much (engine fields, Solver.memory(), and the model's copies
    of positions, velocities, volumes and masses)."""
    from timpm.problems import get_problem

    scenes = [get_problem("vibrating-string").scene(elements=8), _world(),
              timpm.World(domain=(1.0,) * 3, cells=4, transfer="musl", bodies=[timpm.Body(
                  timpm.Box((0.25,) * 3, (0.75,) * 3), "water")])]
    for scene in scenes:
        solver = timpm.Solver(scene, mode="serial", energies=False)
        m = solver.memory()
        model = 8 * (2 * solver.dim + 2)  # positions, velocities, volumes, masses
        taken = (m["particle_bytes"] + model) * m["particles"] + m["node_bytes"] * m["nodes"]
        assert checks.state_bytes(m["particles"], m["nodes"], solver.dim) <= taken
        solver.release()


@pytest.mark.parametrize("command", ["run", "convergence", "demo", "study"])
def test_every_command_with_a_mode_takes_team(command):
    argv = {"run": VS, "convergence": ["convergence", "vibrating-string"],
            "demo": ["demo", "disks"], "study": SE}[command]
    assert _parser().parse_args(argv + ["--mode", "team"]).mode == "team"


def test_list_shows_every_basis_and_each_problems_parameters(capsys):
    from dataclasses import fields

    from timpm.problems import PROBLEMS
    from timpm.scenarios.demos import DEMOS

    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    bases = next(line for line in lines if line.startswith("bases"))
    named, rule = bases.split(": ", 1)[1].split("; ")
    assert named.split(", ") == list(timpm.BASES)
    assert rule == "bsplineN and uniform-bsplineN for degree N = 1 to 8 (clamped, padded uniform)"
    for name, cls in {**PROBLEMS, **DEMOS}.items():
        at = next(i for i, line in enumerate(lines) if line.split()[0] == name)
        shown = lines[at] if "parameters:" in lines[at] else lines[at + 1]
        listed = dict(p.split("=") for p in shown.split("parameters: ")[1].split(", "))
        defaults = cls()
        assert listed == {f.name: f"{getattr(defaults, f.name):g}"
                          if isinstance(getattr(defaults, f.name), float)
                          else str(getattr(defaults, f.name)) for f in fields(cls)}, name


def _timpm(*args, env=None):
    """``python -m timpm ARGS`` in a fresh process, Taichi's banner not silenced."""
    base = {k: v for k, v in os.environ.items() if k != "ENABLE_TAICHI_HEADER_PRINT"}
    return subprocess.run([sys.executable, "-m", "timpm", *args], capture_output=True,
                          text=True, timeout=120, env={**base, **(env or {})})


def test_the_command_exits_fast_and_keeps_its_kernels_and_outputs(tmp_path):
    # the timpm command ends with os._exit after finalising Taichi (exit_process): the
    # kernels it compiled must still reach the offline cache, its outputs their files,
    # and its exit status the caller
    cache, doc = tmp_path / "cache", tmp_path / "table.json"
    proc = _timpm("convergence", "vibrating-string", "--elements", "4", "8", "--t-end", "0.1",
                  "--json", str(doc), env={"TI_OFFLINE_CACHE_FILE_PATH": str(cache)})
    assert proc.returncode == 0, proc.stderr
    runs = json.loads(doc.read_text())["runs"]
    assert [r["elements"] for r in runs] == [4, 8]
    for r in runs:  # the table printed in full before the exit
        assert f"{r['rms_error']:.4e}" in proc.stdout
    cached = [f for f in cache.rglob("*") if f.is_file()]
    assert cached, "no kernel reached Taichi's offline cache"
    refused = _timpm("run", "no-such-problem")
    assert refused.returncode == 2 and "timpm: error" in refused.stderr


def test_help_is_not_preceded_by_the_taichi_banner():
    for args in (["--help"], ["run", "--help"]):
        proc = _timpm(*args)
        assert proc.returncode == 0
        assert proc.stdout.startswith("usage: timpm") and "[Taichi]" not in proc.stdout
    # the banner comes when Taichi starts, once
    base = {k: v for k, v in os.environ.items() if k != "ENABLE_TAICHI_HEADER_PRINT"}
    script = "import timpm; timpm.init(); timpm.init(threads=1)"  # a start, a restart
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120, env=base)
    assert proc.returncode == 0 and proc.stdout.count("[Taichi] version") == 1


def test_a_log_level_set_in_the_environment_is_taichis_without_a_warning():
    # timpm quiets Taichi's notes unless TI_LOG_LEVEL says otherwise; given both, Taichi
    # warned "Environment variable TI_LOG_LEVEL=... overridden by ti.init argument" at
    # every start (the test workers' first lines, 2026-11-28)
    script = "import timpm; timpm.init(); timpm.init(threads=1)"  # a start, a restart
    for level, noted in (("warn", False), ("debug", True)):
        env = dict(os.environ, TI_LOG_LEVEL=level)
        proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                              timeout=120, env=env)
        assert proc.returncode == 0, proc.stderr
        assert "overridden" not in proc.stderr + proc.stdout
        # Taichi's debug notes (its worker threads starting) where asked, and only there
        assert ("[D " in proc.stderr + proc.stdout) == noted, proc.stderr


@pytest.mark.parametrize("value", ["abc", "-2"])
def test_a_bad_TIMPM_THREADS_exits_2_without_a_traceback(value):
    proc = _timpm(*VS, "--elements", "4", env={"TIMPM_THREADS": value})
    assert proc.returncode == 2
    assert proc.stderr.strip() == (f"timpm: error: the environment variable TIMPM_THREADS must "
                                   f"be a positive integer (worker threads), got {value!r}")
    assert "[Taichi]" not in proc.stdout  # refused before Taichi started


def test_a_bad_TIMPM_ARCH_exits_2_without_a_traceback():
    proc = _timpm(*VS, "--elements", "4", env={"TIMPM_ARCH": "gpu"})
    assert proc.returncode == 2
    assert proc.stderr.strip() == ("timpm: error: the environment variable TIMPM_ARCH must "
                                   "name a backend: cpu, cuda, vulkan, metal; got 'gpu'")


@pytest.mark.skipif(is_arch_supported(ti.cuda), reason="this machine has CUDA")
@pytest.mark.parametrize("command", [VS, ["run", str(ROOT / "examples" / "disks.toml")]])
def test_a_missing_gpu_backend_exits_2_not_a_cpu_run(command):
    """--arch cuda without CUDA: one line, exit 2, nothing run on the CPU instead."""
    proc = _timpm(*command, "--arch", "cuda", "--quiet")
    assert proc.returncode == 2
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("timpm: error: timpm cannot run on the cuda backend: it is not "
                           "available on this machine (available: cpu")
    assert "--arch cpu" in last and "Traceback" not in proc.stderr


def test_a_failing_plot_loses_neither_the_result_nor_a_whole_file(tmp_path, capsys,
                                                                   monkeypatch):
    """Output failures after the run (a full disk) are errors, not tracebacks: the JSON,
    the result, is written before the plot, and no partial file is left."""
    import json

    def full_disk(fig, path, **kwargs):  # half a file written, then the disk is full
        with open(path, "wb") as f:
            f.write(b"\x89PNG half")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("matplotlib.figure.Figure.savefig", full_disk)
    out, png = tmp_path / "out.json", tmp_path / "conv.png"
    code = main(["convergence", "vibrating-string", "--elements", "4", "8", "--quiet",
                 "--json", str(out), "--plot", str(png)])
    assert code == 2
    # the message names the file it could not write (issue 35: it named none)
    assert capsys.readouterr().err == f"timpm: error: could not write {png}: No space left on device\n"
    assert [r["elements"] for r in json.loads(out.read_text())["runs"]] == [4, 8]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]  # no half PNG


@pytest.mark.parametrize("args, message", [
    (VS + ["--elements", "1000000000000"], "4e+12 particles, " + INDEX),
    (VS + ["--dt", "1e-300", "--t-end", "1e-290"], _steps("1e+10")),
    (["convergence", "mms-2d", "--elements", "8", "100000"], "4e+10 particles, " + INDEX),
])
def test_sizes_and_step_counts_are_refused_before_taichi_starts(args, message):
    proc = _timpm(*args)
    assert proc.returncode == 2 and message in proc.stderr
    assert proc.stdout == "" and "Traceback" not in proc.stderr  # no banner: Taichi not started


def test_available_memory_is_bounded_by_the_control_groups_limit(tmp_path, monkeypatch):
    limit, unlimited = tmp_path / "memory.max", tmp_path / "unlimited"
    limit.write_text("1000000\n")
    unlimited.write_text("max\n")
    monkeypatch.setattr(checks, "_CGROUP_LIMITS", (str(unlimited),))
    machine = AVAILABLE_MEMORY()
    assert machine is None or machine > 1000000
    monkeypatch.setattr(checks, "_CGROUP_LIMITS", (str(tmp_path / "absent"), str(limit)))
    assert AVAILABLE_MEMORY() == 1000000
