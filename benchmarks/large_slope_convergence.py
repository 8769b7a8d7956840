"""The study's claim at engineering scale (issue 46, item 5, the large slope): the factor of
safety and the run-out of examples/large_slope.toml (a 100 m submarine slope, drained) on
finer and finer grids, per basis, against the cost on two cores.

    python benchmarks/large_slope_convergence.py [--cells 200 400 800]
        [--bases linear uniform-bspline2 uniform-bspline3] [--part factor runout]
        [--json docs/large_slope_factor.json] [--plot FILE.png]
    python benchmarks/large_slope_convergence.py --plot docs/large_slope_convergence.png
        --records docs/large_slope_factor.json docs/large_slope_runout.json   # no runs

``--cells``: cells along the 800 m domain (h = 800 / cells: 4, 2, 1 m by default; the
scene file's own grid is 800).  Each basis with MUSL (the transfer whose run-out does not
depend on its step: docs/results.md, 2026-12-07) at ``--courant`` 0.5:

- **factor**: `timpm study factor-of-safety examples/large_slope.toml` with local damping
  0.2 (as Griffiths & Lane's scene file) and a trial of ``--factor-t-end`` s (12.65 s: the
  4 s of Griffiths & Lane's trials at ten times their height, sqrt(10) x 4 s), bisected in
  ``--bracket`` (0.5 to 1.3) to ``--tolerance`` (0.01), its trials two at a time where
  the study's ``--workers auto`` runs them so (a factor outside the bracket is recorded
  as such, and the sweep goes on);
- **runout**: the scene without damping, as the file stands but for the grid, basis,
  transfer and step, run to its t_end (31.93 s) and on, an eighth of it at a time, until
  the slide has stopped (its centroid moved less than ``--rest`` = 1e-3 of H, 0.1 m, in
  the last eighth) or ``--t-max`` (80 s): the run-out beyond the toe (its 2% front, read
  per grid column), and what the slide moved (the mass that moved more than 2% of H, its
  centroid's travel: benchmarks/runout_convergence.py's ``moved_mass``), the time it
  stopped, the kinetic energy then and at its peak (the deposit's elastic waves are
  undamped: no measure of rest), the fastest particle then.

Per basis, where three meshes halve h and the values change monotonically at a falling
rate, Richardson's extrapolation (benchmarks/runout_convergence.py's ``richardson``).  The
record is rewritten after every row, so an interrupted sweep keeps what it ran.
"""
import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from runout_convergence import moved_mass, richardson  # noqa: E402

SCENE = ROOT / "examples" / "large_slope.toml"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(SCENE))
    ap.add_argument("--cells", type=int, nargs="+", default=[200, 400, 800])
    ap.add_argument("--bases", nargs="+",
                    default=["linear", "uniform-bspline2", "uniform-bspline3"])
    ap.add_argument("--part", nargs="+", choices=("factor", "runout"),
                    default=["factor", "runout"])
    ap.add_argument("--transfer", default="musl")
    ap.add_argument("--courant", type=float, default=0.5)
    ap.add_argument("--factor-t-end", type=float, default=4.0 * math.sqrt(10.0))
    ap.add_argument("--bracket", type=float, nargs=2, default=(0.5, 1.3))
    ap.add_argument("--tolerance", type=float, default=0.01)
    ap.add_argument("--rest", type=float, default=1e-3,
                    help="the slide has stopped once its centroid moves less than this "
                         "share of H in an eighth of t_end")
    ap.add_argument("--t-max", type=float, default=80.0,
                    help="the run-out runs on past t_end to at most this time (s)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--plot", metavar="FILE.png")
    ap.add_argument("--records", nargs="+", metavar="FILE.json", default=[],
                    help="with --plot and no runs: draw these records")
    args = ap.parse_args()
    if args.records:
        if not args.plot:
            ap.error("--records draws a plot: give --plot FILE.png")
        rows = [r for f in args.records for r in json.loads(Path(f).read_text())["rows"]]
        plot(args.plot, rows)
        return

    import timpm

    timpm.init(threads=args.threads, precision="f64")
    doc = {"command": "python benchmarks/large_slope_convergence.py " + " ".join(sys.argv[1:]),
           "date": time.strftime("%Y-%m-%d"), "threads": args.threads, "rows": []}
    for part in args.part:
        for basis in args.bases:
            for cells in args.cells:
                row = (factor_row if part == "factor" else runout_row)(args, basis, cells)
                doc["rows"].append(row)
                print(json.dumps({k: v for k, v in row.items() if k != "trials"}), flush=True)
                doc["richardson"] = extrapolations(doc["rows"])
                if args.json:
                    Path(args.json).write_text(json.dumps(doc, indent=1) + "\n")
    for key, value in doc["richardson"].items():
        print(key, value)
    if args.plot:
        plot(args.plot, doc["rows"])


def scene_for(args, basis, cells, **more):
    from timpm.scenefile import load_scene

    return load_scene(args.scene, overrides={
        "domain.cells": cells, "simulation.basis": basis, "simulation.transfer": args.transfer,
        "simulation.courant": args.courant, **more})


def factor_row(args, basis, cells):
    """The factor of safety by strength reduction on this grid and basis."""
    from timpm.studies.factor_of_safety import factor_of_safety, workers_for

    scene = scene_for(args, basis, cells, **{"simulation.damping": 0.2,
                                             "simulation.t_end": args.factor_t_end})
    t0 = time.perf_counter()
    workers = workers_for("auto", scene.world)
    row = {"part": "factor", "basis": basis, "transfer": args.transfer, "cells": cells,
           "h": scene.world.h, "particles": scene.world.model.n_particles,
           "courant": args.courant, "t_end": scene.t_end, "damping": 0.2, "workers": workers}
    try:
        record, _ = factor_of_safety(scene.world, scene.t_end, *args.bracket,
                                     tolerance=args.tolerance, mode=scene.mode,
                                     workers=workers)
    except ValueError as err:  # the factor outside the bracket: said, and on to the next
        return {**row, "factor_of_safety": None, "outside_the_bracket": str(err),
                "seconds": time.perf_counter() - t0}
    return {**row, "factor_of_safety": record["factor_of_safety"],
            "bracket": record["bracket"], "runs": len(record["trials"]),
            "trials": [{k: t[k] for k in ("F", "failed", "creep", "wall_seconds")}
                       for t in record["trials"]],
            "seconds": time.perf_counter() - t0}


def runout_row(args, basis, cells):
    """The scene's slide to its end on this grid and basis: run-out and moved mass."""
    from timpm.simulation.solver import Solver

    scene = scene_for(args, basis, cells)
    slide = scene.output["landslide"]
    t0 = time.perf_counter()
    solver = Solver(scene.world, mode=scene.mode, energies=True,
                    record_every=max(1, int(round(scene.t_end / scene.world.dt / 200))))
    try:
        # the scene's t_end, then on in eighths of it until the slide has stopped (its
        # centroid moved less than --rest x H in the last eighth) or --t-max (the
        # kinetic energy is no measure: the deposit's elastic waves are undamped)
        solver.run(t_end=scene.t_end)
        travel, moved = moved_mass(solver, slide.height, toe=slide.toe), math.inf
        while moved > args.rest * slide.height and solver.t < args.t_max - 1e-9:
            solver.run(t_end=min(solver.t + scene.t_end / 8, args.t_max))
            last, travel = travel, moved_mass(solver, slide.height, toe=slide.toe)
            moved = abs(travel["centroid_travel"] - last["centroid_travel"])
        rest = {**at_rest(solver), "last_eighth_travel": moved}
        seen = slide.observe(scene.world.model.positions, solver.positions(), solver.h)
        row = {"part": "runout", "basis": basis, "transfer": args.transfer, "cells": cells,
               "h": solver.h, "particles": scene.world.model.n_particles,
               "courant": args.courant, "steps": solver.step, "t_end": solver.t,
               "runout": seen["front"] - slide.toe, "scarp": seen["scarp"],
               "compile_seconds": solver.compile_seconds,
               "stepping_seconds": solver.run_seconds,
               **travel, **rest, "at_rest": moved <= args.rest * slide.height}
    finally:
        solver.release()
    row["seconds"] = time.perf_counter() - t0
    return row


def at_rest(solver):
    """The deposit's motion at the end: the kinetic energy then and at its peak (J per m
    of slope) and the largest particle speed then (m/s); whether the slide has stopped is
    read from its centroid (:func:`runout_row`)."""
    import numpy as np

    kinetic = solver.energies()["kinetic"]
    return {"kinetic_end": float(kinetic[-1]), "kinetic_peak": float(kinetic.max()),
            "speed_end": float(np.linalg.norm(solver.velocities(), axis=1).max())}


#: the quantities extrapolated per part
QUANTITIES = {"factor": ("factor_of_safety",), "runout": ("runout", "centroid_travel")}


def extrapolations(rows):
    """Richardson's order and value of each part's quantities, per basis, from its last
    three meshes (where they halve h)."""
    out = {}
    for part, names in QUANTITIES.items():
        for basis in dict.fromkeys(r["basis"] for r in rows if r["part"] == part):
            sel = sorted((r for r in rows if r["part"] == part and r["basis"] == basis
                          and r.get(names[0]) is not None), key=lambda r: -r["h"])
            if len(sel) < 3 or any(abs(a["h"] / b["h"] - 2.0) > 1e-9
                                   for a, b in zip(sel[-3:], sel[-2:])):
                continue
            for name in names:
                rich = richardson([r.get(name, math.nan) for r in sel])
                out[f"{part}:{basis}:{name}"] = (None if rich is None else
                                                 {"order": rich[0], "value": rich[1]})
    return out


def references(rows):
    """The mesh-converged references the plot draws: the factor, the mean of the
    B-splines' factors on their finest mesh (each basis' factor changed by less than the
    bisection's tolerance over the sequence: no extrapolation); the centroid's travel, the
    range of the B-splines' Richardson extrapolations (the linear basis' order is below 1
    and its changes a quarter of the value: not in its asymptotic range)."""
    finest = {}
    for r in rows:
        if r["part"] == "factor" and r.get("factor_of_safety") is not None \
                and "bspline" in r["basis"]:
            if r["basis"] not in finest or r["h"] < finest[r["basis"]]["h"]:
                finest[r["basis"]] = r
    factor = (sum(r["factor_of_safety"] for r in finest.values()) / len(finest)
              if finest else None)
    travel = [v["value"] for k, v in extrapolations(rows).items()
              if k.startswith("runout:") and "bspline" in k and k.endswith(":centroid_travel")
              and v is not None]
    return factor, (min(travel), max(travel)) if travel else None


#: one colour per basis in every panel
COLOURS = {"linear": "C2", "uniform-bspline2": "C0", "uniform-bspline3": "C1",
           "bspline2": "C0", "bspline3": "C1"}


def plot(path, rows):
    """Factor of safety and centroid travel against h and against the wall time, with
    2% about the reference factor and 5% about the reference travel (:func:`references`)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    factor, travel = references(rows)
    panels = [("factor", "factor_of_safety", "factor of safety", "seconds",
               "the study's wall time, two cores (s)"),
              ("runout", "centroid_travel", "centroid travel of the moved mass (m)",
               "stepping_seconds", "stepping, two threads (s)")]
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5))
    for (part, name, label, cost, cost_label), (a1, a2) in zip(panels, axes):
        for basis in dict.fromkeys(r["basis"] for r in rows if r["part"] == part):
            sel = sorted((r for r in rows if r["part"] == part and r["basis"] == basis
                          and r.get(name) is not None), key=lambda r: -r["h"])
            rich = richardson([r[name] for r in sel])
            tag = basis + ("" if rich is None or part == "factor" else
                           f" (order {rich[0]:.2f}, Richardson {rich[1]:.3g})")
            for ax, x in ((a1, "h"), (a2, cost)):
                ax.plot([r[x] for r in sel], [r[name] for r in sel], "o-", label=tag,
                        color=COLOURS.get(basis))
        for ax in (a1, a2):
            if part == "factor" and factor is not None:
                ax.axhspan(0.98 * factor, 1.02 * factor, color="0.88",
                           label=f"2% of {factor:.3f} (the B-splines' finest)")
            if part == "runout" and travel is not None:
                mid = 0.5 * sum(travel)
                ax.axhspan(0.95 * mid, 1.05 * mid, color="0.9",
                           label=f"5% of {mid:.2f} m")
                ax.axhspan(*travel, color="0.75", label="the B-splines' extrapolations")
            ax.legend(fontsize=7)
        a1.set(xscale="log", xlabel="h (m)", ylabel=label, title=f"{label}: the mesh")
        hs = sorted({r["h"] for r in rows if r["part"] == part})
        a1.set_xticks(hs, [f"{h:g}" for h in hs])
        a1.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        a2.set(xscale="log", xlabel=cost_label, ylabel=label, title=f"{label}: the cost")
    fig.suptitle("examples/large_slope.toml (H = 100 m, drained, under 20 m of sea), MUSL")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}: reference factor {factor}, travel extrapolations {travel}")


if __name__ == "__main__":
    main()
