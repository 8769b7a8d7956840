"""Issue 48 (round 4, second run), items 1, 2, 3 and 6: the factor-of-safety study's
settings checked before any work (--creep, --bracket, a k0 the reduced strength cannot
hold), the scene's [output] in the study honoured or refused, an interrupt during a
scene's gravity loading recorded honestly, gravity loading refused before it runs where it
cannot (gravity along x or none, elastic and fluid bodies, a t_max of billions of steps).
The commands are the issue's, on coarse copies of its scenes."""
import json
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from conftest import CHILD_ENV, default_signals, killed_at_exit
from timpm.cli.main import main

ROOT = Path(__file__).resolve().parent.parent
SLOPE = (ROOT / "examples" / "slope_griffiths_lane.toml").read_text()


def _strict(path):
    """The JSON file read strictly: NaN and Infinity are no JSON."""
    def refuse(name):
        raise ValueError(f"{path}: {name} is not JSON")
    return json.loads(Path(path).read_text(), parse_constant=refuse)


def _timpm(*args, cwd=None, timeout=120):
    return subprocess.run([sys.executable, "-m", "timpm", *map(str, args)], env=CHILD_ENV,
                          cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          preexec_fn=default_signals)


@pytest.fixture
def slope(tmp_path):
    """S: a coarse copy of examples/slope_griffiths_lane.toml (h = 2 m)."""
    def write(name="S.toml", text=SLOPE, output=""):
        text = text.replace("cells = 120", "cells = 30")
        if output:
            text = text.replace("[loads]", f"[output]\n{output}\n\n[loads]")
        (tmp_path / name).write_text(text)
        return tmp_path / name
    return write


def _refused(out, *words):
    assert out.returncode == 2, (out.stdout, out.stderr)
    assert "Traceback" not in out.stderr
    assert "F = 1.0000:" not in out.stderr and "F = 0.5000:" not in out.stderr  # no trial
    for w in words:
        assert w in out.stderr, out.stderr


# ---- item 1: the study's settings ------------------------------------------------------
@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "0.5"])
def test_creep_out_of_range_is_refused_naming_it(value, slope, tmp_path):
    """`--creep 0` gave 0.88 (every slope that moves failed); -1, nan, inf were met with
    'widen the bracket'; 0.5 would take a slide for a standing slope."""
    out = _timpm("study", "factor-of-safety", slope(), "--creep", value,
                 "--json", tmp_path / "f.json")
    _refused(out, f"--creep {value}", "must lie in (0, 0.1]")
    assert not (tmp_path / "f.json").exists()


@pytest.mark.parametrize("bracket, words", [
    (["1e-20", "4"], "--bracket 1e-20 4: both ends must lie in [0.01, 100]"),
    (["0.5", "1e300"], "--bracket 0.5 1e+300: both ends must lie in [0.01, 100]"),
    (["2", "1"], "--bracket 2 1: LOW must be below HIGH"),
    (["0.5", "nan"], "--bracket 0.5 nan: both ends must lie in")])
def test_a_bracket_out_of_range_is_refused_naming_it(bracket, words, slope):
    """1e-20 was blamed on `friction_angle ... got 90.0`; 1e300 planned a thousand
    bisections and printed F to 300 digits."""
    out = _timpm("study", "factor-of-safety", slope(), "--bracket", *bracket)
    _refused(out, words)
    assert "friction_angle" not in out.stderr


def test_a_tolerance_below_what_the_study_resolves_is_refused(slope):
    out = _timpm("study", "factor-of-safety", slope(), "--tolerance", "1e-9")
    _refused(out, "--tolerance 1e-09", "[0.0001, HIGH - LOW)")


def test_a_k0_the_reduced_strength_cannot_hold_names_k0_and_F(slope):
    """`k0 = 0.5` stopped the whole study at its first trial above 1.25 without naming F;
    now refused before the first trial, naming k0, the bracket's F and the largest F that
    holds it (which the check takes)."""
    from timpm.scenefile import load_scene
    from timpm.studies import factor_of_safety as fos

    path = slope("K.toml", SLOPE.replace('kind = "k0"', 'kind = "k0"\nk0 = 0.5'))
    out = _timpm("study", "factor-of-safety", path, "--bracket", "1", "2")
    _refused(out, "the bracket's high end F = 2 (--bracket)", "k0 = 0.5",
              "holds it up to F = 1.250", "HIGH of at most 1.250", "drop k0")
    world = load_scene(path).world
    fos.check_reduced(world, 1.0, 1.25)  # the limit it names holds
    with pytest.raises(ValueError, match="high end F = 1.26"):
        fos.check_reduced(world, 1.0, 1.26)


def test_creep_at_its_default_value_keeps_the_factor_and_output_json_is_the_record(slope,
                                                                                  tmp_path):
    """An accepted --creep equal to the default changes nothing; and (item 2) without
    --json the study's record goes to the scene's output.json, strict JSON; a scene's gif
    dropped with --set output.gif= (the record keeps the override)."""
    path = slope("O.toml", output='json = "scene.json"\ngif = "s.gif"')
    study = ["study", "factor-of-safety", path, "--bracket", "1", "2", "--tolerance", "0.5",
             "--quiet", "--set", "output.gif=", "--set", "simulation.t_end=2.0"]
    given = _timpm(*study, "--creep", "1e-3", cwd=tmp_path)
    assert given.returncode == 0, given.stderr
    record = _strict(tmp_path / "scene.json")
    assert record["study"] == "factor-of-safety" and record["creep"] == 1e-3
    assert record["overrides"] == {"output.gif": None, "simulation.t_end": 2.0}
    assert record["t_end"] == 2.0
    assert not (tmp_path / "s.gif").exists()
    default = _timpm(*study, "--json", tmp_path / "d.json", cwd=tmp_path)
    assert default.returncode == 0, default.stderr
    assert _strict(tmp_path / "d.json")["factor_of_safety"] == record["factor_of_safety"]


# ---- item 2: the scene's [output] -------------------------------------------------------
@pytest.mark.parametrize("output, key", [
    ('gif = "s.gif"', "output.gif"), ('vtk = "fields"', "output.vtk"),
    ('npz = "fields"', "output.npz"), ("landslide = { toe = 40.0, height = 10.0 }",
                                       "output.landslide")])
def test_an_output_of_one_run_is_refused_by_the_study(output, key, slope, tmp_path):
    """The study ignored the scene's gif (and fields) without saying so."""
    out = _timpm("study", "factor-of-safety", slope(output=output), cwd=tmp_path)
    _refused(out, f"S.toml:49: {key}: the factor-of-safety study runs the scene many times",
             f"--set {key}=")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["S.toml"]


def test_the_scenes_output_json_is_checked_before_any_work(slope, tmp_path):
    out = _timpm("study", "factor-of-safety", slope(output='json = "/proc/f.json"'),
                 cwd=tmp_path)
    _refused(out, "output.json", "/proc/f.json")


# ---- item 6: gravity loading refused before it runs --------------------------------------
LAYER = """[simulation]
name = "layer"
t_end = 0.5
basis = "bspline2"
transfer = "musl"
damping = 0.2

[domain]
size = [10.0, 6.0]
cells = CELLS
walls = { default = "roller", bottom = "sticky", top = "none" }

[material.soil]
MATERIAL

[[body]]
name = "layer"
material = "soil"
shape = "box"
lo = [0.0, 0.0]
hi = [10.0, 5.0]
ppc = 2

[initial_stress]
kind = "gravity"
LOADING

[loads]
gravity = GRAVITY

[output]
json = "r.json"
"""
SOIL = ('type = "mohr-coulomb"\nE = 1e7\nnu = 0.3\ndensity = 2000.0\nfriction_angle = 30.0\n'
        'cohesion = 5e3\ndilation_angle = 0.0')


def _layer(tmp_path, cells=10, material=SOIL, loading="", gravity="[0.0, -9.81]"):
    text = (LAYER.replace("CELLS", str(cells)).replace("MATERIAL", material)
            .replace("LOADING", loading).replace("GRAVITY", gravity))
    (tmp_path / "G.toml").write_text(text)
    return tmp_path / "G.toml"


@pytest.mark.parametrize("kw, words", [
    (dict(gravity="[-9.81, 0.0]"), "gravity = (-9.81, 0.0) has no y component"),
    (dict(gravity="[0.0, 0.0]"), "gravity is zero: there is no weight to load it with"),
    (dict(gravity="[0.0, 9.81]"), "has an upward y component"),
    (dict(material='type = "linear-elastic"\nE = 1e7\nnu = 0.3\ndensity = 2000.0'),
     "layer cannot start from one: linear-elastic"),
    (dict(material='type = "fluid"\ndensity = 1000.0\nbulk_modulus = 2e6\nviscosity = 1e-3'),
     "layer cannot start from one: fluid"),
    (dict(cells=20, loading="t_max = 1e7"),
     "t_max = 1e+07 s at dt = 0.00215 s takes 4.64e+09 steps")])
def test_gravity_loading_that_cannot_run_is_refused_before_it_runs(kw, words, tmp_path,
                                                                   monkeypatch, capsys,
                                                                   kernel_calls):
    """Along x or with no gravity the whole loading ran and reported 'kinetic energy
    nan/inf'; elastic and fluid bodies were refused after the full loading; t_max = 1e7
    was refused quoting a t_end of t_max / 40 and advising --allow-many-steps (which the
    loading did not take), or ran billions of steps in chunks each under the limit."""
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(_layer(tmp_path, **kw))]) == 2
    err = capsys.readouterr().err
    assert "G.toml:" in err and "initial_stress" in err and words in err, err
    assert "nan" not in err and "Traceback" not in err
    assert kernel_calls == []  # nothing compiled, nothing run
    assert not (tmp_path / "r.json").exists()


def test_allow_many_steps_lifts_the_loadings_limit(tmp_path, monkeypatch, capsys):
    """The refusal's advice works: --allow-many-steps runs a loading longer than the limit
    (here lowered to 500 steps; t_max = 5 s is 1161 of them)."""
    import timpm.platform.checks as checks

    monkeypatch.setattr(checks, "MAX_STEPS", 500)
    monkeypatch.chdir(tmp_path)
    scene = str(_layer(tmp_path, loading="t_max = 5.0"))
    assert main(["run", scene]) == 2
    err = capsys.readouterr().err
    assert "t_max = 5 s" in err and "[initial_stress] t_max" in err
    assert "--allow-many-steps" in err
    assert main(["run", scene, "--allow-many-steps", "--quiet"]) == 0, capsys.readouterr().err
    assert _strict(tmp_path / "r.json")["steps"] == 116


def test_a_study_on_a_gravity_loaded_slope_with_an_elastic_body_is_refused_first(tmp_path):
    """Every trial's loading was refused (the elastic base takes no initial stress) and
    read as a slope that failed: 'widen the bracket'.  Now refused before any trial."""
    text = _layer(tmp_path).read_text().replace(
        "[[body]]", '[material.base]\ntype = "linear-elastic"\nE = 1e8\nnu = 0.3\n'
        'density = 2000.0\n\n[[body]]\nname = "base"\nmaterial = "base"\nshape = "box"\n'
        'lo = [0.0, 0.0]\nhi = [10.0, 1.0]\nppc = 2\n\n[[body]]', 1).replace(
        "lo = [0.0, 0.0]\nhi = [10.0, 5.0]", "lo = [0.0, 1.0]\nhi = [10.0, 5.0]").replace(
        '[output]\njson = "r.json"\n', "")
    (tmp_path / "G.toml").write_text(text)
    out = _timpm("study", "factor-of-safety", tmp_path / "G.toml", "--bracket", "1", "2")
    _refused(out, "base cannot start from one: linear-elastic")
    assert "widen the bracket" not in out.stderr


# ---- item 3: an interrupt during the gravity loading ---------------------------------------
@pytest.mark.parametrize("with_record", [True, False])
def test_an_interrupt_during_gravity_loading_claims_only_what_it_wrote(with_record,
                                                                         tmp_path):
    """SIGTERM during the scene's gravity loading printed 'partial record r.json' with the
    loading run's step and time, and wrote no record and no checkpoint.  Now: the line
    says the loading was interrupted and no state was saved; the record, where the scene
    asks for one, is written and says so; none is named where none was written."""
    scene = _layer(tmp_path, loading="t_max = 5000.0\ntolerance = 1e-12")
    if not with_record:
        scene.write_text(scene.read_text().replace('[output]\njson = "r.json"\n', ""))
    run = subprocess.Popen([sys.executable, "-m", "timpm", "run", str(scene), "--progress",
                            "--checkpoint", str(tmp_path / "c.npz")], cwd=tmp_path,
                           env=CHILD_ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, preexec_fn=default_signals)
    lines, loading = [], threading.Event()

    def read():
        for line in run.stderr:
            lines.append(line)
            if line.startswith("gravity loading: t ="):
                loading.set()
    reader = threading.Thread(target=read, daemon=True)
    with killed_at_exit(run):
        reader.start()
        assert loading.wait(timeout=120), "".join(lines)
        run.send_signal(signal.SIGTERM)
        run.wait(timeout=60)
        reader.join(timeout=10)
    err = "".join(lines)
    assert run.returncode == 143, err
    assert "Traceback" not in err
    assert "interrupted by SIGTERM during the gravity loading" in err
    assert "no state saved" in err and "state saved to" not in err
    assert not (tmp_path / "c.npz").exists()
    assert not (tmp_path / "timpm-interrupted.npz").exists()
    if with_record:
        assert "partial record r.json" in err
        record = _strict(tmp_path / "r.json")
        assert record["interrupted"] is True and record["steps"] == 0
        assert record["interrupted_during"] == "gravity loading"
        assert record["gravity_loading"]["t_max"] == 5000.0
        assert 0 < record["gravity_loading"]["t"] < 5000.0
    else:
        assert "partial record" not in err
        assert sorted(p.name for p in tmp_path.iterdir()) == ["G.toml"]
