"""Speed against error: which basis and mesh reaches a given accuracy cheapest?

``timpm study speed-error <problem>`` sweeps basis, mass matrix, number of elements and
particles per element (PPC), measures the RMS displacement error against the exact
solution and the wall time of every run, and writes a table, a log-log plot of error
against wall time with the Pareto front marked (:func:`timpm.output.viz.plot_speed_error`)
and, for target errors, the cheapest configuration per basis and its speed-up over linear
elements.

Time step rule
--------------
The study's time integration (Euler-Cromer) is first order in time, so at a fixed time
step the time error puts a floor under the error that a finer mesh or a higher-order
basis cannot go below; compared at one dt, a high-order basis would look no better than
linear.  So every configuration gets its own time step, chosen so that the time error
does not hide the spatial error:

1. ``dt0 = min(problem's default dt, 0.5 * critical dt)`` of that discretisation (the
   critical dt is Eq. 2.4 for linear elements with lumped mass, 2 / w_max of the particle
   discretisation otherwise), rounded down so that it divides ``t_end``:
   ``dt0 = t_end / ceil(t_end / dt0)``;
2. run at ``dt`` and ``dt / 2``; while ``|e(dt) - e(dt/2)| > dt_tolerance * e(dt/2)``
   (halving the step would change the error by more than 10 %: the time error hides
   more than about a tenth of the spatial error), halve ``dt``, at most ``max_halvings``
   times;
3. accept the coarser step of the first pair that passes (the cheapest step whose error
   is, to within ``dt_tolerance``, the spatial error).  If no pair passes, the finest
   step tried is kept and the run is flagged "time error not separated" (``!`` in the
   table, hollow marker in the plot): its error still contains time error.

Each record keeps the accepted ``dt``, its error ``rms_error`` and the time-error
estimate ``time_error_estimate = |e(dt) - e(dt/2)|`` (for a first-order scheme this is
about the time error at ``dt / 2``, half the time error at ``dt``), and all trials in
``dt_trials``.

The rule measures rather than assumes the time error, and it often finds it tiny: a
run that starts with zero acceleration (the vibrating string: u = 0 at t = 0) is
Euler-Cromer started exactly like the second-order leapfrog scheme, and the string's
time error at dt = 1e-4 s is ~1e-11 m.  An error that stops falling with the mesh while
the time error is separated is not time error; the report lists such stalls.  (Measured:
the string's floor of 1.2e-8 m for cubic B-splines is the same at dt = 1e-4 and 1e-5 s
and halves with the small-strain stress update: it is the finite-deformation MPM against
the linear exact solution.)

Wall time
---------
``wall_seconds`` is the stepping time of a run to ``t_end`` at the accepted ``dt``:
kernel compilation (``compile_seconds``, reported apart) and energy recording are
excluded, no particle is tracked.  It is the minimum over ``repeats`` timed runs, the
usual estimate on a shared, noisy machine.  The timed runs advance a solver of the
accepted run's scene by the same number of steps (the work per step does not depend on
the state) on the program already compiled, so they cost no further compilation.  The
accepted run itself is not a sample (its time is kept as ``first_run_seconds``): the
first run of a solver carries one-time costs (Taichi compiles its field accessors on
first use, the first launches warm up) that are far larger than the stepping of a small
1D run - e.g. 3.5 ms against 0.4 ms for 1000 steps of the 4-element string.  Each run of
the dt trials is released as soon as its error is known, and the timed runs advance a new
solver of the accepted run's scene: it takes the compiled program over with nothing to
save (a finer trial had displaced the accepted run's state, and keeping that state cost a
kernel build per feature set).
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..platform.argtypes import add_runtime_arguments, non_negative_int, param, positive_float, positive_int
from ..platform.checks import distinct, whole
from ..bases import BASES, basis_argument, get_basis
from ..engine.features import MODES
from ..problems import PROBLEMS, get_problem
from ..model.scene import MASS_KINDS, PLACEMENTS, STRESS_UPDATES
from .analysis import rms_error
from .sweep import add_arguments, check_executor, interruptible, map_runs
from .speed_error_report import (cheapest_for, default_targets, format_report, merge_studies,
                                 pareto_front, plateaus)

__all__ = ["speed_error_study", "merge_studies", "choose_dt", "pareto_front", "cheapest_for",
           "plateaus", "default_targets", "dt_rule_text", "format_report", "add_parser"]

RECORD_KEYS = ("problem", "basis", "mass", "elements", "ppc", "placement", "dt", "steps",
               "t_end", "rms_error", "time_error_estimate", "time_error_separated",
               "wall_seconds", "compile_seconds", "particles", "grid_crossings",
               "critical_dt", "projection", "integrator", "pareto")


# ---- one run --------------------------------------------------------------------------------

class _Run:
    """One simulation to ``t_end``: error against the exact solution and stepping time.

    Its solver is released once the record is taken; further timing samples advance a
    new solver of the same scene (``time_again``; ``release()`` frees it), which the
    compiled program serves without compiling again.  Nothing is tracked and no energy
    is recorded, so ``run_seconds`` is pure stepping; the error is the study's RMS error
    (3.2), as in :func:`timpm.studies.study.run_problem`.
    """

    def __init__(self, prob, *, elements, ppc, basis, mass, dt, t_end, placement, mode,
                 stress_update="study"):
        from ..simulation.solver import Solver

        scene = prob.scene(elements=elements, ppc=ppc, basis=basis, mass=mass, dt=dt,
                           placement=placement, stress_update=stress_update)
        x0 = scene.positions.copy()
        self.scene, self.mode, self.timer = scene, mode, None
        self.solver = Solver(scene, track=(), energies=False, mode=mode)
        try:
            self.solver.run(t_end, progress=False)
            s = self.solver
            exact = prob.displacement(x0, s.t, stress_update=stress_update)
            self.record = {
                "dt": scene.dt, "steps": s.step, "t_end": s.t,
                "rms_error": rms_error(s.displacements(), exact),
                "wall_seconds": s.run_seconds, "compile_seconds": s.compile_seconds,
                "particles": scene.n_particles, "grid_crossings": s.grid_crossings(),
                "critical_dt": scene.critical_dt, "mode": s.mode,
                # the problem's scheme for this basis and mass (mms-1d: mls, rk4; mms-2d: mls)
                "projection": scene.model.projection, "integrator": scene.model.integrator,
            }
        finally:
            self.solver.release()  # its state is not needed again: nothing to save
            self.solver = None

    def time_again(self) -> float:
        """Advance a solver of the same scene by the run's number of steps (a new one at
        the first call, from the initial state); its stepping seconds."""
        from ..simulation.solver import Solver

        if self.timer is None:
            self.timer = Solver(self.scene, track=(), energies=False, mode=self.mode)
        before = self.timer.run_seconds
        self.timer.run(n_steps=self.record["steps"], progress=False)
        return self.timer.run_seconds - before

    def release(self):
        if self.timer is not None:
            self.timer.release()
            self.timer = None


def _divides(t_end, dt):
    """The largest step <= dt that divides t_end into a whole number of steps."""
    n = max(1, math.ceil(t_end / dt * (1.0 - 1e-12)))
    return t_end / n


def critical_dt(prob, *, elements, ppc, basis, mass, placement) -> float:
    """The critical time step of a discretisation (raises ValueError for invalid ones)."""
    scene = prob.scene(elements=elements, ppc=ppc, basis=basis, mass=mass, dt=prob.dt,
                       placement=placement, allow_unstable_dt=True)
    return float(scene.critical_dt)


def choose_dt(run, dt0, dt_tolerance=0.1, max_halvings=4):
    """The time step rule (module docstring) for one configuration.

    ``run(dt)`` simulates at ``dt`` and returns an object with ``record["rms_error"]`` and
    ``release()``.  Returns ``(accepted_run, info)``; info holds ``dt``, ``rms_error``,
    ``time_error_estimate``, ``time_error_separated`` and ``dt_trials`` (list of
    ``[dt, error]``).  The accepted run is not released: the caller times it further.
    The other runs are released as soon as they cannot be accepted.
    """
    runs = [run(dt0)]
    trials = [[dt0, runs[0].record["rms_error"]]]
    try:
        for k in range(max_halvings + 1):
            dt = dt0 / 2 ** (k + 1)
            runs.append(run(dt))
            trials.append([dt, runs[-1].record["rms_error"]])
            e_coarse, e_fine = trials[k][1], trials[k + 1][1]
            diff = abs(e_coarse - e_fine)
            if diff <= dt_tolerance * e_fine:
                accepted, separated = k, True
                break
            # only the newest run can still be accepted later: free the older one
            runs[k].release()
        else:
            accepted, separated = max_halvings + 1, False
            diff = abs(trials[-2][1] - trials[-1][1])
    except BaseException:
        for r in runs:
            r.release()
        raise
    for r in runs[accepted + 1:]:  # the finer run of the accepted pair
        r.release()
    info = {"dt": trials[accepted][0], "rms_error": trials[accepted][1],
            "time_error_estimate": diff, "time_error_separated": separated,
            "dt_trials": trials}
    return runs[accepted], info


def dt_rule_text(dt_default, dt_tolerance=0.1, max_halvings=4) -> str:
    """The time step rule in one paragraph, for reports."""
    return (f"Time step per run: dt0 = min({dt_default:g} s (the problem's dt), 0.5 x critical "
            f"dt), rounded down to divide t_end; dt is halved (at most {max_halvings} times) "
            f"until halving it once more changes the RMS error by at most "
            f"{100 * dt_tolerance:g} % (|e(dt) - e(dt/2)| <= {dt_tolerance:g} e(dt/2)), and the "
            f"coarser dt of that pair is used: the Euler-Cromer time error then hides at most "
            f"~{100 * dt_tolerance:g} % of the spatial error.  Runs marked '!' did not separate "
            f"within {max_halvings} halvings (their error still contains time error).")


# ---- the sweep ------------------------------------------------------------------------------

def _as_tuple(value):
    if value is None:
        return None
    if isinstance(value, (str, int, np.integer)):
        return (value,)
    return tuple(value)


def speed_error_study(problem, bases=("linear", "bspline2", "bspline3"),
                      masses=("lumped", "consistent"), elements=(4, 8, 16, 32, 64), ppcs=None,
                      placement="study", t_end=None, dt_tolerance=0.1, max_halvings=4,
                      repeats=3, mode="auto", progress=print, combos=None,
                      stress_update="study", params=None, workers=None, dask=None) -> dict:
    """Sweep bases x masses x placements x elements x PPC; see the module docstring.

    ``combos``, a list of (basis, mass) pairs, replaces the product bases x masses;
    ``stress_update`` ("study" or "small") and ``params`` (physical parameters of the
    problem, e.g. ``{"gravity": -0.981}``) are passed on to every run.  ``workers=N``
    runs the configurations in N worker processes, ``dask`` on a Dask cluster (an address,
    or "local"; :mod:`timpm.studies.sweep`): the same records in the same order, but for
    the times, which are then taken with the other runs side by side.

    ``ppcs`` defaults to the problem's PPC; ``placement`` may be one name or several (then
    swept too).  Invalid combinations (a basis that cannot be lumped, too few particles
    per element, a singular mass matrix, a failed run) are skipped with a note in
    ``skipped``.  Returns a JSON-ready document: ``runs`` (records, each with a ``pareto``
    flag), ``skipped``, ``dt_rule`` and the settings.  Interrupted (Ctrl-C, SIGTERM,
    SIGHUP), it raises :class:`~timpm.studies.sweep.SweepInterrupted` carrying that
    document of the configurations done.
    """
    check_executor(workers, dask)
    prob = get_problem(problem, **(params or {}))
    if stress_update not in STRESS_UPDATES:
        raise ValueError(f"unknown stress_update {stress_update!r}: choose one of "
                         f"{', '.join(STRESS_UPDATES)}")
    if not prob.has_exact:
        raise ValueError(f"{prob.name} has no exact solution: no error to measure")
    repeats = whole("repeats", repeats)
    if not 0 < dt_tolerance < math.inf:
        raise ValueError(f"dt_tolerance must be positive, got {dt_tolerance!r}")
    max_halvings = whole("max_halvings", max_halvings, 0)
    t_end = float(prob.t_end if t_end is None else t_end)
    if not (math.isfinite(t_end) and t_end > 0):
        raise ValueError(f"t_end must be a positive time, got {t_end!r}")
    if combos is None:
        combos = [(b, m) for b in _as_tuple(bases) for m in _as_tuple(masses)]
    combos = [(get_basis(b).name, m) for b, m in combos]
    for _, m in combos:
        if m not in MASS_KINDS:
            raise ValueError(f"unknown mass {m!r}: choose one of {', '.join(MASS_KINDS)}")
    bases = tuple(dict.fromkeys(b for b, _ in combos))
    masses = tuple(dict.fromkeys(m for _, m in combos))
    placements = _as_tuple(placement)
    for p in placements:
        if p not in PLACEMENTS:
            raise ValueError(f"unknown placement {p!r}: choose one of {', '.join(PLACEMENTS)}")
    elements = tuple(whole("number of elements", n) for n in _as_tuple(elements))
    ppcs = ((prob.ppc,) if ppcs is None else
            tuple(whole("particles per element", p) for p in _as_tuple(ppcs)))
    if not elements or not ppcs or not combos or not placements:
        raise ValueError("give at least one basis, mass, placement, number of elements and PPC")
    distinct("elements", elements)
    distinct("ppcs", ppcs)
    prob.check_size(max(elements), max(ppcs))  # the largest run, before any is made
    say = progress or (lambda *a, **k: None)

    configurations = [dict(elements=n, ppc=ppc, basis=basis, mass=mass, placement=place)
                      for basis, mass in combos for place in placements for ppc in ppcs
                      for n in elements]
    settings = dict(t_end=t_end, mode=mode, stress_update=stress_update,
                    dt_tolerance=dt_tolerance, max_halvings=max_halvings, repeats=repeats)
    runs, skipped = [], []
    compiled = []  # compile seconds of every configuration, all its kernels included

    def collect(_, outcome):
        compiled.extend(outcome["compile_seconds"])
        if "skipped" in outcome:
            skipped.append(outcome["skipped"])
        else:
            runs.append(outcome["record"])
        say(outcome["note"])

    started = time.perf_counter()

    def document() -> dict:
        flags = pareto_front(runs)
        for rec, on in zip(runs, flags):
            rec["pareto"] = on
        return {
            "command": "speed-error", "problem": prob.name, "t_end": t_end,
            "stress_update": stress_update, "params": dict(params or {}),
            "problem_dt": prob.dt, "dt_tolerance": dt_tolerance,
            "max_halvings": max_halvings, "repeats": repeats,
            "dt_rule": dt_rule_text(prob.dt, dt_tolerance, max_halvings),
            "sweep": {"bases": list(bases), "masses": list(masses),
                      "combos": [list(c) for c in combos], "placements": list(placements),
                      "elements": list(elements), "ppcs": list(ppcs)},
            "runs": runs, "skipped": skipped,
            "sweep_seconds": time.perf_counter() - started,
            "compile_seconds": sum(compiled),
        }

    with interruptible(document, len(configurations)):
        map_runs(_configuration, [(prob, conf, settings) for conf in configurations],
                 workers=workers, dask=dask, on_result=collect,
                 cost=[c["elements"] * c["ppc"] for c in configurations])
    return document()


def _configuration(prob, conf, settings) -> dict:
    """One configuration of :func:`speed_error_study` (a task of its sweep): its dt chosen
    by the rule and its timed record, or why it was skipped.  Returns ``{"record": ...}``
    or ``{"skipped": ...}``, with ``note`` (the progress line) and ``compile_seconds``
    (a list of one entry: all the kernel compilation it caused, its scenes' stencils, the
    dt trials, the state uploads and saves and the readers included)."""
    from ..platform import runtime

    clock = runtime.compile_clock()
    outcome = _configuration_runs(prob, conf, settings)
    outcome["compile_seconds"] = [runtime.compile_clock() - clock]
    return outcome


def _configuration_runs(prob, conf, settings) -> dict:
    from ..simulation.solver import SimulationError

    t_end, mode, stress_update = settings["t_end"], settings["mode"], settings["stress_update"]
    repeats = settings["repeats"]
    tag = f"{conf['basis']}/{conf['mass']}/{conf['placement']} {conf['elements']} el x " \
          f"{conf['ppc']} PPC"

    def skip(reason, **extra):
        return {"skipped": {**conf, "reason": reason, **extra}, "note": f"skip {tag}: {reason}"}

    try:
        crit = critical_dt(prob, **conf)
    except ValueError as exc:
        return skip(str(exc))
    if not crit > 0:
        return skip("singular or indefinite mass matrix: no stable time step")
    dt0 = _divides(t_end, min(prob.dt, 0.5 * crit))
    tried = []

    def run(dt):
        tried.append(dt)
        r = _Run(prob, dt=dt, t_end=t_end, mode=mode, stress_update=stress_update, **conf)
        return r

    try:
        accepted, info = choose_dt(run, dt0, settings["dt_tolerance"], settings["max_halvings"])
    except (ValueError, SimulationError) as exc:
        return skip(f"run failed at dt = {tried[-1]:.4g} s: {exc}", dt=tried[-1])
    try:
        first = accepted.record["wall_seconds"]
        samples = []
        for _ in range(repeats):
            try:
                samples.append(accepted.time_again())
            except SimulationError:
                break  # beyond t_end the run failed: keep what we have
        rec = {"problem": prob.name, **conf, **accepted.record, **info,
               "wall_seconds": min(samples) if samples else first,
               "wall_samples": samples, "first_run_seconds": first,
               "dt0": dt0, "critical_dt": crit, "stress_update": stress_update}
    finally:
        accepted.release()
    rec["dt"], rec["rms_error"] = info["dt"], info["rms_error"]
    note = (f"{tag}: dt = {rec['dt']:.4g} s ({rec['steps']} steps"
            f"{'' if rec['time_error_separated'] else ', time error not separated'}),"
            f" e = {rec['rms_error']:.3e}, wall = {rec['wall_seconds']:.4f} s")
    return {"record": rec, "note": note}


# ---- command line -----------------------------------------------------------------------------

def add_parser(subparsers):
    """Add the ``speed-error`` command's arguments to an argparse subparsers object;
    returns its parser (``timpm.cli`` sets the function that runs it)."""
    p = subparsers.add_parser(
        "speed-error", help="RMS error against wall time over bases, meshes and PPC",
        description="Sweep basis, mass, elements and particles per element; per run choose dt "
                    "so that time error does not hide the spatial error, record RMS error and "
                    "wall time; print a table, the Pareto front and the cheapest configuration "
                    "per target error, with its speed-up over linear elements.")
    p.add_argument("problem", help=f"one of: {', '.join(n for n, c in PROBLEMS.items() if c.has_exact)}")
    p.add_argument("--bases", nargs="+", default=["linear", "bspline2", "bspline3"],
                   type=basis_argument,
                   help=f"bases to sweep (of: {', '.join(BASES)}); default linear bspline2 bspline3")
    p.add_argument("--masses", nargs="+", default=["lumped", "consistent"], choices=list(MASS_KINDS),
                   help="mass matrices to sweep (default: both)")
    p.add_argument("--elements", type=positive_int, nargs="+", default=[4, 8, 16, 32, 64],
                   help="numbers of elements (default: 4 8 16 32 64)")
    p.add_argument("--ppc", type=positive_int, nargs="+", help="particles per element (default: the problem's)")
    p.add_argument("--placement", nargs="+", default=["study"], choices=list(PLACEMENTS),
                   help="particle placement(s) in an element (default: study)")
    p.add_argument("--t-end", type=positive_float, help="end time [s] (default: the problem's)")
    p.add_argument("--stress-update", default="study", choices=list(STRESS_UPDATES),
                   help="study: sigma += (E - sigma) d_eps (2.2.4); small: sigma += E d_eps")
    p.add_argument("--param", type=param, action="append", default=[], metavar="NAME=VALUE",
                   help="override a physical parameter of the problem, e.g. gravity=-0.981")
    p.add_argument("--targets", type=positive_float, nargs="+",
                   help="target errors to answer for (default: decades within the sweep)")
    p.add_argument("--dt-tolerance", type=positive_float, default=0.1,
                   help="accept dt when |e(dt) - e(dt/2)| <= TOL e(dt/2) (default 0.1)")
    p.add_argument("--max-halvings", type=non_negative_int, default=4,
                   help="most halvings of dt (default 4)")
    p.add_argument("--repeats", type=positive_int, default=3,
                   help="timed runs per configuration, the minimum is kept (default 3)")
    p.add_argument("--mode", default="auto", choices=list(MODES))
    add_runtime_arguments(p)
    add_arguments(p)
    p.add_argument("--json", metavar="FILE", help="write runs, answers and settings as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="write the error-against-wall-time plot")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    return p
