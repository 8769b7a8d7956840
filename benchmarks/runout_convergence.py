"""The run-out of the slope that fails (`timpm demo slope`: Griffiths & Lane's slope, its
strength halved) on finer and finer grids, per basis: how the run-out converges and what
each basis pays for it (issue 46, item 5's run-out half).

    python benchmarks/runout_convergence.py [--cells 10 20 40 80] [--courant 0.5 [0.25 ...]]
        [--schemes linear:apic uniform-bspline2:apic uniform-bspline2:mls-mpm
                   uniform-bspline3:apic]
        [--json docs/runout_convergence.json] [--plot docs/runout_convergence.png]
    python benchmarks/runout_convergence.py --replot docs/runout_convergence.json
        --plot docs/runout_convergence.png     # the plot again from a record, no runs
    python benchmarks/runout_convergence.py --travel-plot docs/runout_musl.png
        --records docs/runout_timestep.json docs/runout_musl_*.json   # the travel, no runs

Each row is `timpm demo slope --param cells_per_H=C --param basis=B --param transfer=T`
--param courant=K (no rendering, 10 s of slide; one courant number for every scheme,
0.5 by default: the demo's 0.8 is measured for MLS-MPM only; several: each mesh at each,
the time step's own share of the change): the run-out beyond the toe
(the deposit's front where it is 2% of H thick, read per grid column), the particles,
steps and the stepping's wall time on two threads; besides, what the slide moved, read
from the particles (``moved_mass``): the mass that moved more than 2% of H and its
centroid's travel and drop, and the front where the deposit stands 10% of H deep.  Per scheme, where three meshes halve h and the run-outs change monotonically,
Richardson's extrapolation: the observed order p = log2((R1 - R2) / (R2 - R3)) and R* = R3
+ (R3 - R2) / (2^p - 1).  The reference is the finest mesh's extrapolation of the scheme
that reaches it with the smallest change; each scheme's cheapest mesh within 5% of it is
reported.
"""
import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def richardson(values):
    """(p, extrapolated) of the last three values of a halving sequence, or None."""
    if len(values) < 3:
        return None
    r1, r2, r3 = values[-3:]
    d1, d2 = r2 - r1, r3 - r2
    if d1 == 0.0 or d2 == 0.0 or (d1 > 0) != (d2 > 0) or abs(d2) >= abs(d1):
        return None  # not monotone, or not converging
    p = math.log2(d1 / d2)
    return p, r3 + d2 / (2.0 ** p - 1.0)


def moved_mass(solver, H, toe=None):
    """What the slide moved, read from the particles rather than the deposit's thin front:
    the mass that moved more than 2% of H (kg per metre of slope) and its centroid's travel
    along x and drop along y (m), and the front where the deposit stands 10% of H deep
    beyond the ``toe`` (``runout_10``, per grid column as the 2% front; the toe at 4 H,
    the slope demo's, unless given)."""
    import numpy as np

    from timpm.model.geometry import deposit_front

    x0 = np.asarray(solver.model.positions)
    x, m = solver.positions(), solver.read("m")
    moved = np.linalg.norm(x - x0, axis=1) > 0.02 * H
    out = {"moved_mass": float(m[moved].sum())}
    if moved.any():
        w = m[moved] / m[moved].sum()
        out["centroid_travel"] = float(w @ (x[moved, 0] - x0[moved, 0]))
        out["centroid_drop"] = float(w @ (x0[moved, 1] - x[moved, 1]))
    front = deposit_front(x, solver.h, 0.1 * H)
    out["runout_10"] = front - (4.0 * H if toe is None else toe) if front > 0.0 else None
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[10, 20, 40, 80])
    ap.add_argument("--schemes", nargs="+", default=[
        "linear:apic", "uniform-bspline2:apic", "uniform-bspline2:mls-mpm",
        "uniform-bspline3:apic"])
    ap.add_argument("--courant", type=float, nargs="+", default=[0.5])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--plot", metavar="FILE.png")
    ap.add_argument("--replot", metavar="FILE.json", help="draw --plot from this record")
    ap.add_argument("--travel-plot", metavar="FILE.png", help="draw the centroid's travel "
                    "against h and the particle-steps from --records, no runs")
    ap.add_argument("--records", nargs="+", metavar="FILE.json", default=[])
    args = ap.parse_args()
    if args.travel_plot:
        travel_plot(args.travel_plot, args.records)
        return
    if args.replot:
        doc = json.loads(Path(args.replot).read_text())
        schemes = list(doc["richardson"])
        plot(args.plot, schemes, first_courant_rows(doc), doc["reference_runout"])
        return

    import timpm
    from timpm.scenarios.demos import run_demo

    timpm.init(threads=args.threads)
    rows = []
    for scheme, courant, cells in ((s, k, c) for s in args.schemes for k in args.courant
                               for c in args.cells):
        basis, transfer = scheme.split(":")
        t = time.perf_counter()
        r = run_demo("slope", frames=20, cells_per_H=cells, basis=basis,
                     transfer=transfer, courant=courant)
        row = {"basis": basis, "transfer": transfer, "cells_per_H": cells,
               "courant": courant,
               "h": 10.0 / cells, "particles": r.particles, "steps": r.steps,
               "runout": r.summary["runout"], "stepping_seconds": r.simulation_seconds,
               "compile_seconds": r.compile_seconds,
               "end_to_end_seconds": time.perf_counter() - t,
               "simulated_per_wall_second": r.t_end / r.simulation_seconds,
               "energy_dissipated": r.summary["energy_dissipated"],
               "potential_energy_released": r.summary["potential_energy_released"],
               "work_on_the_soil": r.summary["work_on_the_soil"],
               **moved_mass(r.solver, 10.0)}
        rows.append(row)
        print(f"{basis} {transfer} courant {courant} cells_per_H = {cells}: run-out "
              f"{row['runout']:.3f} m (10% of H: {row['runout_10']}), centroid travel "
              f"{row.get('centroid_travel', float('nan')):.3f} m, moved mass "
              f"{row['moved_mass']:.4g} kg/m, "
              f"{row['particles']} particles, {row['steps']} steps, "
              f"{row['stepping_seconds']:.1f} s stepping", flush=True)
    # the mesh sequences: the first courant number's rows (the others: the step's share)
    all_rows, rows = rows, [r for r in rows if r["courant"] == args.courant[0]]
    summary = {}
    for scheme in args.schemes:
        basis, transfer = scheme.split(":")
        sel = [r for r in rows if (r["basis"], r["transfer"]) == (basis, transfer)]
        rich = richardson([r["runout"] for r in sel])
        travel = richardson([r.get("centroid_travel", math.nan) for r in sel])
        summary[scheme] = {"order": None if rich is None else rich[0],
                           "extrapolated": None if rich is None else rich[1],
                           "finest": sel[-1]["runout"],
                           "travel_order": None if travel is None else travel[0],
                           "travel_extrapolated": None if travel is None else travel[1]}
    # the reference: the extrapolations' scheme whose last refinement moved least
    candidates = [(abs(sel_last_change(rows, s)), s) for s in args.schemes
                  if summary[s]["extrapolated"] is not None]
    reference = None
    if candidates:
        reference = summary[min(candidates)[1]]["extrapolated"]
        for scheme in args.schemes:
            basis, transfer = scheme.split(":")
            sel = [r for r in rows if (r["basis"], r["transfer"]) == (basis, transfer)]
            within = [r for r in sel if abs(r["runout"] - reference) <= 0.05 * reference]
            cheapest = min(within, key=lambda r: r["end_to_end_seconds"]) if within else None
            summary[scheme]["cheapest_within_5_percent"] = (
                None if cheapest is None else {k: cheapest[k] for k in (
                    "cells_per_H", "runout", "end_to_end_seconds", "stepping_seconds")})
    for scheme, s in summary.items():
        print(scheme, json.dumps(s), flush=True)
    print(f"reference run-out: {reference}", flush=True)
    doc = {"command": "python benchmarks/runout_convergence.py " + " ".join(sys.argv[1:]),
           "date": time.strftime("%Y-%m-%d"), "threads": args.threads,
           "courant": args.courant, "rows": all_rows,
           "richardson": summary, "reference_runout": reference}
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=1) + "\n")
    if args.plot:
        plot(args.plot, args.schemes, rows, reference)


def plot(path, schemes, rows, reference):
    """Run-out against h and against the cost, per scheme; Richardson's value +- 5%."""
    if not path:
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    for scheme in schemes:
        basis, transfer = scheme.split(":")
        sel = [r for r in rows if (r["basis"], r["transfer"]) == (basis, transfer)]
        a1.plot([r["h"] for r in sel], [r["runout"] for r in sel], "o-", label=scheme)
        a2.plot([r["end_to_end_seconds"] for r in sel], [r["runout"] for r in sel], "o-",
                label=scheme)
    for ax in (a1, a2):
        if reference is not None:
            ax.axhspan(0.95 * reference, 1.05 * reference, color="0.85",
                       label="Richardson's value +- 5% (see results.md)")
    _finish(path, fig, "run-out beyond the toe (m)", "run-out against the mesh",
            "wall time, two cores (s)", "run-out against cost")


def first_courant_rows(doc):
    """A record's rows at its first courant number (a record of one courant: all)."""
    courant = doc.get("courant", [None])
    first = courant[0] if isinstance(courant, list) else courant
    return [r for r in doc["rows"] if r.get("courant", first) == first]


def _finish(path, fig, ylabel, mesh_title, cost_label, cost_title):
    """Label both panels (against log h, and against the cost), legends, save."""
    a1, a2 = fig.axes[:2]
    for ax in (a1, a2):
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=7)
    a1.set(xscale="log", xlabel="h (m)", title=mesh_title)
    a2.set(xscale="log", xlabel=cost_label, title=cost_title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def travel_plot(path, records):
    """The moved mass's centroid travel against h and against the particle-steps, per
    scheme, from the records' first-courant rows (one row a scheme and mesh, records in
    the order of their meshes), with the band between the Richardson extrapolations (the
    last three meshes) of the schemes whose observed order is at least 0.5."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    series = {}
    for record in records:
        for r in first_courant_rows(json.loads(Path(record).read_text())):
            key = (r["basis"], r["transfer"])
            cells = r.get("cells_per_H", r.get("cells"))
            # (a scratch row keeps no steps: twice the half-resolution row's, dt ~ h)
            steps = r.get("steps")
            if not steps:
                coarser = series.get(key, {}).get(cells // 2)
                if coarser is None:
                    raise SystemExit(f"{record}: the {r['basis']}:{r['transfer']} row at "
                                     f"cells_per_H = {cells} keeps no steps, and no row at "
                                     f"{cells // 2} came before it to infer them from (list "
                                     "that row's record first in --records)")
                steps = 2 * coarser[2]
            particles = r.get("particles", 12 * cells ** 2)  # 3 H^2 of soil, 2 x 2 a cell
            series.setdefault(key, {})[cells] = (r["centroid_travel"], steps * particles,
                                                  steps)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    limits = []
    for (basis, transfer), points in sorted(series.items()):
        cells = sorted(points)
        travel = [points[c][0] for c in cells]
        rich = richardson(travel)
        if rich is not None and rich[0] >= 0.5:  # a sequence that converges
            limits.append(rich[1])
        label = f"{basis}:{transfer}" + ("" if rich is None else
                                          f" (order {rich[0]:.2f}, Richardson {rich[1]:.2f} m)")
        a1.plot([10.0 / c for c in cells], travel, "o-", label=label)
        a2.plot([points[c][1] for c in cells], travel, "o-", label=label)
    for ax in (a1, a2):
        if limits:
            mid = 0.5 * (min(limits) + max(limits))
            ax.axhspan(0.95 * mid, 1.05 * mid, color="0.9", label="5% of the extrapolations' mid")
            ax.axhspan(min(limits), max(limits), color="0.75", label="the extrapolations")
    _finish(path, fig, "centroid travel of the moved mass (m)",
            "the slide's travel against the mesh", "particle-steps", "against the cost")
    print(f"{path}: extrapolations {sorted(round(x, 3) for x in limits)}")


def sel_last_change(rows, scheme):
    basis, transfer = scheme.split(":")
    sel = [r["runout"] for r in rows if (r["basis"], r["transfer"]) == (basis, transfer)]
    return sel[-1] - sel[-2] if len(sel) > 1 else math.inf


if __name__ == "__main__":
    main()
