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


def test_the_bisection_closes_on_the_factor(monkeypatch):
    """With a slope that fails exactly above F* the bracket shrinks around F* to the
    tolerance, and a bracket that does not hold it is refused."""
    true = 1.2345

    def stub(world, F, t_end, creep=1e-3, mode="auto"):
        return {"F": F, "failed": F > true, "displacement_end": 0.0, "creep": 0.0,
                "creep_limit": 0.0, "plastic": None, "positions": None}

    monkeypatch.setattr(fos, "trial", stub)

    class World:  # the record reads these
        h, basis, transfer = 1.0, Linear, "musl"

        class model:
            positions = np.array([[0.0, 0.0], [1.0, 10.0]])
            n_particles = 2
            gravity = (0.0, -9.81)

    record, failed = fos.factor_of_safety(World, 1.0, low=0.5, high=3.0, tolerance=0.01)
    lo, hi = record["bracket"]
    assert lo <= true < hi and hi - lo <= 0.01
    assert record["factor_of_safety"] == pytest.approx(true, abs=0.005)
    assert failed["F"] == hi
    with pytest.raises(ValueError, match="fails at the bracket's low end"):
        fos.factor_of_safety(World, 1.0, low=2.0, high=3.0)
    with pytest.raises(ValueError, match="stands at the bracket's high end"):
        fos.factor_of_safety(World, 1.0, low=0.5, high=1.0)
    with pytest.raises(ValueError, match="0 < low < high"):
        fos.factor_of_safety(World, 1.0, low=2.0, high=1.0)
    # what cannot give a factor is named, not met with "widen the bracket"
    for creep in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="creep must be a positive finite"):
            fos.factor_of_safety(World, 1.0, creep=creep)
    with pytest.raises(ValueError, match="run of positive length"):
        fos.factor_of_safety(World, 0.0)
    World.model.gravity = (0.0, 0.0)
    with pytest.raises(ValueError, match="no weight"):
        fos.factor_of_safety(World, 1.0)


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


def test_the_study_refuses_what_it_cannot_reduce(tmp_path, capsys):
    from timpm.cli.main import main

    text = (ROOT / "examples" / "slope_griffiths_lane.toml").read_text()
    f = tmp_path / "rubber.toml"
    f.write_text(text.replace('type = "mohr-coulomb"', 'type = "neo-hookean"').replace(
        "friction_angle = 20.0", "").replace("cohesion = 10e3                # c' / (gamma H) = 0.05", "")
        .replace("dilation_angle = 0.0", "").replace('[initial_stress]\nkind = "k0"\n', ""))
    assert main(["study", "factor-of-safety", str(f), "--quiet"]) == 2
    assert "neo-hookean has none to divide" in capsys.readouterr().err
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
