"""What every transfer scheme's G2P shares: the particle's new state from the velocity,
the displacement and the velocity gradient that the scheme gathers (volume, stress from its
law, strain energy, loads' work, position), the checks of that state, and the grid rates
that the Runge-Kutta and midpoint integrators gather.

A scheme calls :meth:`G2P.update` from its particle phase; the displacement it passes is
its own position update (``du = v_p dt`` for most; ASFLIP adds its share of the FLIP
velocity).
"""
import taichi as ti

from ..platform.errors import ErrorCode

__all__ = ["G2P"]


class G2P:
    """See the module: the feature set, the stencil, the laws, the loads, the failure
    record, the run fields (the grid crossings) and the add of the mode."""

    def __init__(self, features, stencil, laws, loads, failures, run, accumulate, pores):
        f = self.f = features
        self.dim = f.dim
        self.stencil, self.laws, self.loads, self.failures = stencil, laws, loads, failures
        self.pores = pores
        self.run, self.accumulate = run, accumulate
        # the strain energy: W(F) V0 of a hyperelastic law, else the work sigma : d_eps V
        # integrated along the path (a field only where some material needs it)
        self.path_work = f.path_work

    @ti.func
    def update(self, particles: ti.template(), values: ti.template(), p, vp, du, grad_du):
        """The particle's state from the gathered v_p, du and grad du (below); an excess pore
        pressure follows the skeleton's volumetric strain tr(grad du) (undrained)."""
        self.update_with_pores(particles, values, p, vp, du, grad_du, grad_du.trace())

    @ti.func
    def update_with_pores(self, particles: ti.template(), values: ti.template(), p, vp, du,
                          grad_du, d_eps_pores):
        # the state from the gathered v_p, du and grad du = sum_i v_i dt grad phi_i^T:
        # V_p *= det(I + grad du), sigma_p from the law on the effective stress sigma' =
        # sigma + p_e I, then p_e -= (K_w / n) d_eps_pores, sigma = sigma' - p_e I; x_p += du
        deps = 0.5 * (grad_du + grad_du.transpose())
        vol_old = particles.vol[p]
        sig_old = particles.sigma[p]
        jac = 1.0
        vol_new = vol_old
        if ti.static(self.f.update_volume):
            jac = self.jacobian(grad_du)
            vol_new = vol_old * jac
            particles.vol[p] = vol_new  # the materials read the new volume
        sig_new = self.laws.update(p, grad_du, self.pores.effective(particles, p, sig_old))
        if ti.static(self.f.pore_pressure):
            sig_new = self.pores.seen(particles, p, sig_new, d_eps_pores)
        particles.sigma[p] = sig_new
        if ti.static(self.path_work):
            # strain energy: trapezoidal path integral of sigma : d_eps V
            self.accumulate(particles.work[p],
                            0.5 * ((sig_old * vol_old + sig_new * vol_new) * deps).sum())
        if ti.static(self.f.energies):
            self.loads.record_work(particles, values, p, du)
        if ti.static(self.f.has_u):
            self.accumulate(particles.u[p], du)
        x_new = particles.x[p] + du
        if ti.static(self.f.periodic):  # x periodic: back into [x_0, x_0 + n_x h)
            period = values.elements()[0] * values.h()
            if x_new[0] >= values.origin()[0] + period:
                x_new[0] -= period
                particles.laps[p] += 1.0
            elif x_new[0] < values.origin()[0]:
                x_new[0] += period
                particles.laps[p] -= 1.0
        particles.x[p] = x_new
        if ti.static(self.f.pore_smoothing):  # p_e from the cell's mean (engine/water.py)
            self.pores.deposit(particles, p, x_new, vol_new, d_eps_pores, deps.trace())
        self.check(particles, values, p, x_new, vp, sig_new, vol_new, jac)

    @ti.func
    def jacobian(self, grad_du):
        """det(I + grad du): the step's volume ratio."""
        jac = 1.0 + grad_du[0, 0]
        if ti.static(self.dim > 1):
            jac = (ti.Matrix.identity(float, self.dim) + grad_du).determinant()
        return jac

    @ti.func
    def check(self, particles: ti.template(), values: ti.template(), p, x_new, vp, sig_new,
              vol_new, jac):
        # checks on the new state, from registers (a NaN in the MUSL particle velocity
        # reaches vp through the grid); the first failure of the run is the one reported
        xn = ti.Vector.zero(float, self.dim)
        code = 0
        for k in ti.static(range(self.dim)):
            xn[k] = (x_new[k] - values.origin()[k]) * values.inv_h()
            if not (xn[k] >= 0.0 and xn[k] <= values.elements()[k]):
                code = ErrorCode.OFF_GRID
        if ti.static(self.f.update_volume):
            if not (jac > 0.0):
                code = ErrorCode.INVERTED
            elif ti.static(self.f.volume_guard):
                if not self.laws.volume_in_range(p, vol_new):
                    code = ErrorCode.VOLUME_RANGE
        state = x_new.sum() + vp.sum() + sig_new.sum() + vol_new
        if not (ti.abs(state) < 1e300):  # NaN fails this comparison
            code = ErrorCode.NOT_FINITE
        if code != 0:
            self.failures.fail(code, p)
        if ti.static(self.f.track_crossings):
            e = self.stencil.element_of(xn)
            if (e != particles.elem[p]).any():
                self.accumulate(self.run.crossings[None], 1)
                particles.elem[p] = e

    @ti.func
    def rates(self, grid: ti.template(), base, w, dw):
        """G2P of the rates on the grid (a Runge-Kutta stage, a midpoint iterate): sum_i
        phi_i v_i, sum_i phi_i a_i and grad v = sum_i v_i grad phi_i^T at a particle."""
        v = ti.Vector.zero(float, self.dim)
        acc = ti.Vector.zero(float, self.dim)
        grad_v = ti.Matrix.zero(float, self.dim, self.dim)
        for r in range(self.stencil.rows):
            for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                vi = grid.node_velocity[self.stencil.node(base, offset)]
                v += phi * vi
                acc += phi * grid.node_acceleration[self.stencil.node(base, offset)]
                grad_v += vi.outer_product(grad)
        return v, acc, grad_v

    @ti.func
    def set_state_of_F(self, particles: ti.template(), p, F):
        """sigma_p = sigma(F) and V_p = det F V0_p stored; returns (sigma, V, det F) for the
        particle's checks."""
        jac = F.determinant()
        sig = self.laws.stress(p, F)
        vol = jac * self.laws.reference_volume(p)
        particles.sigma[p] = sig
        particles.vol[p] = vol
        return sig, vol, jac
