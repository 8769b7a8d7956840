"""Random fields of a soil's strength (model/random_field.py, materials/mohr_coulomb_field.py):
the marginals, the correlation GSTools generates against the scale of fluctuation, the
local average, the cross-correlation, reproducibility, a body's law per particle, and the
refusals of bad input in Python and scene files."""
import math
from dataclasses import replace

import numpy as np
import pytest

from timpm.model.random_field import RandomField

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent


class _Soil:  # what a realisation reads of a Mohr-Coulomb material
    cohesion, friction_angle = 10e3, 30.0
    unreduced = property(lambda self: self)


class _Water:  # what a realisation reads of a body's pore water
    conductivity = 1e-5


def test_lognormal_marginal_and_cross_correlation():
    """Point values (one point per cell) over a domain many scales of fluctuation long:
    ln c has the mean ln(mean) - sigma^2 / 2 and the deviation sigma = sqrt(ln(1 + V^2)),
    the friction angle's field is correlated with the cohesion's by r."""
    rf = RandomField(cohesion_cov=0.4, friction_angle_cov=0.2, correlation_length=1.0,
                     cross_correlation=-0.6, points=1, seed=7)
    x = np.stack(np.meshgrid(np.arange(200) + 0.5, np.arange(100) + 0.5, indexing="ij"),
                 -1).reshape(-1, 2) * 2.0  # 20,000 cells of 2 m: theta / h = 0.5
    real = rf.realise(_Soil(), x, 2.0, np.zeros(2))
    for key, V, mean in (("cohesion", 0.4, 10e3), ("friction_angle", 0.2, 30.0)):
        s = math.sqrt(math.log1p(V * V))
        ln = np.log(real[key])
        assert ln.mean() == pytest.approx(math.log(mean) - 0.5 * s * s, abs=0.03)
        assert ln.std() == pytest.approx(s, rel=0.05)
    r = np.corrcoef(np.log(real["cohesion"]), np.log(real["friction_angle"]))[0, 1]
    assert r == pytest.approx(-0.6, abs=0.05)
    assert real["clipped"] == 0 and real["cells"] == 20000
    # generated again (not the memo's): seeded, reproducible
    again = rf._realise({"cohesion": 10e3, "friction_angle": 30.0}, x, 2.0, np.zeros(2))
    assert np.array_equal(again["cohesion"], real["cohesion"])
    other = replace(rf, seed=8).realise(_Soil(), x, 2.0, np.zeros(2))
    assert not np.array_equal(other["cohesion"], real["cohesion"])
    # the pore water's conductivity: lognormal about its own, independent of the strength,
    # which keeps its values (its Gaussian fields the same two)
    wet = replace(rf, conductivity_cov=0.6).realise(_Soil(), x, 2.0, np.zeros(2),
                                                    _Water())
    s = math.sqrt(math.log1p(0.36))
    ln = np.log(wet["conductivity"])
    assert ln.mean() == pytest.approx(math.log(1e-5) - 0.5 * s * s, abs=0.03)
    assert ln.std() == pytest.approx(s, rel=0.05)
    assert abs(np.corrcoef(ln, np.log(wet["cohesion"]))[0, 1]) < 0.05
    assert np.array_equal(wet["cohesion"], real["cohesion"])


def test_a_world_built_again_from_the_same_particles_reuses_its_realisation():
    """A strength-reduction trial's world (the same particles, the soil reduced) takes the
    realisation and the vertical stress computed for the first one, read-only; another
    seed is generated anew."""
    from timpm.scenefile import load_scene
    from timpm.studies.factor_of_safety import reduced_bodies

    world = load_scene(ROOT / "examples" / "slope_griffiths_lane_random.toml",
                       overrides={"domain.cells": 30}).world
    trial = replace(world, bodies=reduced_bodies(world, 1.5))
    first, again = world.random_fields[0], trial.random_fields[0]
    assert again["cohesion"] is first["cohesion"] and not first["cohesion"].flags.writeable
    # the same weight above each particle (K0 = 1 - sin(phi) is the reduced soil's)
    assert np.array_equal(trial.model.initial_stress[:, 1, 1], world.model.initial_stress[:, 1, 1])
    body = world.bodies[0]
    other = replace(world, bodies=(replace(body, random_field=replace(
        body.random_field, seed=body.random_field.seed + 1)),))
    assert not np.array_equal(other.random_fields[0]["cohesion"], first["cohesion"])


@pytest.mark.parametrize("correlation, rho", [("exponential", math.exp(-1.0)),
                                              ("gaussian", math.exp(-math.pi / 4))])
def test_the_correlation_at_half_the_scale_of_fluctuation(correlation, rho):
    """GSTools' len_scale is theta / 2: the Gaussian field's correlation at a lag of theta
    / 2 is exp(-2 tau / theta) = e^-1 (Markov) and exp(-pi tau^2 / theta^2) = e^(-pi/4)
    (Gaussian), horizontally and, with an anisotropic theta, vertically."""
    theta = (8.0, 2.0)
    rf = RandomField(cohesion_cov=0.3, correlation_length=theta, correlation=correlation)
    rng = np.random.default_rng(1)
    a = rng.uniform(0, 400, size=(4000, 2))
    for axis in (0, 1):
        lag = np.zeros(2)
        lag[axis] = theta[axis] / 2
        pairs = []
        for seed in range(6):
            g = rf.gaussian(np.concatenate([a, a + lag]), [seed, seed + 100])[0]
            pairs.append(np.corrcoef(g[:4000], g[4000:])[0, 1])
        assert np.mean(pairs) == pytest.approx(rho, abs=0.04)


def test_local_averages_reduce_the_variance_and_keep_the_median():
    """Averaged over 4 x 4 points of cells as large as theta, the Gaussian field's
    variance falls (the variance function gamma(h / theta) < 1) and the median of c stays
    exp(mu_ln); an infinite theta is one value everywhere."""
    x = np.stack(np.meshgrid(np.arange(150) + 0.5, np.arange(150) + 0.5, indexing="ij"),
                 -1).reshape(-1, 2) * 2.0
    V = 0.5
    s = math.sqrt(math.log1p(V * V))
    point = RandomField(cohesion_cov=V, correlation_length=2.0, points=1, seed=3)
    averaged = replace(point, points=4)
    ln_point = np.log(point.realise(_Soil(), x, 2.0, np.zeros(2))["cohesion"])
    ln_avg = np.log(averaged.realise(_Soil(), x, 2.0, np.zeros(2))["cohesion"])
    assert ln_point.std() == pytest.approx(s, rel=0.05)
    assert 0.5 * s < ln_avg.std() < 0.9 * s
    assert np.median(ln_avg) == pytest.approx(math.log(10e3) - 0.5 * s * s, abs=0.03)
    one = RandomField(cohesion_cov=V, correlation_length=math.inf, seed=3)
    c = one.realise(_Soil(), x, 2.0, np.zeros(2))["cohesion"]
    assert np.all(c == c[0]) and c[0] != 10e3


def test_a_normal_marginal_is_cut_at_the_range_and_counted():
    rf = RandomField(friction_angle_cov=0.8, correlation_length=1.0, marginal="normal",
                     points=1)
    x = np.random.default_rng(0).uniform(0, 100, size=(5000, 2))
    real = rf.realise(_Soil(), x, 1.0, np.zeros(2))
    assert real["friction_angle"].min() >= 0.0 and real["friction_angle"].max() <= 89.0
    assert real["clipped"] > 0  # 30 (1 +- 0.8 G) leaves [0, 89] for |G| > 1.25 or so


def test_a_body_with_zero_variance_steps_as_the_plain_soil_bit_for_bit():
    """MohrCoulombField with every particle at the mean: the same bits as MohrCoulomb
    (one thread), and a varying field changes the run."""
    from timpm.materials import MohrCoulombField
    from timpm.scenefile import load_scene
    from timpm.simulation.solver import Solver

    scene = load_scene(ROOT / "examples" / "slope_griffiths_lane.toml",
                       overrides={"domain.cells": 30})
    w = scene.world
    same = replace(w, bodies=(replace(w.bodies[0], random_field=RandomField(
        correlation_length=5.0)),))
    varied = replace(w, bodies=(replace(w.bodies[0], random_field=RandomField(
        cohesion_cov=0.5, correlation_length=5.0)),))
    assert isinstance(same.model.materials[0], MohrCoulombField)
    runs = []
    for world in (w, same, varied):
        s = Solver(world, energies=False, mode="serial")
        s.run(n_steps=200)
        runs.append((s.positions(), s.read("plastic")))
        s.release()
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])
    assert not np.array_equal(runs[0][0], runs[2][0])


def test_strength_values_reduce_each_particle():
    """The law's strength field at F: c / F and tan(phi) / F particle by particle, psi at
    most phi, the apex c cot(phi), Tresca's unbounded one at phi = 0."""
    from timpm.materials import MohrCoulomb, MohrCoulombField

    law = MohrCoulombField.of(MohrCoulomb(E=1e7, nu=0.3, density=2000.0, friction_angle=30.0,
                                          cohesion=10e3, dilation_angle=10.0))
    k = law.strength_values([10e3, 20e3, 5e3], [30.0, 5.0, 0.0], factor=2.0)
    phi = np.arctan(np.tan(np.radians([30.0, 5.0, 0.0])) / 2.0)
    assert k[:, 0] == pytest.approx(np.sin(phi))
    assert k[:, 1] == pytest.approx(np.sin(np.minimum(np.radians(10.0), phi)))
    assert k[:, 2] == pytest.approx(2 * np.array([5e3, 10e3, 2.5e3]) * np.cos(phi))
    assert k[:2, 3] == pytest.approx([5e3 / math.tan(phi[0]), 10e3 / math.tan(phi[1])])
    assert k[2, 3] >= 1e300 and np.all(k[:, 4] == k[:, 3])
    # the law of a reduced soil (a trial's) reduces from the unreduced psi and cut-off
    soil = MohrCoulomb(E=1e7, nu=0.3, density=2000.0, friction_angle=30.0, cohesion=10e3,
                       dilation_angle=10.0, tensile_strength=5e3)
    c, phi = [10e3, 20e3], [30.0, 60.0]
    assert np.array_equal(MohrCoulombField.of(soil.reduced(2.0)).strength_values(c, phi, 2.0),
                          MohrCoulombField.of(soil).strength_values(c, phi, 2.0))
    assert MohrCoulombField.of(soil).strength_values(c, phi, 2.0)[1, 4] == 2.5e3
    twice = soil.reduced(2.0).reduced(1.5)
    assert twice.unreduced is soil and twice.factor == pytest.approx(3.0)


@pytest.mark.parametrize("kwargs, match", [
    (dict(cohesion_cov=-0.1), "cohesion_cov"),
    (dict(correlation_length=0.0), "correlation_length must be positive"),
    (dict(correlation_length=(5.0, math.inf)), "infinite along both axes"),
    (dict(correlation_length=(1.0, 2.0, 3.0)), "one scale of fluctuation"),
    (dict(marginal="uniform"), "unknown marginal 'uniform'"),
    (dict(correlation="matern"), "unknown correlation 'matern'"),
    (dict(cross_correlation=1.5), "cross_correlation"),
    (dict(seed=-1), "seed must be a whole number"),
    (dict(points=0), "points must be a whole number"),
])
def test_bad_random_fields_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        RandomField(**kwargs)


def test_a_random_field_needs_mohr_coulomb_soil_with_that_strength():
    from timpm import Body, Box, LinearElastic, MohrCoulomb

    with pytest.raises(ValueError, match="varies the strength of Mohr-Coulomb soil, not of "
                                         "linear-elastic"):
        Body(Box((0, 0), (1, 1)), LinearElastic(E=1e6, nu=0.3, density=1e3),
             random_field=RandomField(cohesion_cov=0.2))
    clay = MohrCoulomb(E=1e7, nu=0.3, density=2000.0, friction_angle=0.0, cohesion=5e4)
    with pytest.raises(ValueError, match="friction_angle_cov = 0.2 varies a friction_angle "
                                         "of mean 0"):
        Body(Box((0, 0), (1, 1)), clay, random_field=RandomField(friction_angle_cov=0.2))
    with pytest.raises(ValueError, match="must be a timpm.RandomField"):
        Body(Box((0, 0), (1, 1)), clay, random_field={"cohesion_cov": 0.2})


def test_scene_files_check_the_random_field_table(tmp_path):
    from timpm.scenefile import load_scene

    text = (ROOT / "examples" / "slope_undrained_random.toml").read_text()
    scene = load_scene(ROOT / "examples" / "slope_undrained_random.toml")
    assert scene.world.bodies[0].random_field.cohesion_cov == 0.5
    assert math.isinf(scene.world.bodies[0].random_field.correlation_length[0])
    for old, new, match in [
        ("cohesion_cov = 0.5", "cohesion_cov = -0.5", r"body\[0\]\.random_field\.cohesion_cov"),
        ("correlation_length = inf", "correlation_length = [1.0]",
         r"random_field\.correlation_length: expected a number > 0 or inf, or two"),
        ('marginal = "lognormal"', 'marginal = "gamma"', "unknown value 'gamma'"),
        ("seed = 0", "seed = 1.5", r"random_field\.seed: expected an integer >= 0"),
        ("seed = 0", "sead = 0", "unknown key"),
    ]:
        f = tmp_path / "bad.toml"
        f.write_text(text.replace(old, new))
        with pytest.raises(ValueError, match=match):
            load_scene(f)
