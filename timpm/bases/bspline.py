"""B-splines of any degree: clamped (an open knot vector, the boundary-fitted 1D bases) and
uniform (cardinal, the grid padded beyond both ends: the multi-dimensional variant)."""
import numpy as np
import taichi as ti

from .base import Basis

__all__ = ["QuadraticBSpline", "CubicBSpline", "UniformQuadraticBSpline",
           "UniformCubicBSpline", "bspline", "MAX_BSPLINE_DEGREE"]


@ti.func
def _de_boor(x, knot, degree: ti.template()):
    """Values and derivatives of the degree + 1 B-splines that are non-zero on a knot span.

    ``knot`` holds the 2 degree + 2 knots around the span [knot[degree], knot[degree + 1]];
    Cox-de Boor's triangular scheme (Piegl & Tiller, A2.2), the derivatives from the
    degree - 1 values.  Fully unrolled: no loop or branch depends on run-time values.
    """
    n = ti.Vector.zero(float, degree + 1)
    low = ti.Vector.zero(float, degree + 1)  # the degree - 1 values
    n[0] = 1.0
    for j in ti.static(range(1, degree + 1)):
        if ti.static(j == degree):
            low = n
        saved = 0.0
        for r in ti.static(range(j)):
            right = knot[degree + r + 1] - x
            left = x - knot[degree + r + 1 - j]
            temp = n[r] / (right + left)
            n[r] = saved + right * temp
            saved = left * temp
        n[j] = saved
    dn = ti.Vector.zero(float, degree + 1)
    for r in ti.static(range(degree + 1)):
        # N'_{i,p} = p N_{i,p-1} / (t_{i+p} - t_i) - p N_{i+1,p-1} / (t_{i+p+1} - t_{i+1});
        # a repeated knot makes a denominator zero exactly where N_{.,p-1} is zero
        if ti.static(r > 0):
            dn[r] += degree * low[r - 1] / ti.max(knot[r + degree] - knot[r], 1e-300)
        if ti.static(r < degree):
            dn[r] -= degree * low[r] / ti.max(knot[r + degree + 1] - knot[r + 1], 1e-300)
    return n, dn


class _ClampedBSpline(Basis):
    """B-splines of ``degree`` on an open (clamped) knot vector 0 (x p+1), 1, ..., n-1, n (x p+1).

    Partition of unity holds up to the boundary and only the first (last) function is
    non-zero at the left (right) end, so a Dirichlet condition fixes one coefficient.  In
    2D and 3D their tensor products; a wall at a grid end acts on the one node layer there.
    The control points stand at the Greville abscissae, not uniformly spaced near the
    ends: the affine transfers do not take them.
    """

    degree = 2
    nd = True

    @classmethod
    def n_nodes(cls, n_elements: int) -> int:
        return n_elements + cls.degree

    @classmethod
    def node_coordinates(cls, n_elements: int) -> np.ndarray:
        # Greville abscissae: where each coefficient acts; they reproduce linear fields
        p = cls.degree
        knots = np.clip(np.arange(n_elements + 2 * p + 1) - p, 0, n_elements).astype(float)
        return np.array([knots[i + 1:i + p + 1].mean() for i in range(n_elements + p)])

    @classmethod
    def stencil_func(cls):
        degree = cls.degree

        cardinal = {2: _cardinal_quadratic, 3: _cardinal_cubic}.get(degree)
        closed_form = cardinal is not None

        @ti.func
        def stencil(xi, n_elements):
            e = ti.min(ti.max(ti.floor(xi, ti.i32), 0), n_elements - 1)
            w = ti.Vector.zero(float, degree + 1)
            dw = ti.Vector.zero(float, degree + 1)
            if ti.static(closed_form):
                # a span whose 2p + 2 knots are all distinct (p <= e <= n - p - 1) carries
                # the cardinal B-splines: their closed form, without de Boor's divisions
                if e >= degree and e <= n_elements - degree - 1:
                    w, dw = cardinal(xi - e)
                else:
                    w, dw = _clamped_span(xi, e, n_elements, degree)
            else:
                w, dw = _clamped_span(xi, e, n_elements, degree)
            return e, w, dw

        return stencil


@ti.func
def _clamped_span(xi, e, n_elements, degree: ti.template()):
    """De Boor's values and derivatives on span e of the clamped knot vector t_j = clamp(j -
    p, 0, n) (its knots t_{e+k}, k = 0 .. 2p + 1)."""
    knot = ti.Vector.zero(float, 2 * degree + 2)
    for k in ti.static(range(2 * degree + 2)):
        knot[k] = ti.cast(ti.min(ti.max(e + k - degree, 0), n_elements), float)
    return _de_boor(xi, knot, degree)


@ti.func
def _cardinal_quadratic(t):
    """The three quadratic cardinal B-splines non-zero on a unit span, at t in [0, 1)."""
    s = 1.0 - t
    w = ti.Vector([0.5 * s * s, 0.5 + t * s, 0.5 * t * t])
    dw = ti.Vector([-s, s - t, t])
    return w, dw


@ti.func
def _cardinal_cubic(t):
    """The four cubic cardinal B-splines non-zero on a unit span, at t in [0, 1)."""
    t2 = t * t
    t3 = t2 * t
    w = ti.Vector([(1.0 - t) ** 3 / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
                   (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0])
    dw = ti.Vector([-0.5 * (1.0 - t) ** 2, 1.5 * t2 - 2.0 * t, -1.5 * t2 + t + 0.5, 0.5 * t2])
    return w, dw


class _UniformBSpline(Basis):
    """Uniform (cardinal) B-splines of ``degree`` centred on the grid nodes, the grid
    padded beyond both ends by the basis support: the variant for multi-dimensional grids.

    Partition of unity holds inside [0, n]; no function is interpolatory at the ends, so
    a Dirichlet end fixes every node whose function is non-zero there.
    """

    degree = 2
    nd = True
    uniform_nodes = True

    @classmethod
    def offset(cls):
        """Padding nodes before x = 0 (node j stands at x = j - offset): ceil((p - 1) / 2)."""
        return cls.degree // 2

    @classmethod
    def n_nodes(cls, n_elements: int) -> int:
        # nodes from -offset to floor(n - (p - 1) / 2) + p: n + p + 1 of them
        return n_elements + cls.degree + 1

    @classmethod
    def node_coordinates(cls, n_elements: int) -> np.ndarray:
        return np.arange(cls.n_nodes(n_elements), dtype=np.float64) - cls.offset()

    @classmethod
    def boundary_nodes(cls, n_elements: int):
        x = cls.node_coordinates(n_elements)
        reach = (cls.degree + 1) / 2.0  # support half-width
        left = tuple(int(i) for i in np.flatnonzero(np.abs(x) < reach))
        right = tuple(int(i) for i in np.flatnonzero(np.abs(x - n_elements) < reach))
        return left, right

    @classmethod
    def stencil_func(cls):
        degree, offset = cls.degree, cls.offset()
        if degree == 2:
            return _uniform_quadratic
        if degree == 3:
            return _uniform_cubic

        @ti.func
        def stencil(xi, n_elements):
            # the function of node j is centred at x_j, knots j - (p + 1) / 2 + m: a
            # particle touches the nodes from b = floor(xi - (p - 1) / 2) on
            b = ti.floor(xi - 0.5 * (degree - 1), ti.i32)
            knot = ti.Vector.zero(float, 2 * degree + 2)
            for k in ti.static(range(2 * degree + 2)):
                knot[k] = b + k - 0.5 * (degree + 1)
            w, dw = _de_boor(xi, knot, degree)
            return b + offset, w, dw

        return stencil


@ti.func
def _uniform_quadratic(xi, n_elements):
    # closed form of the quadratic cardinal B-spline (node j at xi = j - 1): nodes b..b+2
    # around the particle, f = xi - b in [0.5, 1.5)
    b = ti.floor(xi - 0.5, ti.i32)
    f = xi - b
    w = ti.Vector([0.5 * (1.5 - f) ** 2, 0.75 - (f - 1.0) ** 2, 0.5 * (f - 0.5) ** 2])
    dw = ti.Vector([f - 1.5, -2.0 * (f - 1.0), f - 0.5])
    return b + 1, w, dw


@ti.func
def _uniform_cubic(xi, n_elements):
    # the cubic cardinal B-splines (node j at xi = j - 1): nodes b..b+3, t = xi - b - 1 in
    # [0, 1)
    b = ti.floor(xi - 1.0, ti.i32)
    w, dw = _cardinal_cubic(xi - b - 1.0)
    return b + 1, w, dw


def _make(base, degree, name, **extra):
    cls = type(f"{base.__name__.strip('_')}{degree}", (base,), dict(
        name=name, degree=degree, support=degree + 1, __doc__=base.__doc__, **extra))
    cls.stencil = staticmethod(cls.stencil_func())
    return cls


#: clamped (open knot vector) B-splines: the bases for boundary-fitted 1D problems
QuadraticBSpline = _make(_ClampedBSpline, 2, "bspline2", min_ppc=2, min_elements=2)
CubicBSpline = _make(_ClampedBSpline, 3, "bspline3", min_ppc=2, min_elements=3)
#: uniform (padded) B-splines: the multi-dimensional grid variant
#: (inertia: D = inertia h^2 I, the second moment sum_i phi_i (x_i - x)(x_i - x)^T of the
#: cardinal B-splines, constant: the affine transfers' D_p, Jiang et al. 2015)
UniformQuadraticBSpline = _make(_UniformBSpline, 2, "uniform-bspline2", min_ppc=2, min_elements=3,
                                inertia=0.25)
UniformCubicBSpline = _make(_UniformBSpline, 3, "uniform-bspline3", min_ppc=2, min_elements=4,
                            inertia=1.0 / 3.0)


#: the highest B-spline degree: each degree compiles its own kernels, unrolled over
#: support = degree + 1 nodes per axis, and compiling grows steeply with the degree (1D,
#: measured: degree 4 3 s, 6 5 s, 8 14 s; 2D and 3D far longer)
MAX_BSPLINE_DEGREE = 8
#: every B-spline made so far, by name (each class once: it is part of a feature set)
_MADE = {cls.name: cls for cls in (QuadraticBSpline, CubicBSpline, UniformQuadraticBSpline,
                                   UniformCubicBSpline)}


def bspline(degree: int, clamped: bool = True) -> type[Basis]:
    """The B-spline basis of degree 1 to :data:`MAX_BSPLINE_DEGREE` (each degree compiles
    its own kernels)."""
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) \
            or not 1 <= degree <= MAX_BSPLINE_DEGREE:
        raise ValueError(f"B-spline degree must be an integer from 1 to "
                         f"{MAX_BSPLINE_DEGREE}, got {degree!r}")
    name = f"{'' if clamped else 'uniform-'}bspline{degree}"
    if name not in _MADE:
        base = _ClampedBSpline if clamped else _UniformBSpline
        _MADE[name] = _make(base, int(degree), name, min_ppc=max(1, min(degree, 2)),
                            min_elements=degree + (0 if clamped else 1))
    return _MADE[name]
