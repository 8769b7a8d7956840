"""Speed against error: which basis and mesh reaches a given accuracy cheapest?

``timpm study speed-error <problem>`` sweeps basis, mass matrix, number of elements and
particles per element (PPC), measures the RMS displacement error against the exact
solution and the wall time of every run, and writes a table, a log-log plot of error
against wall time with the Pareto front marked, and, for target errors, the cheapest
configuration per basis and its speed-up over linear elements.

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
usual estimate on a shared, noisy machine.  The timed runs advance the accepted run's
compiled solver by the same number of steps again (the work per step does not depend on
the state), so they cost no further compilation.  The accepted run itself is not a sample
(its time is kept as ``first_run_seconds``): the first run of a solver carries one-time
costs (Taichi compiles its field accessors on first use, the first launches warm up)
that are far larger than the stepping of a small 1D run - e.g. 3.5 ms against 0.4 ms for
1000 steps of the 4-element string.  The runs of the dt trials are released only after
the timing: freeing a solver's fields makes the next launch of every other solver slow
(~0.4 s, measured).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from .analysis import rms_error
from .argtypes import param, positive_float, positive_int
from .basis import BASES, get_basis
from .problems import PROBLEMS, get_problem
from .scene import MASS_KINDS, PLACEMENTS, STRESS_UPDATES

__all__ = ["speed_error_study", "merge_studies", "choose_dt", "pareto_front", "cheapest_for",
           "plateaus", "default_targets", "dt_rule_text", "format_report", "plot_speed_error",
           "add_parser", "main_from_args"]

RECORD_KEYS = ("problem", "basis", "mass", "elements", "ppc", "placement", "dt", "steps",
               "t_end", "rms_error", "time_error_estimate", "time_error_separated",
               "wall_seconds", "compile_seconds", "particles", "grid_crossings",
               "critical_dt", "pareto")


# ---- one run --------------------------------------------------------------------------------

class _Run:
    """One simulation to ``t_end``: error against the exact solution and stepping time.

    The solver stays alive (``release()`` frees it) so that further timing samples can
    advance it without compiling again.  Nothing is tracked and no energy is recorded, so
    ``run_seconds`` is pure stepping; the error is the study's RMS error (3.2), as in
    :func:`timpm.study.run_problem`.
    """

    def __init__(self, prob, *, elements, ppc, basis, mass, dt, t_end, placement, mode,
                 stress_update="study"):
        from .solver import Solver

        scene = prob.scene(elements=elements, ppc=ppc, basis=basis, mass=mass, dt=dt,
                           placement=placement, stress_update=stress_update)
        x0 = scene.positions.copy()
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
            }
        except BaseException:
            self.release()
            raise

    def time_again(self) -> float:
        """Advance the same solver by the same number of steps; its stepping seconds."""
        before = self.solver.run_seconds
        self.solver.run(n_steps=self.record["steps"], progress=False)
        return self.solver.run_seconds - before

    def release(self):
        if self.solver is not None:
            self.solver.release()
            self.solver = None


def _divides(t_end, dt):
    """The largest step <= dt that divides t_end into a whole number of steps."""
    n = max(1, math.ceil(t_end / dt * (1.0 - 1e-12)))
    return t_end / n


def critical_dt(prob, *, elements, ppc, basis, mass, placement) -> float:
    """The critical time step of a discretisation (raises ValueError for invalid ones)."""
    scene = prob.scene(elements=elements, ppc=ppc, basis=basis, mass=mass, dt=prob.dt,
                       placement=placement, allow_unstable_dt=True)
    return float(scene.critical_dt)


def choose_dt(run, dt0, dt_tolerance=0.1, max_halvings=4, defer_release=None):
    """The time step rule (module docstring) for one configuration.

    ``run(dt)`` simulates at ``dt`` and returns an object with ``record["rms_error"]`` and
    ``release()``.  Returns ``(accepted_run, info)``; info holds ``dt``, ``rms_error``,
    ``time_error_estimate``, ``time_error_separated`` and ``dt_trials`` (list of
    ``[dt, error]``).  The accepted run is not released: the caller times it further.
    The other runs are released, or, if ``defer_release`` is a list, appended to it for
    the caller to release after timing: freeing a Taichi field tree makes the next launch
    of every surviving kernel slow (~0.4 s, measured), which would spoil a timing.
    """
    dropped = []

    def drop(r):
        dropped.append(r)
        if defer_release is None:
            r.release()
        else:
            defer_release.append(r)

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
            # only the newest run can still be accepted later: free the older ones
            drop(runs[k])
        else:
            accepted, separated = max_halvings + 1, False
            diff = abs(trials[-2][1] - trials[-1][1])
    except BaseException:
        for r in runs:
            r.release()
        raise
    for i, r in enumerate(runs):
        if i != accepted and not any(r is d for d in dropped):
            drop(r)
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
                      stress_update="study", params=None) -> dict:
    """Sweep bases x masses x placements x elements x PPC; see the module docstring.

    ``combos``, a list of (basis, mass) pairs, replaces the product bases x masses;
    ``stress_update`` ("study" or "small") and ``params`` (physical parameters of the
    problem, e.g. ``{"gravity": -0.981}``) are passed on to every run.

    ``ppcs`` defaults to the problem's PPC; ``placement`` may be one name or several (then
    swept too).  Invalid combinations (a basis that cannot be lumped, too few particles
    per element, a singular mass matrix, a failed run) are skipped with a note in
    ``skipped``.  Returns a JSON-ready document: ``runs`` (records, each with a ``pareto``
    flag), ``skipped``, ``dt_rule`` and the settings.
    """
    from .solver import SimulationError

    prob = get_problem(problem, **(params or {}))
    if stress_update not in STRESS_UPDATES:
        raise ValueError(f"unknown stress_update {stress_update!r}: choose one of "
                         f"{', '.join(STRESS_UPDATES)}")
    if not prob.has_exact:
        raise ValueError(f"{prob.name} has no exact solution: no error to measure")
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats!r}")
    if not 0 < dt_tolerance:
        raise ValueError(f"dt_tolerance must be positive, got {dt_tolerance!r}")
    if max_halvings < 0:
        raise ValueError(f"max_halvings must be non-negative, got {max_halvings!r}")
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
    elements = tuple(int(n) for n in _as_tuple(elements))
    ppcs = (prob.ppc,) if ppcs is None else tuple(int(p) for p in _as_tuple(ppcs))
    if not elements or not ppcs or not combos or not placements:
        raise ValueError("give at least one basis, mass, placement, number of elements and PPC")
    say = progress or (lambda *a, **k: None)

    runs, skipped = [], []
    started = time.perf_counter()
    for basis, mass in combos:
        for place in placements:
            for ppc in ppcs:
                for n in elements:
                    conf = dict(elements=n, ppc=ppc, basis=basis, mass=mass, placement=place)
                    tag = f"{basis}/{mass}/{place} {n} el x {ppc} PPC"
                    try:
                        crit = critical_dt(prob, **conf)
                    except ValueError as exc:
                        skipped.append({**conf, "reason": str(exc)})
                        say(f"skip {tag}: {exc}")
                        continue
                    if not crit > 0:
                        reason = "singular or indefinite mass matrix: no stable time step"
                        skipped.append({**conf, "reason": reason})
                        say(f"skip {tag}: {reason}")
                        continue
                    dt0 = _divides(t_end, min(prob.dt, 0.5 * crit))

                    tried = []

                    def run(dt, conf=conf, tried=tried):
                        tried.append(dt)
                        return _Run(prob, dt=dt, t_end=t_end, mode=mode,
                                    stress_update=stress_update, **conf)

                    others = []
                    try:
                        accepted, info = choose_dt(run, dt0, dt_tolerance, max_halvings,
                                                   defer_release=others)
                    except (ValueError, SimulationError) as exc:
                        for r in others:
                            r.release()
                        reason = f"run failed at dt = {tried[-1]:.4g} s: {exc}"
                        skipped.append({**conf, "reason": reason, "dt": tried[-1]})
                        say(f"skip {tag}: {reason}")
                        continue
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
                               "dt0": dt0, "critical_dt": crit,
                               "stress_update": stress_update}
                    finally:
                        accepted.release()
                        for r in others:
                            r.release()
                    rec["dt"], rec["rms_error"] = info["dt"], info["rms_error"]
                    runs.append(rec)
                    say(f"{tag}: dt = {rec['dt']:.4g} s ({rec['steps']} steps"
                        f"{'' if rec['time_error_separated'] else ', time error not separated'}),"
                        f" e = {rec['rms_error']:.3e}, wall = {rec['wall_seconds']:.4f} s")
    flags = pareto_front(runs)
    for rec, on in zip(runs, flags):
        rec["pareto"] = on
    return {
        "command": "speed-error", "problem": prob.name, "t_end": t_end,
        "stress_update": stress_update, "params": dict(params or {}),
        "problem_dt": prob.dt, "dt_tolerance": dt_tolerance, "max_halvings": max_halvings,
        "repeats": repeats, "dt_rule": dt_rule_text(prob.dt, dt_tolerance, max_halvings),
        "sweep": {"bases": list(bases), "masses": list(masses),
                  "combos": [list(c) for c in combos], "placements": list(placements),
                  "elements": list(elements), "ppcs": list(ppcs)},
        "runs": runs, "skipped": skipped,
        "sweep_seconds": time.perf_counter() - started,
    }


def merge_studies(docs) -> dict:
    """One document from several sweeps of the same problem (e.g. one per placement):
    runs and skipped notes concatenated, the Pareto front recomputed over all runs."""
    docs = list(docs)
    if not docs:
        raise ValueError("nothing to merge")
    if len({d["problem"] for d in docs}) > 1 or len({d["t_end"] for d in docs}) > 1:
        raise ValueError("only sweeps of one problem to one t_end can be merged")
    out = dict(docs[0])
    out["runs"] = [dict(r) for d in docs for r in d["runs"]]
    out["skipped"] = [s for d in docs for s in d["skipped"]]
    out["sweep"] = [d["sweep"] for d in docs]
    out["sweep_seconds"] = sum(d.get("sweep_seconds", 0.0) for d in docs)
    bases = list(dict.fromkeys(b for d in docs for b in d["sweep"]["bases"]))
    out["bases"] = bases
    for rec, on in zip(out["runs"], pareto_front(out["runs"])):
        rec["pareto"] = on
    return out


# ---- analysis -------------------------------------------------------------------------------

def _valid(rec) -> bool:
    e, w = rec.get("rms_error"), rec.get("wall_seconds")
    return (e is not None and w is not None and math.isfinite(e) and math.isfinite(w))


def pareto_front(records) -> list[bool]:
    """Flags: True where no other record is at least as fast *and* at least as accurate
    and strictly better in one of the two.  Records with equal (wall, error) do not
    dominate each other (both stay on the front); records without an error are never on
    it."""
    pts = [(r["wall_seconds"], r["rms_error"]) if _valid(r) else None for r in records]
    flags = []
    for i, p in enumerate(pts):
        if p is None:
            flags.append(False)
            continue
        dominated = any(q is not None and j != i and q[0] <= p[0] and q[1] <= p[1]
                        and (q[0] < p[0] or q[1] < p[1]) for j, q in enumerate(pts))
        flags.append(not dominated)
    return flags


def _placements(records):
    return {r.get("placement", "study") for r in records}


def group_label(rec, with_placement=False) -> str:
    """basis/mass (and /placement when a sweep has several)."""
    label = f"{rec['basis']}/{rec['mass']}"
    return f"{label}/{rec.get('placement', 'study')}" if with_placement else label


def _groups(records):
    with_place = len(_placements(records)) > 1
    out = {}
    for r in records:
        out.setdefault(group_label(r, with_place), []).append(r)
    return out, with_place


def _brief(rec, label):
    return {"label": label, "basis": rec["basis"], "mass": rec["mass"],
            "placement": rec.get("placement", "study"), "elements": rec["elements"],
            "ppc": rec["ppc"], "wall_seconds": rec["wall_seconds"], "rms_error": rec["rms_error"],
            "dt": rec.get("dt")}


def _extrapolate(runs, target):
    """Elements a basis would need for ``target`` at the rate observed between its two
    finest meshes (same PPC); None when there is no usable rate."""
    runs = sorted((r for r in runs if _valid(r) and r["rms_error"] > 0), key=lambda r: r["elements"])
    if len(runs) < 2:
        return None
    a, b = runs[-2], runs[-1]
    if a["elements"] == b["elements"] or a["ppc"] != b["ppc"]:
        return None
    rate = math.log(a["rms_error"] / b["rms_error"]) / math.log(b["elements"] / a["elements"])
    if not rate > 0.5:
        return None
    return {"rate": rate, "elements": b["elements"] * (b["rms_error"] / target) ** (1.0 / rate)}


def cheapest_for(records, targets) -> list[dict]:
    """For each target error: the cheapest run (least wall time) of every basis/mass group
    reaching ``rms_error <= target``, the overall cheapest, the cheapest linear run and the
    factor ``linear wall time / cheapest wall time`` (None when linear cannot reach the
    target within the sweep; then ``linear_extrapolated`` may hold the elements linear
    would need at its observed rate).  "Linear" is the cheapest linear run of any mass;
    ``linear_lumped`` and ``factor_vs_linear_lumped`` compare with linear elements and
    lumped mass alone (the study's standard MPM).  Each answer has an ``answer``
    sentence."""
    valid = [r for r in records if _valid(r)]
    groups, _ = _groups(valid)
    linear = [r for r in valid if r["basis"] == "linear"]
    out = []
    for target in targets:
        target = float(target)
        per_group = {}
        for label, runs in groups.items():
            ok = [r for r in runs if r["rms_error"] <= target]
            per_group[label] = (_brief(min(ok, key=lambda r: (r["wall_seconds"], r["rms_error"])),
                                       label) if ok else None)
        reached = [g for g in per_group.values() if g is not None]
        best = min(reached, key=lambda g: (g["wall_seconds"], g["rms_error"])) if reached else None
        lin_ok = [r for r in linear if r["rms_error"] <= target]
        lin = None
        if lin_ok:
            r = min(lin_ok, key=lambda r: (r["wall_seconds"], r["rms_error"]))
            lin = _brief(r, group_label(r, len(_placements(valid)) > 1))
        factor = lin["wall_seconds"] / best["wall_seconds"] if lin and best else None
        ll_ok = [r for r in lin_ok if r["mass"] == "lumped"]
        ll = None
        if ll_ok:
            r = min(ll_ok, key=lambda r: (r["wall_seconds"], r["rms_error"]))
            ll = _brief(r, group_label(r, len(_placements(valid)) > 1))
        for g in per_group.values():
            if g is not None:
                g["factor_vs_linear"] = (lin["wall_seconds"] / g["wall_seconds"]) if lin else None
        ans = {"target": target, "best": best, "linear": lin, "factor": factor,
               "linear_lumped": ll,
               "factor_vs_linear_lumped": (ll["wall_seconds"] / best["wall_seconds"]
                                           if ll and best else None),
               "groups": per_group, "linear_best_error": min((r["rms_error"] for r in linear),
                                                             default=None)}
        if lin is None and linear:
            lin_groups, _ = _groups(linear)
            guesses = [g for g in (_extrapolate(rs, target) for rs in lin_groups.values()) if g]
            ans["linear_extrapolated"] = min(guesses, key=lambda g: g["elements"]) if guesses else None
        ans["answer"] = _answer_sentence(ans, bool(linear),
                                         any(r["mass"] == "lumped" for r in linear))
        out.append(ans)
    return out


def _conf(g):
    return f"{g['label']} {g['elements']} el x {g['ppc']} PPC"


def _answer_sentence(ans, have_linear, have_lumped=False) -> str:
    t, best, lin = ans["target"], ans["best"], ans["linear"]
    head = f"e_RMS <= {t:.0e}: "
    if best is None:
        return head + "no configuration of the sweep reaches it."
    text = (f"{head}cheapest {_conf(best)}, {best['wall_seconds']:.4g} s "
            f"(e = {best['rms_error']:.2e}); ")
    if lin is None:
        if not have_linear:
            return text + "no linear runs in the sweep to compare with."
        text += (f"linear cannot reach it within the sweep (best linear e = "
                 f"{ans['linear_best_error']:.2e})")
        ext = ans.get("linear_extrapolated")
        if ext:
            text += (f"; at its observed rate {ext['rate']:.2f} linear would need "
                     f"~{math.ceil(ext['elements'])} elements")
        return text + "."
    if best["basis"] == "linear":
        text += "linear is itself the cheapest (factor 1)"
    else:
        text += (f"cheapest linear {_conf(lin)}, {lin['wall_seconds']:.4g} s: "
                 f"{ans['factor']:.1f}x faster than linear")
    ll = ans.get("linear_lumped")
    if have_lumped and lin["mass"] != "lumped":
        if ll is None:
            text += "; linear with lumped mass cannot reach it within the sweep"
        else:
            text += (f"; over linear with lumped mass ({ll['elements']} el x {ll['ppc']} PPC, "
                     f"{ll['wall_seconds']:.4g} s): {ans['factor_vs_linear_lumped']:.1f}x")
    return text + "."


def plateaus(records, gain=1.25) -> list[dict]:
    """Where refining the mesh stops paying: per basis/mass (and PPC), the first mesh
    from which no further refinement in the sweep lowers the error by ``gain`` or more.
    Each entry: label, ppc, elements (where the stall starts), error (the least error
    from there), separated (True if the time error was separated in all those runs: the
    stall is then not time error), crossings (runs of the stall with grid crossings)."""
    groups, _ = _groups([r for r in records if _valid(r)])
    out = []
    for label, runs in groups.items():
        for ppc in sorted({r["ppc"] for r in runs}):
            rs = sorted((r for r in runs if r["ppc"] == ppc), key=lambda r: r["elements"])
            if len(rs) < 2:
                continue
            k = len(rs) - 1
            while k > 0 and rs[k - 1]["rms_error"] < gain * rs[k]["rms_error"]:
                k -= 1
            if k == len(rs) - 1:
                continue
            tail = rs[k:]
            out.append({"label": label, "ppc": ppc, "elements": rs[k]["elements"],
                        "error": min(r["rms_error"] for r in tail),
                        "separated": all(r.get("time_error_separated", True) for r in tail),
                        "crossings": sum(1 for r in tail if r.get("grid_crossings", 0) > 0)})
    return out


def default_targets(records, most=6) -> list[float]:
    """Targets 1e-k and 3e-k between the smallest and the largest error of the sweep,
    largest first; decades only when there are more than ``most`` (then every other
    decade if still too many, the finest kept)."""
    errs = [r["rms_error"] for r in records if _valid(r) and r["rms_error"] > 0]
    if not errs:
        return []
    lo, hi = min(errs), max(errs)
    ks = range(math.floor(math.log10(lo)) - 1, math.ceil(math.log10(hi)) + 1)
    cands = sorted((float(f"{m}e{k}") for k in ks for m in (1, 3)
                    if lo <= float(f"{m}e{k}") <= hi), reverse=True)
    if len(cands) > most:
        cands = [c for c in cands if f"{c:.0e}".startswith("1")]
    if len(cands) > most:
        step = math.ceil(len(cands) / most)
        cands = cands[::-1][::step][::-1]
    return cands or [float(f"1e{math.ceil(math.log10(hi))}")]


# ---- report -----------------------------------------------------------------------------------

def _sorted_runs(doc):
    sweep = doc.get("sweep", {})
    bases = doc.get("bases") or (sweep.get("bases", []) if isinstance(sweep, dict) else [])
    order = {b: i for i, b in enumerate(bases)}
    morder = {m: i for i, m in enumerate(MASS_KINDS)}
    return sorted(doc["runs"], key=lambda r: (order.get(r["basis"], len(order)), r["basis"],
                                              morder.get(r["mass"], 9), r.get("placement", ""),
                                              r["ppc"], r["elements"]))


def format_table(doc) -> str:
    runs = _sorted_runs(doc)
    with_place = len(_placements(runs)) > 1
    head = (f"{'basis/mass' + ('/placement' if with_place else ''):<28} {'el':>4} {'ppc':>3} "
            f"{'dt [s]':>10} {'steps':>7} {'e_RMS':>10} {'time err':>9} {'wall [s]':>9} "
            f"{'compile':>7} {'cross':>5}  P")
    lines = [head, "-" * len(head)]
    for r in runs:
        flag = "" if r.get("time_error_separated", True) else "!"
        lines.append(f"{group_label(r, with_place):<28} {r['elements']:>4} {r['ppc']:>3} "
                     f"{r['dt']:>10.4g} {r['steps']:>7} {r['rms_error']:>10.3e} "
                     f"{r.get('time_error_estimate', float('nan')):>9.2e} "
                     f"{r['wall_seconds']:>9.4f} {r.get('compile_seconds', float('nan')):>7.2f} "
                     f"{r.get('grid_crossings', 0):>5}  {'*' if r.get('pareto') else ''}{flag}")
    return "\n".join(lines)


def format_report(doc, answers=None) -> str:
    """Table of all runs, the dt rule and the answers for the target errors."""
    runs = doc["runs"]
    if answers is None:
        answers = cheapest_for(runs, default_targets(runs))
    extra = "".join(f", {k} = {v:g}" for k, v in (doc.get("params") or {}).items())
    lines = [f"Speed against error: {doc['problem']}, t_end = {doc['t_end']:g} s, stress update "
             f"'{doc.get('stress_update', 'study')}'{extra}", ""]
    lines.append(doc["dt_rule"])
    lines.append(f"Wall time: stepping only (compilation and first-run warm-up excluded), no "
                 f"energy recording, minimum of {doc.get('repeats', 1)} timed run(s).  time err = |e(dt) - e(dt/2)|.  "
                 "P: * on the Pareto front (no run both faster and more accurate).")
    lines += ["", format_table(doc)]
    for s in doc.get("skipped", []):
        lines.append(f"skipped {s['basis']}/{s['mass']}/{s.get('placement', 'study')} "
                     f"{s['elements']} el x {s['ppc']} PPC: {s['reason']}")
    front = sorted((r for r in runs if r.get("pareto")), key=lambda r: r["wall_seconds"])
    if front:
        with_place = len(_placements(runs)) > 1
        lines += ["", "Pareto front (fastest first): " + ", ".join(
            f"{group_label(r, with_place)} {r['elements']}x{r['ppc']} "
            f"({r['wall_seconds']:.3g} s, {r['rms_error']:.2e})" for r in front)]
    if answers:
        lines += ["", "Cheapest configuration per target error (within the sweep):"]
        for a in answers:
            lines.append("  " + a["answer"])
            parts = []
            for label, g in a["groups"].items():
                if g is None:
                    parts.append(f"{label}: not reached")
                else:
                    f = g.get("factor_vs_linear")
                    parts.append(f"{label}: {g['elements']}x{g['ppc']} {g['wall_seconds']:.3g} s"
                                 + (f" ({f:.1f}x)" if f is not None else ""))
            lines.append("    per basis (speed-up over the cheapest linear): " + "; ".join(parts))
    stalls = plateaus(runs)
    if stalls:
        lines += ["", "Error stalls (refining the mesh further gains less than 1.25x):"]
        for p in stalls:
            why = ("time error separated: not time error, a spatial or model-error floor"
                   if p["separated"] else "time error not separated in some of these runs")
            if p["crossings"]:
                why += f"; grid crossings in {p['crossings']} of these runs"
            lines.append(f"  {p['label']} ({p['ppc']} PPC) from {p['elements']} elements at "
                         f"e ~ {p['error']:.2e} ({why})")
    lines.append(f"\n{len(runs)} runs, {len(doc.get('skipped', []))} skipped, sweep took "
                 f"{doc.get('sweep_seconds', float('nan')):.0f} s (with compilation and dt trials).")
    return "\n".join(lines)


def plot_speed_error(doc, path, title=None):
    """Log-log plot of RMS error against wall time, one colour/marker per basis/mass,
    the Pareto front as a black line, hollow markers where the time error was not
    separated, labels ``elements x PPC`` on the front."""
    from .viz import _pyplot, save

    plt = _pyplot()
    runs = [r for r in doc["runs"] if _valid(r) and r["rms_error"] > 0 and r["wall_seconds"] > 0]
    groups, with_place = _groups(runs)
    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    markers = "osD^vP*Xh<>"
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (label, rs) in enumerate(groups.items()):
        rs = sorted(rs, key=lambda r: (r["ppc"], r["elements"]))
        c, m = colours[i % len(colours)], markers[i % len(markers)]
        w = np.array([r["wall_seconds"] for r in rs])
        e = np.array([r["rms_error"] for r in rs])
        sep = np.array([r.get("time_error_separated", True) for r in rs], dtype=bool)
        ax.loglog(w, e, "-", color=c, lw=0.8, alpha=0.5)
        ax.loglog(w[sep], e[sep], m, color=c, ls="none", label=label)
        if (~sep).any():
            ax.loglog(w[~sep], e[~sep], m, mfc="none", color=c, ls="none")
    front = sorted((r for r in runs if r.get("pareto")), key=lambda r: r["wall_seconds"])
    if front:
        ax.loglog([r["wall_seconds"] for r in front], [r["rms_error"] for r in front], "k-",
                  lw=1.5, alpha=0.7, zorder=0, label="Pareto front")
        for r in front:
            ax.annotate(f"{r['elements']}x{r['ppc']}", (r["wall_seconds"], r["rms_error"]),
                        textcoords="offset points", xytext=(5, 4), fontsize=7)
    if any(not r.get("time_error_separated", True) for r in runs):
        ax.plot([], [], "o", mfc="none", color="gray", ls="none", label="time error not separated")
    ax.set_xlabel("wall time of the run [s] (stepping, compilation excluded)")
    ax.set_ylabel("RMS displacement error [m]")
    ax.set_title(title or f"{doc['problem']}: error against wall time, t_end = {doc['t_end']:g} s"
                 f"\n(dt per run: halved until time error < {100 * doc['dt_tolerance']:g} % of "
                 f"the error; labels: elements x PPC)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return save(fig, path)


# ---- command line -----------------------------------------------------------------------------

def add_parser(subparsers):
    """Add the ``speed-error`` command to an argparse subparsers object."""
    p = subparsers.add_parser(
        "speed-error", help="RMS error against wall time over bases, meshes and PPC",
        description="Sweep basis, mass, elements and particles per element; per run choose dt "
                    "so that time error does not hide the spatial error, record RMS error and "
                    "wall time; print a table, the Pareto front and the cheapest configuration "
                    "per target error, with its speed-up over linear elements.")
    p.add_argument("problem", help=f"one of: {', '.join(n for n, c in PROBLEMS.items() if c.has_exact)}")
    p.add_argument("--bases", nargs="+", default=["linear", "bspline2", "bspline3"],
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
    p.add_argument("--max-halvings", type=int, default=4, help="most halvings of dt (default 4)")
    p.add_argument("--repeats", type=positive_int, default=3,
                   help="timed runs per configuration, the minimum is kept (default 3)")
    p.add_argument("--mode", default="auto", choices=["auto", "serial", "parallel"])
    p.add_argument("--threads", type=positive_int, help="CPU threads for Taichi")
    p.add_argument("--json", metavar="FILE", help="write runs, answers and settings as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="write the error-against-wall-time plot")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(func=main_from_args)
    return p


def main_from_args(args) -> int:
    """Run the ``speed-error`` command; returns the exit code."""
    from . import runtime
    from .solver import SimulationError

    def progress(msg):
        print(msg, file=sys.stderr, flush=True)

    try:
        if args.max_halvings < 0:
            raise ValueError(f"--max-halvings must be non-negative, got {args.max_halvings}")
        get_problem(args.problem, **dict(args.param))
        runtime.init(threads=args.threads)
        doc = speed_error_study(args.problem, bases=args.bases, masses=args.masses,
                                stress_update=args.stress_update, params=dict(args.param),
                                elements=args.elements, ppcs=args.ppc, placement=args.placement,
                                t_end=args.t_end, dt_tolerance=args.dt_tolerance,
                                max_halvings=args.max_halvings, repeats=args.repeats,
                                mode=args.mode, progress=None if args.quiet else progress)
    except (ValueError, SimulationError) as exc:
        print(f"timpm: error: {exc}", file=sys.stderr)
        return 2
    targets = args.targets or default_targets(doc["runs"])
    answers = cheapest_for(doc["runs"], targets)
    doc["targets"] = answers
    print(format_report(doc, answers))
    if args.plot:
        plot_speed_error(doc, args.plot)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(doc, fh, indent=2)
    return 0


def main(argv=None) -> int:
    """Stand-alone entry (``python -m timpm.speed_error <problem> ...``)."""
    ap = argparse.ArgumentParser(prog="timpm study")
    add_parser(ap.add_subparsers(dest="study", required=True))
    args = ap.parse_args(["speed-error", *(sys.argv[1:] if argv is None else argv)])
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
