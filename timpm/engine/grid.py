"""The grid operations the schemes share, in two units: :class:`Boundary`, what holds at
one node (Dirichlet nodes held or moving at a prescribed velocity v_i f(t), walls, the
lumped solve), which the consistent mass solves call; and :class:`GridSolve`, clearing the
grid and the mass solve of the whole grid (lumped, banded or conjugate gradients).
"""
import taichi as ti

from .mls_projection import GAUSS_POINTS

__all__ = ["Boundary", "GridSolve", "NODE_NAMES"]

#: the grid as the kernels name it, by what a field holds in each phase -> its storage (the
#: names Solver.read and the checkpoints take): the mass m_i; the momentum P_i that P2G
#: scatters, turned into the velocity v_i in place by the mass solve; the force F_i, turned
#: into the acceleration a_i in place (the affine midpoint iteration keeps its v_i^(n+1)
#: there); the displacement u_i; a scheme's new velocity v_i^(n+1), the midpoint's iterate
#: (a scheme names a grid field of its own in its declaration: Field.names)
NODE_NAMES = {"node_mass": "gm", "node_momentum": "gp", "node_velocity": "gp",
              "node_force": "gf", "node_acceleration": "gf", "node_end_velocity": "gf",
              "node_displacement": "gu", "node_new_velocity": "gv"}


class Boundary:
    """The boundary conditions and the lumped solve at one node (see the module): the
    feature set's walls and Dirichlet nodes, the grid (``fixed``, ``fixed_v``,
    ``node_mass``), the run fields (its time) and the run-time values."""

    def __init__(self, features, grid, run, values):
        f = self.f = features
        self.dim, self.walls, self.has_walls = f.dim, f.walls, f.has_walls
        self.prescribed_fn = f.prescribed
        self.grid, self.run, self.values = grid, run, values

    @ti.func
    def is_fixed(self, I):
        fixed = 0
        if ti.static(self.f.fixed):
            fixed = self.grid.fixed[I]
        return fixed

    @ti.func
    def prescribed_velocity(self, I, step_end: ti.template()):
        """v_i f(t) of Dirichlet node I at the step's start (t_n) or end (t_n + dt)."""
        t = self.run.time[None]
        if ti.static(step_end):
            t += self.values.dt()
        return self.grid.fixed_v[I] * self.prescribed_fn.at(t, self.values.prescribed_param())

    @ti.func
    def apply_walls(self, I, v):
        """The walls' conditions on the velocity of node I (see :meth:`walls_except`)."""
        return self.walls_except(I, v, ())

    @ti.func
    def walls_except(self, I, v, skip: ti.template()):
        """Wall conditions on the velocity of node I (sides left/right, bottom/top, ...;
        those whose indices ``skip`` holds left out: a drained side's, for the water):
        sticky v = 0; driven (a moving sticky wall) v = v_wall f(t_n + dt); roller v_n = 0;
        slip removes the outward normal component; friction
        also slows the tangential velocity by mu |v_n| (Coulomb), down to rest.  A wall
        acts on the nodes at and beyond it (``wall_nodes``: per side the last node on or
        behind the wall)."""
        for k in ti.static(range(self.dim)):
            for side in ti.static(range(2)):
                if ti.static(self.walls[2 * k + side] != "open" and 2 * k + side not in skip):
                    edge = self.values.wall_nodes()[2 * k + side]
                    hit = I[k] <= edge if ti.static(side == 0) else I[k] >= edge
                    if hit:
                        vn = v[k] if ti.static(side == 0) else -v[k]  # along the inward normal
                        if ti.static(self.walls[2 * k + side] == "sticky"):
                            v = ti.Vector.zero(float, self.dim)
                        elif ti.static(self.walls[2 * k + side] == "driven"):
                            speeds = self.values.wall_velocity()
                            f = self.prescribed_fn.at(self.run.time[None] + self.values.dt(),
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
            out = value / self.grid.node_mass[I]
        return out

    @ti.func
    def is_free(self, I):
        """Node I carries mass (above ``mass_tol``) and is not a Dirichlet node."""
        return not (self.is_fixed(I) or self.grid.node_mass[I] <= self.values.mass_tol())


class GridSolve:
    """Clearing the grid and the mass solve over it (see the module): the grid, the
    run-time values, the boundary, the solves of the consistent mass (``banded``: 1D,
    ``cg``: 2D and 3D), the MLS projections' sums to clear (``mls_nd``: 2D), and the
    stencil and the add of the mode (``project``)."""

    def __init__(self, features, grid, values, boundary, stencil, accumulate, banded=None,
                 cg=None, mls_nd=None, window=None):
        f = self.f = features
        self.dim = f.dim
        self.grid, self.values, self.boundary = grid, values, boundary
        self.stencil, self.accumulate = stencil, accumulate
        self.banded, self.cg, self.mls_nd = banded, cg, mls_nd
        self.window = window
        self.windowed = window is not None  # (engine/window.py)

    @ti.func
    def clear(self, whole: ti.template() = False):
        """m_i, P_i, F_i = 0 over the active window (engine/window.py) or, without one or
        with ``whole``, over the grid."""
        if ti.static(self.windowed and not whole):
            for I in ti.grouped(ti.ndrange(*self.window.ranges())):
                self.clear_node(I)
        else:
            for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                self.clear_node(I)
        if ti.static(self.f.consistent and self.dim == 1):
            for i, k in ti.ndrange(self.values.nodes()[0], 2 * self.f.bandwidth + 1):
                self.grid.band[i, k] = 0.0
        if ti.static(self.f.mls and self.dim > 1):
            self.mls_nd.clear_gauss(self.grid, self.values)
        elif ti.static(self.f.mls):
            order = ti.static(self.f.mls_stress_order)
            for e, g in ti.ndrange(self.values.elements()[0], ti.static(len(GAUSS_POINTS))):
                self.grid.g_mom[e, g] = ti.Vector.zero(float, 2 * order + 1)
                self.grid.g_rho[e, g] = ti.Vector.zero(float, 2)
                self.grid.g_sig[e, g] = ti.Vector.zero(float, order + 1)
            self.grid.body[None] = ti.Vector([1e300, -1e300])
            if ti.static(self.f.mls_study):
                for i in range(self.values.nodes()[0]):
                    self.grid.n_mom[i] = ti.Vector.zero(float, 3)
                    self.grid.n_vel[i] = ti.Vector.zero(float, 2)

    @ti.func
    def clear_node(self, I):
        self.grid.node_mass[I] = 0.0
        self.grid.node_momentum[I] = ti.Vector.zero(float, self.dim)
        if ti.static("gf" in self.grid.storage):
            self.grid.node_force[I] = ti.Vector.zero(float, self.dim)

    @ti.func
    def solve(self, rhs: ti.template(), walls: ti.template()):
        """rhs <- M^-1 rhs with Dirichlet nodes held at zero and empty nodes left at zero;
        ``walls``: apply the wall conditions to the result (a velocity)."""
        if ti.static(not self.f.consistent and self.windowed):
            for I in ti.grouped(ti.ndrange(*self.window.ranges())):
                self.solve_node(rhs, walls, I)
        elif ti.static(not self.f.consistent):
            for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                self.solve_node(rhs, walls, I)
        elif ti.static(self.dim > 1):
            self.cg.solve(rhs)  # the walls' held components are constraints of the solve
        else:
            self.banded.substitute(self.grid, self.values, rhs)

    @ti.func
    def solve_node(self, rhs: ti.template(), walls: ti.template(), I):
        """The lumped solve of ``solve`` at node I."""
        rhs[I] = self.boundary.lumped_solve(I, rhs[I])
        if ti.static(walls and self.f.has_walls):
            rhs[I] = self.boundary.apply_walls(I, rhs[I])
        if ti.static(walls and self.f.has_prescribed):
            # a velocity: Dirichlet nodes at v(t_n + dt)
            if self.boundary.is_fixed(I):
                rhs[I] = self.boundary.prescribed_velocity(I, True)

    @ti.func
    def project(self, particles: ti.template()):
        # the grid cleared, then P2G of mass and momentum alone: m_i = sum m_p phi_i, P_i =
        # sum m_p phi_i v_p (the grid fields of an output frame; the whole grid cleared:
        # the particles have moved since the active window was found)
        self.clear(True)
        for p in range(self.values.n_particles()):
            base, w, dw, xi, inside = self.stencil.of(particles.x[p])
            if inside:
                for r in range(self.stencil.rows):
                    for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                        node = self.stencil.node(base, offset)
                        self.accumulate(self.grid.node_mass[node], particles.m[p] * phi)
                        self.accumulate(self.grid.node_momentum[node],
                                        particles.m[p] * phi * particles.v[p])
