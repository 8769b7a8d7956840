"""The piecewise-linear basis (study 2.2.3)."""
import numpy as np
import taichi as ti

from .base import Basis

__all__ = ["Linear"]


class Linear(Basis):
    """Piecewise-linear hat functions (study section 2.2.3): N1 = 1 - xi, N2 = xi."""

    name = "linear"
    support = 2
    nd = True
    uniform_nodes = True
    kinked = True

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
