"""The classical Runge-Kutta method (RK4) on the particles' semi-discrete equations.

Mixed into :class:`~timpm.engine.program.Program` for ``Model(integrator="rk4")``.  A step
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

__all__ = ["RungeKutta", "rk4_fields", "STAGE_TIMES"]

#: the times, in steps from t_n, at which Python gives the body force for a step: stage
#: s = 0..3 runs at t_n + A_s dt, A = (0, 1/2, 1/2, 1), and reads slot (s + 1) // 2
STAGE_TIMES = (0.0, 0.5, 1.0)


def rk4_fields(d, real, body_force):
    """Per-particle scratch of a step: the state at its start, the B-weighted sums of the
    stage rates, and the body force at the ``STAGE_TIMES``."""
    fields = {"x_start": ti.Vector.field(d, real), "v_start": ti.Vector.field(d, real),
              "F_start": ti.Matrix.field(d, d, real), "x_rate": ti.Vector.field(d, real),
              "v_rate": ti.Vector.field(d, real), "F_rate": ti.Matrix.field(d, d, real)}
    if body_force:
        fields["b_stages"] = ti.Matrix.field(len(STAGE_TIMES), d, real)
    return fields


class RungeKutta:
    """See the module.  The step's functions receive the state they read: the particle
    fields (``particles``), the grid fields (``grid``), the stages' scratch (``stages``:
    the state at the step's start, the weighted rates, the body force at the stage
    times) and the run-time values (``values``); through ``self`` they reach the
    program's operations (the stencil, the grid solve, the law, the checks)."""

    @ti.func
    def rk4_step(self, particles: ti.template(), grid: ti.template(), stages: ti.template(),
                 values: ti.template()):
        # the fused serial step: y_n kept, then the four stages in a run-time loop (one
        # serial task: the stage compiled once).  The parallel mode launches the same
        # functions as kernels, a stage a launch (Program._bind_kernels): its passes must
        # be top-level loops, and four unrolled stages compiled for 20 s
        self.rk4_begin(particles, stages, values)
        for s in range(4):
            self.rk4_stage(particles, grid, stages, values, s)

    @ti.func
    def rk4_begin(self, particles: ti.template(), stages: ti.template(), values: ti.template()):
        # y_n kept for the stages
        for p in range(values.n_particles()):
            stages.x_start[p] = particles.x[p]
            stages.v_start[p] = particles.v[p]
            stages.F_start[p] = particles.F[p]

    @ti.func
    def rk4_stage(self, particles: ti.template(), grid: ti.template(), stages: ti.template(),
                  values: ti.template(), s):
        if ti.static(self.body_force):
            slot = (s + 1) // 2  # b_p at t_n, t_n + dt/2, t_n + dt/2, t_n + dt
            for p in range(values.n_particles()):
                for k in ti.static(range(self.dim)):
                    particles.b[p][k] = stages.b_stages[p][slot, k]
        self.grid_rates()  # the stage's a_i and v_i (transfer.py)
        for p in range(values.n_particles()):
            self._rk4_particle(particles, grid, stages, values, p, s)

    @ti.func
    def _rk4_particle(self, particles: ti.template(), grid: ti.template(),
                      stages: ti.template(), values: ti.template(), p, s):
        # G2P of the stage's rates: x' = sum phi_i v_i, v' = sum phi_i a_i, F' = (sum v_i
        # grad phi_i^T) F; their sums weighted by B; the next stage's state (the step's end
        # after the fourth) with sigma(F) and V = det F V0
        base, w, dw, xi, inside = self.stencil(particles.x[p])
        if inside and not self.halted(p):
            x_rate, v_rate, grad_v = self.particle_rates(grid, base, w, dw)
            F_rate = grad_v @ particles.F[p]
            weight = 1.0 / 6.0 if s == 0 or s == 3 else 1.0 / 3.0  # B_s
            if s == 0:
                stages.x_rate[p] = weight * x_rate
                stages.v_rate[p] = weight * v_rate
                stages.F_rate[p] = weight * F_rate
            else:
                stages.x_rate[p] += weight * x_rate
                stages.v_rate[p] += weight * v_rate
                stages.F_rate[p] += weight * F_rate
            if ti.static(self.record_energies and self.body_force):
                # the body force's work: its power m_p b_p . x' by the same quadrature
                self.add_external_work(values.dt() * weight * particles.m[p]
                                       * particles.b[p].dot(x_rate))
            x_new = stages.x_start[p]
            v_new = stages.v_start[p]
            F_new = stages.F_start[p]
            if s < 3:  # the next stage's state, at A_(s+1) dt
                c = (0.5 if s < 2 else 1.0) * values.dt()
                x_new += c * x_rate
                v_new += c * v_rate
                F_new += c * F_rate
            else:  # the step's end
                x_new += values.dt() * stages.x_rate[p]
                v_new += values.dt() * stages.v_rate[p]
                F_new += values.dt() * stages.F_rate[p]
            particles.x[p] = x_new
            particles.v[p] = v_new
            particles.F[p] = F_new
            sig, vol, jac = self.set_state_of_F(p, F_new)
            if s == 3:
                if ti.static(self.has_u):
                    self.accumulate(particles.u[p], x_new - stages.x_start[p])
                self.check_particle(p, x_new, v_new, sig, vol, jac)
