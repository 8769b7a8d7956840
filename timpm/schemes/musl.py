"""The study's Modified Lagrangian (MUSL) step with Euler-Cromer time stepping (2.2.4,
Figure 2.7), in any dimension, with the lumped or consistent mass and the standard or MLS
projection:

1. P2G of mass and forces (and momentum where the grid phase reads it);
2. a_i = M^-1 F_i on the grid, with local damping and the walls;
3. G2P of the velocity, v_p += dt sum_i phi_i a_i, and P2G of the new momentum;
4. v_i = M^-1 P_i on the grid, with the walls;
5. G2P of displacement, strain, stress and volume from v_i.
"""
import taichi as ti

from ..platform.declare import Field
from ..platform.errors import ErrorCode
from .base import Scheme
from .phases import Nodes, Particles, Scatter, Whole

__all__ = ["MUSL"]


class MUSL(Scheme):
    """See the module."""

    transfers = ("musl",)
    integrators = ("euler-cromer", "rk4", "midpoint")
    #: a variant's own P2G at each stencil node (``p2g_node``), compiled in only where a
    #: variant sets this; ``needs_momentum``: its grid phase reads P2G's momentum
    extended = False
    needs_momentum = False

    @staticmethod
    def grid_fields(features):
        return {"gf": Field("vector", doc="F_i, then a_i = M^-1 F_i")}

    def __init__(self, features, ops):
        super().__init__(features, ops)
        f = features
        self.dim, self.support = f.dim, f.basis.support
        # P2G scatters the momentum where a later phase reads it (the grid phase's damping
        # and walls, the Runge-Kutta and midpoint rates)
        self.scatters_momentum = (f.damping or f.walled or f.rk4 or f.midpoint
                                  or self.needs_momentum)
        momentum = ("node_momentum",) if self.scatters_momentum else ()
        self.p2g = Scatter("P2G: m_i, F_i (and P_i) (A.1/A.2)", self.p2g_particle,
                           rows=("node_mass", "node_force") + momentum,
                           merge=("node_mass", "node_momentum", "node_force"))
        self.velocity = Scatter("G2P: v_p += dt sum phi_i a_i; P2G: P_i = sum m_p phi_i v_p",
                                self.velocity_particle, rows=("node_momentum",),
                                merge=("node_momentum",))

    def phases(self):
        f = self.f
        steps = []
        if not f.private_scatter:  # (a merge stores the copies' sums: nothing to clear)
            steps.append(Whole("clear the grid", self.clear))
        steps.append(self.p2g)
        if f.mls or f.consistent:
            steps.append(Whole("MLS Gauss-point forces; the consistent mass factorised",
                               self.after_p2g))
        steps.append(Nodes("grid: local damping (A.4), a_i = M^-1 F_i, walls",
                           self.acceleration_node))
        if f.consistent:
            steps.append(Whole("grid: a = M^-1 F, the consistent mass", self.acceleration_solve))
        steps.append(self.velocity)
        if f.mls_study or f.consistent:
            steps.append(Whole("grid: v_i = M^-1 P_i (MLS nodal velocity, consistent mass)",
                               self.velocity_solve))
        if f.mls_study or f.consistent:
            if f.grid_displacement:
                steps.append(Nodes("grid: u_i += v_i dt (5.2)", self.displacement_node))
        else:
            steps.append(Nodes("grid: v_i = P_i / m_i, walls; u_i += v_i dt", self.velocity_node))
        steps.append(Particles("G2P: u_p, grad du, sigma_p, V_p", self.update_particle))
        return tuple(steps)

    # ---- P2G -----------------------------------------------------------------------------
    @ti.func
    def clear(self, particles: ti.template(), grid: ti.template(), values: ti.template()):
        # the grid cleared; with the MLS projection in 1D the body's extent
        self.nodes.clear()
        if ti.static(self.f.mls and self.dim == 1):
            self.mls.body_extent(particles, grid, values)

    @ti.func
    def p2g_particle(self, particles: ti.template(), grid: ti.template(), values: ti.template(),
                     p, copy):
        # P2G (2.2.4): M_ij = sum m_p phi_i phi_j (A.1) or M_ii = sum m_p phi_i (A.2);
        # F_i = sum phi_i (m_p (g + b_p(t)) + f_trac(t)) - sigma_p V_p dphi_i
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        node_values = ti.Matrix.zero(float, 3, self.support)
        if not inside:
            self.failures.fail(ErrorCode.OFF_GRID, p)
        else:
            mp = particles.m[p]
            fp = self.loads.force(particles, values, p)
            stress_volume = particles.sigma[p] * particles.vol[p]
            if ti.static(self.f.mls):
                if ti.static(self.f.mls_study):
                    fp[0] -= mp * values.gravity()[0]  # gravity and mass: from the Gauss points
                if ti.static(self.dim == 1):
                    self.mls.scatter_gauss(particles, grid, values, p)
                else:
                    self.mls_nd.scatter_gauss(particles, grid, values, p)
            for r in range(self.stencil.rows):
                for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                    node = self.stencil.node(base, offset)
                    if ti.static(not self.f.mls):
                        node_values = self.scatter.deposit("node_mass", copy, node, offset,
                                                           mp * phi, node_values)
                        node_values = self.scatter.deposit("node_force", copy, node, offset,
                                                           phi * fp - stress_volume @ grad,
                                                           node_values)
                    else:  # MLS: the stress enters at the Gauss points (integrate_gauss)
                        if ti.static(not self.f.mls_study):
                            self.scatter.accumulate(grid.node_mass[node], mp * phi)
                        self.scatter.accumulate(grid.node_force[node], phi * fp)
                    if ti.static(self.scatters_momentum):
                        node_values = self.scatter.deposit("node_momentum", copy, node, offset,
                                                           mp * phi * particles.v[p],
                                                           node_values)
                    if ti.static(self.extended):
                        self.p2g_node(particles, values, p, copy, node, phi, grad)
            if ti.static(self.f.consistent and self.dim == 1):
                for a, c in ti.static(ti.ndrange(self.support, self.support)):
                    self.scatter.accumulate(grid.band[base[0] + a, c - a + self.f.bandwidth],
                                            mp * w[a, 0] * w[c, 0])
        return base, inside, node_values

    @ti.func
    def p2g_node(self, particles: ti.template(), values: ti.template(), p, copy, node, phi,
                 grad):
        """A variant's own P2G of particle p at a stencil node (``extended``; nothing
        here)."""
        pass

    @ti.func
    def after_p2g(self, particles: ti.template(), grid: ti.template(), values: ti.template()):
        # MLS: the stress integrated at the Gauss points; the consistent mass factorised
        # (1D banded LU) or its weights kept for the conjugate gradients
        if ti.static(self.f.mls and self.dim == 1):
            self.mls.integrate_gauss(grid, values)
        elif ti.static(self.f.mls):
            self.mls_nd.integrate_gauss(grid, values)
        if ti.static(self.f.consistent and self.dim == 1):
            self.banded.factorise(grid, values)
        elif ti.static(self.f.consistent):
            self.cg.keep_weights(particles, values)

    # ---- the grid: accelerations -----------------------------------------------------------
    @ti.func
    def acceleration_node(self, grid: ti.template(), values: ti.template(), I):
        # F_damp = -alpha sgn(v_i) |F_i| (A.4), then a = M^-1 F; at a wall
        # a = (wall(v_i + dt a) - v_i) / dt with v_i = P_i / m_i
        if ti.static(self.f.damping):
            grid.node_force[I] -= (values.damping() * ti.math.sign(grid.node_momentum[I])
                                   * ti.abs(grid.node_force[I]))
        if ti.static(self.f.walled and not self.f.consistent):
            a = ti.Vector.zero(float, self.dim)  # Dirichlet and empty nodes: a = 0
            if grid.node_mass[I] > values.mass_tol() and not self.boundary.is_fixed(I):
                vn = grid.node_momentum[I] / grid.node_mass[I]
                a = (self.boundary.apply_walls(I, vn + values.dt() * grid.node_force[I]
                                               / grid.node_mass[I]) - vn) / values.dt()
            grid.node_acceleration[I] = a
        elif ti.static(not self.f.consistent):
            grid.node_acceleration[I] = self.boundary.lumped_solve(I, grid.node_force[I])
        if ti.static(self.f.has_prescribed):
            if self.boundary.is_fixed(I):  # a Dirichlet node: a = (v(t_n + dt) - v(t_n)) / dt
                grid.node_acceleration[I] = (self.boundary.prescribed_velocity(I, True)
                                             - self.boundary.prescribed_velocity(I, False)
                                             ) / values.dt()
        self.after_acceleration(grid, values, I)
        if ti.static(self.scatters_momentum):
            grid.node_momentum[I] = ti.Vector.zero(float, self.dim)  # P2G scattered P_i

    @ti.func
    def after_acceleration(self, grid: ti.template(), values: ti.template(), I):
        """A hook of the grid phase at node I, after a_i (nothing here)."""
        pass

    @ti.func
    def acceleration_solve(self, particles: ti.template(), grid: ti.template(),
                           values: ti.template()):
        # F_i into a_i in place (in 1D the Model refuses walls with the consistent mass)
        self.nodes.solve(grid.node_force, False)

    # ---- G2P of the velocity, P2G of the momentum ------------------------------------------
    @ti.func
    def velocity_particle(self, particles: ti.template(), grid: ti.template(),
                          values: ti.template(), p, copy):
        # G2P: v_p += dt sum_i phi_i(x_p) a_i; P2G: P_i = sum m_p phi_i(x_p) v_p (2.2.4)
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        node_values = ti.Matrix.zero(float, 3, self.support)
        if inside:
            acc = self.stencil.interpolate(grid.node_acceleration, base, w, dw)
            vp = self.new_velocity(grid, values, base, w, dw,
                                   particles.v[p] + values.dt() * acc)
            particles.v[p] = vp
            if ti.static(self.f.mls_study):
                self.mls.scatter_nodes(particles, grid, values, p, vp[0])
            else:
                for r in range(self.stencil.rows):
                    for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                        node_values = self.scatter.deposit("node_momentum", copy,
                                                           self.stencil.node(base, offset), offset,
                                                           particles.m[p] * phi * vp,
                                                           node_values)
        return base, inside, node_values

    @ti.func
    def new_velocity(self, grid: ti.template(), values: ti.template(), base, w, dw, flip):
        """The particle's new velocity from its FLIP update v_p + dt sum phi_i a_i (a hook:
        that update itself here)."""
        return flip

    # ---- the grid: velocities --------------------------------------------------------------
    @ti.func
    def velocity_node(self, grid: ti.template(), values: ti.template(), I):
        # v_i = P_i / m_i with the walls and the prescribed velocities; u_i += v_i dt (5.2)
        self.nodes.solve_node(grid.node_momentum, True, I)  # P_i into v_i in place
        if ti.static(self.f.grid_displacement):
            grid.node_displacement[I] += grid.node_velocity[I] * values.dt()

    @ti.func
    def velocity_solve(self, particles: ti.template(), grid: ti.template(),
                       values: ti.template()):
        if ti.static(self.f.mls_study):
            self.mls.nodal_velocity(grid, values)
        else:
            self.nodes.solve(grid.node_momentum, True)  # P_i into v_i in place

    @ti.func
    def displacement_node(self, grid: ti.template(), values: ti.template(), I):
        grid.node_displacement[I] += grid.node_velocity[I] * values.dt()

    # ---- G2P of the particle state ---------------------------------------------------------
    @ti.func
    def gather(self, particles: ti.template(), grid: ti.template(), values: ti.template(), p,
               base, w, dw, xi):
        """v_p = sum_i phi_i v_i and grad du = sum_i v_i dt grad phi_i^T."""
        vp = ti.Vector.zero(float, self.dim)
        grad_du = ti.Matrix.zero(float, self.dim, self.dim)
        for r in range(self.stencil.rows):
            for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                vi = grid.node_velocity[self.stencil.node(base, offset)]
                vp += phi * vi
                grad_du += (vi * values.dt()).outer_product(grad)
        return vp, grad_du

    @ti.func
    def update_particle(self, particles: ti.template(), grid: ti.template(),
                        values: ti.template(), p):
        # G2P: the scheme's gather of v_p and grad du, then the particle's state from them
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        if inside and not self.failures.halted(p):
            vp, grad_du = self.gather(particles, grid, values, p, base, w, dw, xi)
            du = vp * values.dt()
            self.g2p.update(particles, values, p, vp, du, grad_du)

    # ---- the rates of an integrator's stage (rk4, midpoint) ---------------------------------
    @ti.func
    def grid_rates(self, particles: ti.template(), grid: ti.template(), values: ti.template()):
        # P2G of the particles' state (a Runge-Kutta stage, a midpoint iterate): m_i, P_i =
        # sum m_p phi_i v_p, F_i = sum phi_i m_p (g + b_p) - sigma_p V_p grad phi_i (at the
        # Gauss points with the MLS projection); then a_i = M^-1 F_i and v_i = M^-1 P_i,
        # zero at Dirichlet and empty nodes.  Roller and sticky walls are linear
        # constraints, the same on both (the consistent mass's solve takes them as such;
        # acceleration_node is no fit: it clears P_i at walls)
        self.clear(particles, grid, values)
        self.scatter.run(self.p2g, particles, grid, values)
        if ti.static(self.f.mls or self.f.consistent):
            self.after_p2g(particles, grid, values)
        self.nodes.solve(grid.node_force, True)  # F_i into a_i in place
        self.nodes.solve(grid.node_momentum, True)  # P_i into v_i in place
