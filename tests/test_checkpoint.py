"""Checkpoints and Ctrl-C: a saved run goes on bit for bit (in this process and in a new
one), Ctrl-C stops a run at a step boundary with exit code 130 and keeps its record, and
bad checkpoints are refused clearly."""
import json
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import CHILD_ENV, default_signals, killed_at_exit, wait_until
from timpm import Body, Box, LinearElastic, Ramp, Sine, Solver, Wall, World
from timpm.simulation.checkpoint import VERSION, load_checkpoint, save_checkpoint
from timpm.cli.main import main
from timpm.engine.features import plan
from timpm.engine.state import State
from timpm.model.loads import SurfaceTraction
from timpm.model import SIDES
from timpm.problems import get_problem
from timpm.scenarios.demos import get_demo

ROOT = Path(__file__).resolve().parents[1]
ENV = CHILD_ENV


def _state(solver):
    return {k: solver.read(k) for k in ("x", "v", "F", "sigma", "vol")} | {"t": solver.t}


def test_sand_column_restored_into_a_new_solver_goes_on_bit_for_bit(tmp_path):
    """Drucker-Prager sand (plastic state) in 2D: 40 steps straight, or 15, a checkpoint
    file, a new solver of the same scene, 25 more: the same bits."""
    world = get_demo("column-collapse", cells_per_width=8).world()
    straight = Solver(world, mode="serial").run(n_steps=40)
    expected = _state(straight)
    straight.release()

    first = Solver(world, mode="serial").run(n_steps=15)
    path = save_checkpoint(tmp_path / "sand.npz", first)
    first.release()
    saved = load_checkpoint(path)
    assert saved["step"] == 15 and saved["run"] is None
    again = Solver(world, mode="serial").restore(saved)
    assert again.step == 15 and again.t == saved["t"]
    again.run(n_steps=25)
    got = _state(again)
    for key in expected:
        assert np.array_equal(got[key], expected[key]), key
    assert np.abs(again.read("sigma")).max() > 0  # stressed: the test compares something
    # the energy records go on from the saved ones
    assert len(again.energies()["t"]) == len(Solver(world, mode="serial").run(
        n_steps=40).energies()["t"])
    again.release()


def test_restore_refuses_another_scene(tmp_path):
    small = Solver(get_demo("column-collapse", cells_per_width=8).world(), mode="serial")
    other = Solver(get_demo("column-collapse", cells_per_width=10).world(), mode="serial")
    with pytest.raises(ValueError, match="does not fit this solver: its particles is"):
        other.restore(small.snapshot())
    small.release()
    other.release()


def test_restore_refuses_other_material_parameters_and_wall_friction():
    """The run-time physics of one feature set (same kernels, same sizes and time step):
    a steeper friction angle, a rougher floor."""
    demo = get_demo("column-collapse", cells_per_width=8)
    saved = Solver(demo.world(), mode="serial")
    snapshot = saved.snapshot()
    saved.release()
    steeper = Solver(get_demo("column-collapse", cells_per_width=8,
                              friction_angle=demo.friction_angle + 5.0).world(), mode="serial")
    with pytest.raises(ValueError, match=re.escape(
            f"does not fit this solver: its material 0 parameter friction_angle is "
            f"{demo.friction_angle!r}, this solver's {demo.friction_angle + 5.0!r}")):
        steeper.restore(snapshot)
    steeper.release()
    rougher = Solver(get_demo("column-collapse", cells_per_width=8,
                              floor_friction=2 * demo.floor_friction).world(), mode="serial")
    mu = [demo.floor_friction if side == "bottom" else 0.0 for side in SIDES[:4]]
    with pytest.raises(ValueError, match=re.escape(
            f"does not fit this solver: its wall_mu is {mu!r}, this solver's "
            f"{[2 * m for m in mu]!r}")):
        rougher.restore(snapshot)
    rougher.release()


def test_fingerprint_holds_the_run_time_physics_as_json_values():
    """A moving lid, a prescribed node, a surface traction, damping and a PIC share: their
    values are in the fingerprint, which reads back from JSON equal (a checkpoint's
    header); planned only, nothing compiled."""
    world = World(domain=(1.0, 1.0), cells=4, basis="linear", transfer="musl",
                  bodies=[Body(Box((0.25, 0.25), (0.75, 0.75)),
                               LinearElastic(1e4, 0.3, 1e3), ppc=1)],
                  walls={"default": "slip", "top": Wall("sticky", velocity=(0.5, 0.0))},
                  fixed_nodes={(1, 1): (0.0, -0.25)}, fixed_time=Sine(3.0),
                  tractions=[SurfaceTraction(0, "right", (10.0, 0.0), Ramp(0.5))],
                  damping=0.1, pic_fraction=0.2)
    features, layout = plan(world)
    fingerprint = State(features, layout, world, ()).fingerprint(record_every=1)
    assert json.loads(json.dumps(fingerprint)) == fingerprint
    values = fingerprint["values"]
    assert values["damping"] == 0.1 and values["pic_fraction"] == 0.2
    assert values["prescribed_param"] == 3.0 and values["surface_param"] == 0.5
    assert [0.5, 0.0] in [values["wall_velocity"][k:k + 2] for k in range(0, 8, 2)]
    assert fingerprint["fixed_nodes"] == [[1, 1]]
    assert fingerprint["fixed_velocity"] == [[0.0, -0.25]]
    assert fingerprint["material_parameters"] == [{"E": 1e4, "nu": 0.3, "density": 1e3}]
    assert (fingerprint["prescribed"], fingerprint["surface_force"]) == ("Sine", "Ramp")
    assert "scatter_block" not in values  # the thread count's: may differ on resuming


def _cli(*args):
    return main([str(a) for a in args])


def _with_run(path, to, **changes):
    """A copy at ``to`` of the checkpoint ``path`` whose run description has ``changes``:
    ``timpm resume`` then rebuilds another scene (as a problem whose default changed)."""
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(str(arrays["header"]))
    header["run"].update(changes)
    arrays["header"] = np.array(json.dumps(header))
    np.savez(to, **arrays)
    return to


def test_resume_in_a_new_process_ends_where_the_straight_run_ends(tmp_path, capsys):
    straight, part, resumed = (tmp_path / f"{k}.npz" for k in ("straight", "part", "resumed"))
    common = ("vibrating-string", "--quiet", "--mode", "serial")
    assert _cli("run", *common, "--t-end", 3, "--checkpoint", straight,
                "--json", tmp_path / "straight.json") == 0
    assert _cli("run", *common, "--t-end", 1, "--checkpoint", part,
                "--checkpoint-every", 4000) == 0
    assert load_checkpoint(part)["step"] == 10000  # the last save: the end
    done = subprocess.run([sys.executable, "-m", "timpm", "resume", str(part), "--t-end", "3",
                           "--checkpoint", str(resumed), "--json", str(tmp_path / "r.json"),
                           "--quiet"], env=ENV, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    a, b = load_checkpoint(straight), load_checkpoint(resumed)
    assert a["step"] == b["step"] == 30000
    for block in a["arrays"]:
        assert np.array_equal(a["arrays"][block], b["arrays"][block]), block
    records = [json.loads((tmp_path / f).read_text())["runs"][0]
               for f in ("straight.json", "r.json")]
    assert records[0]["rms_error"] == records[1]["rms_error"]


def test_ctrl_c_stops_the_run_saves_it_and_exits_130(tmp_path):
    saved, record = tmp_path / "run.npz", tmp_path / "run.json"
    run = subprocess.Popen(
        [sys.executable, "-m", "timpm", "run", "vibrating-string", "--t-end", "1e5",
         "--allow-many-steps",
         "--checkpoint", str(saved), "--checkpoint-every", "20000", "--json", str(record)],
        env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=default_signals)
    with killed_at_exit(run):
        wait_until(run, saved.exists)  # running: its first checkpoint is on disk
        run.send_signal(signal.SIGINT)
        out, err = run.communicate(timeout=60)
    assert run.returncode == 130, err
    lines = [line for line in err.splitlines() if line.startswith("timpm")]
    assert len(lines) == 1 and "interrupted at step" in lines[0] and "timpm resume" in lines[0]
    assert "Traceback" not in err
    partial = json.loads(record.read_text())["runs"][0]
    ckpt = load_checkpoint(saved)
    assert partial["interrupted"] is True
    assert partial["steps"] == ckpt["step"] > 0
    assert 0 < partial["t_end"] < 1e5  # stopped at a step boundary, long before its end


def test_resume_refuses_a_checkpoint_of_other_run_time_physics(tmp_path, capsys):
    """The oedometer (damped, 1% PIC): resumed as saved it goes on; with another PIC share
    or damping factor it is refused, naming both values, with exit code 2."""
    part = tmp_path / "part.npz"
    common = ("--quiet", "--stress-update", "small", "--elements", 4, "--ppc", 4)
    assert _cli("run", "oedometer", *common, "--t-end", 0.01, "--checkpoint", part) == 0
    assert _cli("resume", part, "--t-end", 0.02, "--quiet") == 0
    oedometer = get_problem("oedometer")
    for name, saved, value in (("pic_fraction", oedometer.pic_fraction, 0.02),
                               ("damping", oedometer.alpha, 0.5)):
        changed = _with_run(part, tmp_path / f"{name}.npz", **{name: value})
        assert _cli("resume", changed, "--t-end", 0.02) == 2
        err = capsys.readouterr().err
        assert (f"timpm: error: the saved state does not fit this solver: its {name} is "
                f"{saved!r}, this solver's {value!r}") in err, err
        assert "Traceback" not in err


def test_resume_refuses_a_checkpoint_of_format_version_1(tmp_path, capsys):
    old = tmp_path / "old.npz"
    np.savez(old, header=np.array(json.dumps({"format": "timpm-checkpoint", "version": 1})))
    assert _cli("resume", old, "--t-end", 1) == 2
    assert (f"checkpoint {old}: written by an older timpm (format version 1) whose "
            "checkpoints do not record the run-time physics") in capsys.readouterr().err
    with pytest.raises(ValueError, match="rerun from the start"):
        load_checkpoint(old)


@pytest.mark.parametrize("content, message", [
    (None, "no such file"),
    (b"not a zip", "not a timpm checkpoint"),
])
def test_resume_refuses_a_missing_or_foreign_file(tmp_path, capsys, content, message):
    path = tmp_path / "c.npz"
    if content is not None:
        path.write_bytes(content)
    assert _cli("resume", path, "--t-end", 1) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_resume_refuses_a_numpy_file_without_a_header(tmp_path, capsys):
    path = tmp_path / "plain.npz"
    np.savez(path, x=np.zeros(3))
    assert _cli("resume", path, "--t-end", 1) == 2
    assert "no timpm header" in capsys.readouterr().err
    damaged = tmp_path / "damaged.npz"
    np.savez(damaged, header=np.array(json.dumps({"format": "timpm-checkpoint", "version": VERSION,
                                                  "step": 3})))
    assert _cli("resume", damaged, "--t-end", 1) == 2
    assert "its header lacks t, fingerprint, columns" in capsys.readouterr().err


def test_resume_refuses_an_earlier_end_and_a_python_checkpoint(tmp_path, capsys):
    part = tmp_path / "part.npz"
    assert _cli("run", "vibrating-string", "--quiet", "--t-end", 1, "--checkpoint", part) == 0
    assert _cli("resume", part, "--t-end", 0.5) == 2
    assert "lies before the saved run's time 1 s" in capsys.readouterr().err
    solver = Solver(get_demo("disks", cells=16).world())
    bare = save_checkpoint(tmp_path / "bare.npz", solver)
    solver.release()
    assert _cli("resume", bare, "--t-end", 1) == 2
    assert "holds no description of its run" in capsys.readouterr().err


def test_checkpoint_path_checked_before_the_run(tmp_path, capsys):
    assert _cli("run", "vibrating-string", "--checkpoint", tmp_path / "no" / "c.npz") == 2
    err = capsys.readouterr().err
    assert "--checkpoint" in err and "does not exist" in err


def test_ctrl_c_stops_a_scene_file_run_and_keeps_its_frames(tmp_path):
    """A world described by a scene file: Ctrl-C keeps the frames written, the partial
    JSON record and the state (in timpm-interrupted.npz), exits 130 with one line."""
    frames = tmp_path / "frames"
    run = subprocess.Popen(
        [sys.executable, "-m", "timpm", "run", str(ROOT / "examples" / "disks.toml"),
         "--set", "domain.cells=16", "--t-end", "1000", "--frames", "100000",
         "--npz", str(frames), "--json", str(tmp_path / "run.json")],
        cwd=tmp_path, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=default_signals)
    with killed_at_exit(run):
        wait_until(run, lambda: len(list(frames.glob("particles_*.npz"))) >= 3)  # frames
        run.send_signal(signal.SIGINT)
        out, err = run.communicate(timeout=60)
    assert run.returncode == 130, err
    lines = [line for line in err.splitlines() if line.startswith("timpm")]
    assert len(lines) == 1 and "interrupted at step" in lines[0], err
    assert "Traceback" not in err
    doc = json.loads((tmp_path / "run.json").read_text())
    saved = load_checkpoint(tmp_path / "timpm-interrupted.npz")
    assert doc["interrupted"] is True and doc["steps"] == saved["step"] > 0
    last = np.load(sorted(frames.glob("particles_*.npz"))[-1])
    assert int(last["step"]) <= saved["step"]
    # timpm resume rebuilds the scene from the file and its --set, and goes on
    assert _cli("resume", tmp_path / "timpm-interrupted.npz", "--t-end", saved["t"] + 0.05,
                "--quiet") == 0


def test_a_scene_file_run_resumes_bit_for_bit(tmp_path, capsys, monkeypatch):
    """A world's scene file run with --checkpoint, continued by timpm resume, ends where
    the straight run ends: every state array and the records, bit for bit (serial)."""
    monkeypatch.chdir(tmp_path)  # the file's own outputs (disks.gif, disks.json) land here
    scene = ROOT / "examples" / "disks.toml"
    common = ("--set", "domain.cells=16", "--mode", "serial", "--quiet")
    straight, part, resumed = (tmp_path / f"{k}.npz" for k in ("straight", "part", "resumed"))
    assert _cli("run", scene, *common, "--t-end", 0.4, "--checkpoint", straight) == 0
    assert _cli("run", scene, *common, "--t-end", 0.2, "--checkpoint", part) == 0
    assert _cli("resume", part, "--t-end", 0.4, "--checkpoint", resumed, "--npz",
                tmp_path / "frames", "--frames", 2, "--json", tmp_path / "r.json") == 0
    a, b = load_checkpoint(straight), load_checkpoint(resumed)
    assert a["step"] == b["step"] > load_checkpoint(part)["step"] > 0
    for block in a["arrays"]:
        assert np.array_equal(a["arrays"][block], b["arrays"][block]), block
    for key in a["history"]:
        assert np.array_equal(a["history"][key], b["history"][key]), key
    assert len(list((tmp_path / "frames").glob("particles_*.npz"))) == 3
    assert json.loads((tmp_path / "r.json").read_text())["steps"] == b["step"]


def test_resume_refuses_a_scene_file_changed_since_and_the_problem_outputs(tmp_path, capsys,
                                                                          monkeypatch):
    monkeypatch.chdir(tmp_path)  # the file's own outputs (disks.gif, disks.json) land here
    scene = tmp_path / "disks.toml"
    scene.write_text((ROOT / "examples" / "disks.toml").read_text())
    part = tmp_path / "part.npz"
    assert _cli("run", scene, "--set", "domain.cells=16", "--t-end", 0.1, "--checkpoint",
                part, "--quiet") == 0
    assert _cli("resume", part, "--t-end", 0.2, "--plot", tmp_path / "p.png") == 2
    assert "--plot: a scene file's world run" in capsys.readouterr().err
    scene.write_text(scene.read_text().replace("E = 1000.0", "E = 2000.0"))  # a stiffer
    assert _cli("resume", part, "--t-end", 0.2) == 2  # rubber: a shorter Courant step
    err = capsys.readouterr().err
    assert f"{scene} no longer builds the checkpoint's scene" in err and "its dt is" in err
    assert _cli("resume", part, "--t-end", 0.05) == 2  # before the saved time
    assert "is not after the checkpoint's time" in capsys.readouterr().err
    with np.load(part, allow_pickle=False) as data:  # a Ctrl-C save before 2026-11-25
        arrays = {k: data[k] for k in data.files}
    header = json.loads(str(arrays["header"]))
    header["run"] = {"scene_file": header["run"]["scene_file"]}
    arrays["header"] = np.array(json.dumps(header))
    np.savez(tmp_path / "old.npz", **arrays)
    assert _cli("resume", tmp_path / "old.npz", "--t-end", 0.2) == 2
    assert "written by an older timpm" in capsys.readouterr().err
