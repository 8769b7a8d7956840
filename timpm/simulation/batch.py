"""Several small simulations advanced side by side: one kernel launch, each on one thread.

A study's meshes or a parameter sweep over small 1D problems are independent runs of a few
microseconds per step each: too small for a parallel particle loop (waking a thread costs
as much as the loop), but a 2-core machine can run two of them at once.  A :class:`Batch`
launches one kernel whose parallel loop hands each CPU thread a group of members, and each
member takes its fused serial steps (``Solver(mode="serial")``) exactly as it would alone.
"""
import time

import numpy as np
import taichi as ti

from ..platform import runtime
from ..engine.features import MIN_CPU_BLOCK
from ..platform.errors import Released, SimulationError
from ..platform.progress import Progress
from .solver import Solver

__all__ = ["Batch"]

# The batch kernels of this process, per (members' programs, recording intervals, threads):
# a new Batch of the same programs takes them, with their two small fields, and compiles
# nothing.  New fields would get new SNode ids, and so miss Taichi's offline cache too.
_KERNELS = {}


class _Kernels:
    """One batch kernel and its fields: ``order`` (per member: steps to take, thread) and
    ``status`` (per member: steps taken, errors)."""

    def __init__(self, programs, every, n_threads):
        self.programs = programs  # held: the key's ids stay theirs
        fb = ti.FieldsBuilder()
        self.order = ti.Vector.field(2, ti.i32)
        self.status = ti.Vector.field(2, ti.i32)
        fb.dense(ti.i, len(programs)).place(self.order, self.status)
        fb.finalize()
        self.uploaded = None  # the (steps, threads) in the order field
        self.advance_all, self.read_states = _build(programs, every, n_threads,
                                                    self.order, self.status)


def _kernels_for(programs, every, n_threads):
    """The process's batch kernels for these member programs, built on first use."""
    gen = runtime.generation()
    for old in [k for k in _KERNELS if k[0] != gen]:
        del _KERNELS[old]  # Taichi restarted: their fields are gone with it
    key = (gen, tuple(id(p) for p in programs), tuple(every), n_threads)
    if key not in _KERNELS:
        _KERNELS[key] = _Kernels(programs, every, n_threads)
    return _KERNELS[key]


def _build(programs, every, n_threads, order, status):
    """The batch kernel and the one-launch read of the members' states."""
    @ti.kernel
    def advance_all() -> ti.i32:
        # thread q of the static CPU split runs iterations [q B, (q + 1) B): iteration
        # q B takes the members assigned to thread q, one after another; returns the
        # number of members that stopped short or failed (then Python reads the status)
        short = 0
        for r in range(n_threads * MIN_CPU_BLOCK):
            if r % MIN_CPU_BLOCK == 0:
                q = r // MIN_CPU_BLOCK
                for k in ti.static(range(len(programs))):
                    if order[k][1] == q:
                        prog = programs[k]  # k is static: a Python-level lookup
                        done = prog.advance_steps(order[k][0], every[k])
                        errors = prog.err_count[None]
                        status[k] = ti.Vector([done, errors])
                        if done != order[k][0] or errors != 0:
                            short += 1
        return short

    @ti.kernel
    def read_states(u: ti.types.ndarray(), scalars: ti.types.ndarray()):
        ti.loop_config(serialize=True)
        for _ in range(1):
            start = 0
            for k in ti.static(range(len(programs))):
                prog = programs[k]
                n = prog.values.n_particles()
                for p in range(n):
                    u[start + p] = prog.u[p][0]
                start += n
                scalars[k, 0] = prog.step_count[None]
                scalars[k, 1] = prog.time[None]
                scalars[k, 2] = prog.crossings[None]

    return advance_all, read_states


class Batch:
    """Fused serial solvers advanced together, shared out over the CPU threads.

    ``Batch(solvers).run(t_end)`` advances every member to ``t_end`` (each with its own
    time step); a member's results are those of ``member.run(t_end)``: bit for bit without
    fast math (``timpm.init(fast_math=False)``), to round-off with it (LLVM may vectorise
    the sums of the batch kernel and of the member's own kernel apart).  The
    members are assigned to threads longest first, by particle-steps, before each launch.
    Each member's ``run_seconds`` grows by the batch's wall time (they ran side by side);
    the batch keeps its own ``run_seconds`` and ``compile_seconds``.  The batch kernel holds
    every member's step: it compiles more slowly than the members would apart (about 30 s
    cold for the five meshes of Table 3.2, 3 s from Taichi's offline cache), so a batch pays
    off when it runs many times (``reset()`` between runs).  The process keeps it: a later
    batch of the same feature sets, recording intervals and threads compiles nothing.
    """

    def __init__(self, solvers, threads: int | None = None):
        solvers = list(solvers)
        if not solvers:
            raise ValueError("a Batch needs at least one solver")
        for k, s in enumerate(solvers):
            if not isinstance(s, Solver):
                raise TypeError(f"batch member {k} is a {type(s).__name__}, not a timpm.Solver")
            if s.mode != "serial":
                raise ValueError(f"batch member {k} runs in {s.mode} mode: a Batch takes fused "
                                 "serial solvers, Solver(..., mode='serial')")
            if s.features.body_force:
                raise ValueError(f"batch member {k} has a body force b(X, t), evaluated in "
                                 "Python before every step: run it alone (Solver.run)")
            try:
                s.check_usable()
            except RuntimeError as err:
                raise ValueError(f"batch member {k}: {err}") from None
        if len({id(s) for s in solvers}) != len(solvers):
            raise ValueError("a solver appears twice in the batch")
        self.solvers = solvers
        threads = runtime.cpu_threads() if threads is None else int(threads)
        if threads < 1:
            raise ValueError(f"threads must be a positive integer, got {threads!r}")
        # the thread of a member follows from Taichi's static split of CPU range-for loops
        self.n_threads = threads if runtime.static_cpu_blocks() else 1
        for k, s in enumerate(solvers):
            s.move_to_slot(k + 1)  # slot 0 is the program single solvers share
        self._released = False
        self._generation = runtime.generation()
        self._kernels = None  # the batch kernels of the members' programs
        self.run_seconds = 0.0
        self.compile_seconds = 0.0
        self._compiled = False

    def release(self):
        """Mark the batch unusable (the members stay usable; release them apart).  Its
        kernel and two small fields stay with the process, for the next batch of the same
        programs."""
        self._released = True
        self._kernels = None

    def _require_fields(self):
        """A clear error, not a launch on freed memory, for a batch or member without its
        fields."""
        runtime.check_caller()
        if self._released:
            raise Released("this batch was released")
        if self._generation != runtime.generation():
            raise Released("Taichi was restarted (timpm.init with other settings) after "
                           "this batch was built, which freed its fields")
        for k, s in enumerate(self.solvers):
            try:
                s.check_usable()
            except RuntimeError as err:
                raise Released(f"batch member {k}: {err}") from None

    def _members(self):
        """The batch kernels of the members' programs, each program holding its member's
        state; other kernels where a program changed (grown)."""
        self._require_fields()
        programs = [s.program() for s in self.solvers]
        if self._kernels is None or any(a is not b for a, b in
                                        zip(programs, self._kernels.programs)):
            every = [s.record_every for s in self.solvers]
            self._kernels = _kernels_for(programs, every, self.n_threads)
        return self._kernels

    def reset(self):
        """Every member back to its initial state (:meth:`Solver.reset`)."""
        self._require_fields()
        for s in self.solvers:
            s.reset()
        return self

    def compile(self):
        """Compile the batch kernel and the members' accessors (``compile_seconds``)."""
        if self._compiled:
            return
        t0 = time.perf_counter()
        self._members()
        self._launch([0] * len(self.solvers))  # zero steps: compiles, changes nothing
        for s in self.solvers:
            s.compile()
        self.states()
        self.compile_seconds += time.perf_counter() - t0
        self._compiled = True

    def states(self):
        """Per member: displacements ``u``, ``step``, ``t`` and ``grid_crossings``, read in
        one launch (a read-back from Python costs about a launch each); None unless every
        member is 1D and counts grid crossings."""
        if not all(s.dim == 1 and s.has_u and s.track_crossings for s in self.solvers):
            return None
        kernels = self._members()
        counts = [s.n_particles for s in self.solvers]
        u = np.empty(sum(counts))
        scalars = np.empty((len(counts), 3))
        kernels.read_states(u, scalars)
        starts = np.cumsum([0] + counts)
        return [{"u": u[a:b], "step": int(row[0]), "t": float(row[1]),
                 "grid_crossings": int(row[2])}
                for a, b, row in zip(starts[:-1], starts[1:], scalars)]

    def _launch(self, steps):
        """One launch: member k takes steps[k] steps; threads balanced by particle-steps."""
        load = [0] * self.n_threads
        thread_of = [0] * len(steps)
        work = [n * s.n_particles for n, s in zip(steps, self.solvers)]
        for k in sorted(range(len(steps)), key=lambda k: -work[k]):
            q = load.index(min(load))
            thread_of[k] = q
            load[q] += work[k]
        order = (tuple(steps), tuple(thread_of))
        kernels = self._members()
        if order != kernels.uploaded:  # a study's launches repeat: upload only a new order
            kernels.order.from_numpy(np.asarray(order, dtype=np.int32).T.copy())
            kernels.uploaded = order
        if kernels.advance_all() == 0:  # every member took its steps: no read-back
            return np.array([[n, 0] for n in steps])
        return kernels.status.to_numpy()

    def run(self, t_end: float | None = None, n_steps: int | None = None, progress=None,
            allow_many_steps: bool = False):
        """Advance every member to ``t_end`` (or by ``n_steps``); returns self.  A member's
        run of more than :data:`~timpm.platform.checks.MAX_STEPS` steps is refused unless
        ``allow_many_steps``.

        Raises :class:`SimulationError` naming the member at the first invalid state.
        """
        if (t_end is None) == (n_steps is None):
            raise ValueError("give exactly one of t_end and n_steps")
        self._members()
        runtime.ensure_pinned()  # the members share the threads: one per core
        remaining = []
        for k, s in enumerate(self.solvers):
            try:
                remaining.append(s.steps_to(t_end, n_steps, allow_many_steps))
            except ValueError as err:
                raise ValueError(f"batch member {k}: {err}") from None
        self.compile()
        for s in self.solvers:
            s.record_start()
        totals = list(remaining)
        bar = Progress(max(totals), progress)
        start = time.perf_counter()
        done = 0
        while any(remaining):
            chunk = bar.suggested_chunk(done)
            steps = [s.fused_chunk(min(left, chunk))
                     for s, left in zip(self.solvers, remaining)]
            status = self._launch(steps)
            for k, s in enumerate(self.solvers):
                remaining[k] -= int(status[k, 0])
                try:
                    s.drain()  # the energy guard may stop a member here
                    if status[k, 1]:
                        s.check()
                except SimulationError as err:
                    raise SimulationError(f"batch member {k}: {err}", err.code, err.step,
                                          err.particle, err.node) from None
            done = max(t - r for t, r in zip(totals, remaining))
            bar.update(done)
        bar.close()
        for s in self.solvers:
            s.record_end()
        wall = time.perf_counter() - start
        self.run_seconds += wall
        for s in self.solvers:
            s.run_seconds += wall
        return self
