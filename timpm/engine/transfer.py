"""What every transfer scheme shares: the particle's external force, the G2P update of its
state (displacement, strain, stress from its material, volume, the checks) from the
velocity and gradient that the scheme gathers, and the grid rates of the Runge-Kutta and
midpoint integrators.

Mixed into :class:`~timpm.engine.program.Program`; the schemes themselves, one file each,
are in :mod:`timpm.schemes`.
"""
import taichi as ti

from ..platform.errors import ErrorCode

__all__ = ["Transfer"]


class Transfer:
    """See the module."""

    @ti.func
    def material_update(self, p, grad_du, sig_old):
        """New Cauchy stress from the particle's material (one compiled unit per material)."""
        sig_new = sig_old
        if ti.static(not self.multi_material):
            sig_new = self.material_units[0].update(self.material_state, p, grad_du, sig_old)
        else:
            for k in ti.static(range(len(self.material_units))):
                if self.mat[p] == k:
                    sig_new = self.material_units[k].update(self.material_state, p, grad_du,
                                                            sig_old)
        return sig_new

    @ti.func
    def jacobian(self, grad_du):
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
        ok = ratio >= self.values.volume_min()
        if ti.static(not unit.free_expansion):
            ok = ok and ratio <= self.values.volume_max()
        return ok

    @ti.func
    def external_force(self, particles: ti.template(), values: ti.template(), p):
        """The particle's external force: m_p (g + b_p) + its tractions at the step's time."""
        mp = particles.m[p]
        fp = ti.Vector.zero(float, self.dim)
        for k in ti.static(range(self.dim)):
            if ti.static(self.f.gravity[k]):
                fp[k] += mp * values.gravity()[k]
        if ti.static(self.has_traction):
            if p == values.traction_particle():
                fp[0] += values.traction_amplitude() * self.traction_fn.at(
                    self.time[None], values.traction_param())
        if ti.static(self.body_force):
            fp += mp * particles.b[p]
        if ti.static(self.surface_force):
            fp += particles.f_ext[p] * self.surface_fn.at(self.time[None], values.surface_param())
        return fp

    @ti.func
    def g2p_update_particle(self, particles: ti.template(), grid: ti.template(),
                            values: ti.template(), p):
        base, w, dw, xi, inside = self.stencil(particles.x[p])
        if inside and not self.halted(p):
            # the scheme's G2P of the grid velocity: v_p and grad du = sum_i v_i dt grad phi_i^T
            vp, grad_du = self.scheme.gather(self, particles, grid, values, p, base, w, dw, xi)
            du = vp * values.dt()
            deps = 0.5 * (grad_du + grad_du.transpose())
            vol_old = particles.vol[p]
            sig_old = particles.sigma[p]
            jac = 1.0
            vol_new = vol_old
            if ti.static(self.update_volume):
                jac = self.jacobian(grad_du)
                vol_new = vol_old * jac
                particles.vol[p] = vol_new  # the materials read the new volume
            sig_new = self.material_update(p, grad_du, sig_old)
            particles.sigma[p] = sig_new
            if ti.static(self.path_work):
                # strain energy: trapezoidal path integral of sigma : d_eps V
                self.accumulate(particles.work[p],
                               0.5 * ((sig_old * vol_old + sig_new * vol_new) * deps).sum())
            if ti.static(self.record_energies):
                if ti.static(self.has_traction):
                    if p == values.traction_particle():
                        self.add_external_work(values.traction_amplitude()
                                               * self.traction_fn.at(self.time[None],
                                                                     values.traction_param())
                                               * du[0])
                if ti.static(self.body_force):
                    self.add_external_work(particles.m[p] * particles.b[p].dot(du))
                if ti.static(self.surface_force):
                    f_t = self.surface_fn.at(self.time[None], values.surface_param())
                    self.add_external_work(f_t * particles.f_ext[p].dot(du))
            if ti.static(self.has_u):
                self.accumulate(particles.u[p], du)
            x_new = particles.x[p] + du
            particles.x[p] = x_new
            self.check_particle(p, x_new, vp, sig_new, vol_new, jac)

    @ti.func
    def check_particle(self, p, x_new, vp, sig_new, vol_new, jac):
        # checks on the new state, from registers (a NaN in the MUSL particle velocity
        # reaches vp through the grid); the first failure of the run is the one reported
        xn = ti.Vector.zero(float, self.dim)
        code = 0
        for k in ti.static(range(self.dim)):
            xn[k] = (x_new[k] - self.values.origin()[k]) * self.values.inv_h()
            if not (xn[k] >= 0.0 and xn[k] <= self.values.elements()[k]):
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
            self.fail(code, p)
        if ti.static(self.track_crossings):
            e = self.element_of(xn)
            if (e != self.elem[p]).any():
                self.accumulate(self.crossings[None], 1)
                self.elem[p] = e

    @ti.func
    def add_external_work(self, work):
        """The run's record of the external forces' work += work (energies recorded)."""
        self.accumulate(self.ext_work[None], work)

    @ti.func
    def grid_rates(self):
        # P2G of the particles' state (a Runge-Kutta stage, a midpoint iterate): m_i, P_i =
        # sum m_p phi_i v_p, F_i = sum phi_i m_p (g + b_p) - sigma_p V_p grad phi_i (at the
        # Gauss points with the MLS projection); then a_i = M^-1 F_i and v_i = M^-1 P_i,
        # zero at Dirichlet and empty nodes.  Roller and sticky walls are linear
        # constraints, the same on both (the consistent mass's solve takes them as such;
        # MUSL's acceleration_node is no fit: it clears P_i at walls)
        self.scheme.clear(self, self.particles, self.grid, self.values)
        self.run_phase(self.scheme.p2g)
        if ti.static(self.mls or self.consistent):
            self.scheme.after_p2g(self, self.particles, self.grid, self.values)
        self.solve_mass(self.node_force, True)  # F_i into a_i in place
        self.solve_mass(self.node_momentum, True)  # P_i into v_i in place

    @ti.func
    def particle_rates(self, grid: ti.template(), base, w, dw):
        """G2P of the rates that grid_rates left on the grid (a Runge-Kutta stage, a
        midpoint iterate): sum_i phi_i v_i, sum_i phi_i a_i and grad v = sum_i v_i grad
        phi_i^T at a particle."""
        v = ti.Vector.zero(float, self.dim)
        acc = ti.Vector.zero(float, self.dim)
        grad_v = ti.Matrix.zero(float, self.dim, self.dim)
        for r in range(self.stencil_rows):
            row = self.stencil_row(w, dw, r)
            for a in ti.static(range(self.basis.support)):
                offset, phi, grad = self.row_node(w, dw, r, row, a)
                vi = grid.node_velocity[base + offset]
                v += phi * vi
                acc += phi * grid.node_acceleration[base + offset]
                grad_v += vi.outer_product(grad)
        return v, acc, grad_v

    @ti.func
    def stress_of_F(self, p, F):
        """sigma(F) of the particle's law."""
        sig = ti.Matrix.zero(float, self.dim, self.dim)
        if ti.static(not self.multi_material):
            sig = self.material_units[0].stress(self.material_state, p, F)
        else:
            for k in ti.static(range(len(self.material_units))):
                if self.mat[p] == k:
                    sig = self.material_units[k].stress(self.material_state, p, F)
        return sig

    @ti.func
    def set_state_of_F(self, p, F):
        """sigma_p = sigma(F) and V_p = det F V0_p stored; returns (sigma, V, det F) for the
        particle's checks."""
        jac = F.determinant()
        sig = self.stress_of_F(p, F)
        vol = jac * self._reference_volume_of(p)
        self.sigma[p] = sig
        self.vol[p] = vol
        return sig, vol, jac

    @ti.func
    def _reference_volume_of(self, p):
        """V0_p = m_p / density of the particle's law."""
        vol0 = 0.0
        if ti.static(not self.multi_material):
            vol0 = self.material_units[0].reference_volume(self.material_state, p)
        else:
            for k in ti.static(range(len(self.material_units))):
                if self.mat[p] == k:
                    vol0 = self.material_units[k].reference_volume(self.material_state, p)
        return vol0

    @ti.func
    def count_step(self):
        # the step is done: n += 1, t = n dt (not after a failed step)
        if not self.halted(0):
            self.accumulate(self.step_count[None], 1)
            self.time[None] = self.step_count[None] * self.values.dt()
