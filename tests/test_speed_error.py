"""Speed against error: the dt rule, the Pareto front, cheapest-per-target answers, report,
plot and command line (one tiny sweep of the vibrating string, shared by the tests)."""
import json
import math

import pytest

from timpm.cli.main import main
from timpm.output.viz import plot_speed_error
from timpm.studies.speed_error import (RECORD_KEYS, cheapest_for, choose_dt, default_targets,
                                       format_report, merge_studies, pareto_front, plateaus,
                                       speed_error_study)

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def tiny():
    """Linear/lumped on 4, 8, 16 and quadratic B-splines/consistent on 4, 8 elements
    (two sweeps merged: each run compiles its kernels, so the sweep is kept small)."""
    kw = dict(t_end=0.02, repeats=2, progress=None)
    return merge_studies([
        speed_error_study("vibrating-string", combos=(("linear", "lumped"),),
                          elements=(4, 8, 16), **kw),
        speed_error_study("vibrating-string", combos=(("bspline2", "consistent"),),
                          elements=(4, 8), **kw)])


def _rec(basis, mass, elements, wall, error, ppc=4):
    return {"basis": basis, "mass": mass, "elements": elements, "ppc": ppc,
            "placement": "study", "wall_seconds": wall, "rms_error": error}


# ---- the sweep ------------------------------------------------------------------------------

def test_records_have_the_keys_and_skip_nothing_valid(tiny):
    runs = tiny["runs"]
    assert len(runs) == 5 and tiny["skipped"] == []
    assert [s["combos"] for s in tiny["sweep"]] == [[["linear", "lumped"]],
                                                    [["bspline2", "consistent"]]]
    for r in runs:
        assert set(RECORD_KEYS) <= set(r)
        assert r["problem"] == "vibrating-string" and r["placement"] == "study"
        assert r["steps"] * r["dt"] == pytest.approx(0.02)
        assert r["particles"] == 4 * r["elements"]
        assert r["wall_seconds"] > 0 and r["rms_error"] > 0 and len(r["wall_samples"]) == 2
        assert r["wall_seconds"] == min(r["wall_samples"])
        assert r["dt"] <= 0.5 * r["critical_dt"] and r["dt"] <= 1e-4 * (1 + 1e-12)
    # the spatial convergence the study reports survives the dt rule
    bs = sorted((r for r in runs if r["basis"] == "bspline2" and r["mass"] == "consistent"),
                key=lambda r: r["elements"])
    assert bs[0]["rms_error"] / bs[-1]["rms_error"] > 2 ** 2.5
    assert "dt0 = min(0.0001 s" in tiny["dt_rule"]


def test_dt_rule_holds_for_every_accepted_step(tiny):
    tol = tiny["dt_tolerance"]
    for r in tiny["runs"]:
        trials = r["dt_trials"]
        assert [t[0] for t in trials] == pytest.approx(
            [trials[0][0] / 2 ** k for k in range(len(trials))])
        i = [t[0] for t in trials].index(r["dt"])
        if r["time_error_separated"]:
            e, e_half = trials[i][1], trials[i + 1][1]
            assert abs(e - e_half) <= tol * e_half
            assert r["time_error_estimate"] == pytest.approx(abs(e - e_half))
            # the coarser dt of the first passing pair: every coarser pair failed
            for (_, a), (_, b) in zip(trials[:i], trials[1:i + 1]):
                assert abs(a - b) > tol * b
        else:
            assert i == len(trials) - 1 == tiny["max_halvings"] + 1


def test_error_matches_run_problem(tiny):
    from timpm.studies.study import run_problem

    rec = next(r for r in tiny["runs"] if r["basis"] == "linear" and r["elements"] == 8)
    ref = run_problem("vibrating-string", elements=8, dt=rec["dt"], t_end=0.02,
                      energies=False).record
    assert rec["rms_error"] == pytest.approx(ref["rms_error"], rel=1e-12)
    assert rec["steps"] == ref["steps"]


def test_invalid_combinations_are_skipped_with_a_note():
    doc = speed_error_study("vibrating-string", bases=("lagrange2", "bspline3"),
                            masses="lumped", elements=(2,), ppcs=(1, 2), t_end=0.01,
                            repeats=1, progress=None)
    assert doc["runs"] == [] and len(doc["skipped"]) == 4
    reasons = " | ".join(s["reason"] for s in doc["skipped"])
    assert "cannot be lumped" in reasons and "at least 2 particles per element" in reasons
    assert "at least 3 elements" in reasons


# ---- the dt rule on a model error -----------------------------------------------------------

class _Fake:
    released = 0

    def __init__(self, dt, spatial, c):
        self.record = {"rms_error": spatial + c * dt}
        self.alive = True

    def release(self):
        if self.alive:
            _Fake.released += 1
        self.alive = False


@pytest.mark.parametrize("spatial,c,expected", [
    (1e-3, 1.0, 1e-4),          # time error 1e-4 / 2 = 5 % of e(dt/2) at once
    (1e-5, 0.1, 1e-4 / 8),      # e = 1e-5 + 0.1 dt: fails at 1e-4, 5e-5, 2.5e-5
])
def test_choose_dt_halves_until_the_time_error_is_separated(spatial, c, expected):
    _Fake.released = 0
    made = []

    def run(dt):
        made.append(_Fake(dt, spatial, c))
        return made[-1]

    accepted, info = choose_dt(run, 1e-4, dt_tolerance=0.1, max_halvings=4)
    assert info["time_error_separated"] and info["dt"] == pytest.approx(expected)
    e, e2 = spatial + c * info["dt"], spatial + c * info["dt"] / 2
    assert abs(e - e2) <= 0.1 * e2 and info["time_error_estimate"] == pytest.approx(e - e2)
    assert accepted.alive and sum(f.alive for f in made) == 1   # the others were released


def test_choose_dt_flags_a_time_error_it_cannot_separate():
    made = []

    def run(dt):
        made.append(_Fake(dt, 0.0, 1.0))   # pure time error: never separates
        return made[-1]

    accepted, info = choose_dt(run, 1e-4, max_halvings=2)
    assert not info["time_error_separated"]
    assert info["dt"] == pytest.approx(1e-4 / 8) and len(info["dt_trials"]) == 4
    assert accepted is made[-1] and sum(f.alive for f in made) == 1


# ---- Pareto front and cheapest configurations -------------------------------------------------

def _dominated(p, q):
    return (q["wall_seconds"] <= p["wall_seconds"] and q["rms_error"] <= p["rms_error"]
            and (q["wall_seconds"] < p["wall_seconds"] or q["rms_error"] < p["rms_error"]))


def test_pareto_front_on_hand_made_records():
    recs = [_rec("linear", "lumped", 4, 1.0, 1e-3),      # fastest: front
            _rec("linear", "lumped", 8, 2.0, 2e-4),      # front
            _rec("linear", "lumped", 16, 4.0, 5e-5),     # dominated by bspline2 8
            _rec("bspline2", "consistent", 4, 2.0, 3e-4),  # dominated by linear 8 (same time)
            _rec("bspline2", "consistent", 8, 3.0, 1e-5),  # front
            _rec("bspline3", "consistent", 8, 3.0, 1e-5),  # exact tie with the one above: front
            _rec("bspline3", "consistent", 16, 9.0, 1e-5),  # as accurate, slower: dominated
            _rec("bspline3", "consistent", 32, 20.0, 1e-7),  # most accurate: front
            _rec("linear", "consistent", 4, 0.5, None)]   # no error: never on the front
    flags = pareto_front(recs)
    assert flags == [True, True, False, False, True, True, False, True, False]
    valid = [r for r in recs if r["rms_error"] is not None]
    for r, on in zip(recs, flags):
        if r["rms_error"] is None:
            continue
        assert on == (not any(_dominated(r, q) for q in valid if q is not r))


def test_cheapest_for_answers_with_factors_and_unreachable_linear():
    recs = [_rec("linear", "lumped", 4, 0.01, 1e-3), _rec("linear", "lumped", 8, 0.02, 2.5e-4),
            _rec("linear", "lumped", 16, 0.04, 6.25e-5),
            _rec("bspline2", "consistent", 4, 0.015, 1e-4),
            _rec("bspline2", "consistent", 8, 0.02, 1e-5),
            _rec("bspline2", "consistent", 16, 0.05, 1e-6)]
    a1, a2, a3 = cheapest_for(recs, [5e-4, 1e-4, 1e-6])
    # 5e-4: linear 8 (0.02 s) and bspline2 4 (0.015 s) reach it
    assert a1["best"]["basis"] == "bspline2" and a1["best"]["elements"] == 4
    assert a1["linear"]["elements"] == 8 and a1["factor"] == pytest.approx(0.02 / 0.015)
    assert a1["groups"]["linear/lumped"]["factor_vs_linear"] == pytest.approx(1.0)
    # 1e-4: linear 16 at 0.04 s against bspline2 4 at 0.015 s
    assert a2["factor"] == pytest.approx(0.04 / 0.015) and "2.7x faster than linear" in a2["answer"]
    # 1e-6: only bspline2 16; linear cannot, and its rate 2 says it would need 16 * sqrt(62.5) elements
    assert a3["linear"] is None and a3["factor"] is None
    assert a3["groups"]["linear/lumped"] is None
    assert a3["best"]["elements"] == 16 and a3["best"]["basis"] == "bspline2"
    assert "linear cannot reach it" in a3["answer"]
    assert a3["linear_extrapolated"]["elements"] == pytest.approx(16 * 62.5 ** 0.5)
    # nothing reaches 1e-9
    (a4,) = cheapest_for(recs, [1e-9])
    assert a4["best"] is None and "no configuration" in a4["answer"]
    # linear itself cheapest
    (a5,) = cheapest_for(recs, [2e-3])
    assert a5["best"]["basis"] == "linear" and a5["factor"] == pytest.approx(1.0)
    assert default_targets(recs) == [1e-3, 1e-4, 1e-5, 1e-6]      # 7 of 1e-k, 3e-k: decades
    assert default_targets(recs[:3]) == [1e-3, 3e-4, 1e-4]
    assert default_targets([_rec("linear", "lumped", 4, 1.0, 2e-5)]) == [1e-4]


# ---- report, plot, command line ---------------------------------------------------------------

def test_report_and_png(tiny, tmp_path):
    text = format_report(tiny, cheapest_for(tiny["runs"], [1e-4, 1e-6]))
    assert "Time step per run: dt0 = min(" in text and "Pareto front" in text
    assert "e_RMS <= 1e-04" in text and "e_RMS <= 1e-06" in text
    assert text.count("bspline2/consistent") >= 3
    png = tmp_path / "speed_error.png"
    plot_speed_error(tiny, png)
    assert png.read_bytes()[:8] == PNG and png.stat().st_size > 10_000


def test_command_line(tmp_path, capsys):
    out, png = tmp_path / "se.json", tmp_path / "se.png"
    assert main(["study", "speed-error", "vibrating-string", "--bases", "linear", "--masses",
                 "lumped", "--elements", "4", "--t-end", "0.01", "--stress-update", "small",
                 "--repeats", "1", "--targets", "1e-3", "1e-7", "--json", str(out),
                 "--plot", str(png), "--quiet"]) == 0
    doc = json.loads(out.read_text())
    assert doc["stress_update"] == "small" and doc["runs"][0]["stress_update"] == "small"
    assert len(doc["runs"]) == 1 and [a["target"] for a in doc["targets"]] == [1e-3, 1e-7]
    assert png.read_bytes()[:8] == PNG
    text = capsys.readouterr().out
    assert "Time step per run" in text and "e_RMS <= 1e-07: no configuration" in text
    assert main(["study", "speed-error", "large-column", "--quiet"]) == 2
    assert "no exact solution" in capsys.readouterr().err
    assert math.isfinite(doc["runs"][0]["wall_seconds"])


def test_cheapest_for_compares_with_linear_lumped_too():
    recs = [_rec("linear", "lumped", 8, 0.02, 2.5e-4), _rec("linear", "lumped", 16, 0.04, 6e-5),
            _rec("linear", "consistent", 8, 0.025, 3e-5),
            _rec("bspline2", "consistent", 4, 0.01, 5e-5)]
    a1, a2 = cheapest_for(recs, [1e-4, 4e-5])
    assert a1["best"]["basis"] == "bspline2" and a1["linear"]["mass"] == "consistent"
    assert a1["factor"] == pytest.approx(2.5) and a1["factor_vs_linear_lumped"] == pytest.approx(4.0)
    assert "2.5x faster than linear; over linear with lumped mass" in a1["answer"]
    assert a2["best"]["mass"] == "consistent" and a2["best"]["basis"] == "linear"
    assert a2["linear_lumped"] is None and a2["factor_vs_linear_lumped"] is None
    assert "linear with lumped mass cannot reach it" in a2["answer"]


def test_plateaus_and_merge():
    recs = [_rec("linear", "lumped", 4, 1.0, 1e-3), _rec("linear", "lumped", 8, 2.0, 2.5e-4),
            _rec("bspline3", "consistent", 4, 1.0, 1e-5), _rec("bspline3", "consistent", 8, 2.0, 1e-6),
            _rec("bspline3", "consistent", 16, 4.0, 9e-7), _rec("bspline3", "consistent", 32, 8.0, 1e-6)]
    recs[-1]["grid_crossings"] = 3
    (p,) = plateaus(recs)
    assert p["label"] == "bspline3/consistent" and p["elements"] == 8 and p["error"] == 9e-7
    assert p["separated"] and p["crossings"] == 1
    a = {"problem": "x", "t_end": 1.0, "runs": recs[:2], "skipped": [], "sweep": {"bases": ["linear"]}}
    b = {"problem": "x", "t_end": 1.0, "runs": recs[2:], "skipped": [{"reason": "r"}],
         "sweep": {"bases": ["bspline3"]}}
    m = merge_studies([a, b])
    assert len(m["runs"]) == 6 and m["bases"] == ["linear", "bspline3"] and len(m["skipped"]) == 1
    assert [r["pareto"] for r in m["runs"]] == pareto_front(recs)
    with pytest.raises(ValueError):
        merge_studies([a, dict(b, t_end=2.0)])


def test_a_study_whose_every_configuration_is_skipped_is_an_error(capsys):
    from timpm.cli.main import main

    assert main(["study", "speed-error", "vibrating-string", "--bases", "bspline3",
                 "--masses", "lumped", "--elements", "4", "8", "--ppc", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert ("every one of the 2 configurations was skipped, nothing to report (bspline3/lumped/4 "
            "elements: the bspline3 basis needs at least 2 particles per element") in err
