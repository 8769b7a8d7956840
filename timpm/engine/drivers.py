"""The drivers of a step: every driver runs the same list of phases, the scheme's
(:mod:`timpm.schemes`; an integrator's, rk4 or midpoint, where it replaces the transfer's):

- *parallel*: one launch per step, every loop of the step parallel over the CPU threads (a
  ``Repeat`` of phases a launch per repetition: :meth:`Drivers.launch_groups`);
- *serial* (fused): many steps in one launch, one task on one thread (``advance_steps``);
- *team*: many steps in one parallel task, each thread of Taichi's static split a fixed
  block of particles (its own grid copy) and of nodes, spin barriers between the phases
  (``team_steps``).

A failure (a particle off the grid, a NaN, an inverted volume, a singular mass matrix,
a team that does not meet) records its code, step and particle or node
(:class:`~timpm.engine.failures.Failures`); the run stops after that step and Python
raises the error.
"""
import taichi as ti

from ..platform.errors import TEAM_SPIN_LIMIT, ErrorCode

__all__ = ["Drivers", "c_order_index"]


class Drivers:
    """See the module: the feature set, the scheme's ``phases``, the state they receive
    (``particles``, ``grid``, ``values``), the scatter (its strategy runs the scattering
    phases; its copies a team merges), the failure record, the run fields (the step count,
    the time), the recorder (the fused loop records) and a team's barrier fields
    (``team``: ``team_arrived``, ``team_abort``, ``rank_step``)."""

    def __init__(self, features, phases, particles, grid, values, scatter, failures, run,
                 recorder, team, capacity, window=None):
        f = self.f = features
        self.dim, self.phases = f.dim, phases
        self.particles, self.grid, self.values = particles, grid, values
        self.scatter, self.failures, self.run, self.recorder = scatter, failures, run, recorder
        self.team, self.capacity, self.window = team, capacity, window
        self.windowed = window is not None  # (engine/window.py)
        # a team's node phase sums the copies of the scatter before it
        self.merged_before = tuple(
            before.merge if k > 0 and before.kind == "scatter" else ()
            for k, before in enumerate((None,) + phases[:-1]))

    # ---- one phase --------------------------------------------------------------------------
    @ti.func
    def run_phase(self, phase: ti.template(), s):
        """One phase for every particle or node: its loop parallel over the CPU threads,
        or a part of the one serial task (``s``: the index of the Repeat it is in)."""
        if ti.static(phase.kind == "scatter"):
            self.scatter.run(phase, self.particles, self.grid, self.values)
        elif ti.static(phase.kind == "particles"):
            if ti.static(self.f.on_device):  # to the capacity: no serial task for the bound
                for p in range(self.capacity.particles):
                    if p < self.values.n_particles():
                        self._particle(phase, p, s)
            else:
                for p in range(self.values.n_particles()):
                    self._particle(phase, p, s)
        elif ti.static(phase.kind == "nodes"):
            if ti.static(self.f.on_device):
                for I in ti.grouped(ti.ndrange(*self.capacity.nodes)):
                    if (I < self.values.nodes()).all():
                        self._node(phase, I, s)
            elif ti.static(self.windowed):  # the active window's nodes
                for I in ti.grouped(ti.ndrange(*self.window.ranges())):
                    self._node(phase, I, s)
            else:
                for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                    self._node(phase, I, s)
        elif ti.static(phase.kind == "repeat"):
            for r in range(phase.count):  # a run-time loop: its phases compiled once
                for inner in ti.static(phase.phases):
                    self.run_phase(inner, r)
        elif ti.static(phase.staged):
            phase.body(self.particles, self.grid, self.values, s)
        else:
            phase.body(self.particles, self.grid, self.values)

    @ti.func
    def _particle(self, phase: ti.template(), p, s):
        if ti.static(phase.staged):
            phase.particle(self.particles, self.grid, self.values, p, s)
        else:
            phase.particle(self.particles, self.grid, self.values, p)

    @ti.func
    def _node(self, phase: ti.template(), I, s):
        if ti.static(phase.staged):
            phase.node(self.grid, self.values, I, s)
        else:
            phase.node(self.grid, self.values, I)

    # ---- the fused serial loop ---------------------------------------------------------------
    @ti.func
    def advance_steps(self, n_steps, every):
        """Up to n_steps steps, recording every ``every``-th; stops before the step after
        a failure.  Returns the steps done (the body of ``advance`` and of a Batch)."""
        done = 0
        for _ in range(n_steps):
            if self.run.err_count[None] != 0:  # no step after a failed one
                break
            self.one_step()
            done += 1
            if ti.static(self.f.recording):
                if self.run.step_count[None] % every == 0:
                    self.recorder.record_step()
        return done

    @ti.func
    def one_step(self):
        for phase in ti.static(self.phases):  # the scheme's step (schemes/)
            self.run_phase(phase, 0)
        self.count_step()

    @ti.func
    def count_step(self):
        # the step is done: n += 1, t = n dt (not after a failed step)
        if not self.failures.halted(0):
            self.scatter.accumulate(self.run.step_count[None], 1)
            self.run.time[None] = self.run.step_count[None] * self.values.dt()

    # ---- the parallel mode's launches ----------------------------------------------------
    def launch_groups(self):
        """The step as launches: runs of phases, each ``Repeat`` a launch per repetition
        (its phases top-level loops; a step unrolled four times compiled for 20 s)."""
        groups, plain = [], []
        for phase in self.phases:
            if phase.kind == "repeat":
                if plain:
                    groups.append(tuple(plain))
                    plain = []
                groups.append(phase)
            else:
                plain.append(phase)
        if plain or not groups:
            groups.append(tuple(plain))
        return groups

    @ti.func
    def run_group(self, group: ti.template(), s, last: ti.template()):
        """One launch of the parallel step: a run of phases, or repetition s of a Repeat;
        the step counted after the step's last (``last``)."""
        if ti.static(isinstance(group, tuple)):
            for phase in ti.static(group):
                self.run_phase(phase, 0)
            if ti.static(last):
                self.count_step()
        else:
            for inner in ti.static(group.phases):
                self.run_phase(inner, s)
            if ti.static(last):
                if s == group.count - 1:
                    self.count_step()

    # ---- the team ------------------------------------------------------------------------
    @ti.func
    def team_steps(self, n_steps):
        self.team.team_arrived[None] = 0
        self.team.team_abort[None] = 0
        B = self.values.scatter_block()
        for q in range(self.f.n_copies * B):
            if q % B == 0:  # thread q // B of Taichi's static split runs its whole block
                self._team_member(q // B, n_steps)

    @ti.func
    def _team_member(self, c, n_steps):
        """Thread c of the team: n_steps steps of the scheme's phases on its particles [c B,
        (c + 1) B) (scattered into its grid copy) and its share of the nodes, a barrier
        between two phases.  After the first barrier every thread reads the same errors
        (the next is written after the next barrier); after the others, a self.team that did
        not meet."""
        n_nodes = self.values.node_count()
        nodes_per_thread = self.values.nodes_per_thread()
        B = self.values.scatter_block()
        first, end = c * B, ti.min((c + 1) * B, self.values.n_particles())
        lo, hi = c * nodes_per_thread, ti.min((c + 1) * nodes_per_thread, n_nodes)
        start = self.run.step_count[None]  # thread 0 changes it only after the last barrier
        arrivals = 0
        for s in range(n_steps):
            self.team.rank_step[c] = start + s
            going = True
            for k in ti.static(range(len(self.phases))):
                ti.static_assert(self.phases[k].kind in ("scatter", "particles", "nodes"),
                                 "a team runs scatter, particle and node phases only")
                if ti.static(k > 0):
                    if going:
                        arrivals += self.f.n_copies
                        self._team_barrier(c, arrivals)
                        if ti.static(k == 1):
                            going = (ti.atomic_add(self.run.err_count[None], 0) == 0
                                     and ti.atomic_add(self.team.team_abort[None], 0) == 0)
                        else:
                            going = ti.atomic_add(self.team.team_abort[None], 0) == 0
                if going:
                    if ti.static(self.phases[k].kind == "scatter"):  # into the thread's copy
                        for p in range(first, end):
                            self.scatter.particle(self.phases[k], self.particles, self.grid,
                                                  self.values, p, c)
                    elif ti.static(self.phases[k].kind == "particles"):
                        for p in range(first, end):
                            self.phases[k].particle(self.particles, self.grid, self.values, p)
                    else:  # on its nodes, the copies of the scatter before summed in
                        for f in range(lo, hi):
                            I = self.node_of(f)
                            for name in ti.static(self.merged_before[k]):
                                ti.static(getattr(self.grid, name))[I] = self.scatter.merged(
                                    name, I)
                            self.phases[k].node(self.grid, self.values, I)
            if not going:
                break
            if c == 0:
                self.run.step_count[None] = start + s + 1
                self.run.time[None] = (start + s + 1) * self.values.dt()

    @ti.func
    def _team_barrier(self, c, target):
        """Arrive, then spin until ``target`` arrivals (every thread of the team is here);
        after TEAM_SPIN_LIMIT spins (a thread that never came) fail with error 6."""
        ti.atomic_add(self.team.team_arrived[None], 1)
        spins = 0
        while ti.atomic_add(self.team.team_arrived[None], 0) < target:
            spins += 1
            if spins % 1024 == 0:
                if ti.atomic_add(self.team.team_abort[None], 0) != 0:
                    break
                if spins > TEAM_SPIN_LIMIT:
                    ti.atomic_add(self.team.team_abort[None], 1)
                    self.failures.fail(ErrorCode.TEAM_BARRIER,
                                       c * self.values.scatter_block())
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
