"""Speed against error, the analysis and report of a sweep: Pareto front, the cheapest
configuration per target error, error stalls, the table (see :mod:`.speed_error`)."""
from __future__ import annotations

import math

from ..model.scene import MASS_KINDS

__all__ = ["merge_studies", "pareto_front", "cheapest_for", "plateaus", "default_targets",
           "format_table", "format_report", "group_label", "groups_by_label", "is_measured"]


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

def is_measured(rec) -> bool:
    """Whether a run record has a finite error and wall time (a run that failed or was
    skipped has neither)."""
    e, w = rec.get("rms_error"), rec.get("wall_seconds")
    return (e is not None and w is not None and math.isfinite(e) and math.isfinite(w))


def pareto_front(records) -> list[bool]:
    """Flags: True where no other record is at least as fast *and* at least as accurate
    and strictly better in one of the two.  Records with equal (wall, error) do not
    dominate each other (both stay on the front); records without an error are never on
    it."""
    pts = [(r["wall_seconds"], r["rms_error"]) if is_measured(r) else None for r in records]
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


def groups_by_label(records):
    """``({label: [records]}, with_placement)``: the records by :func:`group_label`, with
    the placement in the label when the records hold several."""
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
    runs = sorted((r for r in runs if is_measured(r) and r["rms_error"] > 0),
                  key=lambda r: r["elements"])
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
    valid = [r for r in records if is_measured(r)]
    groups, _ = groups_by_label(valid)
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
            lin_groups, _ = groups_by_label(linear)
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
    groups, _ = groups_by_label([r for r in records if is_measured(r)])
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
    errs = [r["rms_error"] for r in records if is_measured(r) and r["rms_error"] > 0]
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
