"""Moving least squares projection (chapter 4) and the projection study of section 4.4."""
import numpy as np
import pytest

from timpm.studies.mls import (WEIGHTS, cubic_spline, element_points, get_weight, linear_hat,
                       mls_fit, mls_shape_functions, projection_study, quadratic_spline)

H = 0.1


def _random_data(n_elements=10, ppc=4, seed=3):
    rng = np.random.default_rng(seed)
    return element_points(n_elements, ppc, "random", rng=rng), 1.0 / n_elements


# ---- weight functions ----------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(WEIGHTS))
def test_weight_properties(name):
    w = get_weight(name)
    radius = w.support * H
    d = np.linspace(-1.5 * radius, 1.5 * radius, 6001)
    v = w(d, H)
    assert (v >= 0).all()
    np.testing.assert_allclose(v, w(-d, H), atol=1e-15)              # symmetric
    inside = np.abs(d) < radius
    assert (v[inside] > 0).all() and (v[~inside] == 0).all()            # compact support
    right = d >= 0
    assert (np.diff(v[right]) <= 1e-15).all()                           # decreasing in |d|
    # continuous everywhere: no jump larger than the slope allows on this grid
    step = d[1] - d[0]
    assert np.abs(np.diff(v)).max() < 2.0 / H * step
    assert w(radius, H) == pytest.approx(0.0, abs=1e-15)
    # integral h (the study's unit integral after dividing by h; MLS ignores the scale)
    fine = np.linspace(-radius, radius, 200001)
    assert np.trapezoid(w(fine, H), fine) == pytest.approx(H, rel=1e-8)


def test_weight_values():
    assert linear_hat(0.0, H) == 1.0 and linear_hat(0.5 * H, H) == pytest.approx(0.5)
    # cubic spline, r = |d|/(2h): 2/3 at the centre, 1/6 from both pieces at r = 1/2
    assert cubic_spline(0.0, H) == pytest.approx(2 / 3)
    r = 0.5
    assert 2 / 3 - 4 * r**2 + 4 * r**3 == pytest.approx(1 / 6)
    assert 4 / 3 - 4 * r + 4 * r**2 - 4 / 3 * r**3 == pytest.approx(1 / 6)
    assert cubic_spline(H * (1 - 1e-12), H) == pytest.approx(1 / 6)
    assert cubic_spline(H * (1 + 1e-12), H) == pytest.approx(1 / 6)
    assert quadratic_spline(0.0, H) == pytest.approx(0.75)


def test_quadratic_spline_misprint():
    """The study prints 3/4 - 4 r^2 for r <= 1/2: -1/4 at r = 1/2 against 1/2 outside."""
    def printed(r):
        return np.where(r <= 0.5, 0.75 - 4 * r**2, np.where(r <= 1.5, 0.5 * (1.5 - r) ** 2, 0.0))

    eps = 1e-9
    assert printed(0.5 - eps) == pytest.approx(-0.25)                   # negative,
    assert printed(0.5 + eps) == pytest.approx(0.5)                     # and a jump of 3/4
    # the standard quadratic B-spline used: continuous, with continuous slope (-1 both sides)
    left, right = quadratic_spline((0.5 - eps) * H, H), quadratic_spline((0.5 + eps) * H, H)
    assert left == pytest.approx(0.5) and right == pytest.approx(0.5)
    w = lambda r: quadratic_spline(r * H, H)
    delta = 1e-6
    slopes = [(w(0.5) - w(0.5 - delta)) / delta, (w(0.5 + delta) - w(0.5)) / delta]
    np.testing.assert_allclose(slopes, -1.0, atol=1e-5)


def test_unknown_weight():
    with pytest.raises(ValueError, match="unknown weight"):
        get_weight("gaussian")


# ---- the MLS approximation -----------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(WEIGHTS))
@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_partition_of_unity(name, degree):
    xp, h = _random_data()
    x = np.linspace(0.0, 1.0, 101)
    phi = mls_shape_functions(x, xp, name, h, degree)
    np.testing.assert_allclose(phi.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(mls_fit(x, xp, np.ones_like(xp), name, h, degree), 1.0,
                               atol=1e-12)


@pytest.mark.parametrize("name", sorted(WEIGHTS))
@pytest.mark.parametrize("degree", [1, 2, 3])
def test_reproduces_polynomials(name, degree):
    # degree m reproduces every polynomial of degree <= m, the ends of [0, 1] included
    xp, h = _random_data()
    x = np.linspace(0.0, 1.0, 101)
    for k in range(degree + 1):
        f = lambda y: 0.3 - 2.0 * y + (y - 0.4) ** k
        np.testing.assert_allclose(mls_fit(x, xp, f(xp), name, h, degree), f(x), atol=1e-11)


def test_degree_zero_does_not_reproduce_linear_fields():
    xp, h = _random_data()
    x = np.linspace(0.0, 1.0, 11)
    assert np.abs(mls_fit(x, xp, xp, "linear", h, 0) - x).max() > 1e-3


def test_linear_hat_degree_zero_is_the_mpm_projection():
    # section 4.4: p = [1] with the hat of radius h is sum_p N_i(x_p) u_p / sum_p N_i(x_p)
    xp, h = _random_data(n_elements=8, ppc=4)
    nodes = np.arange(9) * h
    up = np.cos(3 * xp)
    n_ip = np.clip(1.0 - np.abs(nodes[:, None] - xp[None, :]) / h, 0.0, None)
    np.testing.assert_allclose(mls_fit(nodes, xp, up, "linear", h, 0),
                               n_ip @ up / n_ip.sum(axis=1), rtol=1e-13)


@pytest.mark.parametrize("degree", [1, 2])
def test_shifted_basis_gives_the_textbook_formula(degree):
    # u^h = p(x)^T A^-1 B u with raw p = [1, x, ..], on a domain away from the origin
    xp, h = _random_data(n_elements=6, seed=5)
    xp, x = xp + 3.0, np.linspace(3.0, 4.0, 13)
    up = np.exp(xp - 3.0)
    for xe, got in zip(x, mls_fit(x, xp, up, "cubic", h, degree)):
        p = xp[:, None] ** np.arange(degree + 1)
        w = cubic_spline(xe - xp, h)
        a = p.T @ (w[:, None] * p)
        expected = xe ** np.arange(degree + 1) @ np.linalg.solve(a, p.T @ (w * up))
        assert got == pytest.approx(expected, rel=1e-7)


def test_singular_moment_matrix_names_the_point():
    xp = np.array([0.40, 0.45])
    with pytest.raises(ValueError, match=r"singular at x = 0\b.*0 distinct"):
        mls_fit([0.42, 0.0], xp, [1.0, 2.0], "linear", 0.2, degree=0)
    # one point in the support of x = 0.3 is enough for p = [1], not for p = [1, x]
    assert mls_fit([0.3], xp, [1.0, 2.0], "linear", 0.12, degree=0) == pytest.approx(1.0)
    with pytest.raises(ValueError, match=r"singular at x = 0\.3\b.*1 distinct.*degree 1"):
        mls_fit([0.3], xp, [1.0, 2.0], "linear", 0.12, degree=1)
    with pytest.raises(ValueError, match=r"singular at x = 0\.42.*1 distinct"):
        mls_fit([0.42], [0.4, 0.4], [1.0, 2.0], "linear", 0.2, degree=1)   # coincident
    with pytest.raises(ValueError, match="singular at x = 0.42"):              # nearly so
        mls_fit([0.42], [0.4, 0.4 + 1e-9], [1.0, 2.0], "linear", 0.2, degree=1)


def test_bad_arguments():
    with pytest.raises(ValueError, match="shape"):
        mls_fit([0.5], [0.4, 0.6], [1.0], "linear", 0.2)
    with pytest.raises(ValueError, match="h must be positive"):
        mls_fit([0.5], [0.4, 0.6], [1.0, 2.0], "linear", 0.0)
    with pytest.raises(ValueError, match="degree"):
        mls_fit([0.5], [0.4, 0.6], [1.0, 2.0], "linear", 0.2, degree=-1)


# ---- section 4.4: convergence of the projection of sin(pi x) --------------------------------

REFINEMENTS = (8, 16, 32, 64, 128)


@pytest.mark.parametrize("points, degree, order", [
    ("equal", 0, 2.0), ("random", 0, 1.0), ("equal", 1, 2.0), ("random", 1, 2.0)])
def test_projection_orders_of_the_study(points, degree, order):
    res = projection_study(REFINEMENTS, points=points, degree=degree)
    assert len(res["errors"]) >= 4
    assert res["order"] == pytest.approx(order, abs=0.15)
    assert (np.diff(np.log(res["errors"])) < 0).all()


@pytest.mark.parametrize("placement", ["study", "centred"])
def test_equal_placements(placement):
    # both equal placements are symmetric about every interior node: order 2 there; the two
    # one-sided boundary nodes (error O(h) with p = [1]) bring the whole sum to h^1.5
    interior = projection_study(REFINEMENTS, "equal", 0, placement=placement)
    everywhere = projection_study(REFINEMENTS, "equal", 0, placement=placement, nodes="all")
    assert interior["order"] == pytest.approx(2.0, abs=0.05)
    assert everywhere["order"] == pytest.approx(1.5, abs=0.05)
    assert projection_study(REFINEMENTS, "equal", 1, placement=placement,
                            nodes="all")["order"] == pytest.approx(2.0, abs=0.05)


def test_random_points_are_reproducible():
    a = projection_study((8, 16), "random", 1, seed=4)
    b = projection_study((16, 8), "random", 1, seed=4)          # per-refinement streams
    np.testing.assert_array_equal(a["errors"], b["errors"][::-1])
    assert not np.array_equal(a["errors"], projection_study((8, 16), "random", 1)["errors"])
