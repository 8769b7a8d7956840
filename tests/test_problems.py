"""Each exact solution satisfies its PDE, boundary and initial conditions numerically."""
import numpy as np
import pytest

from timpm.problems import PROBLEMS, get_problem

D = 1e-4  # finite-difference step in x and t


def _residual(prob, x, t, source=0.0):
    """u_tt - (E/rho) u_xx - source by central differences, scaled by the size of u_tt."""
    u = prob.displacement
    utt = (u(x, t + D) - 2 * u(x, t) + u(x, t - D)) / D ** 2
    uxx = (u(x + D, t) - 2 * u(x, t) + u(x - D, t)) / D ** 2
    return utt - prob.E / prob.density * uxx - source


def test_vibrating_string_solves_wave_equation():
    p = get_problem("vibrating-string")
    x = np.linspace(1.0, p.L - 1.0, 50)
    for t in (0.3, 1.7, 4.2):
        assert np.max(np.abs(_residual(p, x, t))) < 1e-4 * p.v0 * p.omega
    assert np.allclose(p.displacement(np.array([0.0, p.L]), 2.0), 0.0, atol=1e-15)
    assert np.allclose(p.displacement(x, 0.0), 0.0)
    np.testing.assert_allclose(p.velocity(x, 0.0), p.v0 * np.sin(np.pi * x / p.L))
    # velocity is the time derivative of displacement
    np.testing.assert_allclose(p.velocity(x, 1.3),
                               (p.displacement(x, 1.3 + D) - p.displacement(x, 1.3 - D)) / (2 * D),
                               rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("p0", [0.0, 20.0])
def test_soil_column_solves_pde_with_gravity_downwards(p0):
    p = get_problem("soil-column", p0=p0)
    g = -p.gravity  # magnitude: the PDE reads u_tt = (E/rho) u_yy - g
    y = np.linspace(2.0, p.H - 2.0, 40)
    if p0 == 0.0:  # a sudden top load sends kinks (deltas in u_yy) that the series blurs
        for t in (0.013, 0.1, 0.37):
            res = _residual(p, y, t, source=-g)
            assert np.sqrt(np.mean(res ** 2)) < 1e-2 * g
    # u(0) = 0, u_y(H) = p0 / E, u(y, 0) = 0, u_t(y, 0) = 0
    assert abs(p.displacement(np.array([0.0]), 0.2)[0]) < 1e-12
    uy = (p.displacement(np.array([p.H]), 0.2) - p.displacement(np.array([p.H - D]), 0.2)) / D
    assert uy[0] == pytest.approx(p0 / p.E, abs=2e-6)
    ys = np.linspace(0.0, p.H, 30)
    scale = max(p.density * g * p.H ** 2, abs(p0) * p.H) / p.E
    assert np.max(np.abs(p.displacement(ys, 0.0))) < 1e-4 * scale
    assert np.max(np.abs(p.velocity(ys[1:-1], 0.0))) < 1e-12


def test_soil_column_sinks_under_gravity():
    # gravity -9.81 points down: the column is compressed, never lifted
    p = get_problem("soil-column")
    y = np.linspace(0.5, p.H, 50)
    times = np.linspace(0.01, 1.0, 25)
    assert all(np.all(p.displacement(y, t) <= 1e-12) for t in times)
    static_tip = -p.density * (-p.gravity) * p.H ** 2 / (2 * p.E)
    mean_tip = np.mean([p.displacement(np.array([p.H]), t)[0]
                        for t in np.linspace(0, 4 * 2 * p.H / np.sqrt(p.E / p.density), 801)])
    assert mean_tip == pytest.approx(static_tip, rel=1e-2)


def test_vibrating_bar_solution():
    p = get_problem("vibrating-bar")
    x = np.linspace(0.05, 0.95, 19)
    for t in (0.5, 1.0, 1.6, 2.5, 3.5):
        res = _residual(p, x, t)
        near_front = np.isclose((t - p.L + x) % p.L, 0, atol=5 * D) | np.isclose((t - p.L - x) % p.L, 0, atol=5 * D)
        assert np.max(np.abs(res[~near_front])) < 1e-4
    # u(0) = 0, E u_x(L) = tau sin(pi t / L) (the traction), quiet before the wave arrives
    for t in (0.2, 0.7, 1.3):
        assert abs(p.displacement(np.array([0.0]), t)[0]) < 1e-15
        ux = (p.displacement(np.array([p.L]), t) - p.displacement(np.array([p.L - D]), t)) / D
        assert p.E * ux[0] == pytest.approx(p.tau * np.sin(np.pi * t / p.L), abs=1e-3)
    assert p.displacement(np.array([0.3]), 0.5)[0] == 0.0


def test_oedometer_static_strains():
    p = get_problem("oedometer", p0=2e4)
    assert p.strain("small") == pytest.approx(-0.2)
    assert p.strain("study") == pytest.approx(-np.log(1.2))
    # the study's update sigma += (E - sigma) d_eps integrates to sigma = E (1 - 1/stretch):
    # at sigma = -p0 the log strain is -ln(1 + p0/E)
    stretch = np.exp(p.strain("study"))
    assert p.E * (1 - 1 / stretch) == pytest.approx(-p.p0)


@pytest.mark.parametrize("name", sorted(PROBLEMS))
def test_every_problem_builds_a_valid_scene(name):
    p = get_problem(name)
    scene = p.scene(elements=4, ppc=2, dt=1e-5)
    model = scene.model
    assert scene.n_particles == 8 ** model.dim
    assert scene.volume.sum() == pytest.approx(p.domain_length() ** model.dim)
    for k in range(model.dim):
        assert model.origin[k] + model.elements[k] * model.h >= p.domain_length()


def test_unknown_problem_and_parameter_are_refused():
    with pytest.raises(ValueError, match="unknown problem 'string'"):
        get_problem("string")
    with pytest.raises(ValueError, match="no parameter Youngs"):
        get_problem("vibrating-string", Youngs=3.0)
    with pytest.raises(ValueError, match="parameter L must be positive"):
        get_problem("vibrating-string", L=0.0)
    with pytest.raises(ValueError, match="parameter H must be positive"):
        get_problem("soil-column", H=-1.0)


@pytest.mark.slow
def test_the_2d_soil_column_converges_to_the_1d_series():
    # plane strain, nu = 0, slip walls: the 1D series is the exact u_y and u_x stays 0
    from timpm.studies.study import convergence

    doc = convergence("soil-column-2d", elements=(8, 16, 32, 64), basis="bspline2", dt=1e-4,
                      t_end=0.2, series=False, energies=False)
    errors = [r["rms_error"] for r in doc["runs"]]
    assert all(b < a for a, b in zip(errors, errors[1:])), errors
    assert min(r["rate"] for r in doc["rates"]) > 1.4, doc["rates"]


def test_the_2d_soil_column_is_checked():
    with pytest.raises(ValueError, match="width must be a positive number of cells"):
        get_problem("soil-column-2d", width=0)
    with pytest.raises(ValueError, match="the top load p0 acts in 1D only"):
        get_problem("soil-column-2d", p0=1e3)
    with pytest.raises(ValueError, match="needs at least 3 elements, the grid has 2 along axis 0"):
        get_problem("soil-column-2d", width=2).scene(elements=8, basis="bspline3")
