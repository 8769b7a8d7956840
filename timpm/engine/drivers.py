"""The drivers of a step: errors, the fused serial loop, and the team of threads.

Mixed into :class:`~timpm.engine.program.Program`.  Every driver runs the same step
(``_one_step``, or its passes in a team):

- *parallel*: one launch per step, every loop of the step parallel over the CPU threads;
- *serial* (fused): many steps in one launch, one task on one thread (``advance_steps``);
- *team*: many steps (MUSL or affine) in one parallel task, each thread of Taichi's static
  split a fixed block of particles (its own grid copy) and of nodes, spin barriers between
  the passes (``_team_steps``).

A failure (a particle off the grid, a NaN, an inverted volume, a singular mass matrix,
a team that does not meet) records its code, step and particle or node (``_fail``); the
run stops after that step and Python raises the error.
"""
import taichi as ti

from ..errors import TEAM_SPIN_LIMIT, ErrorCode

__all__ = ["Drivers"]


class Drivers:
    """Errors, the fused serial steps and the team (see the module)."""

    @ti.func
    def _fail(self, code, where):
        """Record the first error of the run: its code (an :class:`~timpm.errors.ErrorCode`),
        step and particle or node."""
        first = False
        if ti.static(self.mode == "serial"):
            first = self.err_count[None] == 0
            self.err_count[None] = self.err_count[None] + 1
        else:
            first = ti.atomic_add(self.err_count[None], 1) == 0
        if first:
            self.err[None] = code
            if ti.static(self.team):  # where: a particle of the thread's block
                self.err_step[None] = self.rank_step[where // self.p.scatter_block()]
            else:
                self.err_step[None] = self.step_count[None]
            self.err_where[None] = where

    @ti.func
    def _halted(self, p):
        """A step before this one failed: the particles stay as they were at the failure
        (Python reads the error back every ``check_every`` steps).  The fused serial mode
        stops before the step after a failure instead (see ``_advance``), a team at the
        first barrier after it (its step is that of particle p's thread)."""
        halted = False
        if ti.static(self.team):
            halted = (self.err_count[None] != 0 and
                      self.err_step[None] < self.rank_step[p // self.p.scatter_block()])
        elif ti.static(self.mode != "serial"):
            halted = self.err_count[None] != 0 and self.err_step[None] < self.step_count[None]
        return halted

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
                    self._record()
        return done

    @ti.func
    def _team_steps(self, n_steps):
        self.team_arrived[None] = 0
        self.team_abort[None] = 0
        B = self.p.scatter_block()
        for q in range(self.n_copies * B):
            if q % B == 0:  # thread q // B of Taichi's static split runs its whole block
                if ti.static(self.apic):
                    self._team_member(q // B, n_steps)
                else:
                    self._team_member_musl(q // B, n_steps)

    @ti.func
    def _team_member(self, c, n_steps):
        """Thread c of the team: n_steps affine steps on its particles [c B, (c + 1) B)
        (scattered into its grid copy) and its share of the nodes."""
        n_nodes = self.p.node_count()
        nodes_per_thread = self.p.nodes_per_thread()
        B = self.p.scatter_block()
        first, end = c * B, ti.min((c + 1) * B, self.p.n_particles())
        start = self.step_count[None]  # thread 0 changes it only after the second barrier
        arrivals = 0
        for s in range(n_steps):
            self.rank_step[c] = start + s
            # P2G of the thread's particles into its own grid copy (as _p2g)
            for p in range(first, end):
                self._scatter_particle("p2g", p, c)
            arrivals += self.n_copies
            self._team_barrier(c, arrivals)
            # all threads read the same errors here: the next is written in G2P, after the
            # next barrier
            if (ti.atomic_add(self.err_count[None], 0) != 0
                    or ti.atomic_add(self.team_abort[None], 0) != 0):
                break
            # grid: the copies summed, v = P / m, walls, on the thread's nodes (as
            # _grid_velocity)
            for f in range(c * nodes_per_thread, ti.min((c + 1) * nodes_per_thread, n_nodes)):
                self._grid_velocity_node(self._node_of(f))
            arrivals += self.n_copies
            self._team_barrier(c, arrivals)
            if ti.atomic_add(self.team_abort[None], 0) != 0:
                break
            # G2P of the thread's particles (as _g2p_update): the next P2G reads only them
            for p in range(first, end):
                self._g2p_update_particle(p)
            if c == 0:
                self.step_count[None] = start + s + 1
                self.time[None] = (start + s + 1) * self.p.dt()

    @ti.func
    def _team_member_musl(self, c, n_steps):
        """Thread c of the team: n_steps MUSL steps (the study's, with the private scatter)
        on its particles and its share of the nodes, four barriers a step."""
        n_nodes = self.p.node_count()
        nodes_per_thread = self.p.nodes_per_thread()
        B = self.p.scatter_block()
        first, end = c * B, ti.min((c + 1) * B, self.p.n_particles())
        lo, hi = c * nodes_per_thread, ti.min((c + 1) * nodes_per_thread, n_nodes)
        start = self.step_count[None]  # thread 0 changes it only after the last barrier
        arrivals = 0
        for s in range(n_steps):
            self.rank_step[c] = start + s
            # P2G of mass and forces (and momentum) into the thread's grid copy (as _p2g)
            for p in range(first, end):
                self._scatter_particle("p2g", p, c)
            arrivals += self.n_copies
            self._team_barrier(c, arrivals)
            if (ti.atomic_add(self.err_count[None], 0) != 0
                    or ti.atomic_add(self.team_abort[None], 0) != 0):
                break
            # grid: the copies summed, a = M^-1 F with damping and walls (as
            # _grid_acceleration) on the thread's nodes
            for f in range(lo, hi):
                I = self._node_of(f)
                for name in ti.static(tuple(self.copies)):
                    ti.static(getattr(self, name))[I] = self._merged(name, I)
                self._grid_acceleration_node(I)
            arrivals += self.n_copies
            self._team_barrier(c, arrivals)
            # G2P of the velocity, P2G of the new momentum into the copy (_g2p_velocity)
            for p in range(first, end):
                self._scatter_particle("g2p-velocity", p, c)
            arrivals += self.n_copies
            self._team_barrier(c, arrivals)
            # grid: v = P / m with the walls (as _solve_mass), u_i += v_i dt
            for f in range(lo, hi):
                I = self._node_of(f)
                self.gp[I] = self._merged("gp", I)
                self._solve_mass_node(self.gp, True, I)
                if ti.static(self.grid_displacement):
                    self.gu[I] += self.gp[I] * self.p.dt()
            arrivals += self.n_copies
            self._team_barrier(c, arrivals)
            if ti.atomic_add(self.team_abort[None], 0) != 0:
                break
            # G2P of displacement, strain, stress, volume (as _g2p_update)
            for p in range(first, end):
                self._g2p_update_particle(p)
            if c == 0:
                self.step_count[None] = start + s + 1
                self.time[None] = (start + s + 1) * self.p.dt()

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
                    self._fail(ErrorCode.TEAM_BARRIER, c * self.p.scatter_block())
                    break

    @ti.func
    def _node_of(self, f):
        """Grid index of the node at flat index f (the order of ti.ndrange)."""
        I = ti.Vector.zero(ti.i32, self.dim)
        rest = f
        for k in ti.static(range(self.dim - 1, -1, -1)):
            I[k] = rest % self.p.nodes()[k]
            rest = rest // self.p.nodes()[k]
        return I
