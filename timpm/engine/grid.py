"""The grid operations the schemes share, in two units mixed into
:class:`~timpm.engine.program.Program`: :class:`GridNodes`, what holds at one node (Dirichlet
nodes held or moving at a prescribed velocity v_i f(t), walls, the lumped solve), which the
consistent mass solves call; and :class:`GridSolve`, clearing the grid and the mass solve
of the whole grid, which calls them (lumped, banded or conjugate gradients).
"""
import taichi as ti

from .mls_projection import GAUSS_POINTS

__all__ = ["GridNodes", "GridSolve", "NODE_NAMES"]

#: the grid as the kernels name it, by what a field holds in each phase -> its storage (the
#: names Solver.read and the checkpoints take): the mass m_i; the momentum P_i that P2G
#: scatters, turned into the velocity v_i in place by the mass solve; the force F_i, turned
#: into the acceleration a_i in place (the affine midpoint iteration keeps its v_i^(n+1)
#: there); the displacement u_i; a scheme's new velocity v_i^(n+1), the midpoint's iterate
NODE_NAMES = {"node_mass": "gm", "node_momentum": "gp", "node_velocity": "gp",
              "node_force": "gf", "node_acceleration": "gf", "node_end_velocity": "gf",
              "node_displacement": "gu", "node_new_velocity": "gv"}


class GridNodes:
    """The boundary conditions and the lumped solve at one node (see the module)."""

    @ti.func
    def is_fixed(self, I):
        fixed = 0
        if ti.static(self.f.fixed):
            fixed = self.fixed[I]
        return fixed

    @ti.func
    def prescribed_velocity(self, I, step_end: ti.template()):
        """v_i f(t) of Dirichlet node I at the step's start (t_n) or end (t_n + dt)."""
        t = self.time[None]
        if ti.static(step_end):
            t += self.values.dt()
        return self.fixed_v[I] * self.prescribed_fn.at(t, self.values.prescribed_param())

    @ti.func
    def apply_walls(self, I, v):
        """Wall conditions on the velocity of node I (sides left/right, bottom/top, ...):
        sticky v = 0; driven (a moving sticky wall) v = v_wall f(t_n + dt); roller v_n = 0;
        slip removes the outward normal component; friction
        also slows the tangential velocity by mu |v_n| (Coulomb), down to rest.  A wall
        acts on the nodes at and beyond it (``wall_nodes``: per side the last node on or
        behind the wall)."""
        for k in ti.static(range(self.dim)):
            for side in ti.static(range(2)):
                if ti.static(self.walls[2 * k + side] != "open"):
                    edge = self.values.wall_nodes()[2 * k + side]
                    hit = I[k] <= edge if ti.static(side == 0) else I[k] >= edge
                    if hit:
                        vn = v[k] if ti.static(side == 0) else -v[k]  # along the inward normal
                        if ti.static(self.walls[2 * k + side] == "sticky"):
                            v = ti.Vector.zero(float, self.dim)
                        elif ti.static(self.walls[2 * k + side] == "driven"):
                            speeds = self.values.wall_velocity()
                            f = self.prescribed_fn.at(self.time[None] + self.values.dt(),
                                                      self.values.prescribed_param())
                            for j in ti.static(range(self.dim)):
                                v[j] = speeds[(2 * k + side) * self.dim + j] * f
                        elif ti.static(self.walls[2 * k + side] == "roller"):
                            v[k] = 0.0
                        elif vn < 0.0:
                            if ti.static(self.walls[2 * k + side] == "friction"):
                                vt = v
                                vt[k] = 0.0
                                speed = vt.norm()
                                scale = 0.0
                                if speed > 0.0:
                                    mu = self.values.wall_mu()[2 * k + side]
                                    scale = ti.max(0.0, 1.0 - mu * (-vn) / speed)
                                v = vt * scale
                            else:
                                v[k] = 0.0
        return v

    @ti.func
    def lumped_solve(self, I, value):
        """value / m_i at node I; zero at Dirichlet and empty nodes."""
        out = ti.Vector.zero(float, self.dim)
        if self.is_free(I):
            out = value / self.node_mass[I]
        return out

    @ti.func
    def is_free(self, I):
        """Node I carries mass (above ``mass_tol``) and is not a Dirichlet node."""
        return not (self.is_fixed(I) or self.node_mass[I] <= self.values.mass_tol())


class GridSolve:
    """Clearing the grid and the mass solve over it (see the module)."""

    @ti.func
    def clear_grid(self):
        for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
            self.node_mass[I] = 0.0
            self.node_momentum[I] = ti.Vector.zero(float, self.dim)
            if ti.static(not self.affine or self.midpoint):
                self.node_force[I] = ti.Vector.zero(float, self.dim)
        if ti.static(self.consistent and self.dim == 1):
            for i, k in ti.ndrange(self.values.nodes()[0], 2 * self.bandwidth + 1):
                self.band[i, k] = 0.0
        if ti.static(self.mls and self.dim > 1):
            self.clear_gauss_nd(self.grid, self.values)
        elif ti.static(self.mls):
            for e, g in ti.ndrange(self.values.elements()[0], ti.static(len(GAUSS_POINTS))):
                self.g_mom[e, g] = ti.Vector.zero(float, 2 * self.mls_order + 1)
                self.g_rho[e, g] = ti.Vector.zero(float, 2)
                self.g_sig[e, g] = ti.Vector.zero(float, self.mls_order + 1)
            self.body[None] = ti.Vector([1e300, -1e300])
            if ti.static(self.mls_study):
                for i in range(self.values.nodes()[0]):
                    self.n_mom[i] = ti.Vector.zero(float, 3)
                    self.n_vel[i] = ti.Vector.zero(float, 2)

    @ti.func
    def solve_mass(self, rhs: ti.template(), walls: ti.template()):
        """rhs <- M^-1 rhs with Dirichlet nodes held at zero and empty nodes left at zero;
        ``walls``: apply the wall conditions to the result (a velocity)."""
        if ti.static(not self.consistent):
            for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                self.solve_mass_node(rhs, walls, I)
        elif ti.static(self.dim > 1):
            self.cg_solve(rhs)  # the walls' held components are constraints of the solve
        else:
            self.banded_substitute(self.grid, self.values, rhs)

    @ti.func
    def solve_mass_node(self, rhs: ti.template(), walls: ti.template(), I):
        """The lumped solve of ``solve_mass`` at node I."""
        rhs[I] = self.lumped_solve(I, rhs[I])
        if ti.static(walls and self.has_walls):
            rhs[I] = self.apply_walls(I, rhs[I])
        if ti.static(walls and self.prescribed):  # a velocity: Dirichlet nodes at v(t_n + dt)
            if self.is_fixed(I):
                rhs[I] = self.prescribed_velocity(I, True)
