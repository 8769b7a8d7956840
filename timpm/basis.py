"""Basis functions on a uniform background grid.

Each basis is a small class of compile-time constants and one ``@ti.func``::

    base, w, dw = Basis.stencil(xi, n_elements)

``xi`` is a particle coordinate along one axis in element units (``(x - origin) / h``);
the particle touches the ``support`` nodes ``base, base + 1, ..., base + support - 1``
with values ``w[a]`` and derivatives ``dw[a]`` (per element length: divide by ``h``).
Solvers take the class as a compile-time parameter, so every basis compiles its own
kernels with the stencil unrolled (``ti.static(range(support))``).  Multi-dimensional
stencils are tensor products of this one-dimensional stencil.

Higher-order bases (B-splines, the quadratic Lagrange basis of the study's chapter 5)
implement the same interface; see ``BASES``.
"""

import argparse
import copyreg

import numpy as np
import taichi as ti

__all__ = ["Basis", "Linear", "QuadraticLagrange", "QuadraticBSpline", "CubicBSpline",
           "UniformQuadraticBSpline", "UniformCubicBSpline", "bspline", "BASES", "get_basis",
           "MAX_BSPLINE_DEGREE", "basis_argument", "evaluate", "stencils"]


class _BasisType(type):
    """The type of the basis classes: a model, a scene and the engine carry the class
    itself, resolved from its name once where the name is read; it prints as its name
    and pickles by it (a sweep's worker rebuilds a B-spline of any degree)."""

    def __repr__(cls):
        return f"<basis {cls.name}>" if cls.name else super().__repr__()


def _pickled(cls):
    return (get_basis, (cls.name,)) if cls.name else cls.__qualname__


copyreg.pickle(_BasisType, _pickled)


class Basis(metaclass=_BasisType):
    """Interface of a one-dimensional basis (documentation and defaults)."""

    #: name used on the command line and in result records
    name = ""
    #: number of nodes a particle touches along one axis
    support = 0
    #: grid nodes per element along one axis (2 for the quadratic Lagrange basis)
    nodes_per_element = 1
    #: direct lumping (study A.2) needs non-negative basis functions
    lumpable = True
    #: smallest number of elements the basis is defined on
    min_elements = 1
    #: fewest particles per element its quadrature needs (mass and stiffness of full rank)
    min_ppc = 1
    #: tensor products of it span 2D and 3D grids
    nd = False
    #: node j stands at x = (j - offset) h, uniformly spaced: the node positions the affine
    #: transfers (APIC, MLS-MPM) take for x_i - x_p
    uniform_nodes = False

    @classmethod
    def n_nodes(cls, n_elements: int) -> int:
        """Number of grid nodes (unknowns) along one axis."""
        raise NotImplementedError

    @classmethod
    def node_coordinates(cls, n_elements: int) -> np.ndarray:
        """Node (or control point) positions in element units, for plotting and Dirichlet."""
        raise NotImplementedError

    @classmethod
    def boundary_nodes(cls, n_elements: int):
        """Nodes to hold for a zero Dirichlet value at the left and at the right end."""
        return (0,), (cls.n_nodes(n_elements) - 1,)


class Linear(Basis):
    """Piecewise-linear hat functions (study section 2.2.3): N1 = 1 - xi, N2 = xi."""

    name = "linear"
    support = 2
    nd = True
    uniform_nodes = True

    @classmethod
    def n_nodes(cls, n_elements: int) -> int:
        return n_elements + 1

    @classmethod
    def node_coordinates(cls, n_elements: int) -> np.ndarray:
        return np.arange(n_elements + 1, dtype=np.float64)

    @staticmethod
    @ti.func
    def stencil(xi, n_elements):
        # element index e = floor(xi), clamped so a particle on the last node stays in
        # the last element; local coordinate f = xi - e in [0, 1]
        e = ti.min(ti.max(ti.floor(xi, ti.i32), 0), n_elements - 1)
        f = xi - e
        w = ti.Vector([1.0 - f, f])
        dw = ti.Vector([-1.0, 1.0])
        return e, w, dw


class QuadraticLagrange(Basis):
    """Quadratic Lagrange shape functions, three nodes per element (study 5.1):
    N1 = 2 xi^2 - 3 xi + 1, N2 = -4 xi^2 + 4 xi, N3 = 2 xi^2 - xi.

    The end-node functions are negative inside the element, so the mass matrix has
    negative entries: it cannot be lumped, and the consistent mass may be indefinite.
    """

    name = "lagrange2"
    support = 3
    nodes_per_element = 2
    lumpable = False
    min_ppc = 2

    @classmethod
    def n_nodes(cls, n_elements: int) -> int:
        return 2 * n_elements + 1

    @classmethod
    def node_coordinates(cls, n_elements: int) -> np.ndarray:
        return np.arange(2 * n_elements + 1, dtype=np.float64) / 2.0

    @staticmethod
    @ti.func
    def stencil(xi, n_elements):
        e = ti.min(ti.max(ti.floor(xi, ti.i32), 0), n_elements - 1)
        f = xi - e
        w = ti.Vector([2.0 * f * f - 3.0 * f + 1.0, -4.0 * f * f + 4.0 * f, 2.0 * f * f - f])
        dw = ti.Vector([4.0 * f - 3.0, -8.0 * f + 4.0, 4.0 * f - 1.0])
        return 2 * e, w, dw


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

        @ti.func
        def stencil(xi, n_elements):
            e = ti.min(ti.max(ti.floor(xi, ti.i32), 0), n_elements - 1)
            # knots t_{e+k} of the clamped vector t_j = clamp(j - p, 0, n), k = 0 .. 2p + 1
            knot = ti.Vector.zero(float, 2 * degree + 2)
            for k in ti.static(range(2 * degree + 2)):
                knot[k] = ti.cast(ti.min(ti.max(e + k - degree, 0), n_elements), float)
            w, dw = _de_boor(xi, knot, degree)
            return e, w, dw

        return stencil


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
    # closed form of the cubic cardinal B-spline (node j at xi = j - 1): nodes b..b+3,
    # t = xi - b - 1 in [0, 1)
    b = ti.floor(xi - 1.0, ti.i32)
    t = xi - b - 1.0
    t2 = t * t
    t3 = t2 * t
    w = ti.Vector([(1.0 - t) ** 3 / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
                   (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0])
    dw = ti.Vector([-0.5 * (1.0 - t) ** 2, 1.5 * t2 - 2.0 * t, -1.5 * t2 + t + 0.5, 0.5 * t2])
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


def bspline(degree: int, clamped: bool = True) -> type[Basis]:
    """The B-spline basis of degree 1 to :data:`MAX_BSPLINE_DEGREE` (each degree compiles
    its own kernels)."""
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) \
            or not 1 <= degree <= MAX_BSPLINE_DEGREE:
        raise ValueError(f"B-spline degree must be an integer from 1 to "
                         f"{MAX_BSPLINE_DEGREE}, got {degree!r}")
    name = f"{'' if clamped else 'uniform-'}bspline{degree}"
    if name not in BASES:
        base = _ClampedBSpline if clamped else _UniformBSpline
        BASES[name] = _make(base, int(degree), name, min_ppc=max(1, min(degree, 2)),
                            min_elements=degree + (0 if clamped else 1))
    return BASES[name]


BASES: dict[str, type[Basis]] = {cls.name: cls for cls in (
    Linear, QuadraticBSpline, CubicBSpline, QuadraticLagrange, UniformQuadraticBSpline,
    UniformCubicBSpline)}


def get_basis(name: str) -> type[Basis]:
    """Look a basis up by name (``bsplineN`` / ``uniform-bsplineN`` for any degree N),
    with an error that lists the known ones."""
    if isinstance(name, type) and issubclass(name, Basis):
        return name
    if isinstance(name, str) and name not in BASES:
        for prefix, clamped in (("uniform-bspline", False), ("bspline", True)):
            digits = name[len(prefix):]
            if name.startswith(prefix) and digits.isdigit():
                try:
                    return bspline(int(digits), clamped)
                except ValueError as exc:
                    raise ValueError(f"basis {name!r}: {exc}") from None
    try:
        return BASES[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown basis {name!r}: choose one of {', '.join(BASES)} "
            f"(or bsplineN / uniform-bsplineN for degree N = 1 to {MAX_BSPLINE_DEGREE})") from None


def basis_argument(text: str) -> type[Basis]:
    """A command line's basis name, resolved where the parser reads it (before Taichi
    starts or any work): its class, or argparse's error with the known ones."""
    try:
        return get_basis(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


@ti.kernel
def _stencil_kernel(basis: ti.template(), xi: ti.types.ndarray(), n_elements: ti.i32,
                    base: ti.types.ndarray(), w: ti.types.ndarray(), dw: ti.types.ndarray()):
    for i in range(xi.shape[0]):
        b, wi, dwi = basis.stencil(xi[i], n_elements)
        base[i] = b
        for a in ti.static(range(basis.support)):
            w[i, a] = wi[a]
            dw[i, a] = dwi[a]


def stencils(basis, xi, n_elements: int):
    """``(base, w, dw)`` of every point ``xi`` (element units), arrays of shapes ``(n,)``,
    ``(n, support)`` and ``(n, support)``, computed by the very ``ti.func`` the solver
    kernels use; ``dw`` is per element length."""
    from .runtime import ensure_init

    ensure_init()
    basis = get_basis(basis)
    xi = np.ascontiguousarray(xi, dtype=np.float64).ravel()
    base = np.zeros(len(xi), dtype=np.int32)
    w = np.zeros((len(xi), basis.support))
    dw = np.zeros((len(xi), basis.support))
    if len(xi):
        _stencil_kernel(basis, xi, int(n_elements), base, w, dw)
    return base, w, dw


def evaluate(basis, xi, n_elements: int):
    """Values of every basis function at points ``xi`` (element units).

    Returns ``(phi, dphi)``, arrays of shape ``(len(xi), n_nodes)``; ``dphi`` is per
    element length.
    """
    basis = get_basis(basis)
    xi = np.ascontiguousarray(xi, dtype=np.float64).ravel()
    base, w, dw = stencils(basis, xi, n_elements)
    nn = basis.n_nodes(n_elements)
    phi = np.zeros((len(xi), nn))
    dphi = np.zeros((len(xi), nn))
    rows = np.arange(len(xi))
    for a in range(basis.support):
        np.add.at(phi, (rows, base + a), w[:, a])
        np.add.at(dphi, (rows, base + a), dw[:, a])
    return phi, dphi
