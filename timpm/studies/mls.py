"""Moving least squares (MLS) projection, chapter 4 of the study (NumPy only).

Given values ``u_p`` at data points ``x_p`` (the material points), the MLS approximation at
a point ``x`` is (sections 4.2-4.3)::

    u^h(x) = p(x)^T A(x)^-1 B(x) u,   A = P^T W P,   B = P^T W,   W = diag(w(x - x_p)),

with the monomial basis ``p = [1, x, ..., x^m]``.  With ``p = [1]`` and the linear hat
weight this is the Shepard average ``sum_p w_p u_p / sum_p w_p``, the standard MPM
particle-to-node projection (section 4.4); ``p = [1, x]`` reproduces linear fields.

Shifted coordinates.  At each evaluation point ``x`` the basis is taken as
``q_k(x') = ((x' - x) / h)^k`` instead of ``x'^k``.  For fixed ``x`` this is an invertible
linear change of basis ``q = T p`` of the same polynomial space, so the weighted
least-squares minimiser -- a function of ``x'`` -- is the same and so is its value at
``x' = x``: ``u^h(x) = q(x)^T a_q = a_q[0]`` because ``q(x) = [1, 0, ..., 0]``.  The moment
matrix ``A_q = T A T^T`` then has O(1) entries independent of where ``x`` lies, whereas
``A`` in raw coordinates has condition number growing like ``(x / h)^(2m)``.

Weights are functions ``w(d, h)`` of the signed distance ``d = x - x_p`` with a ``support``
attribute (the radius in units of ``h``); see ``WEIGHTS``.

:func:`projection_study` is the convergence test of section 4.4: ``u = sin(pi x)`` on
[0, 1] from three points per element, evaluated at the nodes.
"""

import numpy as np

__all__ = ["linear_hat", "cubic_spline", "quadratic_spline", "WEIGHTS", "get_weight",
           "mls_shape_functions", "mls_fit", "element_points", "projection_study"]


# ---- weight functions ----------------------------------------------------------------------

def _weight(support):
    def mark(fn):
        fn.support = support
        return fn
    return mark


@_weight(support=1.0)
def linear_hat(d, h):
    """Linear hat ``1 - |d|/h`` for ``|d| <= h`` (section 4.4): MPM projection with p = [1]."""
    q = np.abs(np.asarray(d, dtype=float)) / h
    return np.where(q <= 1.0, 1.0 - q, 0.0)


@_weight(support=2.0)
def cubic_spline(d, h):
    """Cubic B-spline of section 4.4 with ``r = |d| / (2h)`` (support ``2h``).

    ``2/3 - 4r^2 + 4r^3`` for ``r <= 1/2``, ``4/3 - 4r + 4r^2 - 4/3 r^3`` for
    ``1/2 <= r <= 1``, 0 else (both pieces equal 1/6 at ``r = 1/2``).
    """
    r = np.abs(np.asarray(d, dtype=float)) / (2.0 * h)
    inner = 2.0 / 3.0 - 4.0 * r**2 + 4.0 * r**3
    outer = 4.0 / 3.0 * (1.0 - r) ** 3          # = 4/3 - 4r + 4r^2 - 4/3 r^3, no cancellation
    return np.where(r <= 0.5, inner, np.where(r <= 1.0, outer, 0.0))


@_weight(support=1.5)
def quadratic_spline(d, h):
    """Quadratic B-spline with ``r = |d| / h`` (support ``1.5 h``).

    ``3/4 - r^2`` for ``r <= 1/2``, ``1/2 (3/2 - r)^2`` for ``1/2 <= r <= 3/2``, 0 else.
    The study prints ``3/4 - 4 r^2`` for the inner piece: a misprint, since it gives -1/4
    at ``r = 1/2`` (negative, and discontinuous against the outer piece's 1/2); the
    standard B-spline used here is continuous with a continuous derivative.
    """
    r = np.abs(np.asarray(d, dtype=float)) / h
    inner = 0.75 - r**2
    outer = 0.5 * (1.5 - r) ** 2
    return np.where(r <= 0.5, inner, np.where(r <= 1.5, outer, 0.0))


#: weight functions by name
WEIGHTS = {"linear": linear_hat, "cubic": cubic_spline, "quadratic": quadratic_spline}


def get_weight(weight):
    """A weight function from its name in ``WEIGHTS``, or a callable ``w(d, h)`` as is."""
    if callable(weight):
        return weight
    try:
        return WEIGHTS[weight]
    except KeyError:
        raise ValueError(f"unknown weight {weight!r}: choose one of "
                         f"{', '.join(WEIGHTS)} or pass a function w(d, h)") from None


# ---- MLS projection ------------------------------------------------------------------------

_CHUNK = 1 << 21            # evaluation points x data points handled at once
_MAX_COND = 1e12            # moment matrices worse than this count as singular


def mls_shape_functions(x_eval, x_data, weight, h, degree=1):
    """MLS shape functions ``Phi[e, p]`` with ``u^h(x_eval[e]) = sum_p Phi[e, p] u_p``.

    ``Phi[e, :] = q(x_e)^T A^-1 B`` in the shifted basis ``q_k = ((x_p - x_e)/h)^k``,
    ``k = 0..degree`` (see the module docstring).  Raises ``ValueError`` naming the first
    evaluation point where ``A(x)`` is singular: fewer than ``degree + 1`` distinct data
    points inside the weight's support, or an ill-conditioned moment matrix.
    """
    x_eval = np.atleast_1d(np.asarray(x_eval, dtype=float))
    x_data = np.atleast_1d(np.asarray(x_data, dtype=float))
    if x_eval.ndim != 1 or x_data.ndim != 1:
        raise ValueError("x_eval and x_data must be one-dimensional")
    if not (np.isfinite(h) and h > 0):
        raise ValueError(f"support parameter h must be positive and finite, got {h!r}")
    if int(degree) != degree or degree < 0:
        raise ValueError(f"degree must be a non-negative integer, got {degree!r}")
    degree = int(degree)
    weight = get_weight(weight)
    phi = np.empty((x_eval.size, x_data.size))
    step = max(1, _CHUNK // max(1, x_data.size))
    powers = np.arange(degree + 1)
    e0 = np.zeros(degree + 1)
    e0[0] = 1.0
    for start in range(0, x_eval.size, step):
        xe = x_eval[start:start + step]
        d = x_data[None, :] - xe[:, None]             # (e, p): x_p - x
        w = weight(-d, h)                             # w(x - x_p)
        q = (d / h)[:, :, None] ** powers             # (e, p, k) shifted, scaled basis
        a = np.einsum("epk,ep,epl->ekl", q, w, q)     # A(x) = Q^T W Q
        _check_moments(xe, x_data, w, a, degree)
        c = np.linalg.solve(a, np.broadcast_to(e0, (xe.size, degree + 1))[..., None])[..., 0]
        phi[start:start + step] = np.einsum("ek,epk,ep->ep", c, q, w)   # q(x)^T A^-1 Q^T W
    return phi


def _check_moments(xe, x_data, w, a, degree):
    # A(x) is singular exactly when fewer than degree + 1 distinct data points carry weight
    # (a weighted Vandermonde Gram matrix); nearly coincident points make it ill-conditioned.
    with np.errstate(divide="ignore", invalid="ignore"):
        cond = np.linalg.cond(a)
    bad = ~(cond < _MAX_COND)                         # nan (all weights zero) counts as bad
    if bad.any():
        e = int(np.argmax(bad))
        n_distinct = np.unique(x_data[w[e] > 0.0]).size
        raise ValueError(f"MLS moment matrix A(x) is singular at x = {xe[e]:.6g}: "
                         f"{n_distinct} distinct data point(s) inside the weight's support "
                         f"(condition number {cond[e]:.3g}); degree {degree} needs at least "
                         f"{degree + 1} well separated points there")


def mls_fit(x_eval, x_data, u_data, weight, h, degree=1):
    """MLS approximation ``u^h(x_eval) = p^T A^-1 B u`` of data ``u_data`` at ``x_data``.

    ``weight``: a name in ``WEIGHTS`` or a function ``w(d, h)``; ``h``: its support
    parameter (the element size in the study); ``degree``: 0 for ``p = [1]``, 1 for
    ``p = [1, x]``, any ``m`` for ``[1, ..., x^m]``.
    """
    u_data = np.asarray(u_data, dtype=float)
    if u_data.shape != np.shape(np.atleast_1d(x_data)):
        raise ValueError(f"u_data has shape {u_data.shape}, x_data {np.shape(x_data)}")
    return mls_shape_functions(x_eval, x_data, weight, h, degree) @ u_data


# ---- projection study of section 4.4 -------------------------------------------------------

#: local positions in [0, 1] of ``ppc`` equally spaced points in an element
PLACEMENTS = {
    "study": lambda ppc: (np.arange(ppc) + 1.0) / (ppc + 1.0),    # equal gaps, edges too
    "centred": lambda ppc: (np.arange(ppc) + 0.5) / ppc,          # centres of equal cells
}


def element_points(n_elements, ppc=3, points="equal", placement="study", rng=None):
    """``ppc`` points in each of ``n_elements`` elements of [0, 1].

    ``points="equal"``: at the local positions ``PLACEMENTS[placement]``;
    ``points="random"``: uniform in each element, drawn from ``rng``.
    """
    h = 1.0 / n_elements
    left = np.arange(n_elements)[:, None] * h
    if points == "equal":
        if placement not in PLACEMENTS:
            raise ValueError(f"unknown placement {placement!r}: "
                             f"choose one of {', '.join(PLACEMENTS)}")
        local = np.broadcast_to(PLACEMENTS[placement](ppc), (n_elements, ppc))
    elif points == "random":
        local = np.sort(rng.uniform(0.0, 1.0, (n_elements, ppc)), axis=1)
    else:
        raise ValueError(f"points must be 'equal' or 'random', got {points!r}")
    return (left + local * h).ravel()


def projection_study(n_elements_list=(8, 16, 32, 64, 128), points="equal", degree=0,
                     weight="linear", seed=0, ppc=3, placement="study", nodes="interior",
                     n_seeds=16, u=None):
    """Convergence of the MLS projection of ``u = sin(pi x)`` to the nodes (section 4.4).

    For each number of elements ``n`` (``h = 1/n``) the function is sampled at ``ppc``
    points per element (``element_points``; ``placement`` for equal points) and
    reconstructed with ``mls_fit`` (support parameter ``h``) at the nodes ``x_j = j h``:
    ``E = sqrt(sum_j h (u(x_j) - u^h(x_j))^2)``.

    ``nodes="interior"`` sums over ``j = 1..n-1``, ``"all"`` over ``j = 0..n``.  A boundary
    node sees data on one side only, where ``p = [1]`` is only first-order accurate for any
    placement (``u'(0) = pi``); those two terms alone give ``E ~ sqrt(h) h = h^1.5`` and hide
    the second order of the interior.  With ``p = [1, x]`` both choices give order 2.

    Random points are drawn from ``numpy.random.default_rng([seed, n, s])`` for refinement
    ``n`` and sample ``s = 0..n_seeds-1``, so each refinement is reproducible by itself; the
    error is the root mean square over the samples.  One sample gives a noisy order for
    ``p = [1]`` (the error is a random O(h) average; fitted orders over 8..128 elements
    spread about +-0.15 between seeds); 16 samples bring that to about +-0.05.

    Returns a dict with ``n_elements``, ``h``, ``errors`` (arrays), ``order`` (the slope of
    ``polyfit(log h, log E)``) and the settings.
    """
    u = (lambda x: np.sin(np.pi * x)) if u is None else u
    if nodes not in ("interior", "all"):
        raise ValueError(f"nodes must be 'interior' or 'all', got {nodes!r}")
    ns = np.asarray(n_elements_list, dtype=int)
    if ns.size < 2 or (ns < 1).any():
        raise ValueError("need at least two positive numbers of elements")
    if int(n_seeds) != n_seeds or n_seeds < 1:
        raise ValueError(f"n_seeds must be a positive integer, got {n_seeds!r}")
    errors = np.empty(ns.size)
    for i, n in enumerate(ns):
        h = 1.0 / n
        xj = np.arange(n + 1) * h
        if nodes == "interior":
            xj = xj[1:-1]
        sq = []
        for s in range(n_seeds if points == "random" else 1):
            rng = np.random.default_rng([seed, int(n), s])
            xp = element_points(n, ppc, points, placement, rng)
            uh = mls_fit(xj, xp, u(xp), weight, h, degree)
            sq.append(np.sum(h * (u(xj) - uh) ** 2))
        errors[i] = np.sqrt(np.mean(sq))
    hs = 1.0 / ns
    order = float(np.polyfit(np.log(hs), np.log(errors), 1)[0])
    return {"n_elements": ns, "h": hs, "errors": errors, "order": order,
            "points": points, "degree": degree, "weight": weight, "nodes": nodes,
            "placement": placement if points == "equal" else None}
