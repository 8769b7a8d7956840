"""Faults an operator meets (issue 35): outputs that cannot be written or that collide,
refused before any work; SIGTERM and SIGHUP handled as Ctrl-C; sweep workers that die with
their parent; step counts checked before any kernel; unique temporary names; stale field
frames.  The commands are the issue's, as a user types them."""
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from conftest import CHILD_ENV, default_signals, killed_at_exit, wait_until
from timpm.simulation.checkpoint import load_checkpoint
from timpm.cli.main import main
from timpm.platform.files import OutputError, check_distinct, check_output, replacing, write_json

ROOT = Path(__file__).resolve().parent.parent
ENV = CHILD_ENV


def _cli(*args):
    return main([str(a) for a in args])


# ---- outputs checked before any work -----------------------------------------------------
@pytest.mark.parametrize("args, message", [
    (["run", "vibrating-string", "--csv", "/proc/x.csv"], "--csv /proc/x.csv: no file can be written in /proc"),
    (["run", "vibrating-string", "--json", "/proc/x.json"], "--json /proc/x.json: no file can be written"),
    (["run", "vibrating-string", "--checkpoint", "/proc/x.npz"], "--checkpoint /proc/x.npz: no file"),
    (["run", "vibrating-string", "--plot", "p.xyz"], "--plot p.xyz: the format is chosen by the suffix"),
    (["run", "vibrating-string", "--json", ""], "--json needs a file name"),
    (["run", "vibrating-string", "--json", "/nonexistent/dir/r.json"], "the directory /nonexistent/dir does not exist"),
    (["run", "vibrating-string", "--json", "/tmp"], "--json /tmp: is a directory"),
    (["run", "vibrating-string", "--vtk", ""], "--vtk needs a directory name"),
    (["convergence", "vibrating-string", "--plot", "/proc/c.png"], "--plot /proc/c.png: no file"),
    (["demo", "disks", "--out", "/proc/d.gif"], "--out /proc/d.gif: no file"),
    (["demo", "disks", "--json", "/proc/d.json"], "--json /proc/d.json: no file"),
])
def test_an_output_that_cannot_be_written_is_refused_first(args, message, capsys, tmp_path,
                                                            monkeypatch, kernel_calls):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert kernel_calls == []  # before Taichi compiles or runs anything


def test_kernel_calls_sees_a_run(kernel_calls, capsys):
    assert _cli("run", "vibrating-string", "--elements", "4", "--t-end", "0.01") == 0
    assert "Program._bind_kernels.<locals>.advance" in kernel_calls


@pytest.mark.parametrize("args, message", [
    (["run", "vibrating-string", "--json", "c.npz", "--checkpoint", "c.npz"],
     "--checkpoint c.npz names the same file as --json"),
    (["run", "vibrating-string", "--json", "r.out", "--csv", "r.out"], "--csv r.out names the same file as --json"),
    (["run", "vibrating-string", "--json", "r.png", "--plot", "r.png"], "--plot r.png names the same file as --json"),
])
def test_outputs_that_name_one_file_are_refused(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())  # nothing written


@pytest.mark.parametrize("option", ["--json", "--checkpoint"])
def test_a_scene_files_output_may_not_overwrite_it(option, capsys, tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text((ROOT / "examples" / "vibrating_string.toml").read_text())
    before = scene.read_text()
    assert _cli("run", scene, option, scene) == 2
    err = capsys.readouterr().err
    assert "names the" in err and "scene file" in err
    assert scene.read_text() == before


def test_a_toml_option_value_is_not_a_scene_file(tmp_path, monkeypatch):
    """`timpm run vibrating-string --elements 4 --json out.toml`: a problem run whose JSON
    happens to end in .toml (issue 35, 9)."""
    monkeypatch.chdir(tmp_path)
    assert _cli("run", "vibrating-string", "--elements", 4, "--json", "out.toml", "--quiet") == 0
    assert json.loads((tmp_path / "out.toml").read_text())["runs"][0]["elements"] == 4


def test_a_resume_may_not_overwrite_its_checkpoint_with_the_record(tmp_path, capsys):
    saved = tmp_path / "c.npz"
    assert _cli("run", "vibrating-string", "--quiet", "--checkpoint", saved) == 0
    assert _cli("resume", saved, "--t-end", 0.2, "--json", saved) == 2
    assert "the checkpoint resumed" in capsys.readouterr().err
    assert load_checkpoint(saved)["step"] > 0


# ---- the step count before any kernel ----------------------------------------------------
@pytest.mark.parametrize("key, value, message", [
    ("simulation.t_end", 1e300, "more than the 1e+08 a run may take"),
    ("simulation.dt", 1e-300, "more than the 1e+08 a run may take"),
    ("material.rubber.E", 1e300, "a run to t_end = 3.5 s at dt = "),
    ("material.rubber.density", 1e-300, "a run to t_end = 3.5 s at dt = "),
])
def test_huge_step_counts_are_refused_before_taichi(key, value, message, capsys, kernel_calls):
    assert _cli("run", ROOT / "examples" / "disks.toml", "--set", f"{key}={value!r}",
                "--set", "domain.cells=16", "--set", "output.gif=", "--set", "output.frames=") == 2, key
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and "set_arg_int" not in err
    assert "--allow-many-steps" in err
    assert kernel_calls == []


def test_the_scene_file_command_takes_allow_many_steps(capsys):
    # accepted as an option (the run itself is then refused as zero-length, not parsed away)
    assert _cli("run", ROOT / "examples" / "disks.toml", "--allow-many-steps", "--t-end",
                1e-12, "--set", "output.gif=", "--set", "output.frames=") == 2
    assert "the run would take no step" in capsys.readouterr().err


def test_a_zero_step_world_run_is_refused(capsys):
    assert _cli("run", ROOT / "examples" / "disks.toml", "--t-end", 1e-12,
                "--set", "output.gif=", "--set", "output.frames=") == 2
    err = capsys.readouterr().err
    assert "shorter than half a step" in err and "t_end = 1e-12 s" in err


# ---- temporary names, stale frames ---------------------------------------------------------
def test_two_writers_of_one_file_never_leave_it_half_written(tmp_path):
    """Each writer has its own temporary file: no FileNotFoundError, and a reader always
    parses a whole document (issue 35, 8)."""
    target = tmp_path / "r.json"
    errors = []

    def writer(k):
        try:
            for i in range(200):
                write_json(target, {"writer": k, "i": i, "pad": "x" * 2000})
        except Exception as exc:  # noqa: BLE001 - any failure is the finding
            errors.append(exc)

    threads = [threading.Thread(target=writer, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    reads = 0
    while any(t.is_alive() for t in threads):
        if target.exists():
            json.loads(target.read_text())
            reads += 1
    for t in threads:
        t.join()
    assert not errors and reads > 0
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]  # no temporary file left


def test_records_are_strict_json(tmp_path):
    """No record holds Infinity or NaN (strict parsers refuse them): non-finite numbers,
    also NumPy's and those in arrays, are written null."""
    import numpy as np

    target = tmp_path / "r.json"
    write_json(target, {"slid": math.inf, "nan": float("nan"), "np": np.float64(-np.inf),
                        "series": np.array([1.0, np.nan]), "trials": [{"d": (2.0, math.inf)}],
                        "kept": 1.5})
    text = target.read_text()
    assert "Infinity" not in text and "NaN" not in text
    assert json.loads(text) == {"slid": None, "nan": None, "np": None, "series": [1.0, None],
                                "trials": [{"d": [2.0, None]}], "kept": 1.5}


def test_a_failed_write_names_its_file_and_leaves_nothing(tmp_path):
    target = tmp_path / "out.bin"
    with pytest.raises(OutputError, match=f"could not write {target}"):
        with replacing(target):
            raise OSError(28, "No space left on device")
    assert not list(tmp_path.iterdir())


def test_a_new_field_series_replaces_an_older_longer_one(tmp_path):
    frames = tmp_path / "f"
    assert _cli("run", "vibrating-string", "--quiet", "--npz", frames, "--frames", 8) == 0
    assert len(list(frames.glob("particles_*.npz"))) == 9
    assert _cli("run", "vibrating-string", "--quiet", "--npz", frames, "--frames", 3) == 0
    assert sorted(p.name for p in frames.iterdir()) == [f"particles_{i:05d}.npz" for i in range(4)]


def test_output_checks_directly():
    with pytest.raises(ValueError, match="--x needs a file name"):
        check_output("", "--x")
    with pytest.raises(ValueError, match="--b a.json names the same file as the input"):
        check_distinct({"--b": "a.json"}, {"the input": "./a.json"})


# ---- signals -------------------------------------------------------------------------------
@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_sigterm_and_sighup_stop_a_run_like_ctrl_c(tmp_path, sig, code):
    """A batch scheduler's SIGTERM (or a closed terminal's SIGHUP): the run stops at a step
    boundary, writes its checkpoint and partial record, exits 128 + the signal, and the
    checkpoint resumes."""
    saved, record = tmp_path / "run.npz", tmp_path / "run.json"
    run = subprocess.Popen(
        [sys.executable, "-m", "timpm", "run", "vibrating-string", "--t-end", "1e5",
         "--allow-many-steps", "--checkpoint", str(saved), "--checkpoint-every", "20000",
         "--json", str(record)],
        env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=default_signals)
    with killed_at_exit(run):
        wait_until(run, saved.exists)
        run.send_signal(sig)
        out, err = run.communicate(timeout=60)
    assert run.returncode == code, err
    assert "Traceback" not in err and f"interrupted by {signal.Signals(sig).name} at step" in err
    partial = json.loads(record.read_text())["runs"][0]
    ckpt = load_checkpoint(saved)
    assert partial["interrupted"] is True and partial["steps"] == ckpt["step"] > 0
    assert _cli("resume", saved, "--t-end", ckpt["t"] + 0.01, "--quiet") == 0


def _as_background_job(ignored):
    """A child as a non-interactive shell's background job starts it (``cmd &``: SIGINT
    ignored) or as nohup does (SIGHUP ignored)."""
    def start():
        default_signals()
        for sig in ignored:
            signal.signal(sig, signal.SIG_IGN)
    return start


@pytest.mark.parametrize("ignored, sig, code", [
    ((signal.SIGINT,), signal.SIGTERM, 143), ((signal.SIGINT,), signal.SIGHUP, 129),
    ((signal.SIGINT, signal.SIGHUP), signal.SIGTERM, 143)])
def test_a_background_job_keeps_its_outputs_on_sigterm_and_sighup(tmp_path, ignored, sig,
                                                                  code):
    """`timpm run ... --json r.json --checkpoint c.npz &` from a script (SIGINT ignored) or
    under nohup (SIGHUP ignored too), then SIGTERM or SIGHUP: both files written, exit 128 +
    the signal, the checkpoint resumes (the deferral once gave up where SIGINT was
    ignored: exit 143 and neither file)."""
    saved, record = tmp_path / "c.npz", tmp_path / "r.json"
    run = subprocess.Popen(
        [sys.executable, "-m", "timpm", "run", "vibrating-string", "--dt", "1e-4", "--t-end",
         "5000", "--allow-many-steps", "--json", str(record), "--checkpoint", str(saved),
         "--checkpoint-every", "20000"],
        env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=_as_background_job(ignored))
    with killed_at_exit(run):
        wait_until(run, saved.exists)  # stepping (the first periodic checkpoint)
        run.send_signal(sig)
        out, err = run.communicate(timeout=60)
    assert run.returncode == code, err
    assert "Traceback" not in err
    ckpt = load_checkpoint(saved)
    partial = json.loads(record.read_text())["runs"][0]
    assert partial["interrupted"] is True and partial["steps"] == ckpt["step"] > 0
    assert _cli("resume", saved, "--t-end", ckpt["t"] + 0.01, "--quiet") == 0


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_an_interrupted_demo_writes_its_gif_and_json(tmp_path, sig, code):
    """`timpm demo slope --out s.gif --json s.json`, a signal after two frames: the GIF of the
    frames so far (and the state where it stopped) and the JSON of the run so far, marked
    interrupted, exit 128 + the signal (it kept only its PNG frames)."""
    gif, record, pngs = tmp_path / "s.gif", tmp_path / "s.json", tmp_path / "frames"
    run = subprocess.Popen(
        [sys.executable, "-m", "timpm", "demo", "slope", "--out", str(gif), "--json",
         str(record), "--png-dir", str(pngs), "--frames", "200", "--width", "320"],
        env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=default_signals)
    with killed_at_exit(run):
        wait_until(run, lambda: len(list(pngs.glob("*.png"))) >= 3)
        run.send_signal(sig)
        out, err = run.communicate(timeout=120)
    assert run.returncode == code, err
    assert "Traceback" not in err and "the run so far in" in err
    doc = json.loads(record.read_text())
    assert doc["interrupted"] is True and 0.0 < doc["t_end"] < 10.0
    assert 3 <= len(doc["series"]["t"]) < 201 and doc["series"]["t"][-1] == doc["t_end"]
    from PIL import Image
    with Image.open(gif) as im:  # (the writer merges a frame identical to the one before)
        assert 3 <= im.n_frames <= len(doc["series"]["t"])


SWEEP = [sys.executable, "-m", "timpm", "convergence", "vibrating-string", "--basis",
         "bspline2", "--mass", "consistent", "--elements", "32", "64", "128", "256", "512",
         "--t-end", "8", "--workers", "2"]


def _sweep_with_workers(command=SWEEP):
    """The issue's --workers 2 sweep (or ``command``), started, and its worker pids once
    both run."""
    run = subprocess.Popen(command, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, preexec_fn=default_signals)
    wait_until(run, lambda: len(_children(run.pid)) >= 2)
    time.sleep(1.0)
    return run, _children(run.pid)


def _children(pid):
    """The child processes of ``pid``, started by any of its threads (Dask starts them off
    the main thread)."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found += [int(p) for p in (task / "children").read_text().split()]
        except OSError:  # the thread ended
            pass
    return found


def _all_gone(pids, within=10.0):
    """Whether every process of ``pids`` has ended within ``within`` seconds."""
    deadline = time.monotonic() + within
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.2)
    return not any(_alive(p) for p in pids)


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie has died already (it waits for a parent that is gone or busy)
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_sweep_workers_die_with_their_parent(sig):
    """Killing a --workers 2 sweep's main process leaves no worker alive 10 s later (they
    held the caller's stdout open, so a pipeline hung)."""
    run, children = _sweep_with_workers()
    with killed_at_exit(run):
        run.send_signal(sig)
        run.communicate(timeout=60)
    assert _all_gone(children)


# ---- messages that say what to fix -----------------------------------------------------------
@pytest.mark.parametrize("text, message", [
    ('[problem]\nname = "vibrating-string"\nparams = { E = "stiff" }\n',
     'problem.params.E: expected a number, got "stiff" (a string)'),
    ('[problem]\nname = ""\n', "problem.name: expected a name, got an empty string (one of"),
    ('[problem]\nname = "vibrating-string"\nparams = { E = ' + "[" * 3000 + "]" * 3000 + " }\n",
     "nested too deeply"),
])
def test_scene_file_messages_say_what_to_fix(tmp_path, capsys, text, message):
    f = tmp_path / "s.toml"
    f.write_text(text)
    assert _cli("run", f) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and "ufunc" not in err


def test_a_byte_order_mark_is_read_past(tmp_path):
    f = tmp_path / "bom.toml"
    f.write_bytes(b"\xef\xbb\xbf" + (ROOT / "examples" / "vibrating_string.toml").read_bytes())
    assert _cli("run", f, "--quiet", "--t-end", 0.002) == 0


def test_a_demo_png_directory_that_cannot_be_made_is_named(capsys):
    assert _cli("demo", "disks", "--out", "/tmp/timpm-d.gif", "--png-dir", "/proc/frames") == 2
    err = capsys.readouterr().err
    assert "--png-dir /proc/frames" in err and "Traceback" not in err


def test_a_checkpoint_that_fails_at_the_end_keeps_the_record(tmp_path, capsys, monkeypatch):
    """The disk fills as the checkpoint is written after the run: the error names the
    checkpoint, and the JSON record (the result) is written still (issue 35, 1)."""
    import timpm.simulation.checkpoint as ck

    def full(path, *a, **k):
        raise OutputError(28, "No space left on device", str(path))

    monkeypatch.setattr(ck, "save_checkpoint", full)
    monkeypatch.setattr("timpm.studies.study.save_checkpoint", full, raising=False)
    record, saved = tmp_path / "r.json", tmp_path / "c.npz"
    assert _cli("run", "vibrating-string", "--quiet", "--json", record, "--checkpoint", saved) == 2
    err = capsys.readouterr().err
    assert f"could not write {saved}: No space left on device; the record is in {record}" in err
    assert json.loads(record.read_text())["runs"][0]["steps"] > 0


@pytest.mark.parametrize("key, value, message", [
    ("output.json", "/proc/x.json", "output.json /proc/x.json: no file can be written"),
    ("output.gif", "/proc/a.gif", "output.gif /proc/a.gif: no file can be written"),
    ("output.npz", "/proc/frames", "/proc/frames: cannot be created"),
    ("output.json", "", "output.json"),
])
def test_a_scene_files_unwritable_output_is_named(key, value, message, capsys, kernel_calls):
    code = _cli("run", ROOT / "examples" / "disks.toml", "--set", f"{key}={value!r}" if value
                else f"{key}=\"\"", "--set", "domain.cells=16")
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err
    assert kernel_calls == []


def test_a_scene_files_checkpoint_on_proc_is_refused(capsys):
    assert _cli("run", ROOT / "examples" / "disks.toml", "--checkpoint", "/proc/x.npz") == 2
    assert "--checkpoint /proc/x.npz: no file can be written" in capsys.readouterr().err


@pytest.mark.parametrize("args, message", [
    (["--json", "o.json", "--vtk", "o.json"], "names the same file as --json"),
    (["--npz", "frames.json", "--json", "frames.json"], "names the same file"),
])
def test_a_field_directory_may_not_be_another_output(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _cli("run", "vibrating-string", *args) == 2
    assert message in capsys.readouterr().err


def test_a_field_directory_that_is_a_file_is_refused(capsys, tmp_path):
    f = tmp_path / "f.txt"
    f.write_text("mine")
    assert _cli("run", "vibrating-string", "--npz", f) == 2
    assert "is a file, not a directory" in capsys.readouterr().err
    assert f.read_text() == "mine"


@pytest.mark.parametrize("args", [["--out", "d.gif", "--json", "d.gif"],
                                  ["--out", "d.png", "--plot", "d.png"]])
def test_demo_outputs_may_not_collide(args, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _cli("demo", "disks", *args) == 2
    assert "names the same file as" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("executor", [["--workers", "2"], ["--dask", "local"]])
def test_sigterm_to_a_sweep_stops_its_workers_cleanly(executor, tmp_path):
    """SIGTERM to a --workers or --dask local sweep: the command stops its workers itself
    (no leaked semaphore warning, no worker left, no log of Dask's teardown), says how far
    it got in one line, keeps the runs done as a partial record, exit 143."""
    if executor[0] == "--dask":
        pytest.importorskip("distributed")
    record = tmp_path / "sweep.json"
    run, children = _sweep_with_workers(SWEEP[:-2] + executor + ["--json", str(record)])
    with killed_at_exit(run):
        run.send_signal(signal.SIGTERM)
        out, err = run.communicate(timeout=60)
    assert run.returncode == 143, err
    said = [line for line in err.splitlines() if not line.startswith("[W ")]  # Taichi's
    assert len(said) == 1 and said[0].startswith("timpm: interrupted after "), err
    done = int(said[0].split()[3])
    assert said[0].startswith(f"timpm: interrupted after {done} of 5 runs")
    if done:  # the meshes done are kept, marked interrupted
        doc = json.loads(record.read_text())
        assert doc["interrupted"] is True and len(doc["runs"]) == done
    else:
        assert not record.exists()
    assert not list(tmp_path.glob("*.tmp*"))
    assert _all_gone(children)


INTERRUPTED_CLUSTER_START = """
import os, signal, sys, threading
import distributed
from timpm.cli.main import main

real = distributed.LocalCluster

def interrupted_start(*args, **kwargs):
    # a scheduler's SIGTERM while the cluster starts
    threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGTERM)).start()
    return real(*args, **kwargs)

distributed.LocalCluster = interrupted_start
sys.exit(main(["convergence", "vibrating-string", "--elements", "4", "8", "--dask", "local",
               "--json", sys.argv[1]]))
"""


def test_sigterm_while_a_dask_cluster_starts_stops_the_sweep_cleanly(tmp_path):
    """SIGTERM (or Ctrl-C) while the local cluster starts is held until it is up: then the
    sweep stops as at any other time, the cluster closed (stopped half-way, Dask's exit
    handler failed on it with a traceback)."""
    pytest.importorskip("distributed")
    record = tmp_path / "r.json"
    run = subprocess.run([sys.executable, "-c", INTERRUPTED_CLUSTER_START, str(record)],
                         env=ENV, capture_output=True, text=True, timeout=120,
                         preexec_fn=default_signals)
    said = [line for line in run.stderr.splitlines() if not line.startswith("[W ")]
    assert run.returncode == 143 and said == ["timpm: interrupted after 0 of 2 runs"], \
        run.stderr
    assert not record.exists()


@pytest.mark.parametrize("command", ["convergence", "speed-error"])
def test_an_interrupted_sweep_keeps_the_runs_done(command, tmp_path, capsys, monkeypatch):
    """Ctrl-C during a sweep's third run: the two runs done are written to --json, whole
    and marked interrupted, the plot is not drawn, and the command exits 130."""
    from timpm.studies import speed_error, study

    module, task = (study, "_mesh_record") if command == "convergence" else \
        (speed_error, "_configuration")
    calls, real = [], getattr(module, task)

    def stopped_at_the_third(*args):
        calls.append(args)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*args)

    monkeypatch.setattr(module, task, stopped_at_the_third)
    record, plot = tmp_path / "r.json", tmp_path / "r.png"
    args = (["convergence", "vibrating-string", "--elements", "4", "8", "16", "32"]
            if command == "convergence" else
            ["study", "speed-error", "vibrating-string", "--bases", "linear", "--masses",
             "lumped", "--elements", "4", "8", "16", "32", "--repeats", "1"])
    assert _cli(*args, "--json", record, "--plot", plot) == 130
    err = capsys.readouterr().err
    assert f"timpm: interrupted after 2 of 4 runs; partial record {record}" in err
    doc = json.loads(record.read_text())
    assert doc["interrupted"] is True
    assert [r["elements"] for r in doc["runs"]] == [4, 8]
    assert all(r["rms_error"] > 0 for r in doc["runs"])
    assert not plot.exists()


@pytest.mark.parametrize("args, message", [
    (["--json", "/dev/null"], "--json /dev/null: is not a regular file"),
    (["--csv", "/dev/null"], "--csv /dev/null: is not a regular file"),
    (["--json", "/sys/x.json"], "--json /sys/x.json: no file can be written in /sys"),
    (["--plot", "plot"], "--plot plot: the format is chosen by the suffix"),
    (["--json", "f.txt/x.json"], "the directory f.txt does not exist"),
    (["--checkpoint", "r.csv", "--csv", "r.csv"], "--checkpoint r.csv names the same file as --csv"),
])
def test_more_outputs_refused_before_any_work(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "f.txt").write_text("mine")
    assert _cli("run", "vibrating-string", *args) == 2
    assert message in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.txt"]
    assert Path("/dev/null").is_char_device()  # never replaced by a file


def test_a_resume_may_save_back_over_its_checkpoint(tmp_path):
    saved = tmp_path / "c.npz"
    assert _cli("run", "vibrating-string", "--quiet", "--checkpoint", saved) == 0
    step = load_checkpoint(saved)["step"]
    assert _cli("resume", saved, "--t-end", 0.2, "--quiet", "--checkpoint", saved) == 0
    assert load_checkpoint(saved)["step"] > step


def test_a_scene_files_checkpoint_that_fails_keeps_its_record(tmp_path, capsys, monkeypatch):
    def full(path, *a, **k):
        raise OutputError(28, "No space left on device", str(path))

    monkeypatch.setattr("timpm.scenefile.runner.save_checkpoint", full)
    record, saved = tmp_path / "r.json", tmp_path / "c.npz"
    assert _cli("run", ROOT / "examples" / "disks.toml", "--set", "domain.cells=16",
                "--t-end", 0.02, "--set", "output.gif=", "--set", "output.frames=", "--json", record,
                "--checkpoint", saved) == 2
    err = capsys.readouterr().err
    assert f"could not write {saved}: No space left on device; the record is in {record}" in err
    assert json.loads(record.read_text())["steps"] > 0


def test_ctrl_c_during_a_demo_leaves_only_whole_png_frames(tmp_path):
    """`timpm demo disks --out d.gif --png-dir p`, Ctrl-C while it draws: every PNG in p
    opens whole and no temporary file stays (issue 35, 7: a truncated PNG was left)."""
    from PIL import Image

    frames = tmp_path / "p"
    run = subprocess.Popen(
        [sys.executable, "-m", "timpm", "demo", "disks", "--out", str(tmp_path / "d.gif"),
         "--png-dir", str(frames), "--frames", "2000", "--param", "cells=32"],
        cwd=tmp_path, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=default_signals)
    with killed_at_exit(run):
        wait_until(run, lambda: len(list(frames.glob("frame_*.png"))) >= 5)
        run.send_signal(signal.SIGINT)
        out, err = run.communicate(timeout=60)
    assert run.returncode == 130 and "Traceback" not in err
    names = sorted(p.name for p in frames.iterdir())
    assert names and all(n.startswith("frame_") and n.endswith(".png") for n in names)
    for name in names:
        with Image.open(frames / name) as im:
            im.load()  # a truncated file raises here


@pytest.mark.parametrize("args, message", [
    (["--json", "/proc/x.json"], "--json /proc/x.json: no file can be written"),
    (["--plot", "x.svg"], "--plot x.svg: the format is chosen by the suffix, one of .png"),
    (["--json", "a.png", "--plot", "a.png"], "--plot a.png names the same file as --json"),
    (["--json", ""], "--json needs a file name"),
])
def test_element_test_outputs_are_checked_first(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _cli("run", "biaxial-mc", *args) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


# ---- round 4: the runtime's refusals, as one line each -----------------------------------
@pytest.mark.parametrize("argv, env, words", [
    (["--help"], {"TIMPM_TAICHI": "nonsense"}, "TIMPM_TAICHI must be 'taichi' or 'forge'"),
    (["run", "vibrating-string", "--t-end", "0.001"], {"TIMPM_TAICHI": "nonsense"},
     "TIMPM_TAICHI must be"),
    (["study", "factor-of-safety", str(Path(__file__).parent.parent / "examples"
                                       / "slope_griffiths_lane.toml")],
     {"TIMPM_ARCH": "cuda"}, "cannot run on the cuda backend"),
    (["study", "infinite-slope", "--arch", "cuda"], {}, "cannot run on the cuda backend"),
    (["run", "vibrating-string", "--threads", "100000"], {}, "more than 16 times the"),
    (["run", "vibrating-string"], {"TIMPM_THREADS": "100000"}, "TIMPM_THREADS = 100000 is more")])
def test_runtime_settings_are_refused_in_one_line(argv, env, words):
    """A bad TIMPM_TAICHI (even for --help), a backend the machine lacks for a study (which
    now takes --arch and --threads), thousands of threads (a thousand deadlocked Taichi's
    pool under a memory limit): exit 2, one line, no traceback."""
    import shutil
    if (env.get("TIMPM_ARCH") == "cuda" or "--arch" in argv) and shutil.which("nvidia-smi"):
        pytest.skip("this machine may have CUDA")
    out = subprocess.run([sys.executable, "-m", "timpm", *argv], env={**ENV, **env},
                         capture_output=True, text=True, timeout=120,
                         preexec_fn=default_signals)
    assert out.returncode == 2, out.stderr
    assert words in out.stderr and "Traceback" not in out.stderr


@pytest.mark.parametrize("argv", [
    ["large-column", "--dt", "0.1", "--allow-unstable-dt"],
    ["vibrating-bar", "--dt", "1", "--t-end", "1000", "--allow-unstable-dt",
     "--allow-many-steps"]])
def test_a_run_stopped_by_its_physics_keeps_its_record(tmp_path, capsys, argv):
    """An inverted material, an energy that grows without a source: the run stops with
    its error (exit 2, one line), and --json holds the record of the run to there, marked
    failed with the error, its code and step (it was lost)."""
    record = tmp_path / "r.json"
    assert _cli("run", *argv, "--json", record) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and f"the record of the run to there is in {record}" in err
    run = json.loads(record.read_text())["runs"][0]
    assert 0 < run["failed"]["step"] <= run["steps"] and run["failed"]["code"] > 0
    assert run["failed"]["error"] in err


@pytest.mark.parametrize("argv, words", [
    (["run", "vibrating-string", "--frames", "5"], "--frames 5 spaces the field files: give "
                                                   "--vtk DIR or --npz DIR"),
    (["demo", "disks", "--fps", "10"], "--fps shapes the GIF: give --out FILE.gif"),
    (["demo", "disks", "--png-dir", "frames", "--width", "320"],
     "--width, --png-dir shape the GIF: give --out FILE.gif")])
def test_an_option_that_needs_another_is_refused_without_it(capsys, argv, words):
    """Issue 45 item 9: --frames without a field format, a GIF's --fps, --width or --png-dir
    without --out did nothing, silently: refused before any work."""
    assert _cli(*argv) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err
