"""Recording in the kernels: time, energies and tracked particles into a history buffer.

Mixed into :class:`~timpm.engine.program.Program`; Python drains the buffer
(:class:`timpm.solver.Solver`).
"""
import taichi as ti

__all__ = ["Recorder"]


class Recorder:
    """See the module."""

    @ti.func
    def _record(self):
        slot = self.rec_count[None]
        self.h_t[slot] = self.time[None]
        self.h_step[slot] = self.step_count[None]
        if ti.static(self.tracking):
            for j in range(self.p.n_tracked()):
                p = self.track_ids[j]
                self.h_x[slot, j] = self.x[p]
                if ti.static(self.has_u):
                    self.h_u[slot, j] = self.u[p]
                self.h_v[slot, j] = self.v[p]
                self.h_s[slot, j] = self.sigma[p]
        if ti.static(self.record_energies):
            self.h_energy[slot] = ti.Vector.zero(float, 4)
            for p in range(self.p.n_particles()):
                # potential of gravity: -m g . u (1D), -m g . x (2D/3D, taken from its start in energies())
                pot = 0.0
                for k in ti.static(range(self.dim)):
                    if ti.static(self.f.gravity[k]):
                        if ti.static(self.has_u):
                            pot -= self.m[p] * self.p.gravity()[k] * self.u[p][k]
                        else:
                            pot -= self.m[p] * self.p.gravity()[k] * self.x[p][k]
                e = ti.Vector([0.5 * self.m[p] * self.v[p].norm_sqr(), self.work[p], pot, 0.0])
                self.accumulate(self.h_energy[slot], e)
            if ti.static(self.has_traction):
                self.h_energy[slot][3] = self.ext_work[None]
        self.rec_count[None] = slot + 1

    @ti.func
    def _clear_and_project(self):
        self._clear_grid()
        self._project()

    @ti.func
    def _project(self):
        # P2G of mass and momentum alone: m_i = sum m_p phi_i, P_i = sum m_p phi_i v_p
        for p in range(self.p.n_particles()):
            base, w, dw, xi, inside = self._stencil(p)
            if inside:
                for offset in ti.static(ti.grouped(ti.ndrange(*((self.basis.support,) * self.dim)))):
                    phi, grad = self._weight(w, dw, offset)
                    self.accumulate(self.gm[base + offset], self.m[p] * phi)
                    self.accumulate(self.gp[base + offset], self.m[p] * phi * self.v[p])
