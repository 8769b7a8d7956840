"""A slope's factor of safety by strength reduction (Griffiths & Lane 1999).

The strength of every Mohr-Coulomb material is divided by a trial factor F:

    c_F = c / F,   tan(phi_F) = tan(phi) / F,   psi_F = min(psi, phi_F),

and the scene (a scene file's world) runs from its initial state to its ``t_end``.  The
factor of safety is the F at which the slope stops standing, found by bisection between
a factor where it stands and one where it fails.

**Failure criterion.**  The slope has failed at F if its particles still move at the end
of the run: the largest particle displacement grows, over the last quarter of the run, by
more than ``creep`` times the height of the ground (default 1e-3: 1 cm on a 10 m slope).
Defence: a slope that stands, started from the K0 stress, settles by an elastic
displacement of order gamma H^2 / E (2 cm for Griffiths & Lane's slope) and, with the
local damping of the scene, comes to rest exponentially, so its last quarter adds
orders of magnitude less; a slope past its factor of safety has a mechanism (a band of
plastic strain from toe to crest) along which the mass slides on, accelerating, by
decimetres to metres over the same time.  On Griffiths & Lane's slope the factor found is
insensitive to ``creep`` within decades (the test checks a factor of 10: one bracket
width), because at F above the factor the motion is not small.  Where the mechanism
slides partly on a frictional floor the transition is gradual and the criterion moves the
factor (examples/large_slope.toml: -7% and +8% for ``creep`` ten times smaller and
larger, docs/results.md): the record states the criterion with the factor.  A run that
stops because material leaves the grid (or is crushed) has failed too; one that stops for
another reason (the energy guard: an instability) stops the study, since no factor can be
read from it.  The bracket is reported with the factor, which is its midpoint.

**Settings.**  The bracket lies in [0.01, 100] (``BRACKET``: the strength multiplied or
divided by at most a hundred; a factor of safety outside it is no slope's, and at 1e-20
the reduced friction angle is 90 degrees to the last digit), its ends given as
LOW < HIGH; the tolerance is at least 1e-4 (the factor is printed to four decimals;
the bisection then takes at most 20 trials); ``creep`` lies in (0, 0.1] (0 calls every
slope that moves at all failed, and above a tenth of the height a sliding mass is taken
for one that stands).  The scene built with its strength divided by each end of the
bracket is checked before the first trial: an initial stress the reduced soil cannot
hold (a given ``k0``) is refused naming k0 and the largest F that holds it.

**Interrupted and resumed.**  Ctrl-C, SIGTERM or SIGHUP during a trial stops the study with
:class:`StudyInterrupted`, whose ``partial`` record holds the trials finished and the
bracket so far (``"interrupted": true``); given back as ``resume`` (``timpm study
factor-of-safety FILE.toml --resume F.json``) its trials are taken for the runs they were
(the bisection's factors repeat exactly), so the study goes on where it stopped and ends
at the factor it would have found.
"""
import math
import os
import time
from dataclasses import replace

import numpy as np

from ..platform.errors import ErrorCode
from . import trial_pool
from .trial_pool import TrialPool

__all__ = ["reduced", "reduced_bodies", "trial", "factor_of_safety", "add_parser", "workers_for",
           "add_bisection_arguments", "plot_mechanism", "StudyInterrupted", "resumable_trials",
           "check_settings", "BRACKET", "MIN_TOLERANCE", "CREEP"]

#: the factors a bracket may span: the strength multiplied or divided by at most 100
BRACKET = (0.01, 100.0)
#: the finest tolerance: the factor is printed to four decimals
MIN_TOLERANCE = 1e-4
#: the largest creep (a fraction of the ground's height; the default is 1e-3)
CREEP = 0.1


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _shown(x) -> str:
    return f"{x:g}" if isinstance(x, (int, float)) and not isinstance(x, bool) else repr(x)


def check_settings(low, high, tolerance, creep):
    """The bisection's settings in range, before any work (a ValueError naming the option:
    the module's "Settings")."""
    lo, hi = BRACKET
    if not (_number(low) and _number(high) and lo <= low < high <= hi):
        why = ("LOW must be below HIGH" if _number(low) and _number(high) and low >= high
               else f"both ends must lie in [{lo:g}, {hi:g}]")
        raise ValueError(f"--bracket {_shown(low)} {_shown(high)}: {why} (the factors where "
                         f"the slope stands and fails, the strength multiplied or divided by "
                         f"at most {hi:g}); e.g. --bracket 0.5 4")
    if not (_number(tolerance) and MIN_TOLERANCE <= tolerance < high - low):
        raise ValueError(f"--tolerance {_shown(tolerance)}: the final bracket's width must lie in "
                         f"[{MIN_TOLERANCE:g}, HIGH - LOW) = [{MIN_TOLERANCE:g}, "
                         f"{high - low:g}) (the factor is printed to four decimals); the "
                         "default is 0.02")
    if not (_number(creep) and 0.0 < creep <= CREEP):
        raise ValueError(f"--creep {_shown(creep)}: the failure criterion's creep must lie in (0, "
                         f"{CREEP:g}] (a fraction of the ground's height moved over the last "
                         "quarter of the run: 0 calls every slope that moves failed, above "
                         f"{CREEP:g} a sliding mass passes for standing); the default is 1e-3")


class StudyInterrupted(Exception):
    """Ctrl-C, SIGTERM or SIGHUP stopped the study between or during its trials:
    ``partial`` is its record so far (the trials finished, the bracket, ``"interrupted":
    true``)."""

    def __init__(self, partial: dict):
        done = len(partial["trials"])
        super().__init__(f"interrupted after {done} trial{'s' * (done != 1)} (bracket "
                         f"{partial['bracket'][0]:.4f} to {partial['bracket'][1]:.4f})")
        self.partial = partial


#: the settings a resumed study must share with the record it resumes
RESUME_KEYS = ("t_end", "creep", "tolerance", "particles", "h", "basis", "transfer")


def resumable_trials(record, settings) -> dict:
    """The trials of an earlier (interrupted) study's ``record``, F -> trial, checked
    against this study's ``settings`` (``RESUME_KEYS``): a record of another scene or
    other settings is refused, naming what differs."""
    return resumed_entries(record, settings, RESUME_KEYS, "factor-of-safety",
                           "a factor-of-safety study", "trials", "F", float, "a trial")


def resumed_entries(record, settings, keys, study, described, entries, index, kind,
                    entry) -> dict:
    """The entries (``record[entries]``, index -> entry by their ``index`` of type
    ``kind``, each with its ``failed``) of an interrupted ``study``'s record, checked:
    another study's record, or one whose ``keys`` differ from ``settings``, is refused,
    naming what differs (the factor of safety's trials, the Monte Carlo realisations)."""
    if not isinstance(record, dict) or record.get("study") != study \
            or not isinstance(record.get(entries), list):
        raise ValueError(f"--resume takes the JSON record of {described} (its --json file)")
    for key in keys:
        if record.get(key) != settings[key]:
            raise ValueError(f"--resume: the record's {key} is {record.get(key)!r}, this "
                             f"study's {settings[key]!r}: it is another study's record")
    out = {}
    for r in record[entries]:
        if not (isinstance(r, dict) and isinstance(r.get(index), kind)
                and isinstance(r.get("failed"), bool)):
            raise ValueError(f"--resume: {entry} of the record is not one this study wrote: "
                             f"{r!r}")
        out[r[index]] = r
    return out


def reduced(material, F):
    """A Mohr-Coulomb material's strength divided by F (:meth:`MohrCoulomb.reduced`)."""
    from ..materials import MohrCoulomb

    if not isinstance(material, MohrCoulomb):
        raise ValueError(f"strength reduction divides the strength of Mohr-Coulomb soil; "
                         f"{material.name} has none to divide (make it mohr-coulomb)")
    return material.reduced(F)


def reduced_bodies(world, F):
    """The world's bodies, each Mohr-Coulomb one's strength divided by F (the others, an
    elastic base or a structure, as they are); a world without Mohr-Coulomb soil is
    refused, naming its bodies and their materials."""
    from ..materials import MohrCoulomb

    if not any(isinstance(b.material, MohrCoulomb) for b in world.bodies):
        names = ", ".join(f"{b.name or f'body {k}'} ({b.material.name})"
                          for k, b in enumerate(world.bodies))
        raise ValueError(f"strength reduction divides the strength of Mohr-Coulomb soil, and "
                         f"no body is of it: {names} (make the slope's material "
                         "mohr-coulomb)")
    return tuple(replace(b, material=reduced(b.material, F))
                 if isinstance(b.material, MohrCoulomb) else b for b in world.bodies)


#: the parts of a trial's last quarter after each of which its motion is read (a failing
#: trial stops at the first part that decides it)
LAST_QUARTER_PARTS = 8

#: a trial records its energies every this many steps: the energy guard reads them (an
#: instability grows over many more steps), nothing else does (Griffiths & Lane's slope
#: at F = 1.2, a trial to t_end warm: 3.93 s recording every step, 2.10 s every 10th;
#: python /tmp/onetrial.py-style timing of fos.trial, 2026-12-03)
RECORD_EVERY = 10

#: the stops of a run whose mass slid away (off the grid) or was crushed: it failed
SLID = (ErrorCode.OFF_GRID, ErrorCode.VOLUME_RANGE, ErrorCode.INVERTED)


def ground_height(world):
    y = world.model.positions[:, 1]
    return float(y.max() - y.min())


def trial(world, F, t_end, creep=1e-3, mode="auto", run_on=None):
    """Run ``world`` with its soil's strength divided by ``F`` to ``t_end``: whether it
    failed (see the module), the largest displacement at 3/4 and at the end, the
    particles' plastic strain and positions at the end.  ``run_on``: a failed run goes on
    to that time (its run-out: ``displacement_run_on``, the positions and plastic strain
    then; it stops early where its mass leaves the grid)."""
    from ..platform.errors import SimulationError
    from ..model.geostatic import GravityLoading
    from ..simulation.loading import NotAtRest, gravity_loading
    from ..simulation.solver import Solver

    start = time.perf_counter()
    bodies = reduced_bodies(world, F)
    try:
        w = replace(world, bodies=bodies)
    except ValueError as err:  # (an initial stress the reduced soil cannot hold)
        raise ValueError(f"the trial at F = {F:g}: {err}") from None
    if isinstance(w.initial_stress, GravityLoading):
        try:  # the ground loaded under gravity with the reduced strength
            w, _ = gravity_loading(w)
        except (NotAtRest, SimulationError) as err:
            # it did not come to rest, or slid off the grid: it fails under its weight
            if isinstance(err, SimulationError) and err.code not in SLID:
                raise SimulationError(f"the gravity loading at F = {F:g} stopped: {err}",
                                      err.code, err.step, err.particle, err.node) from None
            return {"F": float(F), "stopped": str(err), "failed": True,
                    "displacement_three_quarters": math.inf, "displacement_end": math.inf,
                    "creep": math.inf, "creep_limit": creep * ground_height(world),
                    "wall_seconds": time.perf_counter() - start}
    s = Solver(w, energies=True, record_every=RECORD_EVERY, mode=mode)
    out = {"F": float(F), "stopped": None}
    displacement = _Displacement(w, s)
    limit = creep * ground_height(world)
    try:
        d1 = displacement.run_to(0.75 * t_end)
        d2 = d1
        # the last quarter in parts: decided as soon as the mass has moved on by more
        # than the limit (see the module: a failing trial stops there)
        for k in range(1, LAST_QUARTER_PARTS + 1):
            if not math.isfinite(d2):
                break
            t = t_end
            if k < LAST_QUARTER_PARTS:
                t = (0.75 + 0.25 * k / LAST_QUARTER_PARTS) * t_end
            d2 = displacement.run_to(t)
            if d2 - d1 > limit and k < LAST_QUARTER_PARTS:
                out["decided_at"] = float(s.t)
                break
    except SimulationError as err:
        if err.code not in SLID:
            s.release()  # an instability, not a slope that slid away: no factor from it
            raise SimulationError(f"the run at F = {F:g} stopped: {err}", err.code, err.step,
                                  err.particle, err.node) from None
        out["stopped"] = str(err)  # the mass ran off the grid or crushed: it failed
        d1 = d2 = math.inf
    out.update(displacement_three_quarters=d1, displacement_end=d2,
               creep=d2 - d1 if math.isfinite(d2) else math.inf, creep_limit=limit,
               failed=bool(out["stopped"]) or not math.isfinite(d2) or (d2 - d1) > limit)
    if run_on is not None and out["failed"] and out["stopped"] is None and run_on > s.t:
        try:  # the failed mass runs on (a Monte Carlo study's run-out)
            out["displacement_run_on"] = displacement.run_to(run_on)
        except SimulationError as err:
            if err.code not in SLID:
                s.release()
                raise SimulationError(f"the run at F = {F:g} stopped running on: {err}",
                                      err.code, err.step, err.particle, err.node) from None
            out["stopped_running_on"] = str(err)
        out["run_on"] = float(s.t)
    if out["stopped"] is None and math.isfinite(d2) and "stopped_running_on" not in out:
        out["positions"] = s.positions()
        out["plastic"] = s.read("plastic")
    s.release()
    out["wall_seconds"] = time.perf_counter() - start
    return out


def pool_trial(F):
    """:func:`trial` at ``F`` in a worker of the trial pool (its world and settings)."""
    s = trial_pool.study()
    return trial(s["world"], F, s["t_end"], s["creep"], s["mode"])


class _Displacement:
    """The largest particle displacement of a trial's run from the world's positions; along
    a periodic x from the unwrapped positions (x + laps L: each particle counts the periods
    it has wrapped)."""

    def __init__(self, world, solver):
        self.solver, self.X = solver, world.model.positions
        m = world.model
        self.period = m.elements[0] * m.h if m.periodic else None

    def run_to(self, t_end):
        s = self.solver
        s.run(t_end=t_end)
        x = s.positions()
        if self.period is not None:
            x[:, 0] += self.period * s.read("laps")
        return float(np.linalg.norm(x - self.X, axis=1).max())


def factor_of_safety(world, t_end, low=0.5, high=4.0, tolerance=0.02, creep=1e-3,
                     mode="auto", progress=None, resume=None, workers=1):
    """Bisect on F between ``low`` (the slope must stand) and ``high`` (it must fail) until
    the bracket is at most ``tolerance`` wide; returns the record (``factor_of_safety``,
    ``bracket``, every trial) and the last failed trial (its mechanism).  ``workers`` > 1:
    that many trials at once, each in a worker process of one thread
    (:class:`~timpm.studies.trial_pool.TrialPool`), at the points that split the bracket
    into ``workers`` + 1 equal parts (two workers: a third of the bracket per round).
    ``resume``: an interrupted study's record, whose trials stand for the runs they were
    (the module); interrupted, raises :class:`StudyInterrupted` with the record so far."""
    check_settings(low, high, tolerance, creep)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"--workers must be a whole number of processes, at least 1, got "
                         f"{workers!r}")
    if not (isinstance(t_end, (int, float)) and math.isfinite(t_end) and t_end > 0.0):
        raise ValueError(f"the factor of safety needs a run of positive length: t_end = "
                         f"{t_end!r}")
    if not any(world.model.gravity):
        raise ValueError("the slope has no weight (gravity is zero): it cannot fail, and no "
                         "factor of safety can be read")
    check_reduced(world, low, high)
    t0 = time.perf_counter()
    trials = []
    settings = {"t_end": t_end, "creep": creep, "tolerance": tolerance,
                "particles": world.model.n_particles, "h": world.h, "basis": world.basis.name,
                "transfer": world.transfer}
    done = {} if resume is None else resumable_trials(resume, settings)
    pool = None

    def run_many(factors):
        todo = [F for F in factors if F not in done]
        if pool is not None and todo:  # (one at a time too: compiled there)
            ran = dict(zip(todo, pool.map(pool_trial, todo)))
        else:
            ran = {F: trial(world, F, t_end, creep, mode) for F in todo}
        out = []
        for F in factors:
            r = done.get(F) or ran[F]
            trials.append(r)
            if progress is not None:
                progress(f"F = {F:.4f}: {'fails' if r['failed'] else 'stands'} (from the "
                         "resumed record)" if F in done else
                         f"F = {F:.4f}: {'fails' if r['failed'] else 'stands'} (largest "
                         f"displacement {r['displacement_end']:.3g} m, {r['creep']:.3g} m in "
                         f"the last quarter; limit {r['creep_limit']:.3g} m)")
            out.append(r)
        return out

    def record(low, high):
        return {
            "study": "factor-of-safety", "factor_of_safety": 0.5 * (low + high),
            "bracket": [low, high], **settings, "workers": workers,
            "criterion": f"failed where the largest particle displacement grows by more "
                         f"than {creep:g} x the ground's height over the last quarter of "
                         f"the run",
            "height": ground_height(world), "wall_seconds": time.perf_counter() - t0,
            "trials": [{k: v for k, v in r.items() if k not in ("positions", "plastic")}
                       for r in trials]}

    def check_ends(ends, results):
        for (F, should_fail), r in zip(ends, results):
            if r["failed"] != should_fail:
                raise ValueError(f"the slope {'fails' if not should_fail else 'stands'} at "
                                 f"the bracket's {'low' if not should_fail else 'high'} end F "
                                 f"= {F:g}: widen the bracket (--bracket LOW HIGH)")

    failed = None
    try:
        if workers == 1:  # the low end first: a bracket that does not hold stops after one trial
            check_ends([(low, False)], run_many([low]))
            failed = run_many([high])[0]
            check_ends([(high, True)], [failed])
        else:
            pool = TrialPool(world, t_end, creep, workers, mode)
        low0, high0 = low, high
        while high - low > tolerance:
            if workers == 1:
                points = [0.5 * (low + high)]
            else:
                points = [low + (high - low) * k / (workers + 1) for k in range(1, workers + 1)]
            # the first point that fails bounds the factor above, the one before it below
            for F, r in zip(points, run_many(points)):
                if r["failed"]:
                    high, failed = F, r
                    break
                low = F
        if workers > 1:  # the ends the search never left: run them now, they must hold
            ends = [(F, fails) for F, fails, kept in ((low0, False, low == low0),
                                                       (high0, True, high == high0)) if kept]
            results = run_many([F for F, _ in ends])
            check_ends(ends, results)
            failed = failed or results[-1]
    except KeyboardInterrupt:  # Ctrl-C, SIGTERM, SIGHUP: the trials so far, resumable
        if pool is not None:
            pool.close(wait=False)
            pool = None
        partial = record(low, high)
        partial["interrupted"] = True
        raise StudyInterrupted(partial) from None
    finally:
        if pool is not None:
            pool.close()
    return record(low, high), failed


def check_reduced(world, low, high):
    """The scene built with its strength divided by each end of the bracket, before the
    first trial (NumPy only): an initial stress the reduced soil cannot hold, a gravity
    loading that cannot run (:func:`~timpm.simulation.loading.check_gravity_loading`),
    refused naming the end's F.  A world the study does not build (a test's stand-in) is
    taken as it is."""
    from ..model.geostatic import GravityLoading
    from ..model.world import World
    from ..simulation.loading import check_gravity_loading

    if not isinstance(world, World):
        return
    reduced_bodies(world, low)  # (a world without Mohr-Coulomb soil: named as such)
    if isinstance(world.initial_stress, GravityLoading):
        check_gravity_loading(world)  # (gravity, the laws, t_max: the same at every F)
    for end, F in (("low", low), ("high", high)):
        try:
            replace(world, bodies=reduced_bodies(world, F))
        except ValueError as err:
            raise ValueError(_unbuilt(world, F, end, err)) from None


def _holds(world, F) -> bool:
    """Whether the world's (given, F-independent) initial stress lies inside every
    Mohr-Coulomb material's strength divided by F."""
    from ..materials import MohrCoulomb

    m = world.model
    for k, mat in enumerate(m.materials):
        rows = np.flatnonzero(m.material_index == k)
        if len(rows) and isinstance(mat, MohrCoulomb):
            try:
                mat.reduced(F).initial_state(m.initial_stress[rows], world.dim)
            except ValueError:
                return False
    return True


def _unbuilt(world, F, end, err) -> str:
    """The message of a scene that cannot be built with its strength divided by the
    bracket's ``end`` F: a given k0 names k0 and the largest F that holds its stress."""
    from ..model.geostatic import K0

    where = f"the bracket's {end} end F = {F:g} (--bracket)"
    spec = world.initial_stress
    if not (isinstance(spec, K0) and spec.k0 is not None and F > 1.0
            and world.model.initial_stress is not None and _holds(world, 1.0)):
        return f"{where}: the scene cannot start with its soil's strength divided by F: {err}"
    lo, hi = 1.0, F  # the K0 stress does not change with F; the surface shrinks as F grows
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if _holds(world, mid) else (lo, mid)
    limit = math.floor(lo * 1000.0) / 1000.0
    why = str(err).split(": raise K0")[0]  # (its advice is given below, with the others)
    return (f"{where}: the initial stress of the given k0 = {spec.k0:g} ([initial_stress] k0) "
            f"lies outside the soil's strength divided by F ({why}); the reduced soil holds "
            f"it up to F = {limit:.3f}: give --bracket a HIGH of at most {limit:.3f} (no "
            f"factor above it can be found from this k0), raise k0 toward 1, or drop k0 "
            "(Jaky's K0 of each trial's reduced friction angle, which every F holds)")


def plot_mechanism(world, failed, record, path):
    """The accumulated plastic strain at the smallest factor that failed: the mechanism."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..platform.files import replacing

    if failed.get("plastic") is None and not failed.get("stopped"):  # (a record's trial)
        raise ValueError(f"no mechanism to draw: the run at F = {failed['F']:g}, the smallest "
                         "that failed, came from the resumed record, which keeps no particle "
                         "state; run that factor again (without --resume) to draw it")
    if failed.get("plastic") is None:  # the run stopped (off the grid, no rest under gravity)
        raise ValueError(f"no mechanism to draw: the run at F = {failed['F']:g}, the smallest "
                         f"that failed, stopped ({failed['stopped']}); narrow the tolerance "
                         "or the bracket")
    X = world.model.positions
    fig, ax = plt.subplots(figsize=(9, 4.2))
    sc = ax.scatter(X[:, 0], X[:, 1], c=np.minimum(failed["plastic"], 1.0), s=4, cmap="inferno_r",
                    vmin=0.0, vmax=max(float(np.percentile(failed["plastic"], 99)), 1e-6))
    fig.colorbar(sc, ax=ax, label="accumulated plastic strain (at the reference positions)")
    ax.set_aspect("equal")
    ax.set(xlabel="x [m]", ylabel="y [m]",
           title=f"factor of safety {record['factor_of_safety']:.3f} (bracket "
                 f"{record['bracket'][0]:.3f}-{record['bracket'][1]:.3f}); mechanism at F = "
                 f"{failed['F']:.3f}")
    fig.tight_layout()
    with replacing(path, ".png") as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


#: the particles up to which ``--workers auto`` runs two one-thread trials at once
SMALL = 20_000


def workers_option(text):
    if text == "auto":
        return text
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        import argparse

        raise argparse.ArgumentTypeError(f"N must be a whole number of processes, at least "
                                         f"1, or auto: got {text!r}")
    return n


def workers_for(option, world) -> int:
    """The trials a study runs at once for ``--workers`` ``option`` (see its help)."""
    from ..platform import runtime

    if option != "auto":
        return option
    if not runtime.on_cpu():  # (one device: its trials one after another)
        return 1
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else \
        (os.cpu_count() or 1)
    return 2 if cores >= 2 and world.model.n_particles <= SMALL else 1


def add_bisection_arguments(p, bracket):
    """--bracket LOW HIGH (default ``bracket``) and --tolerance: the bisection's options."""
    p.add_argument("--bracket", type=float, nargs=2, default=bracket, metavar=("LOW", "HIGH"),
                   help=f"factors where the slope stands and fails, {BRACKET[0]:g} <= LOW < "
                        f"HIGH <= {BRACKET[1]:g} (default {bracket[0]:g} {bracket[1]:g})")
    p.add_argument("--tolerance", type=float, default=0.02,
                   help=f"width of the final bracket, at least {MIN_TOLERANCE:g} (default "
                        "0.02)")


def add_parser(subparsers):
    from ..platform.argtypes import add_runtime_arguments

    p = subparsers.add_parser(
        "factor-of-safety", help="a slope's factor of safety by strength reduction",
        description="Divide c and tan(phi) of every Mohr-Coulomb material by F, run the "
                    "scene file to its t_end, and bisect on F until the slope fails (its "
                    "particles still moving over the last quarter of the run).")
    p.add_argument("scene", metavar="FILE.toml", help="a scene file of the slope (2D or 3D)")
    add_bisection_arguments(p, bracket=(0.5, 4.0))
    p.add_argument("--creep", type=float, default=1e-3,
                   help="failure: the largest displacement grows over the last quarter of "
                        f"the run by more than CREEP x the ground's height, in (0, {CREEP:g}]"
                        " (default 1e-3)")
    p.add_argument("--json", metavar="FILE", help="write the factor, bracket and trials "
                   "(interrupted: the trials so far); default: the scene's output.json, if "
                   "it has one (its gif, vtk, npz and landslide are refused: one run's "
                   "outputs)")
    from ..platform.argtypes import scene_setting

    p.add_argument("--set", type=scene_setting, action="append", default=[], metavar="KEY=VALUE",
                   dest="settings", help="set a key of the scene file, as timpm run's --set "
                   "(domain.cells=60; KEY= removes it, e.g. output.gif=)")
    p.add_argument("--workers", type=workers_option, default="auto", metavar="N|auto",
                   help="trials at once, each in a process of one thread (auto: 2 where "
                        f"Taichi runs on a CPU of two cores or more and the slope has at most "
                        f"{SMALL:,} particles, whose step two threads do not speed up; "
                        "else 1)")
    p.add_argument("--resume", metavar="FILE.json", help="go on from an interrupted "
                   "study's --json record: its trials stand for the runs they were")
    p.add_argument("--plot", metavar="FILE.png", help="draw the failure mechanism")
    add_runtime_arguments(p)
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    return p
