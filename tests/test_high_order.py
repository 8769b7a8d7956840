"""Higher-order bases on the three benchmarks: the orders theory gives, and the cure of
grid-crossing errors (study 2.3, chapter 5, issue: high order)."""
import numpy as np
import pytest

import timpm
from timpm.problems import get_problem
from timpm.model.scene import particle_matrices
from timpm.studies.study import convergence, displacement_fields, run_problem


@pytest.mark.parametrize("basis,elements,order", [("bspline2", (4, 8, 16, 32), 3.0),
                                                  ("bspline3", (4, 8, 16), 4.0)])
def test_string_bsplines_converge_at_order_p_plus_one(basis, elements, order):
    # consistent mass (the L2 projection) and Gauss-point particles (exact quadrature of
    # the mass matrix): the displacement converges at order p + 1 down to the 1.2e-8 floor
    # of the model error (finite-deformation MPM against the linear wave equation)
    doc = convergence("vibrating-string", elements=elements, basis=basis, mass="consistent",
                      placement="gauss", dt=1e-5, energies=False)
    rates = [row["rate"] for row in doc["rates"]]
    assert np.mean(rates) > order - 0.5
    assert min(rates) > order - 1.0


def test_string_error_floor_is_model_error_not_time_error():
    kw = dict(elements=32, basis="bspline3", mass="consistent", placement="gauss", energies=False)
    e = {(su, dt): run_problem("vibrating-string", dt=dt, stress_update=su, **kw).record["rms_error"]
         for su in ("study", "small") for dt in (1e-4, 1e-5)}
    assert e["study", 1e-4] == pytest.approx(e["study", 1e-5], rel=0.01)  # not time error
    assert e["small", 1e-5] < 0.6 * e["study", 1e-5]  # the study's update adds to it


def test_string_lumped_mass_caps_bsplines_at_second_order():
    doc = convergence("vibrating-string", elements=(8, 16, 32), basis="bspline2", dt=1e-5,
                      energies=False)
    rates = [row["rate"] for row in doc["rates"]]
    assert max(rates) < 2.6


def test_soil_column_cubic_bsplines_keep_converging_through_128_elements():
    elements = (8, 16, 32, 64, 128)
    cubic = convergence("soil-column", elements=elements, basis="bspline3", ppc=2, dt=1e-4,
                        t_end=0.2, energies=False)
    linear = convergence("soil-column", elements=(64, 128), ppc=2, dt=1e-4, t_end=0.2,
                         energies=False)
    e3 = np.array([r["rms_error"] for r in cubic["runs"]])
    assert np.all(np.diff(e3) < 0)  # monotonically decreasing from 8 to 128 elements
    assert cubic["runs"][-1]["grid_crossings"] > 0  # ... although particles cross
    e1 = [r["rms_error"] for r in linear["runs"]]
    assert e1[1] > 5 * e1[0]  # while linear loses convergence to grid crossing
    assert e3[-1] < e1[1] / 5


def test_vibrating_bar_bsplines_keep_decreasing_where_linear_stalls():
    elements = (8, 16, 32, 64, 128)
    quad = convergence("vibrating-bar", elements=elements, basis="bspline2", energies=False)
    lin = convergence("vibrating-bar", elements=elements, energies=False)
    e2 = np.array([r["rms_error"] for r in quad["runs"]])
    e1 = np.array([r["rms_error"] for r in lin["runs"]])
    assert np.all(np.diff(e2) < 0)
    assert e1[-1] > e1.min() * 3 and e2[-1] < e1[-1] / 5


def test_lagrange_mass_matrix_has_negative_entries():
    scene = get_problem("vibrating-string").scene(elements=4, ppc=4, basis="lagrange2",
                                                   mass="consistent", dt=1e-3)
    base, k, m = particle_matrices(scene.grid, scene.material, "lagrange2", scene.positions,
                                   scene.volume)
    assert m.min() < 0  # entries m_p N_i N_j with N_i < 0 inside the element (5.1)
    with pytest.raises(ValueError, match="cannot be lumped"):
        get_problem("vibrating-string").scene(elements=4, basis="lagrange2")


def test_lagrange_needs_a_much_smaller_step_and_is_diagnosed_above_it():
    p = get_problem("vibrating-string")
    lin = p.scene(elements=8, ppc=4, dt=1e-3)
    lag = p.scene(elements=8, ppc=4, basis="lagrange2", mass="consistent", dt=1e-3)
    assert lag.critical_dt < lin.critical_dt / 4
    dt = 2.0 * lag.critical_dt
    with pytest.raises(timpm.SimulationError, match=r"step \d+"):
        run_problem("vibrating-string", elements=8, ppc=4, basis="lagrange2",
                    mass="consistent", dt=dt, t_end=400 * dt, allow_unstable_dt=True)


def test_lagrange_displacement_field_inside_elements():
    # study 5.2 (Figures 5.5, 5.6): u_h(x) = sum phi_i(x) u_i at 4 elements, t = 0.5 s
    f = displacement_fields(elements=4, ppc=4, dt=1e-3, t_end=0.5, points_per_element=250)
    amplitude = np.abs(f["exact"]).max()
    lagrange = np.abs(f["fields"]["lagrange2, consistent"] - f["exact"])
    linear = np.abs(f["fields"]["linear, lumped"] - f["exact"])
    assert lagrange.max() < 0.1 * amplitude and linear.max() < 0.2 * amplitude
    # linear elements err most inside the elements (the chord), at the element middles
    mids = np.isclose((f["x"] / (f["x"][-1] / 4)) % 1.0, 0.5)
    assert linear[mids].max() > 0.9 * linear.max()


def test_nodal_displacements_follow_the_particles():
    p = get_problem("vibrating-string")
    solver = timpm.Solver(p.scene(elements=8, ppc=4, basis="lagrange2", mass="consistent",
                                  dt=1e-3), grid_displacement=True, energies=False)
    solver.run(0.5)
    u = solver.displacements()
    np.testing.assert_allclose(solver.displacement_field(solver.positions()), u,
                               atol=0.05 * np.abs(u).max())
    solver.release()


@pytest.mark.slow  # the default suite keeps the study's MLS path bit for bit (test_golden)
def test_mls_projection_converges_on_the_string():
    doc = convergence("vibrating-string", elements=(8, 16, 32), projection="mls", energies=False)
    rates = [row["rate"] for row in doc["rates"]]
    assert min(rates) > 1.9
    # it reconstructs the same solution as the standard projection, to within a third
    std = convergence("vibrating-string", elements=(32,), energies=False)
    assert doc["runs"][-1]["rms_error"] == pytest.approx(std["runs"][0]["rms_error"], rel=0.4)


def test_mls_projection_is_musl():
    with pytest.raises(ValueError, match="MLS projection .* implemented with the musl "
                                         "transfer, got apic"):
        get_problem("vibrating-string").scene(projection="mls", transfer="apic")
    with pytest.raises(ValueError, match="unknown projection 'kriging'"):
        get_problem("vibrating-string").scene(projection="kriging")
