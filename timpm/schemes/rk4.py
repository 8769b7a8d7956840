"""The classical Runge-Kutta method (RK4) on the particles' semi-discrete equations.

For ``Model(integrator="rk4")``: an integrator, the step of the transfer scheme it wraps
(MUSL) replaced by the stages below, as a list of phases every driver runs.  A step
integrates the particle state y = (x_p, v_p, F_p) by

    dx_p/dt = sum_i phi_i(x_p) v_i,   dv_p/dt = sum_i phi_i(x_p) a_i,
    dF_p/dt = (sum_i v_i grad phi_i(x_p)^T) F_p,

where v_i = M^-1 P_i and a_i = M^-1 F_i come from one P2G of the state y (mass, momentum
P_i = sum m_p phi_i v_p, and the forces: sigma(F_p) on V_p = det F_p V0_p, gravity and the
body force at the stage's time), the Dirichlet nodes held at rest.  Four such grid solves
a step: stage s evaluates the rates k_s at y_n + A_s dt k_(s-1), t_n + A_s dt with
A = (0, 1/2, 1/2, 1), and y_(n+1) = y_n + dt sum_s B_s k_s with B = (1/6, 1/3, 1/3, 1/6).
Fourth order in time, so that with dt ~ h the spatial error sets the rate (Euler-Cromer's
O(dt^2) caps it at 2; docs/results.md, manufactured solutions).  The law's stress must be
a function of F (``Material.stress_from_F``); the Model refuses what would make the
right-hand side depend on anything else (slip walls, damping, tractions:
``Model._check_integrator``); roller and sticky walls, linear constraints, hold v_i and
a_i alike.  The critical step is sqrt(2) times Euler-Cromer's
(``timpm.model.CRITICAL_STEP_FACTOR``).
"""
import taichi as ti

from ..platform.declare import Field
from .base import Scheme
from .phases import Particles, Repeat, Whole

__all__ = ["RungeKutta", "STAGE_TIMES"]

#: the times, in steps from t_n, at which Python gives the body force for a step: stage
#: s = 0..3 runs at t_n + A_s dt, A = (0, 1/2, 1/2, 1), and reads slot (s + 1) // 2
STAGE_TIMES = (0.0, 0.5, 1.0)


class RungeKutta(Scheme):
    """See the module: the step of ``transfer`` (whose P2G and grid solve give the rates,
    ``grid_rates``) integrated by the classical Runge-Kutta method.  Its phases receive
    the particle fields, the grid fields and the run-time values; the stages' scratch
    (the state at the step's start, the weighted rates, the body force at the stage times)
    travels with the particle fields."""

    @classmethod
    def applies(cls, features):
        return features.rk4

    @staticmethod
    def particle_fields(features):
        # F for every law; per-step scratch: the state at the step's start, the B-weighted
        # sums of the stage rates, the body force at the STAGE_TIMES
        d = features.dim
        vector, matrix = Field("vector", scratch=True), Field("matrix", scratch=True)
        fields = {"F": Field("matrix", initial="identity", doc="the deformation gradient"),
                  "x_start": vector, "v_start": vector, "F_start": matrix,
                  "x_rate": vector, "v_rate": vector, "F_rate": matrix}
        if features.body_force:
            fields["b_stages"] = Field((len(STAGE_TIMES), d), scratch=True)
        return fields

    def __init__(self, features, ops, transfer):
        super().__init__(features, ops)
        self.transfer, self.dim = transfer, features.dim

    def phases(self):
        # the stages a run-time loop (the fused serial mode: the stage compiled once), or a
        # launch each (the parallel mode: its passes top-level loops; four unrolled stages
        # compiled for 20 s)
        stage = ((Particles("b_p at the stage's time", self.stage_body_force, staged=True),)
                 if self.f.body_force else ())
        stage += (Whole("P2G and grid solve: a_i = M^-1 F_i, v_i = M^-1 P_i",
                        self.stage_rates, staged=True),
                  Particles("G2P of the rates x', v', F'; the next stage's state",
                            self.stage_particle, staged=True))
        return (Particles("y_n = (x_p, v_p, F_p) kept", self.begin),
                Repeat("the four stages of the step", 4, stage))

    @ti.func
    def begin(self, particles: ti.template(), grid: ti.template(), values: ti.template(), p):
        # y_n kept for the stages
        particles.x_start[p] = particles.x[p]
        particles.v_start[p] = particles.v[p]
        particles.F_start[p] = particles.F[p]

    @ti.func
    def stage_body_force(self, particles: ti.template(), grid: ti.template(),
                         values: ti.template(), p, s):
        slot = (s + 1) // 2  # b_p at t_n, t_n + dt/2, t_n + dt/2, t_n + dt
        for k in ti.static(range(self.dim)):
            particles.b[p][k] = particles.b_stages[p][slot, k]

    @ti.func
    def stage_rates(self, particles: ti.template(), grid: ti.template(), values: ti.template(),
                    s):
        self.transfer.grid_rates(particles, grid, values)  # the stage's a_i and v_i

    @ti.func
    def stage_particle(self, particles: ti.template(), grid: ti.template(),
                       values: ti.template(), p, s):
        # G2P of the stage's rates: x' = sum phi_i v_i, v' = sum phi_i a_i, F' = (sum v_i
        # grad phi_i^T) F; their sums weighted by B; the next stage's state (the step's end
        # after the fourth) with sigma(F) and V = det F V0
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        if inside and not self.failures.halted(p):
            x_rate, v_rate, grad_v = self.g2p.rates(grid, base, w, dw)
            F_rate = grad_v @ particles.F[p]
            weight = 1.0 / 6.0 if s == 0 or s == 3 else 1.0 / 3.0  # B_s
            if s == 0:
                particles.x_rate[p] = weight * x_rate
                particles.v_rate[p] = weight * v_rate
                particles.F_rate[p] = weight * F_rate
            else:
                particles.x_rate[p] += weight * x_rate
                particles.v_rate[p] += weight * v_rate
                particles.F_rate[p] += weight * F_rate
            if ti.static(self.f.energies and self.f.body_force):
                # the body force's work: its power m_p b_p . x' by the same quadrature
                self.loads.add_work(values.dt() * weight * particles.m[p]
                                    * particles.b[p].dot(x_rate))
            x_new = particles.x_start[p]
            v_new = particles.v_start[p]
            F_new = particles.F_start[p]
            if s < 3:  # the next stage's state, at A_(s+1) dt
                c = (0.5 if s < 2 else 1.0) * values.dt()
                x_new += c * x_rate
                v_new += c * v_rate
                F_new += c * F_rate
            else:  # the step's end
                x_new += values.dt() * particles.x_rate[p]
                v_new += values.dt() * particles.v_rate[p]
                F_new += values.dt() * particles.F_rate[p]
            particles.x[p] = x_new
            particles.v[p] = v_new
            particles.F[p] = F_new
            sig, vol, jac = self.g2p.set_state_of_F(particles, p, F_new)
            if s == 3:
                if ti.static(self.f.has_u):
                    self.g2p.accumulate(particles.u[p], x_new - particles.x_start[p])
                self.g2p.check(particles, values, p, x_new, v_new, sig, vol, jac)
