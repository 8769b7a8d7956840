"""A slope's factor of safety by strength reduction (studies/factor_of_safety.py): the
bisection and its refusals, the reduced strength, Griffiths & Lane's slope on a coarse
grid, and the slope that fails (the demo)."""
import math

import numpy as np
import pytest

from timpm.bases import Linear
from timpm.materials import MohrCoulomb
from timpm.studies import factor_of_safety as fos

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent


def test_strength_reduction_divides_c_and_tan_phi():
    soil = MohrCoulomb(E=1e8, nu=0.3, density=2000.0, friction_angle=30.0, cohesion=10e3,
                       dilation_angle=20.0)
    r = fos.reduced(soil, 2.0)
    assert r.cohesion == pytest.approx(5e3)
    assert math.tan(math.radians(r.friction_angle)) == pytest.approx(math.tan(math.radians(30)) / 2)
    assert r.dilation_angle == pytest.approx(r.friction_angle)  # psi <= phi_F
    assert (r.E, r.nu, r.density) == (soil.E, soil.nu, soil.density)
    from timpm.materials import NeoHookean
    with pytest.raises(ValueError, match="divides the strength of Mohr-Coulomb soil"):
        fos.reduced(NeoHookean(E=1e6, nu=0.3, density=1e3), 1.5)


def _stub_world():
    class World:  # what the record reads
        h, basis, transfer = 1.0, Linear, "musl"

        class model:
            positions = np.array([[0.0, 0.0], [1.0, 10.0]])
            n_particles = 2
            gravity = (0.0, -9.81)
    return World


def test_the_bisection_closes_on_the_factor(monkeypatch):
    """With a slope that fails exactly above F* the bracket shrinks around F* to the
    tolerance, and a bracket that does not hold it is refused."""
    true = 1.2345

    def stub(world, F, t_end, creep=1e-3, mode="auto"):
        return {"F": F, "failed": F > true, "displacement_end": 0.0, "creep": 0.0,
                "creep_limit": 0.0, "plastic": None, "positions": None}

    monkeypatch.setattr(fos, "trial", stub)
    World = _stub_world()
    record, failed = fos.factor_of_safety(World, 1.0, low=0.5, high=3.0, tolerance=0.01)
    lo, hi = record["bracket"]
    assert lo <= true < hi and hi - lo <= 0.01
    assert record["factor_of_safety"] == pytest.approx(true, abs=0.005)
    assert failed["F"] == hi
    with pytest.raises(ValueError, match="fails at the bracket's low end"):
        fos.factor_of_safety(World, 1.0, low=2.0, high=3.0)
    with pytest.raises(ValueError, match="stands at the bracket's high end"):
        fos.factor_of_safety(World, 1.0, low=0.5, high=1.0)
    with pytest.raises(ValueError, match="LOW must be below HIGH"):
        fos.factor_of_safety(World, 1.0, low=2.0, high=1.0)
    # what cannot give a factor is named, not met with "widen the bracket"
    for creep in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="--creep .*: the failure criterion.s creep must lie in"):
            fos.factor_of_safety(World, 1.0, creep=creep)
    with pytest.raises(ValueError, match="run of positive length"):
        fos.factor_of_safety(World, 0.0)
    World.model.gravity = (0.0, 0.0)
    with pytest.raises(ValueError, match="no weight"):
        fos.factor_of_safety(World, 1.0)


class _InProcessPool:
    """TrialPool's stand-in: the (stubbed) trials in this process, each call's factors kept."""
    calls = []

    def __init__(self, world, t_end, creep, workers, mode="auto"):
        self.workers, self.world, self.t_end = workers, world, t_end
        _InProcessPool.calls = []

    def map(self, fn, factors):
        assert fn is fos.pool_trial and 1 <= len(factors) <= self.workers
        _InProcessPool.calls.append(list(factors))
        return [fos.trial(self.world, F, self.t_end) for F in factors]

    def close(self, wait=True):
        pass


@pytest.mark.parametrize("workers", [2, 3])
def test_trials_side_by_side_close_on_the_factor(monkeypatch, workers):
    """Issue 46 item 3: ``workers`` trials a round at the points that split the bracket
    into workers + 1 parts narrow it (workers + 1)-fold a round around a sharp F*; the
    bracket's ends are run only where the search never left them, and a bracket that does
    not hold is still refused."""
    true = 1.2345

    def stub(world, F, t_end, creep=1e-3, mode="auto"):
        return {"F": F, "failed": F > true, "displacement_end": 0.0, "creep": 0.0,
                "creep_limit": 0.0, "plastic": None, "positions": None}

    monkeypatch.setattr(fos, "trial", stub)
    monkeypatch.setattr(fos, "TrialPool", _InProcessPool)
    World = _stub_world()
    record, failed = fos.factor_of_safety(World, 1.0, low=0.5, high=3.0, tolerance=0.01,
                                          workers=workers)
    lo, hi = record["bracket"]
    assert lo <= true < hi and hi - lo <= 0.01 and failed["F"] == hi
    assert record["workers"] == workers
    rounds = _InProcessPool.calls
    assert all(len(c) == workers for c in rounds)  # the factor is inside: no end was run
    assert 0.5 not in sum(rounds, []) and 3.0 not in sum(rounds, [])
    assert len(rounds) == math.ceil(math.log(2.5 / 0.01) / math.log(workers + 1))
    # a factor below the bracket: every point fails, then the low end is run and refused
    with pytest.raises(ValueError, match="fails at the bracket's low end F = 2"):
        fos.factor_of_safety(World, 1.0, low=2.0, high=3.0, tolerance=0.5, workers=workers)
    assert _InProcessPool.calls[-1] == [2.0]
    with pytest.raises(ValueError, match="stands at the bracket's high end F = 1"):
        fos.factor_of_safety(World, 1.0, low=0.5, high=1.0, tolerance=0.2, workers=workers)
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(ValueError, match="--workers must be a whole number"):
            fos.factor_of_safety(World, 1.0, workers=bad)


def test_the_workers_option(capsys):
    """``--workers auto`` runs two trials at once on a CPU of two cores or more for a slope
    of at most SMALL particles, one above; N is taken as given; anything else is refused
    by the command line before any work."""
    from timpm.cli.main import main

    World = _stub_world()
    cores = len(__import__("os").sched_getaffinity(0))
    assert fos.workers_for("auto", World) == (2 if cores >= 2 else 1)
    assert fos.workers_for(3, World) == 3
    World.model.n_particles = fos.SMALL + 1
    assert fos.workers_for("auto", World) == 1
    for bad in ("0", "-2", "two", "1.5"):
        with pytest.raises(SystemExit) as stop:
            main(["study", "factor-of-safety", str(ROOT / "examples" / "slope_griffiths_lane.toml"),
                  "--workers", bad])
        assert stop.value.code == 2
        assert f"N must be a whole number of processes, at least 1, or auto: got '{bad}'" \
            in capsys.readouterr().err


@pytest.fixture(scope="module")
def coarse_slope():
    from timpm.scenefile import load_scene

    return load_scene(ROOT / "examples" / "slope_griffiths_lane.toml",
                      overrides={"domain.cells": 60})  # h = 1 m


def test_griffiths_and_lane_slope_on_a_coarse_grid(coarse_slope):
    """Griffiths & Lane's example 1 (their finite elements: 1.4; Bishop & Morgenstern's
    charts: 1.38) with clamped quadratic B-splines at h = H / 10: within 5% of 1.4; and a
    tenfold looser failure criterion judges the runs two bracket widths either side of the
    factor alike (it stands below, fails above)."""
    scene = coarse_slope
    tol = 0.04
    record, failed = fos.factor_of_safety(scene.world, scene.t_end, low=1.0, high=2.0,
                                          tolerance=tol)
    F = record["factor_of_safety"]
    assert abs(F - 1.4) <= 0.05 * 1.4
    assert failed["failed"] and failed["plastic"].max() > 0.01  # a mechanism formed
    assert not fos.trial(scene.world, F - 2 * tol, scene.t_end, creep=1e-2)["failed"]
    assert fos.trial(scene.world, F + 2 * tol, scene.t_end, creep=1e-2)["failed"]


def test_a_failing_trial_stops_once_decided_and_decides_as_the_whole_run(coarse_slope,
                                                                       monkeypatch):
    """Issue 46 item 3: a trial well past the factor is decided in the first part of its
    last quarter (its ``decided_at``) and fails as the run to t_end does; one that stands
    runs to t_end."""
    scene = coarse_slope
    early = fos.trial(scene.world, 2.0, scene.t_end)
    stands = fos.trial(scene.world, 1.0, scene.t_end)
    monkeypatch.setattr(fos, "LAST_QUARTER_PARTS", 1)  # the whole last quarter at once
    whole = fos.trial(scene.world, 2.0, scene.t_end)
    assert early["failed"] and whole["failed"] and "decided_at" not in whole
    assert early["decided_at"] == pytest.approx(scene.t_end * (0.75 + 0.25 / 8), rel=1e-3)
    assert early["creep"] > early["creep_limit"]
    assert early["creep"] < whole["creep"]  # the mass slides on: the rest was not needed
    assert not stands["failed"] and "decided_at" not in stands


def test_trials_in_worker_processes_find_the_serial_factor(coarse_slope):
    """Two worker processes of one thread each (the trial pool) and the serial bisection
    on the same slope: brackets that overlap, factors within the tolerance."""
    scene = coarse_slope
    tol = 0.05
    serial, _ = fos.factor_of_safety(scene.world, scene.t_end, low=1.0, high=2.0,
                                     tolerance=tol)
    side, failed = fos.factor_of_safety(scene.world, scene.t_end, low=1.0, high=2.0,
                                        tolerance=tol, workers=2)
    (a, b), (c, d) = serial["bracket"], side["bracket"]
    assert max(a, c) < min(b, d)
    assert abs(serial["factor_of_safety"] - side["factor_of_safety"]) <= tol
    assert failed["failed"] and failed["plastic"].max() > 0.01  # its mechanism came back
    assert side["workers"] == 2 and all(t["wall_seconds"] > 0 for t in side["trials"])


def test_the_study_refuses_what_it_cannot_reduce(tmp_path, capsys):
    from timpm.cli.main import main

    text = (ROOT / "examples" / "slope_griffiths_lane.toml").read_text()
    f = tmp_path / "rubber.toml"
    f.write_text(text.replace('type = "mohr-coulomb"', 'type = "neo-hookean"').replace(
        "friction_angle = 20.0", "").replace("cohesion = 10e3                # c' / (gamma H) = 0.05", "")
        .replace("dilation_angle = 0.0", "").replace('[initial_stress]\nkind = "k0"\n', ""))
    assert main(["study", "factor-of-safety", str(f), "--quiet"]) == 2
    assert "no body is of it: slope (neo-hookean)" in capsys.readouterr().err
    assert main(["study", "factor-of-safety", str(ROOT / "examples" / "slope_griffiths_lane.toml"),
                 "--plot", str(tmp_path / "p.svg")]) == 2
    assert "--plot" in (err := capsys.readouterr().err) and "one of .png" in err


def test_the_slope_that_fails_runs_out():
    """Past its factor of safety (strength / 2, F = 1.4) the slope slides: the deposit runs
    beyond the toe, and the potential energy the slide released is dissipated by the end
    (what moves at the end is a small part of it)."""
    from timpm.scenarios.demos import run_demo

    r = run_demo("slope", cells_per_H=10, t_end=6.0)
    s = r.summary
    assert s["runout"] > 0.2 * 10.0
    assert s["potential_energy_released"] > 0.0
    assert s["kinetic_energy_end"] < 0.01 * s["potential_energy_released"]
    assert s["energy_dissipated"] == pytest.approx(s["potential_energy_released"], rel=0.02)


def test_an_interrupted_study_keeps_its_trials_and_resumes_to_the_same_factor(monkeypatch,
                                                                             tmp_path):
    """Interrupted during its fourth trial (Ctrl-C, or SIGTERM as the command line turns
    it), the study raises StudyInterrupted with the three trials and the bracket so far;
    that record, through the strict JSON writer, resumes: its trials are not run again and
    the study ends at the factor of the uninterrupted one.  Another study's record is
    refused."""
    import json

    from timpm.platform.files import write_json

    true, calls = 1.2345, []

    def stub(world, F, t_end, creep=1e-3, mode="auto"):
        calls.append(F)
        if stop_at is not None and len(calls) == stop_at:
            raise KeyboardInterrupt
        return {"F": F, "failed": F > true, "displacement_end": math.inf if F > true else 0.0,
                "creep": math.inf if F > true else 0.0, "creep_limit": 0.01, "stopped": None}

    monkeypatch.setattr(fos, "trial", stub)
    World = _stub_world()
    stop_at = None
    whole, _ = fos.factor_of_safety(World, 1.0, low=0.5, high=3.0, tolerance=0.01)
    calls.clear()
    stop_at = 4
    with pytest.raises(fos.StudyInterrupted) as stop:
        fos.factor_of_safety(World, 1.0, low=0.5, high=3.0, tolerance=0.01)
    partial = stop.value.partial
    assert partial["interrupted"] is True and len(partial["trials"]) == 3
    assert partial["bracket"] == [0.5, 1.75]  # after low, high and the first midpoint
    write_json(tmp_path / "f.json", partial)
    record = json.loads((tmp_path / "f.json").read_text())
    calls.clear()
    stop_at = None
    resumed, _ = fos.factor_of_safety(World, 1.0, low=0.5, high=3.0, tolerance=0.01,
                                      resume=record)
    assert resumed["factor_of_safety"] == whole["factor_of_safety"]
    assert [t["F"] for t in resumed["trials"]] == [t["F"] for t in whole["trials"]]
    assert len(calls) == len(whole["trials"]) - 3  # the three recorded were not run again
    with pytest.raises(ValueError, match="came from the resumed record"):  # (no state kept)
        fos.plot_mechanism(World, record["trials"][1], resumed, tmp_path / "m.png")
    with pytest.raises(ValueError, match="record's creep is 0.001, this study's 0.01"):
        fos.factor_of_safety(World, 1.0, low=0.5, high=3.0, tolerance=0.01, creep=1e-2,
                             resume=record)
    with pytest.raises(ValueError, match="--resume takes the JSON record"):
        fos.factor_of_safety(World, 1.0, resume={"runs": []})


def test_sigterm_to_the_study_writes_the_trials_so_far_and_it_resumes(tmp_path):
    """`timpm study factor-of-safety SLOPE.toml --json f.json`, SIGTERM after its third
    trial: exit 143, f.json holds the three trials and the bracket, marked interrupted;
    `--resume f.json` completes it to the factor of the whole study (the slope at h = 2 m,
    a bracket 0.1 wide: six trials)."""
    import json
    import subprocess
    import sys

    from conftest import CHILD_ENV, default_signals, sigterm_after

    text = (ROOT / "examples" / "slope_griffiths_lane.toml").read_text()
    scene = tmp_path / "slope.toml"
    scene.write_text(text.replace("cells = 120", "cells = 30"))
    study = [sys.executable, "-m", "timpm", "study", "factor-of-safety", str(scene),
             "--bracket", "1", "2", "--tolerance", "0.1"]
    record = tmp_path / "f.json"
    code, err = sigterm_after(study + ["--json", str(record)], "F = ", 3)
    assert code == 143, err
    assert "Traceback" not in err and "interrupted after" in err and "--resume" in err
    partial = json.loads(record.read_text())
    assert partial["interrupted"] is True and len(partial["trials"]) >= 3
    done = subprocess.run(study + ["--resume", str(record), "--json", str(record), "--quiet"],
                          env=CHILD_ENV, capture_output=True, text=True,
                          preexec_fn=default_signals, timeout=600)
    assert done.returncode == 0, done.stderr
    resumed = json.loads(record.read_text())
    assert "interrupted" not in resumed
    whole, _ = fos.factor_of_safety(
        __import__("timpm.scenefile", fromlist=["load_scene"]).load_scene(scene).world,
        resumed["t_end"], low=1.0, high=2.0, tolerance=0.1, workers=resumed["workers"])
    assert resumed["factor_of_safety"] == whole["factor_of_safety"]
    assert len(resumed["trials"]) == len(whole["trials"])


def test_a_slope_on_an_elastic_base_reduces_only_its_soil():
    """Issue 45 item 6: only the Mohr-Coulomb bodies are reduced; an elastic base stays as
    it is (it was refused, naming neither body nor material)."""
    from timpm.materials import LinearElastic
    from timpm.model.world import Body, Box, Polygon, World

    soil = MohrCoulomb(E=1e8, nu=0.3, density=2000.0, friction_angle=30.0, cohesion=1e4)
    base = LinearElastic(E=1e9, nu=0.3, density=2500.0)
    world = World(domain=(20.0, 8.0), cells=20, basis="linear", transfer="musl",
                  bodies=[Body(Box((0.0, 0.0), (20.0, 2.0)), base, name="base"),
                          Body(Polygon([(0.0, 2.0), (15.0, 2.0), (5.0, 6.0), (0.0, 6.0)]),
                               soil, name="slope")])
    out = fos.reduced_bodies(world, 2.0)
    assert out[0].material is base
    assert out[1].material.cohesion == pytest.approx(5e3)
    rock = World(domain=(20.0, 8.0), cells=20, basis="linear", transfer="musl",
                 bodies=[Body(Box((0.0, 0.0), (20.0, 2.0)), base, name="base")])
    with pytest.raises(ValueError, match=r"no body is of it: base \(linear-elastic\)"):
        fos.reduced_bodies(rock, 2.0)


def test_a_script_without_a_main_guard_is_told_not_left_waiting(tmp_path):
    """A script that runs a study with workers at its top level: each spawned worker
    imports it and dies starting the study again; the study says so in seconds (it waited
    for ever while the world went through the pipe that starts a worker)."""
    import subprocess
    import sys

    from conftest import CHILD_ENV

    script = tmp_path / "unguarded.py"
    script.write_text(
        "from timpm.scenefile import load_scene\n"
        "from timpm.studies import factor_of_safety as fos\n"
        f"scene = load_scene({str(ROOT / 'examples' / 'slope_griffiths_lane.toml')!r}, "
        "overrides={'domain.cells': 30})\n"
        "fos.factor_of_safety(scene.world, scene.t_end, low=1.0, high=2.0, tolerance=0.5, "
        "workers=2)\n")
    done = subprocess.run([sys.executable, str(script)], env=CHILD_ENV, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode != 0
    assert "a worker process of the study died" in done.stderr
    assert 'if __name__ == "__main__":' in done.stderr
