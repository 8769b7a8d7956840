"""The grid phases: clearing, boundary conditions (Dirichlet nodes held or moving at a
prescribed velocity v_i f(t), walls), nodal solves.

Mixed into :class:`~timpm.engine.program.Program`.
"""
import taichi as ti

from .mls_projection import GAUSS_POINTS

__all__ = ["GridOps"]


class GridOps:
    """See the module."""

    @ti.func
    def _is_fixed(self, I):
        fixed = 0
        if ti.static(self.f.fixed):
            fixed = self.fixed[I]
        return fixed

    @ti.func
    def _prescribed_velocity(self, I, step_end: ti.template()):
        """v_i f(t) of Dirichlet node I at the step's start (t_n) or end (t_n + dt)."""
        t = self.time[None]
        if ti.static(step_end):
            t += self.p.dt()
        return self.fixed_v[I] * self.prescribed_fn.at(t, self.p.prescribed_param())

    @ti.func
    def _wall(self, I, v):
        """Wall conditions on the velocity of node I (sides left/right, bottom/top, ...):
        sticky v = 0; driven (a moving sticky wall) v = v_wall f(t_n + dt); roller v_n = 0;
        slip removes the outward normal component; friction
        also slows the tangential velocity by mu |v_n| (Coulomb), down to rest.  A wall
        acts on the nodes at and beyond it (``wall_nodes``: per side the last node on or
        behind the wall)."""
        for k in ti.static(range(self.dim)):
            for side in ti.static(range(2)):
                if ti.static(self.walls[2 * k + side] != "open"):
                    edge = self.p.wall_nodes()[2 * k + side]
                    hit = I[k] <= edge if ti.static(side == 0) else I[k] >= edge
                    if hit:
                        vn = v[k] if ti.static(side == 0) else -v[k]  # along the inward normal
                        if ti.static(self.walls[2 * k + side] == "sticky"):
                            v = ti.Vector.zero(float, self.dim)
                        elif ti.static(self.walls[2 * k + side] == "driven"):
                            speeds = self.p.wall_velocity()
                            f = self.prescribed_fn.at(self.time[None] + self.p.dt(),
                                                      self.p.prescribed_param())
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
                                    mu = self.p.wall_mu()[2 * k + side]
                                    scale = ti.max(0.0, 1.0 - mu * (-vn) / speed)
                                v = vt * scale
                            else:
                                v[k] = 0.0
        return v

    @ti.func
    def _clear_grid(self):
        for I in ti.grouped(ti.ndrange(*[self.p.nodes()[k] for k in range(self.dim)])):
            self.gm[I] = 0.0
            self.gp[I] = ti.Vector.zero(float, self.dim)
            if ti.static(not self.apic or self.midpoint):
                self.gf[I] = ti.Vector.zero(float, self.dim)
        if ti.static(self.consistent and self.dim == 1):
            for i, k in ti.ndrange(self.p.nodes()[0], 2 * self.bandwidth + 1):
                self.band[i, k] = 0.0
        if ti.static(self.mls and self.dim > 1):
            self._clear_gauss_nd()
        elif ti.static(self.mls):
            for e, g in ti.ndrange(self.p.elements()[0], ti.static(len(GAUSS_POINTS))):
                self.g_mom[e, g] = ti.Vector.zero(float, 2 * self.mls_order + 1)
                self.g_rho[e, g] = ti.Vector.zero(float, 2)
                self.g_sig[e, g] = ti.Vector.zero(float, self.mls_order + 1)
            self.body[None] = ti.Vector([1e300, -1e300])
            if ti.static(self.mls_study):
                for i in range(self.p.nodes()[0]):
                    self.n_mom[i] = ti.Vector.zero(float, 3)
                    self.n_vel[i] = ti.Vector.zero(float, 2)

    @ti.func
    def _grid_acceleration(self):
        # grid: local damping F_damp = -alpha sgn(v_i) |F_i| (A.4), then a = M^-1 F; at a
        # wall a = (wall(v_i + dt a) - v_i) / dt with v_i = P_i / m_i
        for I in ti.grouped(ti.ndrange(*[self.p.nodes()[k] for k in range(self.dim)])):
            self._grid_acceleration_node(I)
        if ti.static(self.consistent):  # (in 1D the Model refuses walls with it)
            self._solve_mass(self.gf, False)

    @ti.func
    def _grid_acceleration_node(self, I):
        if ti.static(self.damping):
            self.gf[I] -= self.p.damping() * ti.math.sign(self.gp[I]) * ti.abs(self.gf[I])
        if ti.static(self.has_walls and not self.consistent):
            a = ti.Vector.zero(float, self.dim)  # Dirichlet and empty nodes: a = 0
            if self.gm[I] > self.p.mass_tol() and not self._is_fixed(I):
                vn = self.gp[I] / self.gm[I]
                a = (self._wall(I, vn + self.p.dt() * self.gf[I] / self.gm[I]) - vn) / self.p.dt()
            self.gf[I] = a
        elif ti.static(not self.consistent):
            self.gf[I] = self._lumped_solve(I, self.gf[I])  # a = F / m in the same pass
        if ti.static(self.prescribed):
            if self._is_fixed(I):  # a Dirichlet node: a = (v(t_n + dt) - v(t_n)) / dt
                self.gf[I] = (self._prescribed_velocity(I, True)
                              - self._prescribed_velocity(I, False)) / self.p.dt()
        if ti.static(self.pic):
            # the grid velocity after the update, v_i^L = P_i / m_i + dt a_i (a wall's a
            # makes it the wall's velocity; zero at Dirichlet and empty nodes)
            v_new = self._lumped_solve(I, self.gp[I]) + self.p.dt() * self.gf[I]
            if ti.static(self.prescribed):
                if self._is_fixed(I):
                    v_new = self._prescribed_velocity(I, True)
            self.gv[I] = v_new
        if ti.static(self.damping or self.has_walls or self.pic):
            self.gp[I] = ti.Vector.zero(float, self.dim)  # P2G scattered P_i

    @ti.func
    def _grid_velocity(self):
        # grid (APIC): v_i = P_i / m_i, wall conditions applied; in the same pass the
        # private copies are summed in and m_i, P_i cleared for the next P2G
        # (a node no particle reached has m = P = 0 and is left alone: G2P weighs it by 0)
        for I in ti.grouped(ti.ndrange(*[self.p.nodes()[k] for k in range(self.dim)])):
            self._grid_velocity_node(I)

    @ti.func
    def _grid_velocity_node(self, I):
        if self._reached(I):
            m = self._merged("gm", I)
            P = self._merged("gp", I)
            v = ti.Vector.zero(float, self.dim)
            if m > self.p.mass_tol() and not self._is_fixed(I):
                v = P / m
                if ti.static(self.has_walls):
                    v = self._wall(I, v)
            if ti.static(self.prescribed):
                if self._is_fixed(I):
                    v = self._prescribed_velocity(I, True)
            self.gv[I] = v
            if ti.static(self.strain_remap):
                self.gm[I] = m  # P cleared for the remap
                self.gp[I] = ti.Vector.zero(float, self.dim)
            elif ti.static(not self.private_scatter):
                self.gm[I] = 0.0
                self.gp[I] = ti.Vector.zero(float, self.dim)

    @ti.func
    def _solve_mass(self, rhs: ti.template(), walls: ti.template()):
        """rhs <- M^-1 rhs with Dirichlet nodes held at zero and empty nodes left at zero;
        ``walls``: apply the wall conditions to the result (a velocity)."""
        if ti.static(not self.consistent):
            for I in ti.grouped(ti.ndrange(*[self.p.nodes()[k] for k in range(self.dim)])):
                self._solve_mass_node(rhs, walls, I)
        elif ti.static(self.dim > 1):
            self._cg_solve(rhs)  # the walls' held components are constraints of the solve
        else:
            self._banded_substitute(rhs)

    @ti.func
    def _solve_mass_node(self, rhs: ti.template(), walls: ti.template(), I):
        """The lumped solve of ``_solve_mass`` at node I."""
        rhs[I] = self._lumped_solve(I, rhs[I])
        if ti.static(walls and self.has_walls):
            rhs[I] = self._wall(I, rhs[I])
        if ti.static(walls and self.prescribed):  # a velocity: Dirichlet nodes at v(t_n + dt)
            if self._is_fixed(I):
                rhs[I] = self._prescribed_velocity(I, True)

    @ti.func
    def _lumped_solve(self, I, value):
        """value / m_i at node I; zero at Dirichlet and empty nodes."""
        out = ti.Vector.zero(float, self.dim)
        if self._is_free(I):
            out = value / self.gm[I]
        return out

    @ti.func
    def _is_free(self, I):
        """Node I carries mass (above ``mass_tol``) and is not a Dirichlet node."""
        return not (self._is_fixed(I) or self.gm[I] <= self.p.mass_tol())
