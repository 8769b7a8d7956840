"""The moving-least-squares projection of study 4.4 (1D).

The study's case (linear basis,
lumped mass): nodal velocities are reconstructed from the particles by MLS (cubic-spline
weight), density and stress by MLS at the Gauss points of each element's part of the body
(quadratic-spline weight), where mass and forces are integrated.  With any other basis or
the consistent mass only the stress is reconstructed (quadratic MLS for the bases of
degree 2 and up) and the internal force integrated at the Gauss points; mass and momentum
come from the particles as without the projection.  It removes the particle quadrature's
error under stretch (docs/results.md, manufactured solutions).
"""
import taichi as ti

__all__ = ["MLSProjection", "GAUSS_POINTS", "GAUSS_WEIGHTS", "quadratic_spline_weight"]

#: two-point Gauss-Legendre rule on [0, 1] (MLS projection: integration points)
GAUSS_POINTS = (0.5 - 0.5 / 3 ** 0.5, 0.5 + 0.5 / 3 ** 0.5)
GAUSS_WEIGHTS = (0.5, 0.5)


@ti.func
def quadratic_spline_weight(r):
    """Quadratic-spline MLS weight of 4.4, r = |x - x_p| / h (the continuous standard form)."""
    w = 0.0
    if r <= 0.5:
        w = 0.75 - r * r
    elif r <= 1.5:
        w = 0.5 * (1.5 - r) ** 2
    return w


@ti.func
def _cubic_spline(r):
    """Cubic-spline MLS weight of 4.4, r = |x - x_p| / (2 h)."""
    w = 0.0
    if r <= 0.5:
        w = 2.0 / 3.0 - 4.0 * r * r + 4.0 * r * r * r
    elif r <= 1.0:
        w = 4.0 / 3.0 * (1.0 - r) ** 3
    return w


@ti.func
def _mls_value(mom, b):
    """u_h(y) = p(y)^T A^-1 B u with p = [1, d]: the first coefficient of the 2x2 solve;
    Shepard's value sum w u / sum w where A is singular (fewer than two points around)."""
    det = mom[0] * mom[2] - mom[1] * mom[1]
    value = 0.0
    if det > 1e-10 * mom[0] * mom[0] and mom[0] > 0.0:
        value = (mom[2] * b[0] - mom[1] * b[1]) / det
    elif mom[0] > 0.0:
        value = b[0] / mom[0]
    return value


@ti.func
def _mls_value_quadratic(mom, b):
    """As ``_mls_value`` with p = [1, d, d^2] (moments sum w d^k, k = 0..4); the linear
    fit where fewer than three points make A singular."""
    A = ti.Matrix([[mom[0], mom[1], mom[2]], [mom[1], mom[2], mom[3]],
                   [mom[2], mom[3], mom[4]]])
    det = A.determinant()
    value = 0.0
    if mom[0] > 0.0 and det > 1e-10 * mom[0] ** 3:
        value = (A.inverse() @ b)[0]
    else:
        value = _mls_value(ti.Vector([mom[0], mom[1], mom[2]]), ti.Vector([b[0], b[1]]))
    return value


class MLSProjection:
    """See the module: the feature set (the basis, the study's case, the order of the
    stress fit), the add of the mode (``accumulate``) and the boundary (Dirichlet nodes).
    Its functions receive the particle fields, the grid fields (with the Gauss points' and
    the nodes' MLS sums: ``grid.g_mom``, ``grid.g_sig``, ``grid.g_rho``, ``grid.n_mom``,
    ``grid.n_vel``, and the body's extent ``grid.body``) and the run-time values."""

    def __init__(self, features, accumulate, boundary):
        self.basis, self.mode = features.basis, features.mode
        self.mls_study, self.mls_order = features.mls_study, features.mls_stress_order
        self.accumulate, self.boundary = accumulate, boundary

    @ti.func
    def scatter_gauss(self, particles: ti.template(), grid: ti.template(),
                              values: ti.template(), p):
        # MLS moments at the Gauss points within 1.5 h of the particle, quadratic-spline
        # weight, basis [1, d] with d = (x_p - y) / h
        xi = (particles.x[p][0] - values.origin()[0]) * values.inv_h()
        e0 = ti.floor(xi, ti.i32)
        rho = particles.m[p] / particles.vol[p]
        sig = particles.sigma[p][0, 0]
        for k in ti.static(range(-2, 3)):
            e = e0 + k
            if 0 <= e < values.elements()[0]:
                for g in ti.static(range(len(GAUSS_POINTS))):
                    y, jw = self._gauss_point(grid, values, e, g)
                    d = xi - y
                    w = quadratic_spline_weight(ti.abs(d)) if jw > 0.0 else 0.0
                    if w > 0.0:
                        if ti.static(self.mls_order == 1):
                            self.accumulate(grid.g_mom[e, g], w * ti.Vector([1.0, d, d * d]))
                            self.accumulate(grid.g_sig[e, g], w * sig * ti.Vector([1.0, d]))
                        else:
                            d2 = d * d
                            self.accumulate(grid.g_mom[e, g],
                                            w * ti.Vector([1.0, d, d2, d2 * d, d2 * d2]))
                            self.accumulate(grid.g_sig[e, g], w * sig * ti.Vector([1.0, d, d2]))
                        if ti.static(self.mls_study):
                            self.accumulate(grid.g_rho[e, g], w * rho * ti.Vector([1.0, d]))

    @ti.func
    def body_extent(self, particles: ti.template(), grid: ti.template(), values: ti.template()):
        # the body is the union of the particle domains x_p -+ V_p / 2 (element units)
        for p in range(values.n_particles()):
            xi = (particles.x[p][0] - values.origin()[0]) * values.inv_h()
            half = 0.5 * particles.vol[p] * values.inv_h()
            if ti.static(self.mode == "serial"):  # one thread: no atomics (see _sum_into)
                grid.body[None][0] = ti.min(grid.body[None][0], xi - half)
                grid.body[None][1] = ti.max(grid.body[None][1], xi + half)
            else:
                ti.atomic_min(grid.body[None][0], xi - half)
                ti.atomic_max(grid.body[None][1], xi + half)

    @ti.func
    def _gauss_point(self, grid: ti.template(), values: ti.template(), e, g: ti.template()):
        """Gauss point g of element e's part of the body, and its weight times length."""
        a = ti.max(ti.cast(e, float), grid.body[None][0])
        b = ti.min(ti.cast(e + 1, float), grid.body[None][1])
        return a + (b - a) * GAUSS_POINTS[g], GAUSS_WEIGHTS[g] * ti.max(b - a, 0.0) * values.h()

    @ti.func
    def integrate_gauss(self, grid: ti.template(), values: ti.template()):
        # M_ii = int rho phi_i, F_i = int (rho g phi_i - sigma dphi_i) by Gauss quadrature
        # over each element's part of the body, rho and sigma reconstructed by MLS (4.4);
        # beyond the study's case only F_i = -int sigma dphi_i (mass from the particles)
        for e in range(values.elements()[0]):
            for g in ti.static(range(len(GAUSS_POINTS))):
                y, jw = self._gauss_point(grid, values, e, g)
                if jw > 0.0:
                    base, w, dw = self.basis.stencil(y, values.elements()[0])
                    sig = 0.0
                    if ti.static(self.mls_order == 2):
                        sig = _mls_value_quadratic(grid.g_mom[e, g], grid.g_sig[e, g])
                    else:
                        sig = _mls_value(grid.g_mom[e, g], grid.g_sig[e, g])
                    if ti.static(self.mls_study):
                        rho = _mls_value(grid.g_mom[e, g], grid.g_rho[e, g])
                        for a in ti.static(range(self.basis.support)):
                            self.accumulate(grid.node_mass[base + a], jw * rho * w[a])
                            self.accumulate(grid.node_force[base + a][0], jw * (
                                rho * values.gravity()[0] * w[a] - sig * dw[a] * values.inv_h()))
                    else:
                        for a in ti.static(range(self.basis.support)):
                            self.accumulate(grid.node_force[base + a][0],
                                            -jw * sig * dw[a] * values.inv_h())

    @ti.func
    def scatter_nodes(self, particles: ti.template(), grid: ti.template(),
                             values: ti.template(), p, vp):
        # MLS moments at the nodes within 2 h, cubic-spline weight (r = |d| / 2)
        xi = (particles.x[p][0] - values.origin()[0]) * values.inv_h()
        i0 = ti.floor(xi, ti.i32)
        for k in ti.static(range(-1, 3)):
            i = i0 + k
            if 0 <= i < values.nodes()[0]:
                d = xi - i
                w = _cubic_spline(0.5 * ti.abs(d))
                if w > 0.0:
                    self.accumulate(grid.n_mom[i], w * ti.Vector([1.0, d, d * d]))
                    self.accumulate(grid.n_vel[i], w * vp * ti.Vector([1.0, d]))

    @ti.func
    def nodal_velocity(self, grid: ti.template(), values: ti.template()):
        # v_i = sum_p Phi_p(x_i) v_p: the MLS reconstruction of the velocity field (4.4)
        for i in range(values.nodes()[0]):
            v = 0.0
            if not self.boundary.is_fixed(i):
                v = _mls_value(grid.n_mom[i], grid.n_vel[i])
            grid.node_velocity[i][0] = v
