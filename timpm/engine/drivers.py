"""The drivers of a step: the fused serial loop and the team of threads.

Mixed into :class:`~timpm.engine.program.Program`.  Every driver runs the same step, the
phases of the scheme (:mod:`timpm.schemes`), or an integrator's (rk4, midpoint):

- *parallel*: one launch per step, every loop of the step parallel over the CPU threads;
- *serial* (fused): many steps in one launch, one task on one thread (``advance_steps``);
- *team*: many steps in one parallel task, each thread of Taichi's static split a fixed
  block of particles (its own grid copy) and of nodes, spin barriers between the phases
  (``_team_steps``).

A failure (a particle off the grid, a NaN, an inverted volume, a singular mass matrix,
a team that does not meet) records its code, step and particle or node
(:class:`~timpm.engine.failures.Failures`); the run stops after that step and Python
raises the error.  Each phase runs through
:class:`~timpm.schemes.phases.PhaseRunner`.
"""
import taichi as ti

from ..platform.errors import TEAM_SPIN_LIMIT, ErrorCode

__all__ = ["Drivers", "c_order_index"]


class Drivers:
    """The fused serial steps and the team (see the module)."""

    @ti.func
    def advance_steps(self, n_steps, every):
        """Up to n_steps steps, recording every ``every``-th; stops before the step after
        a failure.  Returns the steps done (the body of ``_advance`` and of a Batch)."""
        done = 0
        for _ in range(n_steps):
            if self.err_count[None] != 0:  # no step after a failed one
                break
            self._one_step()
            done += 1
            if ti.static(self.recording):
                if self.step_count[None] % every == 0:
                    self.record_step()
        return done

    @ti.func
    def _one_step(self):
        if ti.static(self.rk4):
            # four grid solves of the Runge-Kutta stages (rk4.py)
            self.rk4_step(self.particles, self.grid, self.rk4_stages, self.values)
        elif ti.static(self.midpoint):
            # the energy-conserving midpoint iteration (midpoint.py)
            if ti.static(self.affine):
                self.affine_midpoint_step(self.particles, self.grid, self.midpoint_iterate,
                                          self.values)
            else:
                self.midpoint_step(self.particles, self.grid, self.midpoint_iterate,
                                   self.values)
        else:
            for phase in ti.static(self.phases):  # the scheme's step (schemes/)
                self.run_phase(phase)
        self.count_step()

    @ti.func
    def _team_steps(self, n_steps):
        self.team_arrived[None] = 0
        self.team_abort[None] = 0
        B = self.values.scatter_block()
        for q in range(self.n_copies * B):
            if q % B == 0:  # thread q // B of Taichi's static split runs its whole block
                self._team_member(q // B, n_steps)

    @ti.func
    def _team_member(self, c, n_steps):
        """Thread c of the team: n_steps steps of the scheme's phases on its particles [c B,
        (c + 1) B) (scattered into its grid copy) and its share of the nodes, a barrier
        between two phases.  After the first barrier every thread reads the same errors
        (the next is written after the next barrier); after the others, a team that did
        not meet."""
        n_nodes = self.values.node_count()
        nodes_per_thread = self.values.nodes_per_thread()
        B = self.values.scatter_block()
        first, end = c * B, ti.min((c + 1) * B, self.values.n_particles())
        lo, hi = c * nodes_per_thread, ti.min((c + 1) * nodes_per_thread, n_nodes)
        start = self.step_count[None]  # thread 0 changes it only after the last barrier
        arrivals = 0
        for s in range(n_steps):
            self.rank_step[c] = start + s
            going = True
            for k in ti.static(range(len(self.phases))):
                ti.static_assert(self.phases[k].kind != "whole", "a team runs no whole phase")
                if ti.static(k > 0):
                    if going:
                        arrivals += self.n_copies
                        self._team_barrier(c, arrivals)
                        if ti.static(k == 1):
                            going = (ti.atomic_add(self.err_count[None], 0) == 0
                                     and ti.atomic_add(self.team_abort[None], 0) == 0)
                        else:
                            going = ti.atomic_add(self.team_abort[None], 0) == 0
                if going:
                    if ti.static(self.phases[k].kind == "scatter"):  # into the thread's copy
                        for p in range(first, end):
                            self.scatter_particle(self.phases[k], p, c)
                    elif ti.static(self.phases[k].kind == "particles"):
                        for p in range(first, end):
                            self.phases[k].particle(self, self.particles, self.grid,
                                                    self.values, p)
                    else:  # on its nodes, the copies of the scatter before summed in
                        for f in range(lo, hi):
                            I = self.node_of(f)
                            for name in ti.static(self.merged_before[k]):
                                ti.static(getattr(self, name))[I] = self.merged(name, I)
                            self.phases[k].node(self, self.grid, self.values, I)
            if not going:
                break
            if c == 0:
                self.step_count[None] = start + s + 1
                self.time[None] = (start + s + 1) * self.values.dt()

    @ti.func
    def _team_barrier(self, c, target):
        """Arrive, then spin until ``target`` arrivals (every thread of the team is here);
        after TEAM_SPIN_LIMIT spins (a thread that never came) fail with error 6."""
        ti.atomic_add(self.team_arrived[None], 1)
        spins = 0
        while ti.atomic_add(self.team_arrived[None], 0) < target:
            spins += 1
            if spins % 1024 == 0:
                if ti.atomic_add(self.team_abort[None], 0) != 0:
                    break
                if spins > TEAM_SPIN_LIMIT:
                    ti.atomic_add(self.team_abort[None], 1)
                    self.fail(ErrorCode.TEAM_BARRIER, c * self.values.scatter_block())
                    break

    @ti.func
    def node_of(self, f):
        """Grid index of the node at flat index f (the order of ti.ndrange)."""
        return c_order_index(f, self.values.nodes(), self.dim)


@ti.func
def c_order_index(f, sizes, dim: ti.template()):
    """The index of flat entry f (C order) of an array of ``sizes`` along its ``dim`` axes
    (run-time sizes, or constants: the divisions then by constants)."""
    I = ti.Vector.zero(ti.i32, dim)
    rest = f
    for k in ti.static(range(dim - 1, -1, -1)):
        I[k] = rest % sizes[k]
        rest = rest // sizes[k]
    return I
