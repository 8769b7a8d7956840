"""The Monte Carlo study of a slope over random fields (studies/monte_carlo.py): the
Wilson interval, the closed form of one random value per realisation, zero variance,
interruption and resumption, Dask, the command line and its refusals."""
import json
import math
from dataclasses import replace

import pytest

from timpm.studies import factor_of_safety as fos
from timpm.studies import monte_carlo as mc

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "slope_undrained_random.toml"


def test_the_wilson_interval():
    """At 0 of n the upper end is z^2 / (n + z^2); 5 of 10 gives the textbook [0.2366,
    0.7634]; it narrows as 1 / sqrt(n)."""
    z = mc.Z95
    assert mc.wilson(0, 10) == pytest.approx((0.0, z * z / (10 + z * z)))
    assert mc.wilson(5, 10) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    w100, w400 = (lambda i: i[1] - i[0])(mc.wilson(20, 100)), \
        (lambda i: i[1] - i[0])(mc.wilson(80, 400))
    assert w100 / w400 == pytest.approx(2.0, rel=0.05)


@pytest.fixture(scope="module")
def undrained():
    """The undrained slope on a coarse grid (h = 2 m) and its factor of safety at the mean
    strength (no random field)."""
    from timpm.scenefile import load_scene

    scene = load_scene(SCENE, overrides={"domain.cells": 30})
    mean = replace(scene.world, bodies=(replace(scene.world.bodies[0], random_field=None),))
    record, _ = fos.factor_of_safety(mean, scene.t_end, low=1.0, high=3.0, tolerance=0.01,
                                     workers=2)
    return scene, record["bracket"]


@pytest.mark.parametrize("cov, factor", [(0.5, 1.5), (0.2, 2.0)])
def test_one_random_value_per_realisation_follows_the_lognormal(undrained, cov, factor):
    """Issue 47: an infinite scale of fluctuation is one c_u over the whole slope, whose
    factor of safety is then F_mean c_u / mean (phi = 0): the slope fails at ``factor``
    where c_u < mean factor / F_mean, with the lognormal's probability Phi((ln(factor /
    F_mean) + s^2 / 2) / s), s^2 = ln(1 + V^2).  120 realisations (fixed seeds): the
    closed form, over the mean's bracket, meets the study's Wilson 95% interval."""
    scene, (F_lo, F_hi) = undrained
    world = replace(scene.world, bodies=(replace(
        scene.world.bodies[0], random_field=replace(scene.world.bodies[0].random_field,
                                                    cohesion_cov=cov)),))
    record = mc.monte_carlo(world, scene.t_end, 120, factor=factor, workers=2)
    s = math.sqrt(math.log1p(cov * cov))
    closed = [0.5 * (1 + math.erf((math.log(factor / F) + 0.5 * s * s) / (s * math.sqrt(2))))
              for F in (F_hi, F_lo)]
    lo, hi = record["wilson_95"]
    assert record["realisations"] == 120 and 0 < record["failures"] < 120
    assert lo <= closed[1] and closed[0] <= hi, (record["probability_of_failure"], closed)
    failed = [r for r in record["results"] if r["failed"]]
    assert all(r["runout"] > 0.1 and r["sliding_volume"] > 0 for r in failed)


def test_zero_variance_gives_the_deterministic_factor(undrained):
    """Every realisation of a field of no variance has the deterministic factor exactly."""
    scene, _ = undrained
    body = scene.world.bodies[0]
    world = replace(scene.world, bodies=(replace(body, random_field=replace(
        body.random_field, cohesion_cov=0.0, correlation_length=(10.0, 2.0))),))
    mean = replace(scene.world, bodies=(replace(body, random_field=None),))
    det, _ = fos.factor_of_safety(mean, scene.t_end, low=1.0, high=3.0, tolerance=0.05)
    record = mc.monte_carlo(world, scene.t_end, 3, factor_of_safety=True, bracket=(1.0, 3.0),
                            tolerance=0.05)
    assert [r["factor_of_safety"] for r in record["results"]] == [det["factor_of_safety"]] * 3
    assert record["factor_of_safety_std"] == 0.0 and record["failures"] == 0


def test_an_interrupted_study_resumes_to_the_same_record(undrained, monkeypatch):
    """Interrupted during its fourth realisation, the study keeps three; resumed (through
    the JSON writer), it runs only the others and ends with the uninterrupted record's
    results; a record of another study is refused."""
    from timpm.platform.files import write_json

    scene, _ = undrained
    whole = mc.monte_carlo(scene.world, scene.t_end, 6)
    real = mc.run_realisation
    ran = []

    def stopping(world, k, *args):
        if k == 3 and not ran:
            ran.append(k)
            raise KeyboardInterrupt
        return real(world, k, *args)

    monkeypatch.setattr(mc, "run_realisation", stopping)
    with pytest.raises(mc.MonteCarloInterrupted) as stop:
        mc.monte_carlo(scene.world, scene.t_end, 6)
    partial = stop.value.partial
    assert partial["interrupted"] and partial["realisations"] == 3
    path = ROOT / "build-test-mc.json"
    try:
        write_json(path, partial)
        resumed_record = json.loads(path.read_text())
    finally:
        path.unlink(missing_ok=True)
    calls = []
    monkeypatch.setattr(mc, "run_realisation", lambda w, k, *a: calls.append(k) or real(w, k, *a))
    resumed = mc.monte_carlo(scene.world, scene.t_end, 6, resume=resumed_record)
    assert calls == [3, 4, 5]
    key = lambda r: (r["k"], r["failed"], r.get("runout"))  # noqa: E731
    assert [key(r) for r in resumed["results"]] == [key(r) for r in whole["results"]]
    assert resumed["probability_of_failure"] == whole["probability_of_failure"]
    with pytest.raises(ValueError, match="the record's question"):
        mc.monte_carlo(scene.world, scene.t_end, 6, factor=1.2, resume=resumed_record)


def test_a_narrow_enough_interval_stops_the_study(undrained):
    scene, _ = undrained
    record = mc.monte_carlo(scene.world, scene.t_end, 100, width=0.99)
    assert record["realisations"] == mc.MIN_REALISATIONS and record["asked"] == 100
    lo, hi = record["wilson_95"]
    assert hi - lo <= 0.99
    assert [row[0] for row in record["convergence"]] == list(range(1, 21))


def test_dask_gives_the_pools_probability(undrained):
    """The same seeds on a local Dask cluster and on the trial pool: the same outcomes."""
    pytest.importorskip("distributed")
    scene, _ = undrained
    pool = mc.monte_carlo(scene.world, scene.t_end, 4, workers=2)
    dask = mc.monte_carlo(scene.world, scene.t_end, 4, dask="local")
    assert [r["failed"] for r in dask["results"]] == [r["failed"] for r in pool["results"]]
    assert dask["probability_of_failure"] == pool["probability_of_failure"]


def test_the_study_refuses_what_it_cannot_run(tmp_path, capsys):
    from timpm.cli.main import main
    from timpm.scenefile import load_scene

    plain = load_scene(ROOT / "examples" / "slope_griffiths_lane.toml",
                       overrides={"domain.cells": 30})
    with pytest.raises(ValueError, match="varies the bodies with a random field"):
        mc.monte_carlo(plain.world, 1.0, 10)
    scene = str(SCENE)
    for args, match in [
        (["--realisations", "0"], "--realisations must be a whole number of at least 1"),
        (["--realisations", "5", "--width", "1.5"], "--width must lie in"),
        (["--realisations", "5", "--factor", "-1"], "--factor must be a positive number"),
        (["--realisations", "5", "--run-on", "1.0"], "--run-on must be a time at least"),
        (["--realisations", "5", "--plot", str(tmp_path / "p.svg")], "--plot"),
    ]:
        assert main(["study", "monte-carlo", scene, "--quiet", *args]) == 2, args
        assert match in capsys.readouterr().err, args
    assert main(["study", "monte-carlo", str(ROOT / "examples" / "slope_griffiths_lane.toml"),
                 "--realisations", "2", "--quiet"]) == 2
    assert "random field" in capsys.readouterr().err


def test_the_command_writes_its_record_and_plots(tmp_path):
    import subprocess
    import sys

    from conftest import CHILD_ENV

    out = subprocess.run(
        [sys.executable, "-m", "timpm", "study", "monte-carlo", str(SCENE), "--realisations",
         "4", "--set", "domain.cells=30", "--json", str(tmp_path / "mc.json"), "--plot",
         str(tmp_path / "mc.png"), "--field", str(tmp_path / "field.png"), "--quiet"],
        env=CHILD_ENV, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert "probability of failure" in out.stdout
    record = json.loads((tmp_path / "mc.json").read_text())
    assert record["realisations"] == 4 and record["overrides"] == {"domain.cells": 30}
    assert (tmp_path / "mc.png").stat().st_size > 1000
    assert (tmp_path / "field.png").stat().st_size > 1000


def test_sigterm_keeps_the_realisations_and_resume_completes_them(tmp_path):
    """Issue 47: SIGTERM to `timpm study monte-carlo` (two worker processes) writes the
    realisations finished, exit 143; --resume runs the rest, to the uninterrupted study's
    outcomes."""
    import subprocess
    import sys

    from conftest import CHILD_ENV, default_signals, sigterm_after

    study = [sys.executable, "-m", "timpm", "study", "monte-carlo", str(SCENE),
             "--realisations", "12", "--set", "domain.cells=30", "--workers", "2"]
    record = tmp_path / "mc.json"
    code, err = sigterm_after(study + ["--json", str(record)], "realisation ", 3)
    assert code == 143, err
    assert "Traceback" not in err and "interrupted after" in err and "--resume" in err
    partial = json.loads(record.read_text())
    assert partial["interrupted"] is True and 3 <= partial["realisations"] < 12
    done = subprocess.run(study + ["--resume", str(record), "--json", str(record), "--quiet"],
                          env=CHILD_ENV, capture_output=True, text=True,
                          preexec_fn=default_signals, timeout=600)
    assert done.returncode == 0, done.stderr
    resumed = json.loads(record.read_text())
    assert "interrupted" not in resumed and resumed["realisations"] == 12
    from timpm.scenefile import load_scene

    scene = load_scene(SCENE, overrides={"domain.cells": 30})
    whole = mc.monte_carlo(scene.world, scene.t_end, 12, workers=2)
    assert [r["failed"] for r in resumed["results"]] == [r["failed"] for r in whole["results"]]
