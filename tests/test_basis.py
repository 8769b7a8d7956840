"""Every basis: partition of unity, derivative against finite differences, linear fields."""
import numpy as np
import pytest

from timpm.bases import BASES, evaluate, get_basis
from timpm.studies.analysis import stretched_quadrature_error

N_ELEMENTS = 6


def _points(n_elements, n=997):
    # points all over the domain, ends and element boundaries included
    xi = np.linspace(0.0, n_elements, n)
    return np.concatenate([xi, np.arange(n_elements + 1, dtype=float)])


@pytest.mark.parametrize("name", sorted(BASES))
def test_partition_of_unity(name):
    phi, dphi = evaluate(get_basis(name), _points(N_ELEMENTS), N_ELEMENTS)
    np.testing.assert_allclose(phi.sum(axis=1), 1.0, atol=1e-13)
    np.testing.assert_allclose(dphi.sum(axis=1), 0.0, atol=1e-12)


@pytest.mark.parametrize("name", sorted(BASES))
def test_gradient_matches_finite_differences(name):
    # central differences away from element boundaries (where the derivative may jump)
    rng = np.random.default_rng(1)
    elem = rng.integers(0, N_ELEMENTS, 200)
    xi = elem + rng.uniform(0.05, 0.95, 200)
    eps = 1e-6
    phi_p, _ = evaluate(get_basis(name), xi + eps, N_ELEMENTS)
    phi_m, _ = evaluate(get_basis(name), xi - eps, N_ELEMENTS)
    _, dphi = evaluate(get_basis(name), xi, N_ELEMENTS)
    np.testing.assert_allclose(dphi, (phi_p - phi_m) / (2 * eps), atol=1e-7)


@pytest.mark.parametrize("name", sorted(BASES))
def test_reproduces_linear_fields(name):
    basis = get_basis(name)
    xi = _points(N_ELEMENTS)
    phi, dphi = evaluate(get_basis(name), xi, N_ELEMENTS)
    nodes = basis.node_coordinates(N_ELEMENTS)
    a, b = 0.3, -1.7
    np.testing.assert_allclose(phi @ (a + b * nodes), a + b * xi, atol=1e-12)
    np.testing.assert_allclose(dphi @ (a + b * nodes), b, atol=1e-11)


@pytest.mark.parametrize("name", sorted(BASES))
def test_support_is_local(name):
    basis = get_basis(name)
    phi, _ = evaluate(get_basis(name), _points(N_ELEMENTS), N_ELEMENTS)
    assert np.all((np.abs(phi) > 0).sum(axis=1) <= basis.support)


def test_linear_hat_values():
    # N1 = 1 - xi, N2 = xi on each element (study 2.2.3)
    phi, dphi = evaluate(get_basis("linear"), np.array([0.25, 2.5, 6.0]), N_ELEMENTS)
    assert phi[0, 0] == pytest.approx(0.75) and phi[0, 1] == pytest.approx(0.25)
    assert phi[1, 2] == pytest.approx(0.5) and phi[1, 3] == pytest.approx(0.5)
    assert phi[2, 6] == pytest.approx(1.0)
    assert dphi[1, 2] == pytest.approx(-1.0) and dphi[1, 3] == pytest.approx(1.0)


def test_unknown_basis_is_refused():
    with pytest.raises(ValueError, match="unknown basis 'cubic'.*linear"):
        get_basis("cubic")


@pytest.mark.parametrize("name, degree", [("linear", 1), ("bspline2", 2), ("bspline3", 3)])
def test_particle_quadrature_error_under_stretch(name, degree):
    # Gauss particles integrate a constant stress exactly in their reference cells; once
    # stretched, a Gauss point sits between the knots of some basis functions, and there the
    # force errs by O(strain^(p-1)), at a share O(strain) of the nodes: an RMS of
    # O(strain^(p-1/2)), whatever the cell size (the MMS floor of docs/results.md)
    assert stretched_quadrature_error(get_basis(name), 0.0) < 1e-12
    strains = [0.01, 0.02, 0.04, 0.08, 0.16]
    errors = [stretched_quadrature_error(get_basis(name), s) for s in strains]
    rate = np.log(errors[-1] / errors[0]) / np.log(strains[-1] / strains[0])
    assert abs(rate - (degree - 0.5)) < 0.2, (name, errors, rate)


def _cox_de_boor(knots, i, p, x):
    """N_{i,p}(x) and its derivative by the recursive definition (x in [t_i, t_{i+p+1}),
    0/0 = 0): an independent reference for the engine's stencils."""
    if p == 0:
        return (1.0 if knots[i] <= x < knots[i + 1] else 0.0), 0.0
    value = slope = 0.0
    for j, sign in ((i, 1.0), (i + 1, -1.0)):
        span = knots[j + p] - knots[j]
        if span > 0.0:
            n, dn = _cox_de_boor(knots, j, p - 1, x)
            far = x - knots[j] if sign > 0 else knots[j + p] - x
            value += far * n / span
            slope += sign * n / span * p
    return value, slope


@pytest.mark.parametrize("name", ["bspline2", "bspline3"])
def test_clamped_bsplines_match_the_recursive_definition(name):
    # the clamped stencil takes the cardinal closed form on spans whose knots are all
    # distinct and de Boor's scheme near the ends: both against the recursion, everywhere
    basis, n = get_basis(name), 9
    p = basis.degree
    knots = np.clip(np.arange(n + 2 * p + 1) - p, 0, n).astype(float)
    xi = np.random.default_rng(3).uniform(0.0, n, 400)
    phi, dphi = evaluate(basis, xi, n)
    ref = np.array([[_cox_de_boor(knots, i, p, x) for i in range(n + p)] for x in xi])
    np.testing.assert_allclose(phi, ref[..., 0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(dphi, ref[..., 1], rtol=0, atol=1e-13)
