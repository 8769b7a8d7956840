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

from ..platform.errors import ErrorCode
from .phases import Nodes, Particles, Scatter, Whole

__all__ = ["MUSL"]


@ti.data_oriented
class MUSL:
    """See the module.  Its phases take the program (whose units they call: the stencil,
    the scatter, the mass solves, the walls, the failure record) and the state they read:
    ``particles``, ``grid`` (:class:`~timpm.engine.views.FieldView`) and the run-time
    ``values``; a node phase the grid and the values only."""

    #: run-time values of its own (name: "real" or "int"), read from the Model's attribute
    PARAMS = {}

    @staticmethod
    def applies(features):
        return features.transfer == "musl"

    @staticmethod
    def grid_fields(dim, real):
        """Grid fields of its own."""
        return {}

    def __init__(self, features):
        f = self.f = features
        # P2G scatters the momentum where a later phase reads it (the grid phase's damping
        # and walls, the Runge-Kutta and midpoint rates)
        self.scatters_momentum = f.damping or f.has_walls or f.rk4 or f.midpoint
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
    def clear(self, prog: ti.template(), particles: ti.template(), grid: ti.template(),
              values: ti.template()):
        # the grid cleared; with the MLS projection in 1D the body's extent
        prog.clear_grid()
        if ti.static(prog.mls and prog.dim == 1):
            prog.body_extent(particles, grid, values)

    @ti.func
    def p2g_particle(self, prog: ti.template(), particles: ti.template(), grid: ti.template(),
                     values: ti.template(), p, copy):
        # P2G (2.2.4): M_ij = sum m_p phi_i phi_j (A.1) or M_ii = sum m_p phi_i (A.2);
        # F_i = sum phi_i (m_p (g + b_p(t)) + f_trac(t)) - sigma_p V_p dphi_i
        base, w, dw, xi, inside = prog.stencil(particles.x[p])
        node_values = ti.Matrix.zero(float, 3, prog.basis.support)
        if not inside:
            prog.fail(ErrorCode.OFF_GRID, p)
        else:
            mp = particles.m[p]
            fp = prog.external_force(particles, values, p)
            stress_volume = particles.sigma[p] * particles.vol[p]
            if ti.static(prog.mls):
                if ti.static(prog.mls_study):
                    fp[0] -= mp * values.gravity()[0]  # gravity and mass: from the Gauss points
                if ti.static(prog.dim == 1):
                    prog.scatter_gauss_moments(particles, grid, values, p)
                else:
                    prog.scatter_gauss_moments_nd(particles, grid, values, p)
            for r in range(prog.stencil_rows):
                row = prog.stencil_row(w, dw, r)
                for a in ti.static(range(prog.basis.support)):
                    offset, phi, grad = prog.row_node(w, dw, r, row, a)
                    node = base + offset
                    if ti.static(not prog.mls):
                        node_values = prog.deposit("node_mass", copy, node, offset, mp * phi,
                                                    node_values)
                        node_values = prog.deposit("node_force", copy, node, offset,
                                                    phi * fp - stress_volume @ grad, node_values)
                    else:  # MLS: the stress enters at the Gauss points (integrate_gauss)
                        if ti.static(not prog.mls_study):
                            prog.accumulate(grid.node_mass[node], mp * phi)
                        prog.accumulate(grid.node_force[node], phi * fp)
                    if ti.static(self.scatters_momentum):
                        node_values = prog.deposit("node_momentum", copy, node, offset,
                                                    mp * phi * particles.v[p], node_values)
            if ti.static(prog.consistent and prog.dim == 1):
                for a, c in ti.static(ti.ndrange(prog.basis.support, prog.basis.support)):
                    prog.accumulate(grid.band[base[0] + a, c - a + prog.bandwidth],
                                    mp * w[a, 0] * w[c, 0])
        return base, inside, node_values

    @ti.func
    def after_p2g(self, prog: ti.template(), particles: ti.template(), grid: ti.template(),
                  values: ti.template()):
        # MLS: the stress integrated at the Gauss points; the consistent mass factorised
        # (1D banded LU) or its weights kept for the conjugate gradients
        if ti.static(prog.mls and prog.dim == 1):
            prog.integrate_gauss(grid, values)
        elif ti.static(prog.mls):
            prog.integrate_gauss_nd(grid, values)
        if ti.static(prog.consistent and prog.dim == 1):
            prog.banded_factorise(grid, values)
        elif ti.static(prog.consistent):
            prog.cg_keep_weights(particles, values)

    # ---- the grid: accelerations -----------------------------------------------------------
    @ti.func
    def acceleration_node(self, prog: ti.template(), grid: ti.template(),
                          values: ti.template(), I):
        # F_damp = -alpha sgn(v_i) |F_i| (A.4), then a = M^-1 F; at a wall
        # a = (wall(v_i + dt a) - v_i) / dt with v_i = P_i / m_i
        if ti.static(prog.damping):
            grid.node_force[I] -= (values.damping() * ti.math.sign(grid.node_momentum[I])
                                   * ti.abs(grid.node_force[I]))
        if ti.static(prog.has_walls and not prog.consistent):
            a = ti.Vector.zero(float, prog.dim)  # Dirichlet and empty nodes: a = 0
            if grid.node_mass[I] > values.mass_tol() and not prog.is_fixed(I):
                vn = grid.node_momentum[I] / grid.node_mass[I]
                a = (prog.apply_walls(I, vn + values.dt() * grid.node_force[I]
                                      / grid.node_mass[I]) - vn) / values.dt()
            grid.node_acceleration[I] = a
        elif ti.static(not prog.consistent):
            grid.node_acceleration[I] = prog.lumped_solve(I, grid.node_force[I])  # a = F / m
        if ti.static(prog.prescribed):
            if prog.is_fixed(I):  # a Dirichlet node: a = (v(t_n + dt) - v(t_n)) / dt
                grid.node_acceleration[I] = (prog.prescribed_velocity(I, True)
                              - prog.prescribed_velocity(I, False)) / values.dt()
        self.after_acceleration(prog, grid, values, I)
        if ti.static(self.scatters_momentum):
            grid.node_momentum[I] = ti.Vector.zero(float, prog.dim)  # P2G scattered P_i

    @ti.func
    def after_acceleration(self, prog: ti.template(), grid: ti.template(),
                           values: ti.template(), I):
        """A hook of the grid phase at node I, after a_i (nothing here)."""
        pass

    @ti.func
    def acceleration_solve(self, prog: ti.template(), particles: ti.template(),
                           grid: ti.template(), values: ti.template()):
        # F_i into a_i in place (in 1D the Model refuses walls with the consistent mass)
        prog.solve_mass(grid.node_force, False)

    # ---- G2P of the velocity, P2G of the momentum ------------------------------------------
    @ti.func
    def velocity_particle(self, prog: ti.template(), particles: ti.template(), grid: ti.template(),
                          values: ti.template(), p, copy):
        # G2P: v_p += dt sum_i phi_i(x_p) a_i; P2G: P_i = sum m_p phi_i(x_p) v_p (2.2.4)
        base, w, dw, xi, inside = prog.stencil(particles.x[p])
        node_values = ti.Matrix.zero(float, 3, prog.basis.support)
        if inside:
            acc = prog.interpolate(grid.node_acceleration, base, w, dw)
            vp = self.new_velocity(prog, grid, values, base, w, dw,
                                   particles.v[p] + values.dt() * acc)
            particles.v[p] = vp
            if ti.static(prog.mls_study):
                prog.scatter_node_moments(particles, grid, values, p, vp[0])
            else:
                for r in range(prog.stencil_rows):
                    row = prog.stencil_row(w, dw, r)
                    for a in ti.static(range(prog.basis.support)):
                        offset, phi, grad = prog.row_node(w, dw, r, row, a)
                        node_values = prog.deposit("node_momentum", copy, base + offset, offset,
                                                    particles.m[p] * phi * vp, node_values)
        return base, inside, node_values

    @ti.func
    def new_velocity(self, prog: ti.template(), grid: ti.template(), values: ti.template(),
                     base, w, dw, flip):
        """The particle's new velocity from its FLIP update v_p + dt sum phi_i a_i (a hook:
        that update itself here)."""
        return flip

    # ---- the grid: velocities --------------------------------------------------------------
    @ti.func
    def velocity_node(self, prog: ti.template(), grid: ti.template(), values: ti.template(), I):
        # v_i = P_i / m_i with the walls and the prescribed velocities; u_i += v_i dt (5.2)
        prog.solve_mass_node(grid.node_momentum, True, I)  # P_i into v_i in place
        if ti.static(prog.grid_displacement):
            grid.node_displacement[I] += grid.node_velocity[I] * values.dt()

    @ti.func
    def velocity_solve(self, prog: ti.template(), particles: ti.template(), grid: ti.template(),
                       values: ti.template()):
        if ti.static(prog.mls_study):
            prog.mls_nodal_velocity(grid, values)
        else:
            prog.solve_mass(grid.node_momentum, True)  # P_i into v_i in place

    @ti.func
    def displacement_node(self, prog: ti.template(), grid: ti.template(),
                          values: ti.template(), I):
        grid.node_displacement[I] += grid.node_velocity[I] * values.dt()

    # ---- G2P of the particle state ---------------------------------------------------------
    @ti.func
    def gather(self, prog: ti.template(), particles: ti.template(), grid: ti.template(),
               values: ti.template(), p, base, w, dw, xi):
        """v_p = sum_i phi_i v_i and grad du = sum_i v_i dt grad phi_i^T."""
        vp = ti.Vector.zero(float, prog.dim)
        grad_du = ti.Matrix.zero(float, prog.dim, prog.dim)
        for r in range(prog.stencil_rows):
            row = prog.stencil_row(w, dw, r)
            for a in ti.static(range(prog.basis.support)):
                offset, phi, grad = prog.row_node(w, dw, r, row, a)
                vi = grid.node_velocity[base + offset]
                vp += phi * vi
                grad_du += (vi * values.dt()).outer_product(grad)
        return vp, grad_du

    @ti.func
    def update_particle(self, prog: ti.template(), particles: ti.template(), grid: ti.template(),
                        values: ti.template(), p):
        prog.g2p_update_particle(particles, grid, values, p)
