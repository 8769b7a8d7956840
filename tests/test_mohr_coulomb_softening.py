"""Mohr-Coulomb with strain softening (materials/mohr_coulomb_softening.py): the element
tests follow the closed-form softening path, kappa is the plastic shear strain, the
softening is regularised by the cell size, bad parameters are refused by name."""
import math

import numpy as np
import pytest

from timpm.materials import MATERIALS, MohrCoulomb, MohrCoulombSoftening
from timpm.studies.element_test import LAWS, run_element_test

SOIL = dict(E=1e5, nu=0.3, density=2000.0)
LAW = "mohr-coulomb-softening"


def _law(**kw):
    return MohrCoulombSoftening(**SOIL, **kw)


def _cauchy_deviator(soil, kappa, p, J):
    """sigma_1 - sigma_3 on the softened surface of ``kappa`` in Cauchy stress: the surface
    is written in Kirchhoff stress tau = J sigma, the confinement held in Cauchy stress, so
    J q = (2 c cos(phi) + 2 J p sin(phi)) / (1 - sin(phi))."""
    s = soil.softened(kappa)
    sin = math.sin(math.radians(s.friction_angle))
    return (s.two_c_cos_phi / J + 2.0 * p * sin) / (1.0 - sin)


@pytest.mark.parametrize("test", ["biaxial-mc", "triaxial-mc"])
@pytest.mark.parametrize("strength", [
    dict(friction_angle=30.0, cohesion=10.0, residual_friction_angle=20.0,
         residual_cohesion=2.0),
    dict(friction_angle=25.0, cohesion=20.0, residual_cohesion=0.0),   # phi kept, c lost
    dict(friction_angle=0.0, cohesion=40.0, residual_cohesion=8.0),    # Tresca: sensitivity 5
])
def test_the_deviator_follows_the_closed_form_softening_path(test, strength):
    p, u_r = 100.0, 0.02  # the element test's point: h = 1, kappa_r = u_r
    r = run_element_test(test, law=LAW, confinement=p, softening_displacement=u_r,
                         axial_strain=0.08, increments=800, **strength)
    soil = _law(softening_displacement=u_r, **strength)
    q = np.asarray(r["series"]["deviator"])
    kappa = np.asarray(r["series"]["state"]["kappa"])
    J = np.exp(np.asarray(r["series"]["volumetric_strain"]))
    flowing = np.flatnonzero(kappa > 0.0)
    assert len(flowing) > 0.8 * len(q) and kappa[-1] > 2 * u_r  # softened past the residual
    # each increment returns to the surface of the kappa it ends at (backward Euler)
    closed = [_cauchy_deviator(soil, kappa[k], p, J[k]) for k in flowing]
    np.testing.assert_allclose(q[flowing], closed, rtol=1e-9)
    # the peak is the intact surface's, the end the residual one's
    assert r["peak_deviator"] <= _cauchy_deviator(soil, 0.0, p, J[flowing[0]]) * (1 + 1e-9)
    assert r["peak_deviator"] >= _cauchy_deviator(soil, kappa[flowing[0]], p, J[flowing[0]]) \
        * (1 - 1e-9)
    assert q[-1] == pytest.approx(_cauchy_deviator(soil, math.inf, p, J[-1]), rel=1e-9)
    assert soil.residual_deviator(p) < 0.8 * soil.peak_deviator(p)
    # softening: the deviator never rises once the soil flows
    assert np.all(np.diff(q[flowing]) <= 1e-9 * q[flowing[0]])


@pytest.mark.parametrize("test, factor", [("biaxial-mc", 2.0), ("triaxial-mc", 1.5)])
def test_kappa_is_the_plastic_shear_strain(test, factor):
    """With psi = 0 the flow is isochoric along the potential's normal: in plane strain
    d eps_p = d gamma (1, 0, -1) (kappa = 2 eps_a^p); in triaxial compression the edge
    t1 = t2 gives (d, d, -2 d) (kappa = 3 d = 1.5 eps_a^p).  The axial plastic strain is the
    record's total less the change of the elastic strain, found apart from kappa."""
    r = run_element_test(test, law=LAW, friction_angle=30.0, cohesion=10.0,
                         residual_cohesion=1.0, residual_friction_angle=22.0,
                         softening_displacement=0.05, axial_strain=0.05, increments=400)
    kappa = np.asarray(r["series"]["state"]["kappa"])
    axial = np.asarray(r["series"]["plastic_axial_strain"])
    assert kappa[-1] > 0.05
    np.testing.assert_allclose(kappa, factor * axial, rtol=1e-8, atol=1e-12)


def test_the_softening_is_regularised_by_the_cell_size():
    """kappa_r = u_r / h: on a grid twice as fine the band is half as wide and its strain
    twice as large for the same displacement across it, so the same displacement softens
    it alike."""
    soil = _law(friction_angle=30.0, cohesion=10.0, residual_cohesion=2.0,
                softening_displacement=0.1)
    for h in (0.5, 0.25, 0.125):
        assert soil.constants(1e-3, h)["kappa_r"] == pytest.approx(0.1 / h, rel=1e-15)
        # half the displacement across a band one cell wide: half way down to the residual
        half = soil.softened(0.05 / h, h)
        assert half.cohesion == pytest.approx(6.0, rel=1e-12)
    assert soil.softened(0.0).cohesion == 10.0 and soil.softened(1e9).cohesion == 2.0


def test_strength_reduction_reduces_peak_and_residual():
    soil = _law(friction_angle=30.0, cohesion=10.0, residual_friction_angle=20.0,
                residual_cohesion=4.0, softening_displacement=0.1)
    weak = soil.reduced(2.0)
    assert isinstance(weak, MohrCoulombSoftening)
    assert weak.cohesion == 5.0 and weak.residual_cohesion == 2.0
    assert math.tan(math.radians(weak.residual_friction_angle)) == pytest.approx(
        math.tan(math.radians(20.0)) / 2.0, rel=1e-14)
    assert weak.softening_displacement == 0.1


def test_it_is_a_registered_soil_law_with_its_state_declared():
    assert MATERIALS[LAW] is MohrCoulombSoftening and LAW in LAWS
    fields = MohrCoulombSoftening.particle_fields(2)
    assert set(fields) == set(MohrCoulomb.particle_fields(2)) | {"kappa"}
    assert fields["kappa"].initial == 0.0


@pytest.mark.parametrize("kwargs, message", [
    (dict(residual_cohesion=12.0), "residual_cohesion 12 Pa must not exceed the cohesion 10"),
    (dict(residual_friction_angle=35.0), "residual_friction_angle 35 must not exceed"),
    (dict(friction_angle=0.0, residual_cohesion=0.0), "a residual soil with neither"),
    (dict(softening_displacement=0.0), r"softening_displacement must be a number in "
                                       r"\(0, inf\) m"),
    (dict(softening_displacement="0.1"), "softening_displacement must be a number"),
    (dict(residual_cohesion=-1.0), r"residual_cohesion must be a number in \[0, inf\) Pa"),
])
def test_bad_parameters_are_refused_by_name(kwargs, message):
    args = dict(friction_angle=30.0, cohesion=10.0, residual_cohesion=2.0,
                softening_displacement=0.1)
    with pytest.raises(ValueError, match=message):
        _law(**{**args, **kwargs})


def test_the_softening_displacement_is_required():
    with pytest.raises(TypeError, match="softening_displacement"):
        MohrCoulombSoftening(**SOIL, friction_angle=30.0, cohesion=10.0)


def test_an_element_test_names_the_parameter_it_lacks(capsys):
    from timpm.cli.main import main

    with pytest.raises(ValueError, match="no default for softening_displacement"):
        run_element_test("biaxial-mc", law=LAW)
    assert main(["run", "biaxial-mc", "--law", LAW]) == 2
    err = capsys.readouterr().err
    assert "--param softening_displacement=VALUE" in err and "Traceback" not in err


def test_the_sensitive_clay_cut_fails_retrogressively(tmp_path):
    """The example scene at h = 1 m: the softening clay slides back into the ground and
    runs out far; the same cut of perfectly plastic clay at its peak strength slumps and
    stops (its run-out a fraction of the softening one's)."""
    import json
    from pathlib import Path

    from timpm.scenefile import load_scene, run_scene

    path = Path(__file__).resolve().parent.parent / "examples" / "retrogressive_clay_slope.toml"
    coarse = {"domain.cells": 100, "output.gif": None, "output.frames": 30}
    runs = {}
    for name, changes in (("softening", {}),
                          ("peak", {"material.clay": {
                              "type": "mohr-coulomb", "E": 1e7, "nu": 0.3,
                              "density": 1834.862385321101, "friction_angle": 0.0,
                              "cohesion": 30e3, "tensile_strength": 15e3}})):
        out = tmp_path / f"{name}.json"
        run_scene(load_scene(path, {**coarse, **changes, "output.json": str(out)}))
        runs[name] = json.loads(out.read_text())["landslide"]
    soft, peak = runs["softening"], runs["peak"]
    H = 10.0
    assert soft["runout"] > 2.5 * H and soft["retrogressions"] >= 1
    assert soft["scarp_retreat"] > 1.5 * H  # the scarp well behind the crest (5 m from the toe)
    assert peak["runout"] < 0.3 * soft["runout"] and peak["scarp_retreat"] < H
