"""The consistent mass matrix (study A.1): banded LU without pivoting, on one thread.

For 1D scenes with ``mass="consistent"``: P2G assembles ``band[i, k] = M[i, i + k - b]``,
``factorise`` factorises it in place every step and ``substitute`` solves ``M x = rhs``.
"""
import taichi as ti

from ..platform.errors import ErrorCode

__all__ = ["BandedMass"]


class BandedMass:
    """See the module: the bandwidth and dimension of the feature set, the boundary (its
    Dirichlet nodes) and the failure record; its functions receive the grid fields (the
    band ``grid.band`` and its rows' flags ``grid.inactive`` with them) and the run-time
    values."""

    def __init__(self, features, boundary, failures):
        self.bandwidth, self.dim = features.bandwidth, features.dim
        self.boundary, self.failures = boundary, failures

    @ti.func
    def factorise(self, grid: ti.template(), values: ti.template()):
        # consistent mass (A.1): banded LU without pivoting, in place, on one thread; fixed
        # and empty rows become identity rows (their right-hand sides are zeroed)
        b = ti.static(self.bandwidth)
        nn = values.nodes()[0]
        for _ in range(1):
            for i in range(nn):
                grid.inactive[i] = 0
                if self.boundary.is_fixed(i) or grid.band[i, b] <= values.mass_tol():
                    grid.inactive[i] = 1
                    for k in ti.static(range(2 * b + 1)):
                        grid.band[i, k] = 0.0
                    for r in ti.static(range(1, b + 1)):
                        if i - r >= 0:
                            grid.band[i - r, b + r] = 0.0
                        if i + r < nn:
                            grid.band[i + r, b - r] = 0.0
                    grid.band[i, b] = 1.0
            for k in range(nn):
                pivot = grid.band[k, b]
                if ti.abs(pivot) <= values.pivot_tol():
                    self.failures.fail(ErrorCode.SINGULAR_MASS, k)
                    pivot = 1.0
                    grid.band[k, b] = 1.0
                if pivot < 0.0:
                    self.failures.count_negative_pivot()
                for r in ti.static(range(1, b + 1)):
                    i = k + r
                    if i < nn:
                        lik = grid.band[i, b - r] / pivot
                        grid.band[i, b - r] = lik  # the multiplier, kept for substitution
                        for c in ti.static(range(1, b + 1)):
                            if c - r <= b:
                                grid.band[i, b - r + c] -= lik * grid.band[k, b + c]

    @ti.func
    def substitute(self, grid: ti.template(), values: ti.template(), rhs: ti.template()):
        b = ti.static(self.bandwidth)
        nn = values.nodes()[0]
        for _ in range(1):
            for i in range(nn):
                if grid.inactive[i]:
                    rhs[i] = ti.Vector.zero(float, self.dim)
            for i in range(nn):  # forward: L y = rhs
                acc = rhs[i]
                for r in ti.static(range(1, b + 1)):
                    if i - r >= 0:
                        acc -= grid.band[i, b - r] * rhs[i - r]
                rhs[i] = acc
            for j in range(nn):  # backward: U x = y
                i = nn - 1 - j
                acc = rhs[i]
                # no test i + c < nn: the band and rhs are zero there (the capacity leaves
                # room for b nodes beyond the last), and a branch-free row is what the
                # compiler contracts into fused multiply-adds
                for c in ti.static(range(1, b + 1)):
                    acc -= grid.band[i, b + c] * rhs[i + c]
                rhs[i] = acc / grid.band[i, b]
