"""Particle values computed in Python and uploaded into a program's state: the body
force of each step and the initial deformation of an initial displacement field.

One kernel launch each, compiled on its first call only (scenes without a body force or
an initial displacement never compile them); neither is part of the step's phases.
"""
import taichi as ti

from ..schemes.rk4 import STAGE_TIMES

__all__ = ["Uploads"]


class Uploads:
    """``set_body_force(values)`` and ``prestrain(grads)``, kernels over the particle
    fields: the feature set, the particles, the laws, the shared G2P (the jacobian), the
    add of the mode and the run-time values."""

    def __init__(self, features, particles, laws, g2p, accumulate, values):
        self.f, self.dim = features, features.dim
        self.particles, self.laws, self.g2p = particles, laws, g2p
        self.accumulate, self.values = accumulate, values
        self.set_body_force = self._body_force_kernel() if features.body_force else None
        self.prestrain = self._prestrain_kernel()

    def _body_force_kernel(self):
        particles = self.particles
        if self.f.rk4:
            @ti.kernel
            def set_body_force(values: ti.types.ndarray(dtype=ti.f64, ndim=3)):
                # b_p at the step's stage times (rk4.STAGE_TIMES), evaluated in Python
                for p in range(self.values.n_particles()):
                    for j, k in ti.static(ti.ndrange(len(STAGE_TIMES), self.dim)):
                        particles.b_stages[p][j, k] = values[p, j, k]
        else:
            @ti.kernel
            def set_body_force(values: ti.types.ndarray(dtype=ti.f64, ndim=2)):
                # b_p = b(X_p, t) of this step, evaluated in Python (one call, all particles)
                for p in range(self.values.n_particles()):
                    for k in ti.static(range(self.dim)):
                        particles.b[p][k] = values[p, k]
        return set_body_force

    def _prestrain_kernel(self):
        @ti.kernel
        def prestrain(grads: ti.types.ndarray(dtype=ti.f64, ndim=3)):
            for p in range(self.values.n_particles()):
                grad_u0 = ti.Matrix.zero(float, self.dim, self.dim)
                for i, k in ti.static(ti.ndrange(self.dim, self.dim)):
                    grad_u0[i, k] = grads[p, i, k]
                self._initial_deformation(p, grad_u0)
        return prestrain

    @ti.func
    def _initial_deformation(self, p, grad_u0):
        # initial displacement: F0 = I + grad u0 as one material update from the undeformed
        # state, V = det(F0) V0 (the materials read the new volume), sigma = law(F0)
        vol_old = self.particles.vol[p]
        vol_new = vol_old
        if ti.static(self.f.update_volume):
            vol_new = vol_old * self.g2p.jacobian(grad_u0)
            self.particles.vol[p] = vol_new
        sig_old = self.particles.sigma[p]
        sig_new = self.laws.update(p, grad_u0, sig_old)
        self.particles.sigma[p] = sig_new
        if ti.static(self.g2p.path_work):
            deps = 0.5 * (grad_u0 + grad_u0.transpose())
            self.accumulate(self.particles.work[p],
                            0.5 * ((sig_old * vol_old + sig_new * vol_new) * deps).sum())
