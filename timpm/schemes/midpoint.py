"""The energy-conserving midpoint integrator: the MUSL step at the mid-step velocity with
the averaged (discrete-gradient) stress, iterated to convergence within each step.

For ``Model(integrator="midpoint")``: an integrator, the step of the transfer scheme it
wraps (MUSL, APIC, MLS-MPM) replaced by one phase that iterates on one thread.  With the
particles' weights at the step's start, phi_i = phi_i(x_p^n), a step solves

    vbar_p = (v_p^n + v_p^(n+1)) / 2,      vbar_i = M^-1 sum_p m_p phi_i vbar_p,
    F_p^(n+1) = (I + dt sum_i vbar_i grad phi_i^T) F_p^n,
    sbar_p = [int_0^1 P(F_p^n + s (F_p^(n+1) - F_p^n)) ds] F_p^nT / J_p^n,
    a_i = M^-1 (sum_p m_p phi_i g - sbar_p V_p^n grad phi_i),
    v_p^(n+1) = v_p^n + dt sum_i phi_i a_i,   x_p^(n+1) = x_p^n + dt sum_i phi_i vbar_i,

P(F) = J sigma(F) F^-T the first Piola-Kirchhoff stress, the integral by three-point
Gauss-Legendre quadrature (its error O(|dF|^6)).  Then the kinetic energy changes by
dt a . M vbar = dt f . vbar and the stored energy sum V0_p W(F_p) by sum V0_p Pbar : dF_p =
-dt f_int . vbar: kinetic + stored + gravity's potential energy is conserved to the
iteration's tolerance whatever the particles' motion through the grid (lumped or
consistent mass; roller and sticky walls, linear constraints, hold vbar_i and a_i alike).
Euler-Cromer conserves it only on a fixed mapping (docs/results.md, stability audit).

The iteration starts from the state at t_n (vbar = v_n, sbar = sigma_n).  A pass takes
vbar from sbar and sbar from vbar, so on a mode of frequency w, mu = |w dt| / 2 (0.9 at
0.9x of Euler-Cromer's critical step 2 / w_max), its eigenvalues are +-i mu.  vbar is
relaxed, vbar <- (1 - r) vbar + r new, sbar taken whole: the eigenvalues solve
l^2 - (1 - r) l + r mu^2 = 0, of modulus at most max(1 - r, sqrt(r) mu_max), balanced by
sqrt(r) = (sqrt(mu_max^2 + 4) - mu_max) / 2 with mu_max = dt / dt_crit from the scene's
critical step (1 without one): 0.58 at 0.9x, 0.39 at 0.5x.  The passes of a step start
plain (r = 1: where only slow modes move, as in smooth motion, they converge in a few)
and turn relaxed once the residual falls by less than half in a pass.  It stops when the
residual new - vbar is within ``MIDPOINT_TOLERANCE`` of the largest vbar and F_end moved
by less than that of the largest F increment; after ``MIDPOINT_MAX_ITERATIONS`` passes
the run stops with ``ErrorCode.MIDPOINT``.  The whole step runs on one thread (the fused
serial mode).  A body force enters as b(X_p, t_n + dt / 2), its work m_p b_p . dx_p.

The affine transfers (APIC, MLS-MPM) rebuild the grid velocity from v_p and C_p each
step, so their iteration runs on the grid (``affine_midpoint_step``): v_i^n from P2G
once, vbar_i = v_i^n + dt / 2 a_i(sbar(vbar)) iterated as above, then v_p and C_p from
v_i^n + dt a_i and x_p += dt sum phi_i vbar_i.  The grid step conserves the energy; P2G and
G2P can only lose it (docs/method.md).
"""
import math

import taichi as ti

from ..platform.declare import Field
from ..platform.errors import ErrorCode
from .base import Scheme
from .phases import Whole

__all__ = ["Midpoint", "MIDPOINT_MAX_ITERATIONS", "MIDPOINT_TOLERANCE"]

#: iterations after which a step that has not converged stops the run
MIDPOINT_MAX_ITERATIONS = 400
#: the largest residual of the iterate vbar_p relative to the largest vbar_p, and the
#: largest change of F_end relative to the largest F increment, that end a step's
#: iteration (per precision)
MIDPOINT_TOLERANCE = {"f64": 1e-12, "f32": 1e-5}
#: an absolute floor under the tolerance on F, a few rounding errors of F ~ 1 (an F
#: increment near round-off would otherwise never settle)
F_FLOOR = {"f64": 1e-15, "f32": 1e-6}
#: three-point Gauss-Legendre rule on [0, 1]: (abscissa, weight)
_GAUSS_3 = ((0.5 - math.sqrt(15.0) / 10.0, 5.0 / 18.0), (0.5, 8.0 / 18.0),
            (0.5 + math.sqrt(15.0) / 10.0, 5.0 / 18.0))


class Midpoint(Scheme):
    """See the module: the step of ``transfer`` (MUSL's P2G and grid solve, ``grid_rates``;
    the affine transfers' gathers) replaced by the midpoint iteration.  Its functions
    receive the particle fields (with the iteration's scratch: F at the step's start, and
    for MUSL v_start, v_end and x_end), the grid fields and the run-time values."""

    @classmethod
    def applies(cls, features):
        return features.midpoint

    @staticmethod
    def particle_fields(features):
        # F for every law; per-step scratch: F at the step's start, and for MUSL the velocity
        # at its start, the iterate of the velocity at its end and the position it reaches
        # (an affine transfer iterates on the grid)
        fields = {"F": Field("matrix", initial="identity", doc="the deformation gradient"),
                  "F_start": Field("matrix", scratch=True)}
        if not features.affine:
            fields.update(v_start=Field("vector", scratch=True),
                          v_end=Field("vector", scratch=True), x_end=Field("vector", scratch=True))
        return fields

    @staticmethod
    def grid_fields(features):
        # the affine iteration's forces, then its v_i^(n+1) (MUSL has them)
        return {"gf": Field("vector", doc="F_i, a_i, v_i^(n+1)")} if features.affine else {}

    def __init__(self, features, ops, transfer):
        super().__init__(features, ops)
        self.transfer, self.dim, self.support = transfer, features.dim, features.basis.support

    def phases(self):
        if self.f.affine:
            return (Whole("the midpoint iteration on the grid (APIC, MLS-MPM)",
                          self.affine_iteration),)
        return (Whole("the midpoint iteration: vbar, sbar to convergence, then the step's end",
                      self.iteration),)

    @ti.func
    def iteration(self, particles: ti.template(), grid: ti.template(), values: ti.template()):
        # the state at t_n: v_n and F_n kept; V_p stays V_p^n through the iteration
        for p in range(values.n_particles()):
            particles.v_start[p] = particles.v[p]
            particles.F_start[p] = particles.F[p]
        converged = False
        relax = 1.0  # plain passes while the residual falls fast, then relaxed
        previous = 0.0
        for it in range(MIDPOINT_MAX_ITERATIONS):
            # grid: P2G of m_i, P_i = sum m_p phi_i vbar_p and the forces from sbar_p V_p^n;
            # a_i = M^-1 F_i, vbar_i = M^-1 P_i
            self.transfer.grid_rates(particles, grid, values)
            # converged: the residual new - iterate of vbar within tol of the largest vbar,
            # and F_end (sbar's argument) moved by less than tol of the largest increment
            change = ti.Vector.zero(float, 2)
            largest = ti.Vector.zero(float, 2)
            for p in range(values.n_particles()):
                c, s = self._midpoint_particle(particles, grid, values, p, relax)
                change = ti.max(change, c)
                largest = ti.max(largest, s)
            if self.failures.failed():  # an iterate inverted or left the finite numbers
                break
            if it > 0 and self._midpoint_converged(change, largest, 0.0):
                converged = True
                break
            relax = self._midpoint_relaxation(values, it, change[0], previous, relax)
            previous = change[0]
        if not converged and not self.failures.failed():
            self.failures.fail(ErrorCode.MIDPOINT, -1)  # -1: no particle to name
        if not self.failures.failed():
            for p in range(values.n_particles()):
                self._midpoint_finish(particles, values, p)

    @ti.func
    def _midpoint_converged(self, change, largest, v_floor):
        """The residual of vbar (change[0]) within tolerance of the largest vbar, and F_end's
        change (change[1]) within it of the largest F increment, each above its floor."""
        tol = ti.static(MIDPOINT_TOLERANCE[self.f.precision])
        floor = ti.static(F_FLOOR[self.f.precision])
        return (change <= tol * largest + ti.Vector([v_floor, floor])).all()

    @ti.func
    def _midpoint_relaxation(self, values: ti.template(), it, change, previous, relax):
        """The relaxation of the next pass: r once the residual falls by less than half in
        a pass (a fast mode near +-i mu), else as it was."""
        out = relax
        if it > 1 and change > 0.5 * previous:
            out = values.midpoint_relaxation()
        return out

    @ti.func
    def _midpoint_particle(self, particles: ti.template(), grid: ti.template(),
                           values: ti.template(), p, relax):
        # G2P of the iterate: v_end = v_n + dt sum phi_i a_i, F_end = (I + dt grad vbar) F_n,
        # x_end = x_n + dt sum phi_i vbar_i; the next iterate's vbar_p (relaxed) and sbar_p.
        # Returns the residual of vbar_p, the change of F_end and their scales (max norms)
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        change = ti.Vector.zero(float, 2)
        size = ti.Vector.zero(float, 2)
        if inside:
            v_mid, accel, grad_v = self.g2p.rates(grid, base, w, dw)
            v_end = particles.v_start[p] + values.dt() * accel
            F0 = particles.F_start[p]
            F1 = (ti.Matrix.identity(float, self.dim) + values.dt() * grad_v) @ F0
            v_bar = 0.5 * (particles.v_start[p] + v_end)
            self._check_iterate(p, F1, v_bar)
            change = ti.Vector([ti.abs(v_bar - particles.v[p]).max(),
                                ti.abs(F1 - particles.F[p]).max()])
            size = ti.Vector([ti.abs(v_bar).max(), ti.abs(F1 - F0).max()])
            particles.v_end[p] = v_end
            particles.x_end[p] = particles.x[p] + values.dt() * v_mid
            particles.F[p] = F1
            # the next iterate: vbar relaxed, (1 - r) old + r new; sbar that of F1
            particles.v[p] += relax * (v_bar - particles.v[p])
            particles.sigma[p] = self._averaged_stress(p, F0, F1)
        return change, size

    @ti.func
    def _check_iterate(self, p, F1, v_bar):
        # an iterate with det F <= 0 or a non-finite value ends the iteration, naming p (a
        # step too large for the motion, or passes that diverge): sigma(F) has no value
        state = F1.sum() + v_bar.sum()
        if not (F1.determinant() > 0.0 and ti.abs(state) < 1e300):  # NaN fails both
            self.failures.fail(ErrorCode.MIDPOINT, p)

    @ti.func
    def _averaged_stress(self, p, F0, F1):
        """sbar = [int_0^1 P(F0 + s (F1 - F0)) ds] F0^T / det F0, so that sbar V^n : dt
        grad vbar = V0 (W(F1) - W(F0)) to the quadrature's O(|F1 - F0|^6)."""
        P_mean = ti.Matrix.zero(float, self.dim, self.dim)
        for q in ti.static(range(3)):
            F = F0 + ti.static(_GAUSS_3[q][0]) * (F1 - F0)
            P_mean += ti.static(_GAUSS_3[q][1]) * (
                F.determinant() * self.laws.stress(p, F) @ F.inverse().transpose())
        return P_mean @ F0.transpose() / F0.determinant()

    @ti.func
    def _midpoint_finish(self, particles: ti.template(), values: ti.template(), p):
        # the step's end: x, v, F of the converged iterate, sigma(F) and V = det F V0
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        if inside:
            self._midpoint_end_state(particles, values, p, particles.x_end[p],
                                     particles.v_end[p])

    @ti.func
    def _midpoint_end_state(self, particles: ti.template(), values: ti.template(), p, x_new,
                            v_new):
        # x, v and F of the converged iterate (F in place), sigma(F) and V = det F V0; the
        # body force's work m_p b_p . (x_new - x_n)
        if ti.static(self.f.body_force and self.f.energies):
            self.loads.add_work(particles.m[p] * particles.b[p].dot(x_new - particles.x[p]))
        if ti.static(self.f.has_u):
            self.g2p.accumulate(particles.u[p], x_new - particles.x[p])
        particles.x[p] = x_new
        particles.v[p] = v_new
        sig, vol, jac = self.g2p.set_state_of_F(particles, p, particles.F[p])
        self.g2p.check(particles, values, p, x_new, v_new, sig, vol, jac)

    # ---- the affine transfers (APIC, MLS-MPM): the iteration on the grid ------------------
    @ti.func
    def affine_iteration(self, particles: ti.template(), grid: ti.template(),
                         values: ti.template()):
        # P2G at t_n: m_i and P_i = sum m_p phi_i (v_p + C_p (x_i - x_p)) (the linear basis:
        # m_p (phi_i v_p + B_p grad phi_i)); v_i^n = P_i / m_i with the wall conditions
        # (node_velocity), the iterate vbar_i (node_new_velocity, which the scheme's G2P
        # reads) starts there
        self.nodes.clear()
        for p in range(values.n_particles()):
            particles.F_start[p] = particles.F[p]
            self._affine_momentum(particles, grid, values, p)
        self.nodes.solve(grid.node_momentum, True)  # P_i into v_i^n in place
        for I in ti.grouped(ti.ndrange(*[values.nodes()[k] for k in range(self.dim)])):
            grid.node_new_velocity[I] = grid.node_velocity[I]
        converged = False
        relax = 1.0
        previous = 0.0
        for it in range(MIDPOINT_MAX_ITERATIONS):
            # particles: F_end = (I + dt grad vbar) F_n, sbar; F_i = sum phi_i f_p - sbar_p
            # V_p^n grad phi_i (MLS-MPM: D^-1 (x_i - x_p) phi_i for grad phi_i)
            for I in ti.grouped(ti.ndrange(*[values.nodes()[k] for k in range(self.dim)])):
                grid.node_force[I] = ti.Vector.zero(float, self.dim)
            change = ti.Vector.zero(float, 2)
            largest = ti.Vector.zero(float, 2)
            for p in range(values.n_particles()):
                c, s = self._affine_midpoint_particle(particles, grid, values, p)
                change[1] = ti.max(change[1], c)
                largest[1] = ti.max(largest[1], s)
            if self.failures.failed():  # off the grid, or an iterate inverted
                break
            # grid: a_i = M^-1 F_i (walls), v_i^(n+1) = v_i^n + dt a_i kept in place of a_i
            # (node_end_velocity); the residual of vbar_i = (v_i^n + v_i^(n+1)) / 2
            self.nodes.solve(grid.node_force, True)  # F_i into a_i in place
            for I in ti.grouped(ti.ndrange(*[values.nodes()[k] for k in range(self.dim)])):
                v_end = grid.node_velocity[I] + values.dt() * grid.node_acceleration[I]
                grid.node_end_velocity[I] = v_end
                v_bar = 0.5 * (grid.node_velocity[I] + v_end)
                change[0] = ti.max(change[0], ti.abs(v_bar - grid.node_new_velocity[I]).max())
                largest[0] = ti.max(largest[0], ti.abs(v_bar).max())
            # (the floor of vbar_i: the velocity whose difference over a cell moves F by its
            # floor in a step; APIC's transfers dissipate, and a velocity fallen to the
            # rounding of the forces would otherwise never settle)
            v_floor = ti.static(F_FLOOR[self.f.precision]) * values.h() / values.dt()
            if it > 0 and self._midpoint_converged(change, largest, v_floor):
                converged = True  # F_end and x_end from this iterate, v from its forces
                break
            relax = self._midpoint_relaxation(values, it, change[0], previous, relax)
            previous = change[0]
            for I in ti.grouped(ti.ndrange(*[values.nodes()[k] for k in range(self.dim)])):
                grid.node_new_velocity[I] += relax * (
                    0.5 * (grid.node_velocity[I] + grid.node_end_velocity[I])
                    - grid.node_new_velocity[I])
        if not converged and not self.failures.failed():
            self.failures.fail(ErrorCode.MIDPOINT, -1)  # -1: no particle to name
        if not self.failures.failed():
            # G2P: v_p = sum phi_i v_i^(n+1), C_p from v_i^(n+1), x_p += dt sum phi_i vbar_i
            for I in ti.grouped(ti.ndrange(*[values.nodes()[k] for k in range(self.dim)])):
                grid.node_velocity[I] = grid.node_new_velocity[I]  # vbar_i
                grid.node_new_velocity[I] = grid.node_end_velocity[I]  # v_i^(n+1): G2P
            for p in range(values.n_particles()):
                self._affine_midpoint_finish(particles, grid, values, p)

    @ti.func
    def _affine_momentum(self, particles: ti.template(), grid: ti.template(),
                         values: ti.template(), p):
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        if not inside:
            self.failures.fail(ErrorCode.OFF_GRID, p)
        else:
            mp = particles.m[p]
            affine = mp * particles.C[p]
            mom = mp * particles.v[p] - affine @ self.stencil.from_first_node(xi, base)
            h_affine = values.h() * affine
            for r in range(self.stencil.rows):
                for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                    node = base + offset
                    grid.node_mass[node] += mp * phi
                    if ti.static(self.support > 2 or self.f.mls_mpm):
                        grid.node_momentum[node] += phi * (
                            mom + self.stencil.times_offset(h_affine, r, a))
                    else:
                        grid.node_momentum[node] += (phi * mp * particles.v[p]
                                                     + mp * (particles.C[p] @ grad))

    @ti.func
    def _affine_midpoint_particle(self, particles: ti.template(), grid: ti.template(),
                                  values: ti.template(), p):
        # returns the change of F_end and the largest F increment
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        change = 0.0
        size = 0.0
        if inside:
            _, B, grad_du = self.transfer.affine_gather(grid, values, base, w, dw, xi,
                                                        not self.f.mls_mpm)
            if ti.static(self.f.mls_mpm):
                grad_du = B * values.D_inv() * values.dt()
            F0 = particles.F_start[p]
            F1 = (ti.Matrix.identity(float, self.dim) + grad_du) @ F0
            self._check_iterate(p, F1, ti.Vector.zero(float, self.dim))
            change = ti.abs(F1 - particles.F[p]).max()
            size = ti.abs(F1 - F0).max()
            particles.F[p] = F1
            stress_volume = self._averaged_stress(p, F0, F1) * particles.vol[p]
            fp = self.loads.force(particles, values, p)
            A = stress_volume  # MLS-MPM: D^-1 sbar V
            if ti.static(self.f.mls_mpm):
                A = values.D_inv() * stress_volume
            d = self.stencil.from_first_node(xi, base)
            for r in range(self.stencil.rows):
                for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                    force = phi * fp
                    if ti.static(self.f.mls_mpm):
                        force -= phi * (values.h() * self.stencil.times_offset(A, r, a) - A @ d)
                    else:
                        force -= stress_volume @ grad
                    grid.node_force[base + offset] += force
        return change, size

    @ti.func
    def _affine_midpoint_finish(self, particles: ti.template(), grid: ti.template(),
                                values: ti.template(), p):
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        if inside:
            v_new, B, _ = self.transfer.affine_gather(grid, values, base, w, dw, xi, False)
            particles.C[p] = self.transfer.affine_of(values, B, base, w, xi)
            dx = ti.Vector.zero(float, self.dim)
            for r in range(self.stencil.rows):
                for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                    dx += phi * grid.node_velocity[base + offset]  # vbar_i
            self._midpoint_end_state(particles, values, p, particles.x[p] + values.dt() * dx,
                                     v_new)
