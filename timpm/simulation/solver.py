"""The solver users call: a scene, its compiled program, its state, and the run loop.

``Solver(scene, ...)`` plans the scene (:func:`timpm.engine.features.plan`: the feature
set and the run-time layout), takes the process's :class:`~timpm.engine.program.Program`
of that feature set (compiled once, whatever the mesh size or particle count) and keeps
the state of this scene.  Several solvers of one feature set share the program's fields:
each activates its state before it runs or reads (the state it replaces is saved to host
memory), so they can be used in any order.

One step is the study's Modified Lagrangian algorithm with Euler-Cromer time stepping
(section 2.2.4, Figure 2.7) or, in 2D/3D, an affine transfer (APIC, MLS-MPM): see
:mod:`timpm.engine.transfer`.  Nothing is ever read or written out of bounds: a particle
outside the grid, a NaN, an inverted volume or a singular mass matrix sets an error record
(code, step, particle or node) and the run stops with a :class:`SimulationError` that
names them.
"""
import contextlib
import time

import numpy as np

from ..platform import interrupt, runtime
from ..platform.checks import (check_steps, index, is_whole, matrices, solver_options, step_count,
                               whole)
from ..engine.failures import energy_balance, recorded_failure
from ..model.geostatic import GravityLoading
from ..engine.features import SCATTERS, auto_mode, plan
from ..engine.program_cache import program_for, release_state_of
from ..engine.recorder import energy_series, tracked_series
from ..engine.state import State
from ..platform.errors import ERRORS, Released, SimulationError
from ..platform.progress import Progress

__all__ = ["Solver", "SimulationError", "ERRORS", "SCATTERS", "auto_mode"]


class Solver:
    """Particles and grid of one :class:`Scene` (1D), :class:`World` (1D to 3D) or their
    :class:`~timpm.model.Model`.

    ``track`` lists particle indices whose state is recorded every ``record_every`` steps
    together with the energies; ``mode`` is ``"parallel"``, ``"serial"`` (fused steps, one
    thread, bit-reproducible), ``"team"`` (the private scatter on two CPU threads or
    more, MUSL or affine: the passes of many steps in one parallel task, each thread a
    fixed block of particles and nodes, spin barriers between the passes; the parallel
    mode's results bit for bit) or ``"auto"`` (serial up to ``serial_threshold`` particles
    and at any size where Taichi runs one CPU thread, else team where it applies, else
    parallel).

    ``grid`` is ``"dense"`` (every node loop over the whole grid), ``"window"`` (over the
    box of nodes the particles reach this step and the last: the same results, the empty
    space skipped; 2D and 3D, the Euler-Cromer step with the lumped mass and standard
    projection, no team, not periodic; :mod:`timpm.engine.window`) or ``"auto"`` (the
    window where it applies, no team runs and the bodies start in less than half the
    domain).

    ``grid_displacement=True`` accumulates the nodal displacements u_i += v_i dt, so that
    the displacement field u_h(x) = sum_i phi_i(x) u_i can be drawn (study 5.2).

    With energies recorded, ``energy_guard`` stops an unstable run: kinetic + strain energy
    may not exceed ``energy_guard`` times the energy put in so far (initial kinetic and
    strain energy plus the magnitudes of the gravity and external work); ``None`` turns the
    check off (it is off where nodes move at prescribed velocities or a drained side's
    prescribed pore pressure drives the water, ``Water.side_pressure``: their work is not
    recorded).  ``volume_range`` (lowest, highest) stops a run whose particle's volume
    ratio V/V0 leaves it, naming step and particle (a crushed or torn body is no longer
    resolved); a material without tension (fluids, sand) is bounded only below; ``None``
    turns the check off.  The kernels hold up to ``history_chunk`` records between two reads from
    Python (default: about 4 MiB of them, 512 to 16384).  A failure is read back every
    ``check_every`` steps where steps are launched one or a few at a time (the parallel
    mode, and the fused mode with a body force, evaluated in Python before each step):
    the first failure is the one reported (the fused mode stops at its step; the parallel
    mode's later steps skip the failed particle).
    """

    def __init__(self, scene, track=(), record_every: int = 1, energies: bool = True,
                 mode: str = "auto", serial_threshold: int = 4096,
                 history_chunk: int | None = None,
                 track_crossings: bool | None = None, energy_guard: float | None = 2.0,
                 grid_displacement: bool = False, small_mass: float = 1e-3,
                 scatter: str = "auto", check_every: int = 16,
                 volume_range: tuple | None = (1e-2, 1e2), grid: str = "auto"):
        if isinstance(track, (str, bytes)) or not hasattr(track, "__iter__"):
            raise ValueError(f"track must be a sequence of particle indices, got {track!r}")
        track = [index("tracked particle", p) for p in track]
        record_every = whole("record_every", record_every)
        check_every = whole("check_every", check_every)
        if history_chunk is not None:
            history_chunk = whole("history_chunk", history_chunk)
        solver_options(energies, energy_guard, serial_threshold, small_mass)
        runtime.ensure_init()
        if isinstance(getattr(scene, "initial_stress", None), GravityLoading):
            raise ValueError("this world starts from its gravity loading: run it first, "
                             "world, record = timpm.gravity_loading(world) (scene files and "
                             "the factor-of-safety study do), then Solver(world)")
        self._generation = runtime.generation()  # the Taichi start that holds the fields
        self.check_every = check_every
        self.features, self.layout = plan(
            scene, track=track, energies=energies, mode=mode,
            serial_threshold=serial_threshold, history_chunk=history_chunk,
            track_crossings=track_crossings, grid_displacement=grid_displacement,
            small_mass=small_mass, scatter=scatter, volume_range=volume_range, grid=grid)
        f, lay = self.features, self.layout
        self.scene, self.track = scene, track
        self.model = getattr(scene, "model", scene)  # the one model of 1D to 3D
        self.basis = f.basis
        self.dim, self.mode, self.scatter, self.team = f.dim, f.mode, f.scatter, f.team
        self.n_copies, self.transfer = f.n_copies, f.transfer
        self.n_particles, self.n_tracked = lay.n_particles, lay.n_tracked
        self.grid_elements, self.grid_nodes = lay.elements, lay.nodes
        self.n_elements, self.n_nodes = lay.elements[0], lay.nodes[0]
        self.h, self.inv_h, self.dt = lay.h, lay.values["inv_h"], self.model.dt
        self.origin, self.materials = lay.origin, lay.materials
        self.record_every, self.history_chunk = record_every, lay.history
        # prescribed node motion and side pressures do work the records do not count: no
        # energy balance
        self.energy_guard = (energy_guard if energies and self.features.prescribed is None
                             and not self.features.has_side_pressure else None)
        self._slot = 0
        self.state = State(self.features, self.layout, scene, track)
        self._released = False
        self.history = {"t": [], "step": []}
        self.compile_seconds = 0.0
        self.run_seconds = 0.0
        self._energy_input = 0.0
        self._compiled = False
        self._timed_steps = 0  # parallel mode: the first launch of a new program is timed
        self._first_step = 0.0
        self.program()  # allocate (or reuse) the program's fields, upload this state

    # ---- compile-time choices, as attributes -----------------------------------------------
    def __getattr__(self, name):
        # the feature set's flags (consistent, recording, ...) read as attributes
        features = self.__dict__.get("features")
        if features is not None and not name.startswith("_") and hasattr(features, name):
            return getattr(features, name)
        raise AttributeError(f"{type(self).__name__!s} has no attribute {name!r}")

    @property
    def record_energies(self) -> bool:
        return self.features.energies

    # ---- the program and this state ----------------------------------------------------------
    def program(self):
        """The compiled program of this solver's feature set, with this solver's state in
        its fields (the state there before is saved to its owner first; drivers such as
        :class:`~timpm.simulation.batch.Batch` launch its kernels)."""
        self.check_usable()
        with self._compiling():  # the first upload (or save) of a program compiles it
            prog = program_for(self.features, self.layout, self._slot)
            prog.activate(self)
        return prog

    @contextlib.contextmanager
    def _compiling(self):
        """Book the kernels and field readers built inside in ``compile_seconds``."""
        clock = runtime.compile_clock()
        try:
            yield
        finally:
            self.compile_seconds += runtime.compile_clock() - clock

    def _scalar(self, name: str):
        """The run scalar ``name`` (``step_count``, ``time``, ...) of this state."""
        prog = self.program()
        with self._compiling():  # Taichi builds a field's reader at its first read
            return getattr(prog, name)[None]

    def move_to_slot(self, slot: int):
        """Keep this solver's state in copy ``slot`` of its feature set's program (a
        :class:`Batch` gives each member its own copy, so that they run side by side)."""
        self.check_usable()
        if slot != self._slot:
            prog = program_for(self.features, self.layout, self._slot)
            if prog.active is self:
                self.save_to_host(prog)
                prog.deactivate(self)
            self._slot = slot

    def check_usable(self):
        """A clear error, not a launch on freed memory, for a solver without its fields
        (released, or Taichi restarted since it was built) or called from a thread that
        does not own the runtime."""
        runtime.check_caller()
        if self._released:
            raise Released("this solver was released")
        if self._generation != runtime.generation():
            raise Released("Taichi was restarted (timpm.init with other settings) after "
                           "this solver was built, which freed its fields: build a new Solver")

    def load_into(self, prog):
        """Upload this solver's state into ``prog`` (called by ``prog.activate``)."""
        self.state.load_into(prog)

    def save_to_host(self, prog):
        """Keep this solver's state in host memory (another solver takes the program)."""
        self.state.save_to_host(prog)

    def read(self, name: str) -> np.ndarray:
        """The live values of state field ``name`` (``"x"``, ``"v"``, ``"sigma"``, ``"F"``,
        the grid's ``"gm"``, ``"gp"``, ``"gf"``, ``"gv"``, ``"gu"`` or the names the kernels
        give them, ``"node_mass"``, ``"node_velocity"``, ...; ``memory()`` lists the
        particle fields) as NumPy."""
        prog = self.program()
        if not hasattr(prog, name) or name.startswith("_"):
            raise KeyError(f"this solver has no state field {name!r}")
        with self._compiling():  # Taichi's to_numpy compiles a reader per field
            return self.state.read(prog, name)

    def active_window(self):
        """The box of grid nodes the last step's node loops ran over, ((lo, ...), (hi,
        ...)) with hi exclusive, or None where every loop runs over the whole grid
        (``grid``; :mod:`timpm.engine.window`)."""
        return self.state.window(self.program())

    def write(self, name: str, values):
        """Set the live values of state field ``name`` (for tests and inspection): finite
        numbers only (a NaN or an infinity written would stop the next step, blamed on
        the time step)."""
        prog = self.program()
        if not hasattr(prog, name) or name.startswith("_"):
            raise KeyError(f"this solver has no state field {name!r}")
        try:
            values = np.asarray(values)
        except (TypeError, ValueError) as exc:  # a ragged list
            raise ValueError(f"write({name!r}): the values must be an array of numbers "
                             f"({exc})") from None
        if values.dtype.kind not in "biuf":
            raise ValueError(f"write({name!r}): the values must be numbers, got an array of "
                             f"dtype {values.dtype}")
        if values.dtype.kind == "f" and not np.all(np.isfinite(values)):
            bad = ~np.isfinite(values)
            first = np.unravel_index(int(np.flatnonzero(bad)[0]), values.shape)
            raise ValueError(f"write({name!r}): {int(bad.sum())} of the {values.size} values "
                             f"are not finite (NaN or infinity), the first at index "
                             f"{tuple(int(i) for i in first)}: write finite numbers")
        try:
            self.state.write(prog, name, values)
        except ValueError as exc:  # a wrong shape: NumPy's reshape names both
            raise ValueError(f"write({name!r}): {exc}") from None

    # ---- snapshot and restore (checkpoints) ----------------------------------------------------
    def fingerprint(self) -> dict:
        """What a saved state must match to be restored into this solver, as JSON values:
        the feature set's physics, the sizes, the grid and the time step (the mode and the
        scatter may differ), the tracked particles, ``record_every`` and the run-time
        physics (material constants, gravity, damping, pic_fraction, walls, loads, fixed
        nodes: :meth:`timpm.engine.state.State.fingerprint`)."""
        return self.state.fingerprint(self.record_every)

    def snapshot(self) -> dict:
        """The whole state of this run as NumPy arrays (particles, grid, time, step, the
        first error), the records so far, and :meth:`fingerprint`: what :meth:`restore`
        takes to go on bit for bit."""
        prog = self.program()
        self.drain()
        arrays = self.state.snapshot(prog)
        history = {k: np.concatenate(v) for k, v in self.history.items() if len(v)}
        return {"arrays": arrays, "history": history, "fingerprint": self.fingerprint(),
                "columns": prog.state_layout(), "energy_input": self._energy_input,
                "run_seconds": self.run_seconds}

    def restore(self, snapshot: dict):
        """Continue from a :meth:`snapshot` of a solver of the same scene (this process's
        or another's, e.g. read from a checkpoint file); returns self."""
        prog = self.program()
        self.state.check_fits(prog, snapshot, self.record_every)
        self.state.restore(prog, snapshot["arrays"])
        self.history = {k: [np.asarray(v)] for k, v in snapshot["history"].items()}
        self.history.setdefault("t", [])
        self.history.setdefault("step", [])
        self._energy_input = float(snapshot["energy_input"])
        self.run_seconds = float(snapshot["run_seconds"])
        return self

    # ---- reset and release -----------------------------------------------------------------
    def reset(self):
        """Back to the scene's initial state, keeping the compiled kernels: a second run
        of the same scene (a study repeated, a parameter sweep over loads read at run time)
        costs no compilation."""
        prog = self.program()
        self.state.host = None
        self.state.load_into(prog)
        self.history = {"t": [], "step": []}
        self.run_seconds = 0.0
        self.compile_seconds = 0.0
        self._energy_input = 0.0
        return self

    def release(self):
        """Free this solver's state (it cannot be used afterwards; the compiled program
        stays for other solvers)."""
        if not self._released:
            release_state_of(self)
            self.state.host = None
            self._released = True

    def memory(self) -> dict:
        """Bytes per particle and per grid node of the state fields this scene uses, the
        names of those fields, and the bytes per node of the private scatter's grid copies
        (``scatter_node_bytes``, 0 for the other strategies)."""
        return self.state.memory(self.program())

    # ---- running -------------------------------------------------------------------------
    @property
    def step(self) -> int:
        return int(self._scalar("step_count"))

    @property
    def t(self) -> float:
        return float(self._scalar("time"))

    def steps_for(self, t_end: float, allow_many_steps: bool = False) -> int:
        """Number of steps of size dt that reach ``t_end`` (rounded to the nearest step);
        more than :data:`~timpm.platform.checks.MAX_STEPS` are refused unless ``allow_many_steps``."""
        return step_count(t_end, self.dt, allow_many_steps)

    def compile(self):
        """Compile the kernels this run needs (timed apart as ``compile_seconds``); a
        program already compiled for this feature set compiles nothing."""
        if self._compiled:
            return
        prog = self.program()
        with self._compiling():
            if self.mode == "serial" and "advance" not in prog.compiled:
                prog.advance(0, self.record_every, 0)  # zero steps: compiles, changes nothing
                prog.compiled.add("advance")
            if self.recording and "record" not in prog.compiled:
                if self.mode != "serial":  # the fused mode records with advance (_record_now)
                    prog.record()
                    prog.rec_count[None] = 0
                prog.read_history(0, self.n_tracked)
                prog.compiled.add("record")
            if "io" not in prog.compiled:
                int(prog.err[None]) + int(prog.err_count[None])
                prog.compiled.add("io")
        self._compiled = True

    def run(self, t_end: float | None = None, n_steps: int | None = None, progress=None,
            allow_many_steps: bool = False):
        """Advance to ``t_end`` (or by ``n_steps``); returns self.

        A run of more than :data:`~timpm.platform.checks.MAX_STEPS` (1e8) steps is refused before
        it starts (a mistaken dt or t_end) unless ``allow_many_steps``.
        Raises :class:`SimulationError` at the first step whose state is invalid.  A
        progress line is drawn on stderr for runs that last more than two seconds when
        stderr is a terminal (``progress=True`` forces it, ``False`` turns it off).
        Wall time spent stepping accumulates in ``run_seconds``; kernel compilation is
        booked apart in ``compile_seconds``.  Inside :func:`timpm.platform.interrupt.deferred_sigint`
        a Ctrl-C stops the run at the next step boundary (launches then last at most about
        half a second) with :class:`~timpm.platform.interrupt.RunInterrupted`; the state is whole
        and can be saved (:meth:`snapshot`).
        """
        total = self.steps_to(t_end, n_steps, allow_many_steps)
        prog = self.program()
        if self.mode != "serial":
            runtime.ensure_pinned()  # the workers, one per core, before they first wake
        self.compile()
        self.record_start()
        bar = Progress(total, progress, bounded=interrupt.active())
        done = 0
        loads = self.features.body_force  # b(X, t) evaluated in Python before every step
        first_step = self.step if loads else 0
        # fused steps with a body force: read back every check_every steps, sooner if the
        # history buffer would fill
        check_interval = self.fused_chunk(self.check_every)
        unchecked = 0
        start = time.perf_counter()
        # Ctrl-C (deferred): stop at the next step boundary, the state whole
        while done < total and not interrupt.requested():
            if loads:
                self.state.upload_body_force(prog, first_step + done)
            if self.mode == "serial" and loads:
                # a launch per step (b uploaded before each); the records read back and
                # the failure checked every few steps, as the parallel mode does
                done += int(prog.advance(1, self.record_every, 0))
                unchecked += 1
                if unchecked >= check_interval:
                    self.drain()
                    self.check()
                    unchecked = 0
            elif self.mode == "serial":
                chunk = self.fused_chunk(min(total - done, bar.suggested_chunk(done)))
                done += int(prog.advance(chunk, self.record_every, 0))
                self.drain()
                self.check()
            elif "step" not in prog.compiled:
                t0 = time.perf_counter()
                prog.launch(1)
                took = time.perf_counter() - t0
                # the first launch compiles: book its excess over the second apart
                if self._timed_steps == 0:
                    self._first_step = took
                    self._timed_steps = 1
                else:
                    extra = max(self._first_step - took, 0.0)
                    self.compile_seconds += extra
                    start += extra
                    prog.compiled.add("step")
                done += 1
                self.check()
                self._record_step(prog)
            else:
                # one launch per step (a team: one per chunk); the checks read back every
                # check_every steps (a failed particle is skipped by later steps, the first
                # failure is kept)
                chunk = min(total - done, self.check_every, bar.suggested_chunk(done))
                if loads:
                    chunk = 1
                if self.recording:
                    chunk = min(chunk, self.record_every - self.step % self.record_every)
                prog.launch(chunk)
                done += chunk
                self.check()
                self._record_step(prog)
            bar.update(done)
        bar.close()
        if unchecked:
            self.drain()
            self.check()
        self.record_end()
        self.run_seconds += time.perf_counter() - start
        if interrupt.requested():
            raise interrupt.RunInterrupted(self.step, self.t)
        return self

    def steps_to(self, t_end, n_steps, allow_many_steps=False) -> int:
        """Steps a run to ``t_end`` (or of ``n_steps``) takes from here."""
        if (t_end is None) == (n_steps is None):
            raise ValueError("give exactly one of t_end and n_steps")
        if n_steps is not None:
            if not is_whole(n_steps) or n_steps < 0:
                raise ValueError(f"n_steps must be a non-negative integer, got {n_steps!r}")
            check_steps(n_steps, self.dt, allow_many_steps)
            return int(n_steps)
        total = self.steps_for(t_end, allow_many_steps=True) - self.step
        if total < 0:
            raise ValueError(f"t_end = {t_end} lies before the current time {self.t}")
        check_steps(total, self.dt, allow_many_steps, t_end=t_end)
        return total

    def fused_chunk(self, n: int) -> int:
        """At most n fused steps, fewer if the history buffer (history_chunk records)
        would overflow."""
        return min(n, self.history_chunk * self.record_every) if self.recording else n

    def record_start(self):
        """Record the initial state before the first step."""
        if self.recording and self.step == 0 and not self.history["t"]:
            self._record_now()

    def record_end(self):
        """Read back the records and record the final state if the last step was not."""
        if self.recording:
            self.drain()
            if self.history["step"][-1][-1] != self.step:
                self._record_now()

    def _record_step(self, prog):
        if self.recording and self.step % self.record_every == 0:
            prog.record()
            if prog.rec_count[None] == self.history_chunk:
                self.drain()

    def _record_now(self):
        prog = self.program()
        if self.mode == "serial" and "advance" in prog.compiled:
            prog.advance(0, self.record_every, 1)  # records, no step: one kernel less to build
        else:
            prog.record()
        self.drain()

    def drain(self):
        """Move the records of the kernel's history buffer to ``self.history``."""
        if not self.recording:
            return
        prog = self.program()
        n = int(prog.rec_count[None])
        if n == 0:
            return
        # kept as one array per drain (rows one by one would cost more than the steps)
        chunk = prog.read_history(n, self.n_tracked)
        for key, values in chunk.items():
            self.history.setdefault(key, []).append(values)
        prog.rec_count[None] = 0
        if self.record_energies:
            self._guard_energy(chunk["energy"], chunk["step"])

    def _guard_energy(self, energy, steps):
        if self.energy_guard is None or not len(self.history["energy"]):
            return
        self._energy_input, error = energy_balance(
            self.history["energy"][0][0], energy, steps, self._energy_input,
            self.energy_guard, self.dt)
        if error is not None:
            raise error

    def check(self):
        """Raise the run's first failure, if any, as a :class:`SimulationError`."""
        error = recorded_failure(self.program(), self.state)
        if error is not None:
            raise error

    # ---- results ---------------------------------------------------------------------------
    def project(self):
        """Nodal mass and momentum projected from the particles now (P2G alone).

        For inspection and tests; it overwrites the grid, so call it between steps only.
        """
        prog = self.program()
        prog.project()
        out = self.read("gm"), self._component(self.read("gp"))
        if self.features.affine:
            prog.clear()  # the affine step expects a cleared grid
        return out

    def positions(self) -> np.ndarray:
        return self._component(self.read("x"))

    def displacements(self) -> np.ndarray:
        """u_p: accumulated in 1D (the study's u), x_p - X_p in 2D and 3D."""
        if self.has_u:
            return self._component(self.read("u"))
        return self.positions() - self.model.positions

    def velocities(self) -> np.ndarray:
        return self._component(self.read("v"))

    def displacement_field(self, x) -> np.ndarray:
        """u_h(x) = sum_i phi_i(x) u_i at points x from the accumulated nodal displacements."""
        if not self.grid_displacement:
            raise RuntimeError("build the solver with grid_displacement=True")
        from ..bases import evaluate

        phi, _ = evaluate(self.basis, (np.asarray(x, dtype=float) - self.origin[0]) * self.inv_h,
                          self.n_elements)
        return phi @ self._component(self.read("gu"))

    def _inertia(self):
        """D_p = sum_i phi_i (x_i - x_p)(x_i - x_p)^T of every particle (diagonal), (n, dim)."""
        return self.state.inertia(self.read("x").reshape(self.n_particles, self.dim))

    def affine(self) -> np.ndarray:
        """The affine velocity C_p = B_p D_p^-1 of the APIC transfers, (n, dim, dim)."""
        if not self.features.affine:
            raise RuntimeError(f"the {self.transfer} transfer keeps no affine velocity")
        C = self.read("C")
        if self.basis.support == 2:  # the linear basis stores B_p
            C = C / self._inertia()[:, None, :]
        return C

    def set_affine(self, C):
        """Set the affine velocity C_p of every particle ((n, dim, dim) or one matrix)."""
        if not self.features.affine:
            raise RuntimeError(f"the {self.transfer} transfer keeps no affine velocity")
        C = matrices("set_affine", C, self.n_particles, self.dim)
        if self.basis.support == 2:
            C = C * self._inertia()[:, None, :]
        self.write("C", C)

    def stresses(self) -> np.ndarray:
        """Cauchy stress: one value per particle in 1D, else (n, dim, dim)."""
        return self._tensor(self.read("sigma"))

    def strains(self) -> np.ndarray:
        """Accumulated (logarithmic) strain, sum of the increments d_eps."""
        return self._tensor(self.read("eps"))

    def volumes(self) -> np.ndarray:
        """Particle volumes: V_p, or J V0 where the materials keep V0 and a J (JFluid)."""
        vol = self.read("vol")
        if not self.update_volume and "J" in self.needs:
            vol = vol * self.read("J")
        return vol

    def densities(self) -> np.ndarray:
        return self.read("m") / self.volumes()

    def grid_crossings(self) -> int:
        if not self.track_crossings:
            raise RuntimeError("this solver was built with track_crossings=False")
        return int(self._scalar("crossings"))

    def negative_pivots(self) -> int:
        """Steps x nodes at which the consistent mass matrix had a negative pivot."""
        return int(self._scalar("neg_pivots"))

    def energies(self) -> dict:
        """Recorded energies over time: kinetic, strain, gravity (potential), external work
        and total = kinetic + strain + gravity - external work."""
        if not self.record_energies:
            raise RuntimeError("this solver was built with energies=False")
        self.check_usable()
        return energy_series(self.history, self.has_u)

    def tracked(self) -> dict:
        """Recorded time series of the tracked particles: arrays of shape (records, tracked)."""
        self.check_usable()
        return tracked_series(self.history, self.dim)

    def _tensor(self, a):
        # Taichi returns a 1x1 matrix field as (..., 1): one value per entry in 1D
        return a[..., 0] if self.dim == 1 else a

    def _component(self, a):
        return a[:, 0] if self.dim == 1 else a
