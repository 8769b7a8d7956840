"""Drivers: run a benchmark problem, compare with its exact solution, study convergence."""
from collections import OrderedDict
from dataclasses import dataclass, field
import errno
import inspect
import os
import time

import numpy as np

from ..simulation.batch import Batch
from ..platform.checks import distinct, finite, step_count, whole
from ..problems import get_problem
from ..platform.errors import SimulationError
from ..simulation.solver import Solver
from .analysis import energy_drift, observed_rates, rms_error
from .sweep import check_executor, interruptible, map_runs

__all__ = ["RunResult", "run_problem", "resume_problem", "convergence", "clear_solvers"]


@dataclass
class RunResult:
    """One run: the JSON record, final particle state and the monitored time series."""

    record: dict
    x0: np.ndarray
    displacement: np.ndarray
    exact_displacement: np.ndarray | None
    series: dict = field(default_factory=dict)
    energies: dict | None = None


def _default_record_every(steps: int) -> int:
    return max(1, steps // 10000)


def run_problem(problem="vibrating-string", *, elements=None, ppc=None, basis="linear",
                mass=None, dt=None, t_end=None, placement=None, stress_update="study",
                damping=None, allow_unstable_dt=False, mode="auto", record_every=None,
                progress=None, params=None, energies=True, projection=None,
                series=True, reuse=True, transfer="musl", pic_fraction=None,
                transfer_params=None, integrator=None, fields=None,
                frames=20, checkpoint=None, checkpoint_every=None,
                interrupted_to=None, resume=None, allow_many_steps=False) -> RunResult:
    """Build the problem's scene, run it to ``t_end`` and compare with the exact solution.

    Unset numerical values take the problem's defaults (``placement`` too: the study's
    problems place particles as the study does, the manufactured solutions at Gauss
    points; ``mass``, ``projection`` and ``integrator``: lumped, standard and
    euler-cromer, but consistent, mls and rk4 for mms-1d and mls for mms-2d beyond the
    linear basis, see ``Problem.scheme``); ``params`` overrides physical parameters (e.g.
    ``{"p0": 5e4}``).  The record holds at least problem, elements, ppc,
    basis, mass, dt, t_end, steps, rms_error, wall_seconds (stepping only; compilation is
    ``compile_seconds``) and grid_crossings.  ``series=False`` records no time series of
    the monitored particle (the study's figures need it, its tables do not);
    ``transfer`` is the particle-grid transfer (``"musl"``, ``"apic"``, ``"mls-mpm"``);
    ``transfer_params`` the transfer scheme's parameters and ``pic_fraction`` the PIC share
    of the MUSL velocity update among them (None: the problem's, 0 for all but the
    oedometer; see :class:`timpm.model.Model`); ``reuse=True`` keeps the
    scene for a later run with the same arguments (see :func:`clear_solvers`).  Solvers of
    one feature set share their compiled program, so a run after the first of its kind
    compiles nothing.  ``fields`` (a
    :class:`timpm.output.fields.FieldWriter`) receives the particle fields at ``frames``
    times spread evenly over the run, and at its start.  A ``t_end`` shorter than half a
    step is refused, and so is a run of more than :data:`~timpm.platform.checks.MAX_STEPS` steps
    unless ``allow_many_steps``.

    ``checkpoint`` (a file name) receives the whole state and the run's description every
    ``checkpoint_every`` steps, at the end, and when Ctrl-C stops the run inside
    :func:`timpm.platform.interrupt.deferred_sigint` (then :class:`~timpm.platform.interrupt.RunInterrupted`
    is raised carrying the partial ``result`` and the ``checkpoint`` written; there
    ``interrupted_to``, when given, names the file instead);
    ``resume`` (a :func:`timpm.simulation.checkpoint.load_checkpoint` dict) continues a saved run of
    the same arguments from its step (see :func:`resume_problem`).
    """
    given = dict(locals())  # the arguments: the first statement, before any other name
    from ..simulation.checkpoint import save_checkpoint
    from ..platform.interrupt import RunInterrupted

    if fields is not None and (isinstance(frames, bool) or not isinstance(frames, int)
                               or frames < 1):
        raise ValueError(f"frames must be a positive integer, got {frames!r}")
    if checkpoint_every is not None:
        if checkpoint is None:
            raise ValueError("checkpoint_every needs a checkpoint file")
        if (isinstance(checkpoint_every, bool) or not isinstance(checkpoint_every, int)
                or checkpoint_every < 1):
            raise ValueError("checkpoint_every must be a positive number of steps, got "
                             f"{checkpoint_every!r}")
    run = _plan(problem, {name: given[name] for name in RUN_OPTIONS}, reuse=reuse)
    description = None
    if isinstance(problem, str):
        model = run.scene.model
        description = dict(problem=problem, elements=run.elements, ppc=run.ppc,
                           basis=run.scene.basis.name, mass=model.mass_matrix,
                           dt=run.scene.dt, placement=run.placement,
                           stress_update=stress_update, damping=damping,
                           allow_unstable_dt=allow_unstable_dt, mode=mode,
                           record_every=run.every, params=dict(params or {}),
                           energies=bool(energies), projection=model.projection,
                           series=bool(series), transfer=transfer, pic_fraction=pic_fraction,
                           transfer_params=dict(transfer_params or {}),
                           integrator=model.integrator)
    steps = step_count(run.t_end, run.scene.dt, allow_many_steps)  # before any is built
    t_build = time.perf_counter()
    solver = Solver(run.scene, track=run.track, record_every=run.every, energies=energies,
                    mode=mode)
    build_seconds = time.perf_counter() - t_build
    try:
        if resume is not None:
            solver.restore(resume)
        if steps < solver.step:
            raise ValueError(f"t_end = {run.t_end:g} s lies before the saved run's time "
                             f"{solver.t:g} s (step {solver.step})")
        # the steps at which something is written: field frames, checkpoints
        stops, saves = {steps}, set()
        if fields is not None:
            start = solver.step
            stops.update(start + (steps - start) * k // frames for k in range(1, frames + 1))
            fields.write(solver)
        if checkpoint_every is not None:
            saves = set(range(solver.step + checkpoint_every, steps, checkpoint_every))
            stops.update(saves)
        saved = None  # the step of the last checkpoint this run wrote
        try:
            for stop in sorted(s for s in stops if s > solver.step):
                solver.run(n_steps=stop - solver.step, progress=progress,
                           allow_many_steps=allow_many_steps)
                if fields is not None:
                    fields.write(solver)
                if checkpoint is not None and stop in saves:
                    try:
                        save_checkpoint(checkpoint, solver, description)
                    except OSError as err:  # a full disk: stop here, the last one kept
                        raise _checkpoint_failed(err, checkpoint, solver, saved,
                                                 run.result(solver, build_seconds)) from None
                    saved = solver.step
        except SimulationError as err:  # a physics failure: the record of the run to there
            try:
                err.result = run.result(solver, build_seconds)
                err.result.record["failed"] = {"error": str(err), "code": int(err.code),
                                               "step": int(err.step)}
            except Exception:  # (a state too broken for the record: the error alone)
                err.result = None
            raise
        except RunInterrupted as stop:
            to = interrupted_to or checkpoint
            if to is not None:
                stop.checkpoint = save_checkpoint(to, solver, description)
            stop.result = run.result(solver, build_seconds)
            stop.result.record["interrupted"] = True
            raise
        if checkpoint is not None:
            try:
                save_checkpoint(checkpoint, solver, description)  # the end
            except OSError as err:  # the run's record is not lost with its checkpoint
                err.result = run.result(solver, build_seconds)
                raise
        return run.result(solver, build_seconds)
    finally:
        solver.release()


def _checkpoint_failed(err, path, solver, saved, result):
    """A periodic checkpoint that could not be written (a full disk: ENOSPC): the run stops
    at that step rather than go on without a state to restart from (the next saves, and
    the outputs at the end, would meet the same disk).  The file keeps the last checkpoint
    written whole (``saved``: its step; the writer replaces the file only once the new one
    is complete), and the error carries the record of the run to the step it stopped at
    (``result``, marked ``checkpoint_failed``) for the caller to write."""
    from ..platform.files import OutputError

    kept = (f"{path} still holds the checkpoint of step {saved}, whole (timpm resume "
            f"{path} --t-end T, once there is room)" if saved is not None else
            f"this run wrote no checkpoint before it: {path} is as it was")
    reason = f"{err.strerror or err}" + (" (the disk is full)"
                                         if err.errno == errno.ENOSPC else "")
    message = (f"{reason}: the periodic checkpoint of step {solver.step} (t = {solver.t:g} s) "
               f"failed and the run stopped there; {kept}")
    result.record["checkpoint_failed"] = {"error": message, "step": int(solver.step),
                                          "kept_step": saved}
    out = OutputError(err.errno, message, os.fspath(path))
    out.result = result
    return out


def resume_problem(path, t_end, saved=None, **options) -> RunResult:
    """Continue the run saved in ``path`` (a file written by ``run_problem(...,
    checkpoint=...)`` or ``timpm run --checkpoint``) to ``t_end``, in this process, with the
    saved run's arguments; ``saved``: the file's ``load_checkpoint`` where the caller read
    it already; ``options`` are run_problem's output and progress options (``fields``,
    ``frames``, ``checkpoint``, ``checkpoint_every``, ``progress``)."""
    from ..simulation.checkpoint import load_checkpoint

    if saved is None:
        saved = load_checkpoint(path)
    if saved["run"] is None:
        raise ValueError(f"checkpoint {path}: it holds no description of its run (it "
                         "was written from Python without one): build the solver of the "
                         "same scene and call solver.restore(load_checkpoint(...))")
    if "problem" not in saved["run"]:
        raise ValueError(f"checkpoint {path}: it holds a run of the scene file "
                         f"{saved['run'].get('scene_file')!r}: continue it with timpm "
                         "resume or timpm.scenefile.resume_scene")
    allowed = {"fields", "frames", "checkpoint", "checkpoint_every", "interrupted_to",
               "progress", "mode", "allow_many_steps"}
    unknown = set(options) - allowed
    if unknown:
        raise ValueError(f"resume_problem takes only {sorted(allowed)}, got {sorted(unknown)}")
    kwargs = dict(saved["run"])
    kwargs.update(options)
    return run_problem(kwargs.pop("problem"), t_end=t_end, resume=saved, **kwargs)


#: the arguments of :func:`run_problem` that build a run's scene and say what it records
#: (one :class:`_Run` each)
RUN_OPTIONS = ("elements", "ppc", "basis", "mass", "dt", "t_end", "placement", "stress_update",
               "damping", "allow_unstable_dt", "record_every", "params", "energies",
               "projection", "series", "transfer", "pic_fraction", "transfer_params",
               "integrator")


def _run_options(elements, options) -> dict:
    """The ``RUN_OPTIONS`` of ``run_problem(..., elements=elements, **options)``, its
    defaults filled in (an unknown option raises TypeError, as run_problem would)."""
    given = inspect.signature(run_problem).bind(None, elements=elements, **options)
    given.apply_defaults()
    return {name: given.arguments[name] for name in RUN_OPTIONS}


def _plan(problem, options, reuse=True):
    """The :class:`_Run` of ``options`` (``RUN_OPTIONS`` by name); with ``reuse`` one built
    earlier from equal options (a problem named by a string, hashable values), whose scene
    is then built once: a warm study spends no time on its scenes."""
    key = None
    if reuse and isinstance(problem, str):
        # the physical params are a dict: its items stand for it
        key = (problem, *((name, tuple(sorted(value.items())) if isinstance(value, dict)
                           else value) for name, value in sorted(options.items())))
        try:
            hash(key)
        except TypeError:
            key = None
    run = _PLANS.pop(key, None) if key is not None else None
    if run is None:
        run = _Run(problem, **options)
    if key is not None:
        _keep(_PLANS, key, run)
    return run


class _Run:
    """One run of a problem: its scene and what is recorded, then its result (a run keeps
    no state of its own: :func:`_plan` may hand the same one out again)."""

    def __init__(self, problem, *, elements, ppc, basis, mass, dt, t_end, placement,
                 stress_update, damping, allow_unstable_dt, record_every, params, energies,
                 projection, series, transfer, pic_fraction, transfer_params, integrator):
        self.prob = prob = get_problem(problem, **(params or {}))
        self.elements = prob.elements if elements is None else elements
        self.ppc = prob.ppc if ppc is None else ppc
        self.t_end = prob.t_end if t_end is None else finite("t_end", t_end)
        if not self.t_end > 0:
            raise ValueError(f"t_end must be a positive time, got {t_end!r}")
        placement = prob.placement if placement is None else placement
        self.placement, self.stress_update = placement, stress_update
        self.energies, self.series = bool(energies), bool(series)
        self.scene = prob.scene(elements=self.elements, ppc=self.ppc, basis=basis, mass=mass,
                                dt=dt, placement=placement, stress_update=stress_update,
                                allow_unstable_dt=allow_unstable_dt, damping=damping,
                                projection=projection, transfer=transfer,
                                pic_fraction=pic_fraction, transfer_params=transfer_params,
                                integrator=integrator)
        self.projection = self.scene.model.projection
        self.x0 = self.scene.positions.copy()
        self.monitor = prob.monitored_particle(self.x0)
        self.track = [self.monitor] if series else []
        steps = step_count(self.t_end, self.scene.dt, allow_many_steps=True)
        if steps == 0:
            raise ValueError(f"t_end = {self.t_end:g} s is shorter than half a time step "
                             f"(dt = {self.scene.dt:g} s): the run would take no step")
        self.every = (_default_record_every(steps) if record_every is None
                      else whole("record_every", record_every))

    def result(self, solver, build_seconds, state=None) -> RunResult:
        """The run's result from the solver, or from its ``state`` read by the batch."""
        prob, x0, monitor, stress_update = self.prob, self.x0, self.monitor, self.stress_update
        scene = self.scene
        if state is None:
            state = {"t": solver.t, "u": solver.displacements(), "step": solver.step,
                     "grid_crossings": solver.grid_crossings() if solver.track_crossings
                     else None}
        t, u = state["t"], state["u"]
        exact = prob.displacement(x0, t, stress_update=stress_update) if prob.has_exact else None
        series = {}
        if self.series:
            # the monitored particle's time series (in 2D and 3D: its x component)
            rec = solver.tracked()
            first = (lambda a: a[:, 0]) if x0.ndim == 1 else (lambda a: a[:, 0, 0])
            u_monitor = rec["u"] if x0.ndim == 1 else rec["x"] - x0[monitor]
            stress = rec["stress"][:, 0] if x0.ndim == 1 else rec["stress"][:, 0, 0, 0]
            series = {"t": rec["t"], "particle": monitor,
                      "x0": float(np.ravel(x0[monitor])[0]), "u": first(u_monitor),
                      "v": first(rec["v"]), "stress": stress}
            if prob.has_exact:
                at = x0[monitor:monitor + 1]
                series["u_exact"] = np.array([np.ravel(prob.displacement(
                    at, s, stress_update=stress_update))[0] for s in series["t"]])
                series["v_exact"] = np.array([np.ravel(prob.velocity(at, s))[0]
                                              for s in series["t"]])
        en = solver.energies() if self.energies else None
        record = {
            "problem": prob.name, "elements": int(self.elements), "ppc": int(self.ppc),
            "basis": scene.basis.name, "mass": scene.mass, "dt": scene.dt, "t_end": t,
            "steps": state["step"], "rms_error": rms_error(u, exact) if exact is not None else None,
            "wall_seconds": solver.run_seconds, "compile_seconds": solver.compile_seconds,
            "build_seconds": build_seconds, "grid_crossings": state["grid_crossings"],
            "particles": scene.n_particles, "placement": self.placement,
            "stress_update": stress_update, "projection": self.projection,
            "transfer": solver.transfer, "integrator": scene.model.integrator,
            "mode": solver.mode,
            "critical_dt": scene.critical_dt, "monitored_particle": monitor,
            # damping and Darcy's drag dissipate energy by design: no conservation measure
            "energy_drift": (energy_drift(en) if en is not None and scene.damping == 0
                             and not _dissipates(scene.model) else None),
        }
        if scene.mass == "consistent":
            record["negative_pivots"] = solver.negative_pivots()
        record.update(prob.summary(x0, solver, stress_update))
        return RunResult(record, x0.copy(), u, exact, series, en)


def _dissipates(model) -> bool:
    """The model dissipates energy besides damping: the drag of flowing pore water."""
    return model.water is not None and model.water.analysis == "coupled"


#: runs (their scenes) by the arguments that built them (oldest first)
_PLANS: "OrderedDict[tuple, _Run]" = OrderedDict()
KEEP = {"plans": 64}


def _keep(cache, key, item):
    """Keep ``item`` under ``key``, forgetting the oldest beyond the cache's limit."""
    cache[key] = item
    while len(cache) > KEEP["plans"]:
        cache.popitem(last=False)


def clear_solvers():
    """Forget the scenes kept for later runs with the same arguments."""
    _PLANS.clear()


def convergence(problem="vibrating-string", elements=(4, 8, 16, 32, 64), batch=False,
                workers=None, dask=None, **kwargs) -> dict:
    """Run the problem on each mesh; returns the records and the observed rates.

    ``batch=True`` runs the meshes side by side, one thread each (:class:`timpm.Batch` of
    fused serial solvers): the records' wall seconds are then the batch's, shared by all
    runs.  ``workers=N`` runs them in N worker processes, ``dask`` on a Dask cluster (an
    address, or "local"; :mod:`timpm.studies.sweep`): the records are those of this
    serial loop, in its order, but for the times; no progress line is drawn there.
    No time series of the monitored particle is recorded by default: the records do not
    hold one.  Interrupted (Ctrl-C, SIGTERM, SIGHUP), it raises
    :class:`~timpm.studies.sweep.SweepInterrupted` carrying the record of the meshes done.
    """
    kwargs.setdefault("series", False)
    if len(elements) == 0:
        raise ValueError("give at least one number of elements")
    check_executor(workers, dask)
    remote = workers is not None or dask is not None
    if batch and remote:
        raise ValueError("batch runs the meshes side by side in this process: give batch "
                         "or workers / dask, not both")
    distinct("elements", elements, "give each mesh once (a rate compares two different meshes)")
    if batch:
        records = [r.record for r in _batch_runs(problem, elements, **kwargs)]
    else:
        if remote:
            _check_options(problem, elements[0], kwargs)
            kwargs = {**kwargs, "progress": False}
        records = []
        with interruptible(lambda: _convergence_doc(problem, records), len(elements)):
            map_runs(_mesh_record, [(problem, n, kwargs) for n in elements],
                     workers=workers, dask=dask, cost=list(elements),
                     on_result=lambda _, record: records.append(record))
    return _convergence_doc(problem, records)


def _convergence_doc(problem, records) -> dict:
    """The record of a convergence sweep's ``records`` (those done, when interrupted)."""
    doc = {"problem": records[0]["problem"] if records else problem, "runs": records}
    errors = [r["rms_error"] for r in records]
    if all(e is not None for e in errors):
        doc["rates"] = observed_rates([r["elements"] for r in records], errors)
    return doc


def _check_options(problem, elements, options) -> None:
    """Build the scene of one mesh here (NumPy only), so that a bad option raises before
    worker processes start."""
    _plan(problem, _run_options(elements, options), reuse=options.get("reuse", True))


def _mesh_record(problem, elements, options) -> dict:
    """The record of one mesh of :func:`convergence` (a task of its sweep)."""
    return run_problem(problem, elements=elements, **options).record


def _batch_runs(problem, elements, *, mode="serial", progress=None, reuse=True,
                allow_many_steps=False, **options):
    """The runs of ``elements`` side by side (``options``: run_problem's)."""
    if mode != "serial":
        raise ValueError("a batch runs fused serial solvers: mode must be 'serial'")
    per_mesh = [_run_options(n, options) for n in elements]  # an unknown name raises here
    other = sorted(set(options) - set(RUN_OPTIONS))
    if other:
        raise ValueError(f"a batch writes no outputs of its own: {', '.join(other)} "
                         "apply to single runs (run_problem)")
    runs = [_plan(problem, run_options, reuse=reuse) for run_options in per_mesh]
    energies = runs[0].energies
    if len({r.t_end for r in runs}) != 1:
        raise ValueError("the runs of a batch share t_end")
    for r in runs:
        step_count(r.t_end, r.scene.dt, allow_many_steps)
    t_build = time.perf_counter()
    batch = Batch([Solver(r.scene, track=r.track, record_every=r.every, energies=energies,
                          mode="serial") for r in runs])
    build_seconds = time.perf_counter() - t_build
    try:
        batch.run(runs[0].t_end, progress=progress, allow_many_steps=allow_many_steps)
        states = batch.states() or [None] * len(runs)
        return [r.result(s, build_seconds, state)
                for r, s, state in zip(runs, batch.solvers, states)]
    finally:
        for s in batch.solvers:
            s.release()
        batch.release()


def compare_large_column(elements=30, ppc=50, dt=1e-3, t_end=3.0, basis="linear",
                         mass="lumped", allow_many_steps=False) -> dict:
    """MPM against the updated-Lagrangian FEM on the large-deformation column of A.5.

    Returns the position over time of the point initially at y = 0.5 m from both (the MPM
    particle just below it, the ULFEM node at it), and the oscillation periods taken, as
    the study does, from successive maxima of the potential (strain + gravitational) energy:
    it peaks at both turning points, so the period is twice the spacing of its maxima.
    """
    from .ulfem import large_column, period_from_maxima

    mpm = run_problem("large-column", elements=elements, ppc=ppc, dt=dt, t_end=t_end,
                      basis=basis, mass=mass, record_every=1,
                      allow_many_steps=allow_many_steps)
    fem = large_column(n_elements=elements, dt=dt, t_end=t_end)
    en = mpm.energies
    potential = en["strain"] + en["gravity"]
    return {
        "mpm": {"t": mpm.series["t"], "position": mpm.series["x0"] + mpm.series["u"],
                "period": 2.0 * period_from_maxima(en["t"], potential),
                "position_period": period_from_maxima(mpm.series["t"], mpm.series["u"]),
                "record": mpm.record},
        "ulfem": {"t": fem["t"], "position": fem["position"], "period": fem["period"],
                  "position_period": fem["position_period"]},
        "study_periods": {"mpm": 0.374, "ulfem": 0.364},
    }


def displacement_fields(problem="vibrating-string", elements=4, ppc=4, dt=1e-3, t_end=0.5,
                        variants=(("lagrange2", "consistent"), ("linear", "lumped")),
                        points_per_element=1000) -> dict:
    """u_h(x) = sum_i phi_i(x) u_i on a fine grid of points for each (basis, mass), with
    the exact displacement (the study's Figures 5.5 and 5.6)."""
    prob = get_problem(problem)
    x = np.linspace(0.0, prob.domain_length(), elements * points_per_element + 1)
    out = {"x": x, "problem": prob.name, "elements": elements, "fields": {}}
    for basis, mass in variants:
        scene = prob.scene(elements=elements, ppc=ppc, basis=basis, mass=mass, dt=dt)
        solver = Solver(scene, grid_displacement=True, energies=False)
        try:
            solver.run(t_end)
            out["fields"][f"{basis}, {mass}"] = solver.displacement_field(x)
            out["t"] = solver.t
        finally:
            solver.release()
    out["exact"] = prob.displacement(x, out["t"])
    return out
