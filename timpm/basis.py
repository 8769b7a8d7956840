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

import numpy as np
import taichi as ti

__all__ = ["Basis", "Linear", "BASES", "get_basis", "evaluate", "stencils"]


class Basis:
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
    #: critical time step of the lumped mass over h / c (Euler-Cromer: dt <= 2 / w_max
    #: of the element eigenproblem K x = w^2 M x with exact integration)
    critical_factor = 1.0

    @classmethod
    def n_nodes(cls, n_elements: int) -> int:
        """Number of grid nodes (unknowns) along one axis."""
        raise NotImplementedError

    @classmethod
    def node_coordinates(cls, n_elements: int) -> np.ndarray:
        """Node (or control point) positions in element units, for plotting and Dirichlet."""
        raise NotImplementedError

    @classmethod
    def boundary_nodes(cls, n_elements: int) -> tuple[int, int]:
        """Indices of the coefficient that carries a Dirichlet value at each end."""
        return 0, cls.n_nodes(n_elements) - 1


class Linear(Basis):
    """Piecewise-linear hat functions (study section 2.2.3): N1 = 1 - xi, N2 = xi."""

    name = "linear"
    support = 2

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


BASES: dict[str, type[Basis]] = {cls.name: cls for cls in (Linear,)}


def get_basis(name: str) -> type[Basis]:
    """Look a basis up by name, with an error that lists the known ones."""
    if isinstance(name, type) and issubclass(name, Basis):
        return name
    try:
        return BASES[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown basis {name!r}: choose one of {', '.join(sorted(BASES))}") from None


@ti.data_oriented
class _Evaluator:
    """Evaluates a basis' stencil at given points through its ``ti.func`` (tests, plots)."""

    def __init__(self, basis: type[Basis], n_points: int):
        self.basis = basis
        fb = ti.FieldsBuilder()
        self.xi, self.base = ti.field(ti.f64), ti.field(ti.i32)
        self.w, self.dw = ti.field(ti.f64), ti.field(ti.f64)
        fb.dense(ti.i, n_points).place(self.xi, self.base)
        fb.dense(ti.ij, (n_points, basis.support)).place(self.w, self.dw)
        self._tree = fb.finalize()

    def release(self):
        self._tree.destroy()

    @ti.kernel
    def run(self, n_elements: ti.i32):
        for i in self.xi:
            base, w, dw = self.basis.stencil(self.xi[i], n_elements)
            self.base[i] = base
            for a in ti.static(range(self.basis.support)):
                self.w[i, a] = w[a]
                self.dw[i, a] = dw[a]


def stencils(basis, xi, n_elements: int):
    """``(base, w, dw)`` of every point ``xi`` (element units), arrays of shapes ``(n,)``,
    ``(n, support)`` and ``(n, support)``, computed by the very ``ti.func`` the solver
    kernels use; ``dw`` is per element length."""
    from .runtime import ensure_init

    ensure_init()
    basis = get_basis(basis)
    xi = np.ascontiguousarray(xi, dtype=np.float64).ravel()
    ev = _Evaluator(basis, len(xi))
    try:
        ev.xi.from_numpy(xi)
        ev.run(n_elements)
        return ev.base.to_numpy(), ev.w.to_numpy(), ev.dw.to_numpy()
    finally:
        ev.release()


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
