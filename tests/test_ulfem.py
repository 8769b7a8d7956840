"""The NumPy updated-Lagrangian FEM reference (study 2.4, A.4, A.5)."""
import numpy as np
import pytest

from timpm.studies.ulfem import ULFEM, large_column, oedometer_strain, period_from_maxima

E = 1e5


@pytest.fixture(scope="module")
def column():
    """The A.5 column: 30 elements, dt = 1e-3 s, 3 s, the study's stress update."""
    return large_column(n_elements=30, dt=1e-3, t_end=3.0)


# ---- A.4: the loaded oedometer ---------------------------------------------------------

@pytest.mark.parametrize("ratio", [1e-3, 0.2, 0.5])
def test_oedometer_small_deformation_strain_is_linear(ratio):
    # the study's standard FEM (Figure A.1): Delta H / H = -p0 / E
    strain = oedometer_strain(ratio * E, stress_update="small")
    assert strain == pytest.approx(-ratio, rel=1e-2)


@pytest.mark.parametrize("ratio", [1e-3, 0.2, 0.5])
def test_oedometer_ulfem_strain_is_logarithmic(ratio):
    # the ULFEM with sigma += (E - sigma) d_eps: ln(1 + Delta H / H) = -ln(1 + p0 / E)
    exact = -np.log1p(ratio)
    assert oedometer_strain(ratio * E, stress_update="study") == pytest.approx(exact, rel=1e-2)
    if ratio == 0.5:
        # the accumulated strain sum d_eps measures the same logarithmic strain
        accumulated = oedometer_strain(ratio * E, stress_update="study", measure="accumulated")
        assert accumulated == pytest.approx(exact, rel=1e-2)


def test_small_strain_update_on_updated_mesh_gives_log_strain():
    # sum dh / h is ln(h / h0): sigma = E ln(h / h0), so Delta H / H = exp(-p0 / E) - 1,
    # 9% away from -p0 / E at p0 / E = 0.2: why "small" defaults to the initial geometry
    strain = oedometer_strain(0.2 * E, stress_update="small", geometry="updated")
    assert strain == pytest.approx(np.expm1(-0.2), rel=1e-3)


def test_oedometer_comes_to_rest_with_uniform_stress():
    model = ULFEM(n_elements=10, top_load=0.2 * E, ramp=1.0, damping=0.7, dt=1e-3)
    res = model.run(6.0, record_every=500)
    assert np.abs(res.final["v"]).max() < 1e-6
    np.testing.assert_allclose(res.final["sigma"], -0.2 * E, rtol=1e-6)
    # nodes moved: uniform compression, element lengths h0 / (1 + p0 / E)
    np.testing.assert_allclose(res.final["h"], 0.1 / 1.2, rtol=1e-3)
    assert res.final["min_critical_dt"] > model.dt


def test_step_load_energy_balance():
    # undamped step load: kinetic + strain energy = work of the traction
    model = ULFEM(n_elements=20, top_load=0.1 * E, ramp=0.0, damping=0.0, dt=1e-3)
    res = model.run(1.0)
    e = res.energy
    assert np.max(np.abs(e["total"])) < 0.02 * np.max(e["external_work"])
    assert np.all(e["damping_work"] == 0.0)


def test_damped_self_weight_column_carries_its_weight():
    model = ULFEM(n_elements=8, gravity=-9.81, damping=0.7, dt=1e-3, stress_update="small",
                  geometry="initial")
    res = model.run(4.0, record_every=4000)
    weight_above = np.cumsum(model.f_grav[::-1])[::-1][1:]  # nodal gravity above each element
    np.testing.assert_allclose(res.final["sigma"], weight_above, rtol=1e-4)
    assert model.mass.sum() == pytest.approx(1e3 * 1.0)


# ---- A.5: the large-deformation column -------------------------------------------------

def test_column_energy_is_conserved(column):
    # Euler-Cromer keeps the energy bounded: 0.24% of the largest strain energy here
    assert column["energy_drift"] < 0.01
    assert np.max(np.abs(column["total"])) < 0.01 * np.max(column["strain"])
    # the column swings between the undeformed state and about twice its static sag
    assert column["position"].max() == pytest.approx(0.5, abs=1e-3)
    y, H = 0.5, 1.0
    static_sag = 1e3 * 9.81 * (H * y - y ** 2 / 2) / E  # small-strain statics, 0.037 m
    assert column["position"].min() < 0.5 - 1.5 * static_sag


def test_column_period(column):
    # the potential energy peaks twice per displacement period (both turning points)
    assert column["potential_maxima_spacing"] == pytest.approx(column["period"] / 2)
    for other in ("strain_energy_period", "position_period"):
        assert column[other] == pytest.approx(column["period"], rel=1e-2)
    # Our period is 0.374 s, converged: dt = 1e-4 s gives 0.3743 s, 60 elements 0.3741 s,
    # and an independent RK4 integration of sigma = E (1 - h0 / h) gives 0.376 s for the
    # mid-point position.  The study reports 0.364 s for its ULFEM (0.374 s for its MPM):
    # ours is 2.8% longer.  Assert our value tightly and the study's loosely.
    assert column["period"] == pytest.approx(0.3741, rel=5e-3)
    assert column["period"] == pytest.approx(0.364, rel=0.04)
    # stiffening in compression: shorter than the small-deformation 4 H / c = 0.4 s
    assert column["period"] < 0.39


def test_small_deformation_column_period_is_4H_over_c():
    small = large_column(n_elements=10, t_end=2.0, stress_update="small", geometry="initial")
    assert small["period"] == pytest.approx(4.0 / np.sqrt(E / 1e3), rel=1e-2)


# ---- period_from_maxima ----------------------------------------------------------------

def test_period_from_maxima_sub_step_accuracy():
    t = np.arange(0.0, 3.0, 0.01)
    period = 0.3741
    assert period_from_maxima(t, np.cos(2 * np.pi * t / period)) == pytest.approx(period, rel=1e-3)
    # ripples from a higher mode are not taken for maxima
    rippled = np.cos(2 * np.pi * t / period) + 0.02 * np.sin(2 * np.pi * t / 0.03)
    assert period_from_maxima(t, rippled) == pytest.approx(period, rel=1e-2)
    # non-uniform sampling
    tn = np.sort(np.concatenate([t, t[:-1] + 0.003]))
    assert period_from_maxima(tn, np.sin(2 * np.pi * tn / period)) == pytest.approx(period, rel=1e-3)


def test_period_from_maxima_needs_two_maxima():
    t = np.linspace(0.0, 1.0, 101)
    with pytest.raises(ValueError, match="two local maxima"):
        period_from_maxima(t, np.sin(np.pi * t))
    with pytest.raises(ValueError, match="same length"):
        period_from_maxima(t, t[:-1])


# ---- bookkeeping and bad input ---------------------------------------------------------

def test_run_continues_from_the_current_state():
    kw = dict(n_elements=6, gravity=-9.81, dt=1e-3)
    whole = ULFEM(**kw).run(0.5)
    split = ULFEM(**kw)
    split.run(0.2)
    part = split.run(0.5)
    assert part.t[0] == pytest.approx(0.2) and part.t[-1] == pytest.approx(0.5)
    np.testing.assert_allclose(part.x[-1], whole.x[-1], rtol=0, atol=1e-14)
    np.testing.assert_allclose(part.energy["total"][-1], whole.energy["total"][-1], atol=1e-9)


@pytest.mark.parametrize("kwargs, name", [
    (dict(E=0.0), "E"),
    (dict(E=-1.0), "E"),
    (dict(density=0.0), "density"),
    (dict(length=-1.0), "length"),
    (dict(length=float("nan")), "length"),
    (dict(n_elements=0), "n_elements"),
    (dict(n_elements=2.5), "n_elements"),
    (dict(dt=0.0), "dt"),
    (dict(dt=-1e-3), "dt"),
    (dict(damping=1.0), "damping"),
    (dict(damping=-0.1), "damping"),
    (dict(ramp=-1.0), "ramp"),
    (dict(gravity=float("inf")), "gravity"),
    (dict(top_load="a lot"), "top_load"),
    (dict(stress_update="large"), "stress_update"),
    (dict(geometry="eulerian"), "geometry"),
    (dict(fixed_nodes=(11,)), "fixed_nodes"),
    (dict(fixed_nodes=(0.5,)), "fixed_nodes"),
    (dict(load_node=-1), "load_node"),
])
def test_bad_input_names_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name):
        ULFEM(**kwargs)


def test_time_step_above_critical_is_refused():
    # 10 elements over 1 m, c = 10 m/s: critical step 1e-2 s (Eq. 2.4)
    with pytest.raises(ValueError, match="critical time step"):
        ULFEM(n_elements=10, dt=2e-2)
    model = ULFEM(n_elements=10, dt=2e-2, allow_unstable_dt=True)
    assert model.dt_critical == pytest.approx(1e-2)


def test_bad_run_arguments():
    model = ULFEM(n_elements=4)
    with pytest.raises(ValueError, match="record_every"):
        model.run(0.01, record_every=0)
    model.run(0.01)
    with pytest.raises(ValueError, match="t_end"):
        model.run(0.0)
    with pytest.raises(ValueError, match="measure"):
        oedometer_strain(1e3, measure="nodal")
