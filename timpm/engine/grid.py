"""The grid operations the schemes share, in two units: :class:`Boundary`, what holds at
one node (Dirichlet nodes held or moving at a prescribed velocity v_i f(t), walls on the
box's sides and plane walls, the lumped solve), which the consistent mass solves call; and
:class:`GridSolve`, clearing the grid and the mass solve of the whole grid (lumped, banded
or conjugate gradients).

A plane wall (model/walls.py: Plane) holds the nodes on or beyond it, xi . n >= level with
xi the node's coordinates in cells from the grid's origin (the basis' node coordinates) and
level = (p - origin) . n / h less a tolerance (engine/features.py); its kind and whether
the pore water drains through it are compiled in (``FeatureSet.planes``), its normal,
level and mu are run-time values (``plane_normal``, ``plane_level``, ``plane_mu``): moving
or turning a plane compiles nothing.
"""
import numpy as np
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
        self.planes = f.planes
        self.wall_axes = f.dim if f.has_walls else 0  # (none: planes only)
        self.prescribed_fn = f.prescribed
        self.grid, self.run, self.values = grid, run, values
        if self.planes:
            self.node_rule = _node_rule(f.basis)

    @ti.func
    def node_cell(self, k: ti.template(), j):
        """The coordinate of node j along axis k in cells from the grid's origin (the
        basis' ``node_coordinates``: j less the padded B-splines' offset; the clamped
        B-splines' Greville abscissa (1 / p) sum_(m=1..p) clamp(j + m - p, 0, n))."""
        value = ti.static(self.node_rule[1])
        out = ti.cast(j, float)
        if ti.static(self.node_rule[0] == "shift"):
            out -= value
        else:
            n = self.values.elements()[k]
            total = 0
            for m in ti.static(range(1, value + 1)):
                total += ti.min(ti.max(j + m - value, 0), n)
            out = ti.cast(total, float) / value
        return out

    @ti.func
    def on_plane(self, I, j: ti.template()):
        """Plane j holds node I: xi . n >= its level (the module)."""
        normals = self.values.plane_normal()
        d = 0.0
        for k in ti.static(range(self.dim)):
            d += self.node_cell(k, I[k]) * normals[j * self.dim + k]
        return d >= self.values.plane_level()[j]

    @ti.func
    def plane_normal(self, j: ti.template()):
        normals = self.values.plane_normal()
        return ti.Vector([normals[j * self.dim + k] for k in ti.static(range(self.dim))])

    @ti.func
    def apply_planes(self, I, v):
        """The plane walls' conditions on the velocity of node I, one plane after the other
        (model/walls.py), with n the outward normal (into the wall) and v_n = v . n: sticky
        v = 0; roller v -= v_n n; slip, where v_n > 0 (moving into the wall), v -= v_n n;
        friction there also scales the tangential part v - v_n n by max(0, 1 - mu v_n /
        |v_t|) (Coulomb).  At a plane along an axis the same numbers as a box wall's."""
        for j in ti.static(range(len(self.planes))):
            if self.on_plane(I, j):
                n = self.plane_normal(j)
                vn = v.dot(n)
                if ti.static(self.planes[j][0] == "sticky"):
                    v = ti.Vector.zero(float, self.dim)
                elif ti.static(self.planes[j][0] == "roller"):
                    v = v - vn * n
                elif vn > 0.0:
                    if ti.static(self.planes[j][0] == "friction"):
                        vt = v - vn * n
                        speed = vt.norm()
                        scale = 0.0
                        if speed > 0.0:
                            scale = ti.max(0.0, 1.0 - self.values.plane_mu()[j] * vn / speed)
                        v = vt * scale
                    else:
                        v = v - vn * n
        return v

    @ti.func
    def water_at_planes(self, I, w, v):
        """The impermeable planes' condition on the pore water's velocity w at node I,
        given the skeleton's v there (after the walls): its normal component the
        skeleton's, w -= (w . n - v . n) n, its tangential part free; the drained planes
        leave it alone (the water's own balance, schemes/two_phase.py)."""
        for j in ti.static(range(len(self.planes))):
            if ti.static(not self.planes[j][1]):
                if self.on_plane(I, j):
                    n = self.plane_normal(j)
                    w = w - (w.dot(n) - v.dot(n)) * n
        return w

    @ti.func
    def on_drained_plane(self, I):
        """Some drained plane (Plane.drained) holds node I."""
        out = False
        for j in ti.static(range(len(self.planes))):
            if ti.static(self.planes[j][1]):
                if self.on_plane(I, j):
                    out = True
        return out

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
        """The walls' conditions on the velocity of node I: the box's sides' (see
        :meth:`walls_except`), then the planes' (:meth:`apply_planes`)."""
        out = self.walls_except(I, v, ())
        if ti.static(self.f.has_planes):
            out = self.apply_planes(I, out)
        return out

    @ti.func
    def walls_except(self, I, v, skip: ti.template()):
        """Wall conditions on the velocity of node I (sides left/right, bottom/top, ...;
        those whose indices ``skip`` holds left out: a drained side's, for the water):
        sticky v = 0; driven (a moving sticky wall) v = v_wall f(t_n + dt); roller v_n = 0;
        slip removes the outward normal component; friction
        also slows the tangential velocity by mu |v_n| (Coulomb), down to rest.  A wall
        acts on the nodes at and beyond it (``wall_nodes``: per side the last node on or
        behind the wall)."""
        for k in ti.static(range(self.wall_axes)):
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


def _node_rule(basis):
    """How the kernels find a node's coordinate along an axis from its index (Boundary.
    node_cell): ("shift", offset), x = j - offset, or ("greville", p), the clamped
    B-splines' control points; checked against the basis' own node_coordinates."""
    if basis.uniform_nodes:
        rule = ("shift", basis.offset() if hasattr(basis, "offset") else 0)
    else:
        rule = ("greville", int(getattr(basis, "degree", 0)))
    for n in range(max(basis.min_elements, 1), 12):
        j = np.arange(basis.n_nodes(n))
        if rule[0] == "shift":
            mine = j - float(rule[1])
        else:
            p = rule[1]
            mine = sum(np.clip(j + m - p, 0, n) for m in range(1, p + 1)) / p if p else j
        if not np.allclose(mine, basis.node_coordinates(n), rtol=0.0, atol=1e-12):
            raise NotImplementedError(f"plane walls do not know the {basis.name} basis' node "
                                      "positions")
    return rule


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
        if ti.static(walls and self.f.walled):
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
