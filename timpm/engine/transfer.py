"""The transfers between particles and grid, and the step as a list of phases.

Mixed into :class:`~timpm.engine.program.Program`.  One step (``_one_step``) is either

- the study's Modified Lagrangian (MUSL) step with Euler-Cromer time stepping (2.2.4,
  Figure 2.7): P2G of mass and forces, a = M^-1 F, G2P of the velocity, P2G of the new
  momentum, v = M^-1 P, G2P of displacement, strain, stress, volume; or
- an affine transfer (APIC, MLS-MPM): P2G of mass and momentum with the affine part and
  dt times the force, v = P / m with the wall conditions, G2P of v_p, C_p and the
  velocity gradient.
"""
import taichi as ti

from ..errors import ErrorCode

__all__ = ["Transfer"]


class Transfer:
    """See the module."""

    @ti.func
    def _material_update(self, p, grad_du, sig_old):
        """New Cauchy stress from the particle's material (one compiled unit per material)."""
        sig_new = sig_old
        if ti.static(not self.multi_material):
            sig_new = self.material_units[0].update(self, p, grad_du, sig_old)
        else:
            for k in ti.static(range(len(self.material_units))):
                if self.mat[p] == k:
                    sig_new = self.material_units[k].update(self, p, grad_du, sig_old)
        return sig_new

    @ti.func
    def _jacobian(self, grad_du):
        """det(I + grad du): the step's volume ratio."""
        jac = 1.0 + grad_du[0, 0]
        if ti.static(self.dim > 1):
            jac = (ti.Matrix.identity(float, self.dim) + grad_du).determinant()
        return jac

    @ti.func
    def _volume_in_range(self, p, vol):
        """volume_min <= V_p / V0 <= volume_max, V0 = m_p / density of the particle's
        material; a material that expands freely (no tension) has no upper bound."""
        ok = True
        if ti.static(not self.multi_material):
            ok = self._ratio_in_range(self.material_units[0], p, vol)
        else:
            for k in ti.static(range(len(self.material_units))):
                if self.mat[p] == k:
                    ok = self._ratio_in_range(self.material_units[k], p, vol)
        return ok

    @ti.func
    def _ratio_in_range(self, unit: ti.template(), p, vol):
        ratio = vol * unit.c.density() / self.m[p]
        ok = ratio >= self.p.volume_min()
        if ti.static(not unit.free_expansion):
            ok = ok and ratio <= self.p.volume_max()
        return ok

    @ti.func
    def _p2g(self):
        # P2G (2.2.4): M_ij = sum m_p phi_i phi_j (A.1) or M_ii = sum m_p phi_i (A.2);
        # F_i = sum phi_i (m_p (g + b_p(t)) + f_trac(t)) - sigma_p V_p dphi_i; with the
        # affine transfer (APIC) P_i = sum m_p phi_i (v_p + C_p (x_i - x_p)) + dt F_i in
        # the same pass
        self._scatter_particles("p2g")
        if ti.static(self.private_scatter and not self.apic):
            self._merge_copies(ti.static(tuple(self.copies)))  # the affine grid pass sums them

    @ti.func
    def _external_force(self, p):
        """The particle's external force: m_p (g + b_p) + its tractions at the step's time."""
        mp = self.m[p]
        fp = ti.Vector.zero(float, self.dim)
        for k in ti.static(range(self.dim)):
            if ti.static(self.f.gravity[k]):
                fp[k] += mp * self.p.gravity()[k]
        if ti.static(self.has_traction):
            if p == self.p.traction_particle():
                fp[0] += self.p.traction_amplitude() * self.traction_fn.at(self.time[None], self.p.traction_param())
        if ti.static(self.body_force):
            fp += mp * self.b[p]
        if ti.static(self.surface_force):
            fp += self.f_ext[p] * self.surface_fn.at(self.time[None], self.p.surface_param())
        return fp

    @ti.func
    def _p2g_particle(self, p, copy):
        base, w, dw, xi, inside = self._stencil(p)
        node_values = ti.Matrix.zero(float, 3, self.basis.support)
        if not inside:
            self._fail(ErrorCode.OFF_GRID, p)
        else:
            mp = self.m[p]
            fp = self._external_force(p)
            stress_volume = self.sigma[p] * self.vol[p]
            affine = ti.Matrix.zero(float, self.dim, self.dim)
            if ti.static(self.mls_mpm):
                affine = mp * self.C[p] - self.p.dt_D_inv() * stress_volume
            if ti.static(self.mls):
                if ti.static(self.mls_study):
                    fp[0] -= mp * self.p.gravity()[0]  # gravity and mass: from the Gauss points
                if ti.static(self.dim == 1):
                    self._scatter_gauss_moments(p)
                else:
                    self._scatter_gauss_moments_nd(p)
            # the affine momentum A (x_i - x_p) with x_i - x_p = h o - d (o: the node's
            # offset in the stencil) is h A o - A d: one vector per particle, then adds
            d = self._from_first_node(xi, base)
            if ti.static(self.apic and not self.mls_mpm and self.basis.support > 2):
                affine = mp * self.C[p]  # APIC: the stress enters through grad phi
            mom = mp * self.v[p] + self.p.dt() * fp - affine @ d
            h_affine = self.p.h() * affine
            for r in range(self.stencil_rows):
                for a in ti.static(range(self.basis.support)):
                    offset, phi, grad = self._stencil_node(w, dw, r, a)
                    node = base + offset
                    if ti.static(self.mls_mpm):
                        self._add("gm", copy, node, mp * phi)
                        self._add("gp", copy, node,
                                  phi * (mom + self._times_offset(h_affine, r, a)))
                    elif ti.static(self.apic):
                        # m_p C_p (x_i - x_p) phi_i; the linear basis keeps B_p in C and
                        # applies D_p^-1 at the new position: B_p D_p^-1 (x_i - x_p) phi_i =
                        # B_p grad phi_i (Jiang et al. 2015), bounded where a particle barely
                        # touches a node
                        momentum = ti.Vector.zero(float, self.dim)
                        if ti.static(self.basis.support > 2):
                            momentum = phi * (mom + self._times_offset(h_affine, r, a))
                        else:
                            momentum = (phi * (mp * self.v[p] + self.p.dt() * fp)
                                        + mp * (self.C[p] @ grad))
                        self._add("gm", copy, node, mp * phi)
                        self._add("gp", copy, node, momentum - self.p.dt() * (stress_volume @ grad))
                    elif ti.static(not self.mls):
                        node_values = self._deposit("gm", copy, node, offset, mp * phi, node_values)
                        node_values = self._deposit("gf", copy, node, offset,
                                                    phi * fp - stress_volume @ grad, node_values)
                    else:  # MLS: the stress enters at the Gauss points (_integrate_gauss)
                        if ti.static(not self.mls_study):
                            self.accumulate(self.gm[node], mp * phi)
                        self.accumulate(self.gf[node], phi * fp)
                    if ti.static(not self.apic and (self.damping or self.has_walls or self.pic
                                                    or self.rk4 or self.midpoint)):
                        node_values = self._deposit("gp", copy, node, offset, mp * phi * self.v[p],
                                                    node_values)
            if ti.static(self.consistent and self.dim == 1):
                for a, c in ti.static(ti.ndrange(self.basis.support, self.basis.support)):
                    self.accumulate(self.band[base[0] + a, c - a + self.bandwidth],
                                   mp * w[a, 0] * w[c, 0])
        return base, inside, node_values

    @ti.func
    def _g2p_velocity(self):
        # G2P: v_p += dt sum_i phi_i(x_p) a_i (APIC: v_p = sum_i phi_i v_i, C_p; with a
        # PIC fraction b: v_p = (1 - b)(v_p + dt sum phi_i a_i) + b sum phi_i v_i^L);
        # P2G: P_i = sum m_p phi_i(x_p) v_p (2.2.4)
        self._scatter_particles("g2p-velocity")
        if ti.static(self.private_scatter):
            self._merge_copies(("gp",))

    @ti.func
    def _g2p_velocity_particle(self, p, copy):
        base, w, dw, xi, inside = self._stencil(p)
        node_values = ti.Matrix.zero(float, 3, self.basis.support)
        if inside:
            vp = ti.Vector.zero(float, self.dim)
            if ti.static(self.apic):
                # APIC (the strain remap): v_p = sum_i phi_i v_i, C_p = B_p as in _g2p_update
                B = ti.Matrix.zero(float, self.dim, self.dim)
                vp, B, _ = self._affine_gather(base, w, dw, xi, False)
                self.C[p] = B  # the linear basis keeps B_p (see _p2g)
            else:
                acc = ti.Vector.zero(float, self.dim)
                pic = ti.Vector.zero(float, self.dim)
                for r in range(self.stencil_rows):
                    for a in ti.static(range(self.basis.support)):
                        offset, phi, grad = self._stencil_node(w, dw, r, a)
                        acc += phi * self.gf[base + offset]
                        if ti.static(self.pic):
                            pic += phi * self.gv[base + offset]
                vp = self.v[p] + self.p.dt() * acc
                if ti.static(self.pic):
                    b = self.p.pic_fraction()
                    vp = (1.0 - b) * vp + b * pic
            self.v[p] = vp
            if ti.static(self.mls_study):
                self._scatter_node_moments(p, vp[0])
            else:
                for r in range(self.stencil_rows):
                    for a in ti.static(range(self.basis.support)):
                        offset, phi, grad = self._stencil_node(w, dw, r, a)
                        node_values = self._deposit("gp", copy, base + offset, offset,
                                                    self.m[p] * phi * vp, node_values)
        return base, inside, node_values

    @ti.func
    def _affine_gather(self, base, w, dw, xi, gradient: ti.template()):
        """G2P of the grid velocity (affine transfers): v_p = sum_i phi_i v_i, B_p = sum_i
        phi_i v_i (x_i - x_p)^T and, with ``gradient``, grad du = sum_i v_i dt grad phi_i^T."""
        vp = ti.Vector.zero(float, self.dim)
        grad_du = ti.Matrix.zero(float, self.dim, self.dim)
        B = ti.Matrix.zero(float, self.dim, self.dim)  # sum_i phi_i v_i o_i^T
        for r in range(self.stencil_rows):
            for a in ti.static(range(self.basis.support)):
                offset, phi, grad = self._stencil_node(w, dw, r, a)
                vi = self.gv[base + offset]
                vp += phi * vi
                if ti.static(gradient):
                    grad_du += (vi * self.p.dt()).outer_product(grad)
                B += self._outer_offset(phi * vi, r, a)
        # sum_i phi_i v_i (x_i - x_p)^T = h sum_i phi_i v_i o_i^T - v_p d^T
        d = self._from_first_node(xi, base)
        return vp, self.p.h() * B - vp.outer_product(d), grad_du

    @ti.func
    def _affine_of(self, B, base, w, xi):
        """C_p = B_p D_p^-1 from B_p = sum_i phi_i v_i (x_i - x_p)^T: D^-1 the constant of
        MLS-MPM, else D_p = sum_i phi_i (x_i - x_p)(x_i - x_p)^T, diagonal for tensor
        products of a basis reproducing linear fields (the linear basis keeps B_p, see
        _p2g)."""
        C = B
        if ti.static(self.mls_mpm):
            C = B * self.p.D_inv()
        elif ti.static(self.basis.support > 2):
            for k in ti.static(range(self.dim)):
                dk = 0.0
                for a in ti.static(range(self.basis.support)):
                    r = (base[k] + a - self.node_offset - xi[k]) * self.p.h()
                    dk += w[a, k] * r * r
                for j in ti.static(range(self.dim)):
                    C[j, k] /= dk
        return C

    @ti.func
    def _g2p_update(self):
        # G2P: du_p = sum_i phi_i v_i dt (u_p, x_p); grad du = sum_i v_i dt dphi_i^T;
        # stress from the material (2.2.4 in 1D); V *= det(I + grad du); with the affine
        # transfer v_p = sum_i phi_i v_i and C_p = sum_i phi_i v_i (x_i - x_p)^T D_p^-1
        for p in range(self.p.n_particles()):
            self._g2p_update_particle(p)

    @ti.func
    def _g2p_update_particle(self, p):
        base, w, dw, xi, inside = self._stencil(p)
        if inside and not self._halted(p):
            vp = ti.Vector.zero(float, self.dim)
            grad_du = ti.Matrix.zero(float, self.dim, self.dim)
            if ti.static(self.strain_remap):
                vp = self.v[p]  # v_p and C_p came with the remap (_g2p_velocity)
                for r in range(self.stencil_rows):
                    for a in ti.static(range(self.basis.support)):
                        offset, phi, grad = self._stencil_node(w, dw, r, a)
                        grad_du += (self.gp[base + offset] * self.p.dt()).outer_product(grad)
            elif ti.static(self.apic):
                B = ti.Matrix.zero(float, self.dim, self.dim)
                vp, B, grad_du = self._affine_gather(base, w, dw, xi, not self.mls_mpm)
                self.v[p] = vp
                self.C[p] = self._affine_of(B, base, w, xi)
                if ti.static(self.mls_mpm):
                    grad_du = self.C[p] * self.p.dt()
            else:
                for r in range(self.stencil_rows):
                    for a in ti.static(range(self.basis.support)):
                        offset, phi, grad = self._stencil_node(w, dw, r, a)
                        vi = self.gp[base + offset]
                        vp += phi * vi
                        grad_du += (vi * self.p.dt()).outer_product(grad)
            du = vp * self.p.dt()
            deps = 0.5 * (grad_du + grad_du.transpose())
            vol_old = self.vol[p]
            sig_old = self.sigma[p]
            jac = 1.0
            vol_new = vol_old
            if ti.static(self.update_volume):
                jac = self._jacobian(grad_du)
                vol_new = vol_old * jac
                self.vol[p] = vol_new  # the materials read the new volume
            sig_new = self._material_update(p, grad_du, sig_old)
            self.sigma[p] = sig_new
            if ti.static(self.path_work):
                # strain energy: trapezoidal path integral of sigma : d_eps V
                self.accumulate(self.work[p],
                               0.5 * ((sig_old * vol_old + sig_new * vol_new) * deps).sum())
            if ti.static(self.record_energies):
                if ti.static(self.has_traction):
                    if p == self.p.traction_particle():
                        self.accumulate(self.ext_work[None], self.p.traction_amplitude() *
                                       self.traction_fn.at(self.time[None], self.p.traction_param()) * du[0])
                if ti.static(self.body_force):
                    self.accumulate(self.ext_work[None], self.m[p] * self.b[p].dot(du))
                if ti.static(self.surface_force):
                    f_t = self.surface_fn.at(self.time[None], self.p.surface_param())
                    self.accumulate(self.ext_work[None], f_t * self.f_ext[p].dot(du))
            if ti.static(self.has_u):
                self.accumulate(self.u[p], du)
            x_new = self.x[p] + du
            self.x[p] = x_new
            self._check_particle(p, x_new, vp, sig_new, vol_new, jac)

    @ti.func
    def _check_particle(self, p, x_new, vp, sig_new, vol_new, jac):
        # checks on the new state, from registers (a NaN in the MUSL particle velocity
        # reaches vp through the grid); the first failure of the run is the one reported
        xn = ti.Vector.zero(float, self.dim)
        code = 0
        for k in ti.static(range(self.dim)):
            xn[k] = (x_new[k] - self.p.origin()[k]) * self.p.inv_h()
            if not (xn[k] >= 0.0 and xn[k] <= self.p.elements()[k]):
                code = ErrorCode.OFF_GRID
        if ti.static(self.update_volume):
            if not (jac > 0.0):
                code = ErrorCode.INVERTED
            elif ti.static(self.f.volume_guard):
                if not self._volume_in_range(p, vol_new):
                    code = ErrorCode.VOLUME_RANGE
        state = x_new.sum() + vp.sum() + sig_new.sum() + vol_new
        if not (ti.abs(state) < 1e300):  # NaN fails this comparison
            code = ErrorCode.NOT_FINITE
        if code != 0:
            self._fail(code, p)
        if ti.static(self.track_crossings):
            e = self._element(xn)
            if (e != self.elem[p]).any():
                self.accumulate(self.crossings[None], 1)
                self.elem[p] = e

    @ti.func
    def _p2g_assembled(self):
        # the grid cleared, P2G of mass, forces (and momentum where a phase needs it); with
        # the MLS projection the body's extent before and the Gauss-point forces after; the
        # consistent mass factorised
        self._clear_grid()
        if ti.static(self.mls and self.dim == 1):
            self._body_extent()
        self._p2g()
        if ti.static(self.mls and self.dim == 1):
            self._integrate_gauss()
        elif ti.static(self.mls):
            self._integrate_gauss_nd()
        if ti.static(self.consistent and self.dim == 1):
            self._banded_factorise()
        elif ti.static(self.consistent):
            self._cg_keep_weights()

    @ti.func
    def _grid_rates(self):
        # P2G of the particles' state (a Runge-Kutta stage, a midpoint iterate): m_i, P_i =
        # sum m_p phi_i v_p, F_i = sum phi_i m_p (g + b_p) - sigma_p V_p grad phi_i (at the
        # Gauss points with the MLS projection); then a_i = M^-1 F_i and v_i = M^-1 P_i,
        # zero at Dirichlet and empty nodes.  Roller and sticky walls are linear
        # constraints, the same on both (the consistent mass's solve takes them as such;
        # Euler-Cromer's _grid_acceleration is no fit: it clears P_i at walls)
        self._p2g_assembled()
        self._solve_mass(self.gf, True)
        self._solve_mass(self.gp, True)

    @ti.func
    def _stress_of_F(self, p, F):
        """sigma(F) of the particle's law."""
        sig = ti.Matrix.zero(float, self.dim, self.dim)
        if ti.static(not self.multi_material):
            sig = self.material_units[0].stress(self, p, F)
        else:
            for k in ti.static(range(len(self.material_units))):
                if self.mat[p] == k:
                    sig = self.material_units[k].stress(self, p, F)
        return sig

    @ti.func
    def _set_state_of_F(self, p, F):
        """sigma_p = sigma(F) and V_p = det F V0_p stored; returns (sigma, V, det F) for the
        particle's checks."""
        jac = F.determinant()
        sig = self._stress_of_F(p, F)
        vol = jac * self._reference_volume_of(p)
        self.sigma[p] = sig
        self.vol[p] = vol
        return sig, vol, jac

    @ti.func
    def _reference_volume_of(self, p):
        """V0_p = m_p / density of the particle's law."""
        vol0 = 0.0
        if ti.static(not self.multi_material):
            vol0 = self.material_units[0].reference_volume(self, p)
        else:
            for k in ti.static(range(len(self.material_units))):
                if self.mat[p] == k:
                    vol0 = self.material_units[k].reference_volume(self, p)
        return vol0

    @ti.func
    def _one_step(self):
        if ti.static(self.rk4):
            self._rk4_step()  # four grid solves of the Runge-Kutta stages (rk4.py)
        elif ti.static(self.midpoint):
            if ti.static(self.apic):  # the energy-conserving midpoint iteration (midpoint.py)
                self._affine_midpoint_step()
            else:
                self._midpoint_step()
        elif ti.static(self.apic):
            # affine transfer: P2G of mass and momentum + dt force, v = P / m (the grid
            # pass leaves m and P cleared: no separate clearing pass), G2P
            if ti.static(self.strain_remap):
                self._clear_grid()  # m_i stays for the remap
            self._p2g()
            self._grid_velocity()
            if ti.static(self.strain_remap):
                # G2P of v_p and C_p, P'_i = sum m_p phi_i v_p, v'_i = P'_i / m_i
                self._g2p_velocity()
                self._solve_mass(self.gp, True)
            self._g2p_update()
        else:
            # the study's MUSL scheme with Euler-Cromer stepping (2.2.4, Figure 2.7)
            self._p2g_assembled()
            self._grid_acceleration()
            self._g2p_velocity()
            if ti.static(self.mls_study):
                self._mls_nodal_velocity()
            else:
                self._solve_mass(self.gp, True)
            if ti.static(self.grid_displacement):
                for I in ti.grouped(ti.ndrange(*[self.p.nodes()[k] for k in range(self.dim)])):
                    self.accumulate(self.gu[I], self.gp[I] * self.p.dt())  # u_i += v_i dt (5.2)
            self._g2p_update()
        self._count_step()

    @ti.func
    def _count_step(self):
        # the step is done: n += 1, t = n dt (not after a failed step)
        if not self._halted(0):
            self.accumulate(self.step_count[None], 1)
            self.time[None] = self.step_count[None] * self.p.dt()
