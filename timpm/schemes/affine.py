"""The affine transfers, APIC (Jiang et al. 2015) and MLS-MPM (Hu et al. 2018):

1. P2G of mass and momentum with the affine part, P_i = sum m_p phi_i (v_p + C_p (x_i -
   x_p)) + dt F_i (MLS-MPM: the stress through D^-1 in the same affine matrix);
2. v_i = P_i / m_i on the grid, with the walls (m_i, P_i cleared in the same pass);
3. (APIC with the linear basis: G2P of v_p and C_p, P2G P'_i = sum m_p phi_i v_p, v'_i =
   P'_i / m_i, the study's strain remap);
4. G2P of v_p, C_p = B_p D_p^-1, the velocity gradient, stress and volume.
"""
import taichi as ti

from ..platform.declare import Field
from ..platform.errors import ErrorCode
from .base import Scheme
from .phases import Nodes, Particles, Scatter, Whole

__all__ = ["Affine"]


class Affine(Scheme):
    """See the module."""

    transfers = ("apic", "mls-mpm")
    affine = True
    integrators = ("euler-cromer", "midpoint")  # the midpoint iteration on the grid
    #: a variant's own P2G at each stencil node (``p2g_node``) and grid update at each node
    #: (``after_velocity``): compiled in only where a variant sets this
    extended = False

    @classmethod
    def check(cls, transfer, dim, basis, mass, projection, damping, params):
        if not basis.uniform_nodes:
            raise ValueError(f"the {transfer} transfer takes node positions x_i spaced "
                             f"uniformly (linear, uniform-bsplineN); the {basis.name} basis' "
                             "nodes are not (control points at the Greville abscissae, or "
                             "mid-element nodes): use transfer='musl'")
        if transfer == "mls-mpm" and basis.name == "linear":
            raise ValueError("the mls-mpm transfer needs a B-spline basis (its D_p is "
                             "constant); use transfer='apic' with the linear basis")
        if mass == "consistent":
            raise ValueError("the consistent mass matrix is implemented with the musl "
                             f"transfer, not {transfer}")
        if projection == "mls":
            raise ValueError(f"the MLS projection (4.4) is implemented with the musl "
                             f"transfer, got {transfer}")
        if damping:
            raise ValueError("local damping (A.4) acts on the grid forces of the musl "
                             f"transfer; the {transfer} transfer folds them into the momentum:"
                             " use transfer='musl' or damping=0")

    @staticmethod
    def particle_fields(features):
        return {"C": Field("matrix", doc="the affine velocity C_p (B_p = C_p D_p for the "
                                         "linear basis)")}

    @staticmethod
    def grid_fields(features):
        return {"gv": Field("vector", doc="v_i of the last grid update (G2P reads it)")}

    def __init__(self, features, ops):
        super().__init__(features, ops)
        self.dim, self.support = features.dim, features.basis.support
        self.p2g = Scatter("P2G: m_i, P_i = sum m_p phi_i (v_p + C_p (x_i - x_p)) + dt F_i",
                           self.p2g_particle, rows=("node_mass", "node_momentum"))
        self.remap = Scatter("G2P: v_p, C_p; P2G: P'_i = sum m_p phi_i v_p (strain remap)",
                             self.remap_particle, rows=("node_momentum",),
                             merge=("node_momentum",))

    def phases(self):
        steps = []
        if self.f.strain_remap:
            steps.append(Whole("clear the grid (m_i stays for the remap)", self.clear))
        steps += [self.p2g, Nodes("grid: v_i = P_i / m_i, walls", self.velocity_node)]
        if self.f.strain_remap:
            steps += [self.remap, Nodes("grid: v'_i = P'_i / m_i, walls", self.remap_node)]
        steps.append(Particles("G2P: v_p, C_p, grad v, sigma_p, V_p", self.update_particle))
        return tuple(steps)

    @ti.func
    def clear(self, particles: ti.template(), grid: ti.template(), values: ti.template()):
        self.nodes.clear()

    @ti.func
    def p2g_particle(self, particles: ti.template(), grid: ti.template(), values: ti.template(),
                     p, copy):
        # P2G: m_i = sum m_p phi_i; P_i = sum m_p phi_i (v_p + C_p (x_i - x_p)) + dt F_i,
        # F_i = sum phi_i m_p (g + b_p) - sigma_p V_p grad phi_i (MLS-MPM: the stress as
        # -dt D^-1 sigma_p V_p (x_i - x_p) phi_i, in the affine matrix)
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        node_values = ti.Matrix.zero(float, 3, self.support)
        if not inside:
            self.failures.fail(ErrorCode.OFF_GRID, p)
        else:
            mp = particles.m[p]
            fp = self.loads.force(particles, values, p)
            stress_volume = particles.sigma[p] * particles.vol[p]
            affine = ti.Matrix.zero(float, self.dim, self.dim)
            if ti.static(self.f.mls_mpm):
                affine = mp * particles.C[p] - values.dt_D_inv() * stress_volume
            # the affine momentum A (x_i - x_p) with x_i - x_p = h o - d (o: the node's
            # offset in the stencil) is h A o - A d: one vector per particle, then adds
            d = self.stencil.from_first_node(xi, base)
            if ti.static(not self.f.mls_mpm and self.support > 2):
                affine = mp * particles.C[p]  # APIC: the stress enters through grad phi
            mom = mp * particles.v[p] + values.dt() * fp - affine @ d
            h_affine = values.h() * affine
            for r in range(self.stencil.rows):
                for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                    node = self.stencil.node(base, offset)
                    if ti.static(self.f.mls_mpm):
                        self.scatter.add("node_mass", copy, node, mp * phi)
                        self.scatter.add("node_momentum", copy, node,
                                         phi * (mom + self.stencil.times_offset(h_affine, r, a)))
                    else:
                        # m_p C_p (x_i - x_p) phi_i; the linear basis keeps B_p in C and
                        # applies D_p^-1 at the new position: B_p D_p^-1 (x_i - x_p) phi_i =
                        # B_p grad phi_i (Jiang et al. 2015), bounded where a particle barely
                        # touches a node
                        momentum = ti.Vector.zero(float, self.dim)
                        if ti.static(self.support > 2):
                            momentum = phi * (mom + self.stencil.times_offset(h_affine, r, a))
                        else:
                            momentum = (phi * (mp * particles.v[p] + values.dt() * fp)
                                        + mp * (particles.C[p] @ grad))
                        self.scatter.add("node_mass", copy, node, mp * phi)
                        self.scatter.add("node_momentum", copy, node,
                                         momentum - values.dt() * (stress_volume @ grad))
                        if ti.static(self.extended):
                            self.p2g_node(values, copy, node, phi, momentum, fp)
        return base, inside, node_values

    @ti.func
    def p2g_node(self, values: ti.template(), copy, node, phi, momentum, fp):
        """A variant's own P2G at a stencil node (``extended``): ``momentum`` is APIC's
        phi_i (m_p v_p + m_p C_p (x_i - x_p) + dt f_p), ``fp`` the particle's external force
        (nothing here)."""
        pass

    @ti.func
    def velocity_node(self, grid: ti.template(), values: ti.template(), I):
        # v_i = P_i / m_i, wall conditions applied; in the same pass the private copies
        # are summed in and m_i, P_i cleared for the next P2G (a node no particle reached
        # has m = P = 0 and is left alone: G2P weighs it by 0)
        if self.scatter.reached(I):
            m = self.scatter.merged("node_mass", I)
            P = self.scatter.merged("node_momentum", I)
            v = ti.Vector.zero(float, self.dim)
            if m > values.mass_tol() and not self.boundary.is_fixed(I):
                v = P / m
                if ti.static(self.f.walled):
                    v = self.boundary.apply_walls(I, v)
            if ti.static(self.f.has_prescribed):
                if self.boundary.is_fixed(I):
                    v = self.boundary.prescribed_velocity(I, True)
            grid.node_new_velocity[I] = v
            if ti.static(self.extended):
                self.after_velocity(grid, values, I, m)
            if ti.static(self.f.strain_remap):
                grid.node_mass[I] = m  # P cleared for the remap
                grid.node_momentum[I] = ti.Vector.zero(float, self.dim)
            elif ti.static(not self.f.private_scatter):
                grid.node_mass[I] = 0.0
                grid.node_momentum[I] = ti.Vector.zero(float, self.dim)

    @ti.func
    def after_velocity(self, grid: ti.template(), values: ti.template(), I, m):
        """A variant's own grid update at node I (``extended``) after v_i, with the node's
        mass m (the private copies summed); before m_i and P_i are cleared (nothing
        here)."""
        pass

    @ti.func
    def remap_particle(self, particles: ti.template(), grid: ti.template(),
                       values: ti.template(), p, copy):
        # the strain remap: v_p = sum_i phi_i v_i, C_p = B_p (as update_particle), then
        # P'_i = sum m_p phi_i v_p
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        node_values = ti.Matrix.zero(float, 3, self.support)
        if inside:
            vp, B, _ = self.affine_gather(grid, values, base, w, dw, xi, False)
            particles.C[p] = B  # the linear basis keeps B_p (see p2g_particle)
            particles.v[p] = vp
            for r in range(self.stencil.rows):
                for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                    node_values = self.scatter.deposit("node_momentum", copy, self.stencil.node(base, offset),
                                                       offset, particles.m[p] * phi * vp,
                                                       node_values)
        return base, inside, node_values

    @ti.func
    def remap_node(self, grid: ti.template(), values: ti.template(), I):
        self.nodes.solve_node(grid.node_momentum, True, I)  # P'_i into v'_i in place

    @ti.func
    def affine_gather(self, grid: ti.template(), values: ti.template(), base, w, dw, xi,
                      gradient: ti.template()):
        """G2P of the grid velocity: v_p = sum_i phi_i v_i, B_p = sum_i phi_i v_i (x_i -
        x_p)^T and, with ``gradient``, grad du = sum_i v_i dt grad phi_i^T."""
        vp = ti.Vector.zero(float, self.dim)
        grad_du = ti.Matrix.zero(float, self.dim, self.dim)
        B = ti.Matrix.zero(float, self.dim, self.dim)  # sum_i phi_i v_i o_i^T
        for r in range(self.stencil.rows):
            for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                vi = grid.node_new_velocity[self.stencil.node(base, offset)]
                vp += phi * vi
                if ti.static(gradient):
                    grad_du += (vi * values.dt()).outer_product(grad)
                B += self.stencil.outer_offset(phi * vi, r, a)
        # sum_i phi_i v_i (x_i - x_p)^T = h sum_i phi_i v_i o_i^T - v_p d^T
        d = self.stencil.from_first_node(xi, base)
        return vp, values.h() * B - vp.outer_product(d), grad_du

    @ti.func
    def affine_of(self, values: ti.template(), B, base, w, xi):
        """C_p = B_p D_p^-1 from B_p = sum_i phi_i v_i (x_i - x_p)^T: D^-1 the constant of
        MLS-MPM, else D_p = sum_i phi_i (x_i - x_p)(x_i - x_p)^T, diagonal for tensor
        products of a basis reproducing linear fields (the linear basis keeps B_p, see
        p2g_particle)."""
        C = B
        if ti.static(self.f.mls_mpm):
            C = B * values.D_inv()
        elif ti.static(self.support > 2):
            for k in ti.static(range(self.dim)):
                dk = 0.0
                for a in ti.static(range(self.support)):
                    r = (base[k] + a - self.stencil.node_offset - xi[k]) * values.h()
                    dk += w[a, k] * r * r
                for j in ti.static(range(self.dim)):
                    C[j, k] /= dk
        return C

    @ti.func
    def gather(self, particles: ti.template(), grid: ti.template(), values: ti.template(), p,
               base, w, dw, xi):
        """v_p and grad du: from the remapped P'_i (the strain remap: v_p and C_p came with
        it), else v_p = sum_i phi_i v_i, C_p = B_p D_p^-1 stored and grad du from the grid
        (MLS-MPM: C_p dt)."""
        vp = ti.Vector.zero(float, self.dim)
        grad_du = ti.Matrix.zero(float, self.dim, self.dim)
        if ti.static(self.f.strain_remap):
            vp = particles.v[p]
            for r in range(self.stencil.rows):
                for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                    grad_du += (grid.node_velocity[self.stencil.node(base, offset)]
                                * values.dt()).outer_product(grad)
        else:
            B = ti.Matrix.zero(float, self.dim, self.dim)
            vp, B, grad_du = self.affine_gather(grid, values, base, w, dw, xi,
                                                not self.f.mls_mpm)
            particles.v[p] = vp
            particles.C[p] = self.affine_of(values, B, base, w, xi)
            if ti.static(self.f.mls_mpm):
                grad_du = particles.C[p] * values.dt()
        return vp, grad_du

    @ti.func
    def update_particle(self, particles: ti.template(), grid: ti.template(),
                        values: ti.template(), p):
        # G2P: v_p, C_p and grad du from the grid, then the particle's state from them
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        if inside and not self.failures.halted(p):
            vp, grad_du = self.gather(particles, grid, values, p, base, w, dw, xi)
            du = vp * values.dt()
            self.g2p.update(particles, values, p, vp, du, grad_du)
