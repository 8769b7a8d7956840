"""Faults of issue 48 (round 4, second run), items 4, 5 and 7, and issue 45's item 9
leftovers: the K0 weight of overlapping bodies as placed, TI_ARCH against --arch, and the
small surfaces (demo help, the slope demo's advice, shared edges, --set blamed, non-finite
writes, element tests at zero strength, huge increment counts).  The commands are the
issues', small and fast."""
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import CHILD_ENV, default_signals
from timpm import Body, Box, K0, MohrCoulomb, World
from timpm.model.geostatic import vertical_stress

ROOT = Path(__file__).resolve().parent.parent
G = 9.81


def _timpm(*args, env=None, timeout=120, cwd=None):
    """``timpm ARGS`` in a child process: (exit code, stdout + stderr)."""
    p = subprocess.run([sys.executable, "-m", "timpm", *map(str, args)], capture_output=True,
                       text=True, env={**CHILD_ENV, **(env or {})}, timeout=timeout,
                       cwd=cwd or ROOT, preexec_fn=default_signals)
    return p.returncode, p.stdout + p.stderr


# ---- item 4: K0 weighs every body as placed ---------------------------------------------
def _soil(density):
    return MohrCoulomb(E=1e7, nu=0.3, density=density, friction_angle=30.0, cohesion=5e3)


@pytest.mark.parametrize("lens_first", [False, True])
def test_k0_weighs_a_denser_lens_placed_inside_a_layer(lens_first):
    """A lens (2 <= y <= 3, 4 <= x <= 6) placed with allow_overlap inside a layer 4 m deep:
    the World fills the common region with the particles of both bodies, so the column
    through the lens carries the lens's whole weight on top of the layer's.  The stress
    under it exceeds the stress beside it by rho_lens g t (t = 1 m), to the integral's
    1e-4 of sigma_v, whichever body comes first."""
    rho, rho_lens, t = 1800.0, 2600.0, 1.0
    layer, lens = Body(Box((0, 0), (10, 4)), _soil(rho)), Body(Box((4, 2), (6, 3)), _soil(rho_lens))
    w = World(domain=(10.0, 5.0), cells=10, basis="linear", transfer="musl",
              allow_overlap=True, bodies=[lens, layer] if lens_first else [layer, lens],
              gravity=(0, -G), initial_stress=K0(0.5))
    m = w.model
    x, sv = m.positions, -m.initial_stress[:, 1, 1]
    at = lambda xc, yc: sv[(np.abs(x[:, 0] - xc) < 1e-9) & (np.abs(x[:, 1] - yc) < 1e-9)]
    beside, under = at(1.25, 1.25), at(5.25, 1.25)
    assert len(beside) == 1 and len(under) == 1  # the layer's particle; the lens's are above
    assert beside[0] == pytest.approx(rho * G * (4.0 - 1.25), rel=1e-4)
    assert under[0] - beside[0] == pytest.approx(rho_lens * G * t, abs=1e-4 * under[0])
    # inside the lens both bodies' particles sit at each point and weigh the same
    inside = at(5.25, 2.25)
    assert len(inside) == 2 and inside[0] == inside[1]
    assert inside[0] == pytest.approx((rho * (4 - 2.25) + rho_lens * (3 - 2.25)) * G, rel=1e-4)


def test_vertical_stress_adds_the_densities_of_overlapping_shapes():
    bodies = [(Box((0.0, 0.0), (10.0, 4.0)), 1800.0), (Box((4.0, 2.0), (6.0, 3.0)), 2600.0)]
    sv = vertical_stress(np.array([[1.0, 1.0], [5.0, 1.0]]), bodies, G, top=4.0)
    np.testing.assert_allclose(sv, [1800 * G * 3, 1800 * G * 3 + 2600 * G], rtol=1e-4)


# ---- item 5: TI_ARCH never overrides --arch silently -------------------------------------
@pytest.mark.parametrize("value", ["cuda", "vulkan"])
def test_ti_arch_that_disagrees_with_the_cpu_run_is_refused(value):
    """``TI_ARCH=cuda timpm run vibrating-string`` on a CPU run: refused before Taichi
    starts (it printed Taichi's "falling back to CPU" and ran on), naming TI_ARCH, the
    backend asked for and how to fix it."""
    code, out = _timpm("run", "vibrating-string", env={"TI_ARCH": value})
    assert code == 2, out
    assert f"TI_ARCH='{value}' asks Taichi for the {value} backend, but timpm was asked for " \
           f"cpu" in out
    assert "unset TI_ARCH" in out and f"--arch {value}" in out
    assert "falling back" not in out and "Traceback" not in out and "e_RMS" not in out


def test_ti_arch_bogus_is_a_clear_error_not_an_abort():
    code, out = _timpm("run", "vibrating-string", env={"TI_ARCH": "bogus"})
    assert code == 2, out  # was -6: Taichi's C++ assertion
    assert "TI_ARCH='bogus' names no Taichi backend" in out and "unset TI_ARCH" in out
    assert "Assertion" not in out and "Traceback" not in out


@pytest.mark.parametrize("env, args", [({"TI_ARCH": "opengl"}, ()),
                                       ({"TI_ARCH": "cuda"}, ("--arch", "cpu")),
                                       ({"TI_ARCH": "cuda", "TIMPM_ARCH": "cpu"}, ())])
def test_ti_arch_is_checked_against_every_way_of_asking(env, args):
    code, out = _timpm("run", "vibrating-string", *args, env=env)
    assert code == 2 and "TI_ARCH" in out and "Traceback" not in out, out
    if args:
        assert "by --arch" in out
    elif "TIMPM_ARCH" in env:
        assert "by the environment variable TIMPM_ARCH" in out


@pytest.mark.parametrize("value", ["x64", "cpu", "CPU"])
def test_a_ti_arch_that_agrees_runs(value):
    """Taichi's name of the CPU, or timpm's (on which Taichi itself aborts), agree with a
    CPU run: it runs, on the CPU."""
    code, out = _timpm("run", "vibrating-string", "--elements", "8", env={"TI_ARCH": value})
    assert code == 0, out
    assert "energy_drift" in out


def test_ti_arch_is_refused_from_python_before_taichi_starts():
    code = ("import os; os.environ['TI_ARCH'] = 'cuda'\n"
            "from timpm.platform import runtime\n"
            "try:\n    runtime.init()\nexcept ValueError as e:\n    print('refused:', e)\n"
            "from taichi.lang import impl\nprint('started:', impl.get_runtime().prog is not None)")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=CHILD_ENV, timeout=120)
    assert "refused: the environment variable TI_ARCH='cuda'" in p.stdout, p.stdout + p.stderr
    assert "started: False" in p.stdout


def test_a_cpu_request_is_checked_against_the_arch_taichi_started():
    """A CPU run that Taichi started elsewhere (a GPU node's TI_* settings) is refused,
    naming the arch it started: faked here by a check that sees no CPU."""
    code = ("from timpm.platform import runtime\n"
            "runtime._started = lambda arch: False\n"
            "try:\n    runtime.init(arch='cpu')\nexcept runtime.BackendUnavailable as e:\n"
            "    print('refused:', e)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=CHILD_ENV, timeout=120)
    assert "refused: timpm asked Taichi for the CPU and it started on " in p.stdout, \
        p.stdout + p.stderr


# ---- item 7: small surfaces --------------------------------------------------------------
def test_demo_help_names_every_demo():
    from timpm.scenarios.demos import DEMOS

    code, out = _timpm("demo", "--help")
    assert code == 0
    assert "slope" in DEMOS and "submarine-slope" in DEMOS
    text = " ".join(out.split())  # argparse wraps the list
    assert f"one of: {', '.join(DEMOS)}" in text


def test_the_slope_demo_at_phi_0_names_the_k0_it_needs():
    """``timpm demo slope --param friction_angle=0``: Jaky's K0 of a soil without friction
    is nu / (1 - nu) = 0.43, beyond the reduced cohesion (5 kPa) under 10 m of soil; the
    demo now takes k0 and the refusal names ``--param k0`` with the least value the soil
    holds, 1 - 2 c / (gamma H) = 0.95."""
    code, out = _timpm("demo", "slope", "--param", "friction_angle=0", "--t-end", "0.01")
    assert code == 2, out
    assert "--param k0=K with K >= 0.95" in out and "raise K0" not in out
    assert "Traceback" not in out


def test_the_slope_demo_takes_k0():
    from timpm.scenarios.demos import get_demo

    world = get_demo("slope", friction_angle=0.0, k0=1.0, cells_per_H=4).world()
    s = world.model.initial_stress
    np.testing.assert_allclose(s[:, 0, 0], s[:, 1, 1])  # K0 = 1: isotropic
    with pytest.raises(ValueError, match=r"K >= 0\.95"):
        get_demo("slope", friction_angle=0.0, k0=0.9, cells_per_H=4).world()
    for bad in (0, 1.5, "abc", True):
        with pytest.raises(ValueError, match=r"demo slope: k0 \(--param k0=K\) must lie in "
                                             r"\(0, 1\]"):
            get_demo("slope", k0=bad, cells_per_H=4).world()
    # the default (Jaky's 1 - sin(phi) of the reduced soil) as before
    default = get_demo("slope", cells_per_H=4).world().model.initial_stress
    phi = np.degrees(np.arctan(np.tan(np.radians(20.0)) / 2.0))
    deep = default[:, 1, 1] < -1e3
    np.testing.assert_allclose(default[deep, 0, 0] / default[deep, 1, 1],
                               1 - np.sin(np.radians(phi)))


@pytest.mark.parametrize("edge", [4.25, 4.0])
def test_a_box_and_a_polygon_sharing_an_edge_do_not_overlap(edge):
    """A box under a polygon, the shared edge y = 4.25 on the particles' lattice (h = 1,
    ppc 2: points at 0.25, 0.75, ...): refused as overlapping (the Box was closed, the
    Polygon half-open), its points filled by both.  Both are half-open now: each lattice
    point is one body's, the one above, the bodies touch and together fill the rectangle."""
    from timpm import Polygon

    soil = _soil(1800.0)
    w = World(domain=(10.0, 10.0), cells=10, basis="linear", transfer="musl",
              bodies=[Body(Box((0, 0), (10, edge)), soil),
                      Body(Polygon([(0, edge), (10, edge), (10, 8), (0, 8)]), soil)])
    x = w.model.positions
    assert len(np.unique(x, axis=0)) == len(x) == 20 * 16
    on_edge = np.abs(x[:, 1] - edge) < 1e-12
    if edge == 4.25:
        assert on_edge.sum() == 20 and np.all(w.model.body_index[on_edge] == 1)


def test_two_boxes_and_two_prisms_sharing_a_face_do_not_overlap():
    from timpm import Prism

    soil = _soil(1800.0)
    w = World(domain=(4.0, 4.0), cells=4, basis="linear", transfer="musl",
              bodies=[Body(Box((0, 0), (4, 1.25)), soil), Body(Box((0, 1.25), (4, 3)), soil)])
    assert len(w.model.positions) == 8 * 6
    square = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)]
    w = World(domain=(2.0, 2.0, 2.0), cells=2, basis="linear", transfer="musl",
              bodies=[Body(Prism(square, z=(0.0, 1.25)), soil),
                      Body(Prism(square, z=(1.25, 2.0)), soil)])
    assert len(w.model.positions) == 4 * 4 * 4


def test_bodies_that_do_overlap_are_still_refused():
    soil = _soil(1800.0)
    with pytest.raises(ValueError, match="bodies 0 and 1 overlap"):
        World(domain=(10.0, 10.0), cells=10, basis="linear", transfer="musl",
              bodies=[Body(Box((0, 0), (10, 4.5)), soil), Body(Box((0, 4.25), (10, 8)), soil)])


@pytest.mark.parametrize("setting, blamed", [
    ("problem.params.E=-5", "problem.params.E (overridden): vibrating-string: parameter E "
                            "must be positive, got -5"),
    ("problem.params.L=0", "problem.params.L (overridden)"),
])
def test_a_set_value_out_of_range_is_blamed_on_the_override(setting, blamed, tmp_path):
    """``timpm run examples/vibrating_string.toml --set problem.params.E=-5`` was blamed
    on the file's line 18, the [problem.params] table, not the override."""
    code, out = _timpm("run", ROOT / "examples" / "vibrating_string.toml", "--set", setting,
                       cwd=tmp_path)
    assert code == 2, out
    assert blamed in out
    assert "vibrating_string.toml:18" not in out and "Traceback" not in out


def test_a_table_refused_as_a_whole_names_the_overrides_inside_it(tmp_path):
    """An error about the whole [problem.params] table (a check that names no key) names
    the override inside it besides the table's line; one that names its key blames it."""
    from timpm.scenefile import load_scene

    scene = tmp_path / "k0.toml"
    scene.write_text('[problem]\nname = "k0-layer"\nelements = 4\n\n[problem.params]\n'
                     'cohesion = 1000.0\n')
    with pytest.raises(ValueError, match=r"problem\.params\.k0 \(overridden\): k0-layer: k0 "
                                         r"must lie in \(0, 1\]"):
        load_scene(scene, {"problem.params.k0": 3.0})
    from timpm.scenefile.reader import Reader

    reader = Reader(scene, {}, {}, {("problem", "params", "k0")})
    assert reader.where(("problem", "params")) == \
        f"{scene}: problem.params (with problem.params.k0 overridden)"
    assert reader.where(("problem", "params", "k0")) == f"{scene}: problem.params.k0 (overridden)"


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_write_is_refused_naming_the_field(bad):
    """``solver.write('sigma', nan)`` was accepted and the next run stopped blaming the time
    step; now the write is refused, naming the field, and the state is as it was."""
    from timpm.simulation.solver import Solver

    w = World(domain=(1.0, 1.0), cells=4, bodies=[Body(Box((0.25, 0.25), (0.75, 0.75)),
                                                       "rubber")], gravity=(0, -9.81))
    s = Solver(w)
    sigma = s.read("sigma")
    sigma[3, 0, 1] = bad
    with pytest.raises(ValueError, match=r"write\('sigma'\): 1 of the \d+ values are not "
                                         r"finite \(NaN or infinity\), the first at index "
                                         r"\(3, 0, 1\)"):
        s.write("sigma", sigma)
    assert np.all(np.isfinite(s.read("sigma")))
    with pytest.raises(ValueError, match=r"write\('x'\): the values must be numbers"):
        s.write("x", np.full(s.read("x").shape, "a"))
    s.run(0.001)  # the run goes on
    assert np.all(np.isfinite(s.read("x")))
    s.release()


@pytest.mark.parametrize("test", ["biaxial-mc", "triaxial-mc"])
def test_an_element_test_without_strength_gives_its_result_and_record(test, tmp_path):
    """``timpm run biaxial-mc --param confinement=0 --param cohesion=0 --json r.json``
    ended in a TypeError (a relative error of 0 / 0, None, formatted) and lost its
    record.  The sample has no strength: its deviator stays 0, the closed form's; the line
    gives the absolute error and the record is written."""
    out_json = tmp_path / "r.json"
    code, out = _timpm("run", test, "--param", "confinement=0", "--param", "cohesion=0",
                       "--param", "increments=20", "--json", out_json)
    assert code == 0, out
    assert "Traceback" not in out
    assert "closed form 0 (error 0 Pa: no strength, c = 0 with p = 0 or phi = 0)" in out
    run = json.loads(out_json.read_text())["runs"][0]
    assert run["peak_deviator"] == 0.0 and run["exact_peak_deviator"] == 0.0
    assert run["peak_relative_error"] is None and run["peak_absolute_error"] == 0.0
    assert run["increments_done"] == 20


def test_a_long_element_test_says_how_long_and_keeps_its_increments_on_sigterm(tmp_path):
    """``timpm run biaxial-mc --param increments=1e6`` ran for half an hour with no word
    and kept nothing when stopped.  Now it says how long it will take after its first
    second, and SIGTERM stops it after the increment it is in: the record holds the
    increments done, marked interrupted, and the exit status is 143."""
    out_json = tmp_path / "r.json"
    p = subprocess.Popen([sys.executable, "-m", "timpm", "run", "biaxial-mc", "--param",
                          "increments=1e6", "--json", str(out_json)], cwd=tmp_path,
                         env=CHILD_ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, preexec_fn=default_signals)
    deadline = time.monotonic() + 60
    line = ""
    while time.monotonic() < deadline:  # the estimate comes after the first second
        line = p.stderr.readline()
        if "increments take about" in line or not line:
            break
    assert "timpm: biaxial-mc: 1000000 increments take about" in line
    assert "Ctrl-C stops the test and keeps the increments done" in line
    p.send_signal(signal.SIGTERM)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == 128 + signal.SIGTERM, stdout + stderr
    assert "Traceback" not in stderr
    assert "interrupted after" in stderr and f"the increments done in {out_json}" in stderr
    assert "the peak so far, after" in stdout
    run = json.loads(out_json.read_text())["runs"][0]
    done = run["increments_done"]
    assert 0 < done < 1_000_000 and run["interrupted"].startswith("biaxial-mc interrupted "
                                                                  f"after {done} of 1000000")
    assert len(run["series"]["deviator"]) == done + 1


def test_an_element_test_reports_progress():
    from timpm.studies.element_test import run_element_test

    calls = []
    r = run_element_test("biaxial-mc", increments=50, progress=lambda d, n: calls.append((d, n)))
    assert calls[-1] == (50, 50) and len(calls) == 50
    assert r["increments_done"] == 50 and "interrupted" not in r


# ---- issue 45 item 9 (c): output.frames without any output written frame by frame ---------
_FRAMES_WORLD = """[simulation]
t_end = 0.01

[domain]
size = [1.0, 1.0]
cells = 4

[[body]]
shape = "box"
lo = [0.25, 0.25]
hi = [0.75, 0.75]
material = "rubber"

[output]
frames = 5
"""


def test_a_scene_files_frames_without_frame_outputs_is_refused(tmp_path):
    """``[output] frames = 5`` with no vtk, npz, gif or landslide ran and did nothing with
    it, exit 0, while the command line refuses ``--frames`` without ``--vtk``/``--npz``;
    now refused the same way before any work, naming the key and its line."""
    path = tmp_path / "f.toml"
    path.write_text(_FRAMES_WORLD)
    code, out = _timpm("run", path, cwd=tmp_path)
    assert code == 2, out
    assert (f"{path}:15: output.frames: frames spaces the outputs written frame by frame, "
            "and the scene asks for none: give output.vtk, output.npz, output.gif or "
            "output.landslide too (or leave frames out)") in out
    assert "Starting on arch" not in out  # refused before Taichi starts
    # with an output that is written by frames it runs; a problem scene names its own
    code, out = _timpm("run", path, "--npz", tmp_path / "fr", cwd=tmp_path)
    assert code == 0, out
    assert len(list((tmp_path / "fr").glob("particles_*.npz"))) == 6
    problem = tmp_path / "p.toml"
    problem.write_text('[problem]\nname = "vibrating-string"\n\n[output]\nframes = 3\n')
    code, out = _timpm("run", problem, cwd=tmp_path)
    assert code == 2 and "give output.vtk or output.npz too" in out, out


def test_frames_from_the_command_line_or_python_are_refused_alike(tmp_path):
    from timpm.scenefile import load_scene

    path = tmp_path / "f.toml"
    path.write_text(_FRAMES_WORLD.replace("frames = 5\n", ""))
    load_scene(path)  # no frames: fine
    with pytest.raises(ValueError, match=r"output\.frames \(overridden\): frames spaces"):
        load_scene(path, {"output.frames": 3})
    code, out = _timpm("run", path, "--frames", "3", cwd=tmp_path)
    assert code == 2 and "output.frames (overridden): frames spaces" in out, out
    load_scene(path, {"output.frames": 3, "output.gif": str(tmp_path / "a.gif")})


# ---- issue 45 item 9 (b): a full disk during periodic checkpoints -------------------------
def test_a_full_disk_at_a_periodic_checkpoint_stops_cleanly_keeping_the_last_one(
        tmp_path, monkeypatch, capsys):
    """ENOSPC injected into the checkpoint writer at its third save (after part of the
    file is written): the run stops at that step (exit 2), the message says the disk is
    full, where it stopped and which checkpoint the file still holds; that checkpoint is
    whole and resumable, no temporary file stays, and --json holds the record to the step
    it stopped at, marked checkpoint_failed."""
    import errno
    import os

    from timpm.cli.main import main
    from timpm.simulation.checkpoint import load_checkpoint

    real, calls = np.savez, []

    def savez(fh, **arrays):
        calls.append(1)
        if len(calls) >= 3:
            fh.write(b"PK\x03\x04 half a file")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fh, **arrays)

    monkeypatch.setattr(np, "savez", savez)
    monkeypatch.chdir(tmp_path)
    code = main(["run", "vibrating-string", "--elements", "8", "--checkpoint", "c.npz",
                 "--checkpoint-every", "100", "--json", "r.json"])
    err = capsys.readouterr().err
    assert code == 2
    assert ("could not write c.npz: No space left on device (the disk is full): the periodic "
            "checkpoint of step 300 (t = 0.03 s) failed and the run stopped there; c.npz "
            "still holds the checkpoint of step 200, whole (timpm resume c.npz --t-end T, "
            "once there is room); the record is in r.json") in err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.npz", "r.json"]  # no temp file
    assert load_checkpoint(tmp_path / "c.npz")["step"] == 200
    run = json.loads((tmp_path / "r.json").read_text())["runs"][0]
    assert run["checkpoint_failed"]["step"] == 300 and run["checkpoint_failed"]["kept_step"] == 200
    assert run["steps"] == 300
    monkeypatch.setattr(np, "savez", real)
    assert main(["resume", "c.npz", "--t-end", "0.05", "--json", "r2.json"]) == 0
    assert json.loads((tmp_path / "r2.json").read_text())["runs"][0]["steps"] == 500


# ---- issue 45 item 9 (a): a huge value that overflows later, blamed on its own key --------
def _scene_file(tmp_path):
    from test_scenefile import SCENE

    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return path


@pytest.mark.parametrize("setting, blamed", [
    # E near the float's limit: lambda + 2 mu overflowed, the CFL limit gave dt = 0, and the
    # error blamed simulation.dt, a key the file does not give
    ("material.jelly.E=1.7e308", "material.jelly.E (overridden): neo-hookean: E = 1.7e+308 "
                                 "with density = 1000 gives a wave speed of inf m/s"),
    ("body[0].velocity=[1e300, 0.0]", "body[0] (with body[0].velocity overridden): body 0: "
                                      "its initial speed overflows a float"),
    ("loads.gravity=[0.0, -1e300]", "loads.gravity (overridden): gravity (0.0, -1e+300) "
                                    "overflows a float in the free fall"),
])
def test_a_huge_value_is_blamed_on_its_own_key(setting, blamed, tmp_path):
    code, out = _timpm("run", _scene_file(tmp_path), "--set", setting, cwd=tmp_path)
    assert code == 2, out
    assert blamed in out, out
    assert "simulation.dt" not in out and "Traceback" not in out


def test_python_refuses_the_same_overflowing_values():
    from timpm import NeoHookean, WeaklyCompressibleFluid

    with pytest.raises(ValueError, match="E = 1.7e\\+308 with density = 1000") as err:
        NeoHookean(E=1.7e308, nu=0.3, density=1000.0)
    assert err.value.key == "E"
    with pytest.raises(ValueError, match="bulk_modulus = 1e\\+308 with density = 1e-10"):
        WeaklyCompressibleFluid(bulk_modulus=1e308, density=1e-10)
    with pytest.raises(ValueError, match="a wave speed of 0 m/s"):  # underflows to 0
        NeoHookean(E=1e-300, nu=0.3, density=1e300)
    with pytest.raises(ValueError, match="body 0: its initial speed overflows") as err:
        World(domain=(1.0, 1.0), cells=4, bodies=[Body(Box((0.25, 0.25), (0.75, 0.75)),
                                                       "rubber", velocity=(1e300, 1e300))])
    assert err.value.key == "bodies[0]"
