"""The quadratic Lagrange basis, three nodes per element (study 5.1)."""
import numpy as np
import taichi as ti

from .base import Basis

__all__ = ["QuadraticLagrange"]


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
    kinked = True

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
