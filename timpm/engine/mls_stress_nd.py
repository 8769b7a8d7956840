"""The MLS stress projection in 2D: internal forces at the Gauss points.

For ``projection="mls"`` on a 2D grid with a B-spline basis of degree 2 or more and the
lumped mass).  The code is written for any dimension, but the Model refuses 3D (10 x 10
fits, 10^3 candidate points per particle: neither compiled nor measured).  The 1D
projection of study 4.4 (:mod:`.mls_projection`) taken to tensor products, stress part
only: each particle adds its moments to the Gauss points (2 per cell and axis) within 1.5 h
along every axis, weight the product of the quadratic-spline weights of 4.4 per axis; at
each Gauss point the Cauchy stress is the MLS fit's value (basis 1, d, and with the bases
of degree 2 and up the products d_j d_k), and the internal force ``F_i = -sum_g w_g
sigma_h(y_g) grad phi_i(y_g)`` is integrated over every cell.  The body must fill the grid
(the manufactured solutions do; the Model checks it): the cells are the integration domain.
Mass and momentum come from the particles.
"""
import taichi as ti

from .mls_projection import GAUSS_POINTS, GAUSS_WEIGHTS, quadratic_spline_weight

__all__ = ["MLSStressND", "mls_nd_fields", "monomial_count"]


def monomial_count(dim, order):
    """The size of the MLS basis: 1 + dim, plus dim (dim + 1) / 2 at order 2."""
    return 1 + dim + (dim * (dim + 1) // 2 if order == 2 else 0)


def mls_nd_fields(dim, order, real):
    """The Gauss points' moment sums: sum w P P^T and sum w P vec(sigma_p)^T."""
    n = monomial_count(dim, order)
    return {"q_mom": ti.Matrix.field(n, n, real), "q_sig": ti.Matrix.field(n, dim * dim, real)}


class MLSStressND:
    """See the module: the feature set (dimension, order of the fit), the stencil and the
    add of the mode (``accumulate``).  Its functions receive the particle fields, the grid
    fields (with the Gauss points' sums ``grid.q_mom``, ``grid.q_sig``) and the run-time
    values."""

    def __init__(self, features, stencil, accumulate):
        self.dim, self.mls_order = features.dim, features.mls_stress_order
        self.stencil, self.accumulate = stencil, accumulate

    @ti.func
    def _monomials(self, d):
        """P(d) = [1, d_0, .., d_{dim-1}(, d_j d_k for j <= k)]."""
        n = ti.static(monomial_count(self.dim, self.mls_order))
        P = ti.Vector.zero(float, n)
        P[0] = 1.0
        for k in ti.static(range(self.dim)):
            P[1 + k] = d[k]
        if ti.static(self.mls_order == 2):
            r = ti.static(1 + self.dim)
            for j in ti.static(range(self.dim)):
                for k in ti.static(range(j, self.dim)):
                    # the index of (j, k) in the upper triangle, row by row
                    P[r + j * self.dim - j * (j - 1) // 2 + k - j] = d[j] * d[k]
        return P

    @ti.func
    def scatter_gauss(self, particles: ti.template(), grid: ti.template(),
                                 values: ti.template(), p):
        # MLS moments at the Gauss points within 1.5 h along each axis: the Gauss points of
        # the cells e0 - 2 .. e0 + 2 per axis (global index 2 e + g), weight prod w(|d_k|)
        xi = ti.Vector.zero(float, self.dim)
        lo = ti.Vector.zero(ti.i32, self.dim)
        for k in ti.static(range(self.dim)):
            xi[k] = (particles.x[p][k] - values.origin()[k]) * values.inv_h()
            lo[k] = 2 * (ti.floor(xi[k], ti.i32) - 2)
        sig = ti.Vector.zero(float, self.dim * self.dim)
        for j, k in ti.static(ti.ndrange(self.dim, self.dim)):
            sig[j * self.dim + k] = particles.sigma[p][j, k]
        for J in ti.grouped(ti.ndrange(*((10,) * self.dim))):
            d = ti.Vector.zero(float, self.dim)
            w = 1.0
            cell = ti.Vector.zero(ti.i32, self.dim)
            g = 0  # the Gauss point's index in its cell, axis 0 fastest
            for k in ti.static(range(self.dim)):
                jk = lo[k] + J[k]
                cell[k] = jk // 2
                gk = jk - 2 * cell[k]
                g += gk << k
                y = cell[k] + GAUSS_POINTS[0] + gk * (GAUSS_POINTS[1] - GAUSS_POINTS[0])
                d[k] = xi[k] - y
                if not (0 <= cell[k] < values.elements()[k]):
                    w = 0.0
                else:
                    w *= quadratic_spline_weight(ti.abs(d[k]))
            if w > 0.0:
                P = self._monomials(d)
                self.accumulate(grid.q_mom[cell, g], w * P.outer_product(P))
                self.accumulate(grid.q_sig[cell, g], w * P.outer_product(sig))

    @ti.func
    def _mls_fit_nd(self, A, B):
        """The first row of A^-1 B (A = sum w P P^T symmetric): the fit's value at the
        Gauss point.  Cholesky of the leading block of size n, 1 + dim or 1, the largest
        whose pivots stay above 1e-10 of A_00 (too few points around for a higher order)."""
        n = ti.static(monomial_count(self.dim, self.mls_order))
        L = ti.Matrix.zero(float, n, n)
        rank = 0  # the leading block size factorised with healthy pivots
        tol = 1e-10 * A[0, 0]
        for j in ti.static(range(n)):
            s = A[j, j]
            for k in ti.static(range(j)):
                s -= L[j, k] * L[j, k]
            if rank == j and s > tol and A[0, 0] > 0.0:
                L[j, j] = ti.sqrt(s)
                for i in ti.static(range(j + 1, n)):
                    t = A[i, j]
                    for k in ti.static(range(j)):
                        t -= L[i, k] * L[j, k]
                    L[i, j] = t / L[j, j]
                rank = j + 1
        size = 0
        if rank >= n:
            size = n
        elif rank >= 1 + self.dim:
            size = 1 + self.dim
        elif rank >= 1:
            size = 1
        # solve L L^T z = e_0 in the leading block of that size; value = z^T B
        z = ti.Vector.zero(float, n)
        for i in ti.static(range(n)):
            if i < size:
                t = 1.0 if ti.static(i == 0) else 0.0
                for k in ti.static(range(i)):
                    t -= L[i, k] * z[k]
                z[i] = t / L[i, i]
        for ii in ti.static(range(n)):
            i = ti.static(n - 1 - ii)
            if i < size:
                t = z[i]
                for k in ti.static(range(i + 1, n)):
                    if k < size:
                        t -= L[k, i] * z[k]
                z[i] = t / L[i, i]
        return z @ B

    @ti.func
    def integrate_gauss(self, grid: ti.template(), values: ti.template()):
        # F_i = -sum_cells sum_g w_g h^dim sigma_h(y_g) grad phi_i(y_g), sigma_h the MLS fit
        # of the particles' stress at the Gauss point y_g (each cell full: the body fills
        # the grid)
        jw = ti.static(GAUSS_WEIGHTS[0] ** self.dim)
        for I in ti.grouped(ti.ndrange(*[values.elements()[k] for k in range(self.dim)])):
            for g in range(2 ** self.dim):  # a run-time loop: one copy of the fit to compile
                if grid.q_mom[I, g][0, 0] > 0.0:
                    s = self._mls_fit_nd(grid.q_mom[I, g], grid.q_sig[I, g])
                    sig = ti.Matrix.zero(float, self.dim, self.dim)
                    for j, k in ti.static(ti.ndrange(self.dim, self.dim)):
                        sig[j, k] = s[j * self.dim + k]
                    y = ti.Vector.zero(float, self.dim)  # the Gauss point, element units
                    for k in ti.static(range(self.dim)):
                        y[k] = I[k] + GAUSS_POINTS[0] + ((g >> k) & 1) * (GAUSS_POINTS[1]
                                                                         - GAUSS_POINTS[0])
                    base, w, dw, _ = self.stencil.at(y)
                    scale = jw * values.h() ** self.dim
                    for r in range(self.stencil.rows):
                        for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                            node = self.stencil.node(base, offset)
                            self.accumulate(grid.node_force[node], -scale * (sig @ grad))

    @ti.func
    def clear_gauss(self, grid: ti.template(), values: ti.template()):
        n = ti.static(monomial_count(self.dim, self.mls_order))
        for I in ti.grouped(ti.ndrange(*[values.elements()[k] for k in range(self.dim)])):
            for g in ti.static(range(2 ** self.dim)):
                grid.q_mom[I, g] = ti.Matrix.zero(float, n, n)
                grid.q_sig[I, g] = ti.Matrix.zero(float, n, self.dim * self.dim)
