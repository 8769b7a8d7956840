"""A basis sampled at points from Python: the stencils and the functions' values, computed
by the very ``ti.func`` the engine's kernels use (tests, plots, the critical time step)."""
import numpy as np
import taichi as ti

from ..platform.runtime import ensure_init

__all__ = ["stencils", "evaluate", "integrals"]


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
    kernels use; ``dw`` is per element length.  ``basis``: the class (names are
    resolved where they are read: :func:`timpm.bases.get_basis`)."""
    ensure_init()
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


def integrals(basis, n_elements: int, lo: float, hi: float):
    """int_lo^hi phi_j dxi of every basis function over [lo, hi] (element units), an array
    of shape ``(n_nodes,)``: Gauss-Legendre with ``support`` points on each half element
    within [lo, hi], exact (every basis is a polynomial of degree below 2 support on a
    half element: the knots stand at whole elements, or at half ones for the uniform
    B-splines of even degree)."""
    cuts = np.arange(np.ceil(2.0 * lo), np.floor(2.0 * hi) + 1.0) / 2.0
    cuts = np.unique(np.concatenate(([lo], cuts[(cuts > lo) & (cuts < hi)], [hi])))
    t, g = np.polynomial.legendre.leggauss(basis.support)
    half = 0.5 * np.diff(cuts)[:, None]
    xi = (0.5 * (cuts[:-1] + cuts[1:]))[:, None] + half * t
    phi, _ = evaluate(basis, xi.ravel(), n_elements)
    return (half * g).ravel() @ phi
