"""A slope's probability of failure over random fields of its strength (Monte Carlo).

The scene's bodies with a random field (``Body(random_field=RandomField(...))``, a scene
file's ``[body.random_field]``) are realised again and again: realisation k takes seed
s + k for each body of seed s.  Each realisation asks one of two questions:

- **stands or fails** at a factor F (default 1: the slope as it is): one strength-
  reduction trial (:func:`timpm.studies.factor_of_safety.trial`, its failure criterion);
  where it fails, the failed mass runs on to ``run_on`` (default: the scene's t_end
  twice) and its run-out (the largest particle displacement then) and sliding volume
  (the volume, an area per metre in 2D, of the particles displaced by more than
  ``SLIDING`` x the ground's height) are kept;
- **its factor of safety** (``factor_of_safety=True``): the bisection of
  :func:`timpm.studies.factor_of_safety.factor_of_safety` per realisation; it fails where
  the factor is below F.

The probability of failure is the share of realisations that failed, with its Wilson
score interval (95%, z = 1.96), which keeps its coverage at probabilities near 0 and 1
where the normal approximation does not; the study records it after every realisation
(``convergence``) and stops early where ``width`` is given and the interval has become
narrower (after at least ``MIN_REALISATIONS``).  Realisations run on ``workers``
processes of one thread each (each compiles its program once: only the field values
change from one realisation to the next) or on a Dask cluster (``dask``: an address, or
"local"), results streamed back as they complete.  Interrupted (Ctrl-C, SIGTERM), the
study raises :class:`MonteCarloInterrupted` with the realisations finished; given back as
``resume`` they stand for the runs they were and the study goes on with the others, to
the same result.
"""
import math
import time
from dataclasses import replace

import numpy as np

__all__ = ["monte_carlo", "realisation", "wilson", "MonteCarloInterrupted", "SLIDING",
           "MIN_REALISATIONS", "random_bodies"]

#: a particle slides where it moved by more than this share of the ground's height
SLIDING = 0.01
#: the fewest realisations before ``width`` may stop a study
MIN_REALISATIONS = 20
#: the normal quantile of a two-sided 95% interval
Z95 = 1.959963984540054


class MonteCarloInterrupted(Exception):
    """The study was interrupted; ``partial`` is its record so far (resumable)."""

    def __init__(self, partial):
        super().__init__(f"interrupted after {partial['realisations']} realisations")
        self.partial = partial


def wilson(failures: int, n: int, z: float = Z95) -> tuple:
    """The Wilson score interval of a probability seen ``failures`` times in ``n``."""
    if n == 0:
        return (0.0, 1.0)
    p = failures / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def random_bodies(world) -> list:
    """The indices of the bodies with a random field."""
    return [k for k, b in enumerate(world.bodies) if b.random_field is not None]


def realisation(world, k: int):
    """``world`` with realisation ``k`` of its random fields (each body's seed + k)."""
    bodies = tuple(replace(b, random_field=b.random_field.with_seed(b.random_field.seed + k))
                   if b.random_field is not None else b for b in world.bodies)
    return replace(world, bodies=bodies)


def _sliding_volume(world, trial, height):
    if trial.get("positions") is None:
        return None
    d = np.linalg.norm(trial["positions"] - world.model.positions, axis=1)
    return float(np.sum(world.model.volume[d > SLIDING * height]))


def run_realisation(world, k, question, t_end, creep, mode):
    """Realisation ``k`` of ``world`` asked ``question`` (see :func:`monte_carlo`): its
    result (plain numbers)."""
    from . import factor_of_safety as fos

    start = time.perf_counter()
    w = realisation(world, k)
    fields = w.random_fields
    out = {"k": k, "clipped": int(sum(f["clipped"] for f in fields.values()))}
    height = fos.ground_height(world)
    if question["kind"] == "stands":
        r = fos.trial(w, question["factor"], t_end, creep, mode, run_on=question["run_on"])
        out.update(failed=bool(r["failed"]), stopped=r["stopped"],
                   displacement=r["displacement_end"], creep=r["creep"])
        if r["failed"]:
            out["runout"] = r.get("displacement_run_on", r["displacement_end"])
            out["sliding_volume"] = _sliding_volume(w, r, height)
    else:
        record, _ = fos.factor_of_safety(w, t_end, low=question["low"], high=question["high"],
                                         tolerance=question["tolerance"], creep=creep,
                                         mode=mode)
        out.update(factor_of_safety=record["factor_of_safety"], bracket=record["bracket"],
                   failed=record["factor_of_safety"] < question["factor"])
    for key in ("displacement", "creep", "runout"):
        if key in out and not (out[key] is None or math.isfinite(out[key])):
            out[key] = None  # (the strict JSON record: a mass that left the grid)
    out["wall_seconds"] = time.perf_counter() - start
    return out


def _task(k, question):
    """A worker's realisation (the trial pool's world and settings)."""
    from .trial_pool import study

    s = study()
    return run_realisation(s["world"], k, question, s["t_end"], s["creep"], s["mode"])


def _check(world, realisations, factor, width, workers):
    if not random_bodies(world):
        raise ValueError("a Monte Carlo study varies the bodies with a random field: give a "
                         "Mohr-Coulomb body a [body.random_field] (Python: Body(..., "
                         "random_field=RandomField(...)))")
    check_numbers(realisations, factor, width)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"--workers must be a whole number of processes, at least 1, got "
                         f"{workers!r}")


def check_numbers(realisations, factor, width):
    """--realisations, --factor and --width (before the scene is read)."""
    if isinstance(realisations, bool) or not isinstance(realisations, int) or realisations < 1:
        raise ValueError(f"--realisations must be a whole number of at least 1, got "
                         f"{realisations!r}")
    if not (isinstance(factor, (int, float)) and math.isfinite(factor) and factor > 0):
        raise ValueError(f"--factor must be a positive number (the strength divided by it), "
                         f"got {factor!r}")
    if width is not None and not (isinstance(width, (int, float)) and 0.0 < width < 1.0):
        raise ValueError(f"--width must lie in (0, 1) (the Wilson interval's width at which "
                         f"the study stops), got {width!r}")


#: what a resumed record must share with the study it resumes
RESUME_KEYS = ("question", "t_end", "creep", "particles", "h", "basis", "transfer", "seeds",
               "random_fields")


def monte_carlo(world, t_end, realisations, factor=1.0, creep=1e-3, mode="auto",
                factor_of_safety=False, bracket=(0.5, 4.0), tolerance=0.02, run_on=None,
                width=None, workers=1, dask=None, progress=None, resume=None):
    """The probability of failure of ``world`` over ``realisations`` realisations of its
    random fields (see the module): the record (``probability_of_failure``, ``wilson_95``,
    ``convergence``, every realisation's result)."""
    from . import factor_of_safety as fos

    _check(world, realisations, factor, width, workers)
    fos.check_settings(bracket[0], bracket[1], tolerance, creep)
    if not (isinstance(t_end, (int, float)) and math.isfinite(t_end) and t_end > 0.0):
        raise ValueError(f"a Monte Carlo study needs a run of positive length: t_end = "
                         f"{t_end!r}")
    if factor_of_safety:
        question = {"kind": "factor-of-safety", "factor": float(factor), "low": bracket[0],
                    "high": bracket[1], "tolerance": tolerance}
    else:
        run_on = 2.0 * t_end if run_on is None else float(run_on)
        if not (math.isfinite(run_on) and run_on >= t_end):
            raise ValueError(f"--run-on must be a time at least the scene's t_end = "
                             f"{t_end:g} s, got {run_on!r}")
        question = {"kind": "stands", "factor": float(factor), "run_on": run_on}
    fields = {str(k): _spec(world.bodies[k].random_field) for k in random_bodies(world)}
    settings = {"question": question, "t_end": t_end, "creep": creep,
                "particles": world.model.n_particles, "h": world.h, "basis": world.basis.name,
                "transfer": world.transfer,
                "seeds": {k: f["seed"] for k, f in fields.items()}, "random_fields": fields}
    done = {} if resume is None else _resumable(resume, settings)
    results = dict(done)
    t0 = time.perf_counter()

    def record():
        rows = [results[k] for k in sorted(results)]
        n = len(rows)
        failures = sum(r["failed"] for r in rows)
        out = {"study": "monte-carlo", **settings, "realisations": n, "asked": realisations,
               "failures": failures, "probability_of_failure": failures / n if n else None,
               "wilson_95": list(wilson(failures, n)), "workers": workers,
               "dask": dask, "wall_seconds": time.perf_counter() - t0,
               "convergence": _convergence(rows), "results": rows}
        if question["kind"] == "factor-of-safety" and rows:
            F = np.array([r["factor_of_safety"] for r in rows])
            out["factor_of_safety_mean"] = float(F.mean())
            out["factor_of_safety_std"] = float(F.std(ddof=1)) if n > 1 else 0.0
        return out

    def narrow_enough():
        if width is None or len(results) < MIN_REALISATIONS:
            return False
        lo, hi = wilson(sum(r["failed"] for r in results.values()), len(results))
        return hi - lo <= width

    def take(r):
        results[r["k"]] = r
        if progress is not None:
            n = len(results)
            f = sum(x["failed"] for x in results.values())
            lo, hi = wilson(f, n)
            what = (f"F = {r['factor_of_safety']:.4f}" if "factor_of_safety" in r
                    else "fails" if r["failed"] else "stands")
            progress(f"realisation {r['k']}: {what} ({r['wall_seconds']:.1f} s); P_f = "
                     f"{f}/{n} = {f / n:.4f} [{lo:.4f}, {hi:.4f}]")

    todo = [k for k in range(realisations) if k not in done]
    try:
        if narrow_enough():
            todo = []
        if todo and dask is not None:
            _on_dask(world, t_end, creep, mode, question, todo, dask, take, narrow_enough)
        elif todo and workers > 1:
            _on_pool(world, t_end, creep, mode, question, todo, workers, take, narrow_enough)
        else:
            for k in todo:
                take(run_realisation(world, k, question, t_end, creep, mode))
                if narrow_enough():
                    break
    except KeyboardInterrupt:  # Ctrl-C, SIGTERM, SIGHUP: the realisations so far
        partial = record()
        partial["interrupted"] = True
        raise MonteCarloInterrupted(partial) from None
    return record()


def _spec(field) -> dict:
    from dataclasses import asdict

    out = asdict(field)
    out["correlation_length"] = [c if math.isfinite(c) else "inf"
                                 for c in field.correlation_length]
    return out


def _convergence(rows) -> list:
    """[n, P_f, Wilson low, Wilson high] after each realisation, in realisation order."""
    out, failures = [], 0
    for n, r in enumerate(rows, 1):
        failures += bool(r["failed"])
        out.append([n, failures / n, *wilson(failures, n)])
    return out


def _resumable(record, settings) -> dict:
    from .factor_of_safety import resumed_entries

    return resumed_entries(record, settings, RESUME_KEYS, "monte-carlo",
                           "a Monte Carlo study", "results", "k", int, "a realisation")


def _on_pool(world, t_end, creep, mode, question, todo, workers, take, narrow_enough):
    from .trial_pool import TrialPool

    pool = TrialPool(world, t_end, creep, workers, mode)
    stopped = False
    try:
        queue = list(todo)
        running = set()
        while queue or running:
            while queue and len(running) < 2 * workers and not narrow_enough():
                running.add(pool.submit(_task, queue.pop(0), question))
            if not running:
                break
            finished, running = pool.wait(running, first=True)
            for f in finished:
                take(f.result())
            if narrow_enough():
                queue = []
    except KeyboardInterrupt:
        stopped = True
        pool.close(wait=False)
        raise
    finally:
        if not stopped:
            pool.close()


#: realisations a Dask cluster is given at once (between two batches ``width`` may stop
#: the study)
DASK_BATCH = 64


def _on_dask(world, t_end, creep, mode, question, todo, address, take, narrow_enough):
    from .sweep import map_runs

    for first in range(0, len(todo), DASK_BATCH):
        calls = [(world, k, question, t_end, creep, mode)
                 for k in todo[first:first + DASK_BATCH]]
        map_runs(run_realisation, calls, dask=address, on_result=lambda i, r: take(r))
        if narrow_enough():
            break


# ---- the command line ---------------------------------------------------------------

def add_parser(subparsers):
    from ..platform.argtypes import add_runtime_arguments, scene_setting
    from . import factor_of_safety as fos

    p = subparsers.add_parser(
        "monte-carlo", help="a slope's probability of failure over random fields of its "
                            "strength",
        description="Realise the random fields of the scene file's bodies ([body."
                    "random_field]) again and again and ask each realisation whether the "
                    "slope stands at a factor F (one strength-reduction trial) or its factor "
                    "of safety (--factor-of-safety): the probability of failure with its "
                    "Wilson interval, the run-out where it fails.")
    p.add_argument("scene", metavar="FILE.toml", help="a scene file of the slope with a "
                   "[body.random_field]")
    p.add_argument("--realisations", type=int, required=True, metavar="N",
                   help="realisations to run (realisation k: each body's seed + k)")
    p.add_argument("--factor", type=float, default=1.0, help="the factor the slope must "
                   "stand at (its strength divided by it; default 1: as it is)")
    p.add_argument("--factor-of-safety", action="store_true", help="each realisation's "
                   "factor of safety by bisection (--bracket, --tolerance) instead of one trial")
    fos.add_bisection_arguments(p, bracket=(0.5, 4.0))
    p.add_argument("--creep", type=float, default=1e-3, help="the failure criterion, as "
                   "timpm study factor-of-safety's (default 1e-3)")
    p.add_argument("--run-on", type=float, metavar="T", help="a failed realisation runs on "
                   "to T seconds for its run-out (default: twice the scene's t_end)")
    p.add_argument("--width", type=float, help="stop once the 95%% Wilson interval of P_f is "
                   f"at most this wide (after at least {MIN_REALISATIONS} realisations)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--workers", type=fos.workers_option, default="auto", metavar="N|auto",
                       help="realisations at once, each in a process of one thread (auto: as "
                            "timpm study factor-of-safety)")
    group.add_argument("--dask", metavar="ADDRESS", help="run them on a Dask cluster (its "
                       "scheduler's address, or 'local'), one Taichi thread a worker")
    p.add_argument("--set", type=scene_setting, action="append", default=[],
                   metavar="KEY=VALUE", dest="settings", help="set a key of the scene file, "
                   "as timpm run's --set")
    p.add_argument("--json", metavar="FILE", help="write the record (interrupted: the "
                   "realisations so far, resumable)")
    p.add_argument("--resume", metavar="FILE.json", help="go on from an interrupted study's "
                   "--json record: its realisations stand for the runs they were")
    p.add_argument("--plot", metavar="FILE.png", help="draw P_f against N and the run-out "
                   "exceedance (or the factors' histogram)")
    p.add_argument("--field", metavar="FILE.png", help="draw the first realisation's field")
    add_runtime_arguments(p)
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    return p


def plot_study(record, path):
    """P_f against N with its Wilson interval, beside the run-out exceedance curve (or the
    histogram of the realisations' factors of safety)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..platform.files import replacing

    conv = np.array(record["convergence"]) if record["convergence"] else np.zeros((0, 4))
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    if len(conv):
        a.fill_between(conv[:, 0], conv[:, 2], conv[:, 3], alpha=0.25, label="Wilson 95%")
        a.plot(conv[:, 0], conv[:, 1], "k-", label="P_f")
    a.set(xlabel="realisations N", ylabel="probability of failure", xscale="log",
          title=f"P_f = {record['failures']}/{record['realisations']}")
    a.legend()
    rows = record["results"]
    if record["question"]["kind"] == "factor-of-safety":
        F = [r["factor_of_safety"] for r in rows]
        b.hist(F, bins=max(5, min(40, len(F) // 5)), color="0.5")
        b.axvline(record["question"]["factor"], color="r", label="F")
        b.set(xlabel="factor of safety", ylabel="realisations",
              title="the realisations' factors of safety")
        b.legend()
    else:
        runout = np.sort([r["runout"] for r in rows if r["failed"] and r.get("runout")
                          is not None])[::-1]
        if len(runout):
            b.step(runout, np.arange(1, len(runout) + 1) / len(rows), where="post")
        b.set(xlabel="run-out: largest displacement [m]", ylabel="P(run-out > x)",
              title=f"run-out exceedance (failed realisations, t = "
                    f"{record['question']['run_on']:g} s)")
    fig.tight_layout()
    with replacing(path, ".png") as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


#: a realisation's parameters a picture draws: key -> (unit, divisor)
PICTURED = {"cohesion": ("kPa", 1e3), "friction_angle": ("degrees", 1.0),
            "conductivity": ("m/s", 1.0)}


def plot_field(world, path, k=0):
    """Realisation ``k``'s varied parameters (cohesion, friction angle, conductivity) on
    the particles, a panel each."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..platform.files import replacing

    w = realisation(world, k)
    keys = [key for key in PICTURED if any(key in r for r in w.random_fields.values())]
    fig, axes = plt.subplots(len(keys), 1, figsize=(9, 3.5 * len(keys)), squeeze=False)
    for body, real in w.random_fields.items():
        X = w.model.positions[w.model.body_index == body]
        for ax, key in zip(axes[:, 0], keys):
            if key not in real:
                continue
            unit, divisor = PICTURED[key]
            sc = ax.scatter(X[:, 0], X[:, 1], c=real[key] / divisor, s=3, cmap="viridis")
            fig.colorbar(sc, ax=ax, label=f"{key.replace('_', ' ')} [{unit}]")
            ax.set_aspect("equal")
            ax.set(xlabel="x [m]", ylabel="y [m]", title=f"realisation {k}: "
                   f"{key.replace('_', ' ')}")
    fig.tight_layout()
    with replacing(path, ".png") as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
