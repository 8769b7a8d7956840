"""Griffiths & Lane's (1999) example 1 by strength reduction on finer and finer grids,
per basis: how the factor of safety converges (Bishop & Morgenstern 1.38, Griffiths &
Lane's finite elements 1.4).

    python benchmarks/factor_of_safety.py [--cells 60 120 240] [--bases linear bspline2]
        [--tolerance 0.02] [--workers auto] [--json docs/factor_of_safety.json]
    python benchmarks/factor_of_safety.py --plot docs/factor_of_safety_cost.png
        --records docs/factor_of_safety_20261203.json [study.json ...]   # no runs

Each row is `timpm study factor-of-safety examples/slope_griffiths_lane.toml` with the
grid and basis changed (cells along the 60 m domain: h = 60 / cells), its factor, bracket,
particles and wall time (the study's trials on ``--workers``, as the command runs them).
Per basis, where three meshes halve h and the factors fall monotonically, Richardson's
extrapolation: the observed order p = log2((F1 - F2) / (F2 - F3)) and F* = F3 - (F2 -
F3) / (2^p - 1).  ``--plot`` draws the factor against h and against the study's wall time
from ``--records`` (this benchmark's JSON, and single studies' records: `timpm study
factor-of-safety ... --json`), with 2% about the extrapolation of the basis whose last
refinement moved it least.
"""
import math
import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from runout_convergence import richardson  # noqa: E402 (one Richardson for the benchmarks)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[60, 120, 240])
    ap.add_argument("--bases", nargs="+", default=["linear", "bspline2"])
    ap.add_argument("--tolerance", type=float, default=0.02)
    ap.add_argument("--bracket", type=float, nargs=2, default=(1.0, 2.0))
    ap.add_argument("--workers", default="auto", help="trials at once (N or auto)")
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--plot", metavar="FILE.png")
    ap.add_argument("--records", nargs="+", metavar="FILE.json", default=[])
    args = ap.parse_args()
    if args.records:
        if not args.plot:
            ap.error("--records draws a plot: give --plot FILE.png")
        plot(args.plot, args.records)
        return

    import timpm
    from timpm.scenefile import load_scene
    from timpm.studies.factor_of_safety import factor_of_safety, workers_for

    timpm.init(precision="f64")
    rows = []
    for basis in args.bases:
        for cells in args.cells:
            scene = load_scene(ROOT / "examples" / "slope_griffiths_lane.toml",
                               overrides={"domain.cells": cells, "simulation.basis": basis})
            t0 = time.perf_counter()
            workers = workers_for(args.workers if args.workers == "auto"
                                  else int(args.workers), scene.world)
            record, _ = factor_of_safety(scene.world, scene.t_end, *args.bracket,
                                         tolerance=args.tolerance, mode=scene.mode,
                                         workers=workers)
            row = {"basis": basis, "cells": cells, "h": scene.world.h,
                   "particles": scene.world.model.n_particles,
                   "factor_of_safety": record["factor_of_safety"], "bracket": record["bracket"],
                   "runs": len(record["trials"]), "workers": workers,
                   "seconds": time.perf_counter() - t0}
            rows.append(row)
            print(f"{basis:10s} h = {row['h']:5.3f} m  {row['particles']:6d} particles  F = "
                  f"{row['factor_of_safety']:.3f} [{row['bracket'][0]:.3f}, "
                  f"{row['bracket'][1]:.3f}]  {row['seconds']:6.1f} s", flush=True)
    extrapolated = {}
    for basis in args.bases:
        mine = sorted((r for r in rows if r["basis"] == basis), key=lambda r: -r["h"])
        if len(mine) >= 3 and all(abs(a["h"] / b["h"] - 2.0) < 1e-9
                                  for a, b in zip(mine[-3:], mine[-2:])):
            rich = richardson([r["factor_of_safety"] for r in mine])
            if rich is not None:
                p = rich[0]
                extrapolated[basis] = {"order": p, "factor_of_safety": rich[1]}
                print(f"{basis}: Richardson order {p:.2f}, F* = "
                      f"{extrapolated[basis]['factor_of_safety']:.3f}")
            else:
                print(f"{basis}: the factors do not converge monotonically at a falling "
                      "rate: no extrapolation")
    if args.json:
        doc = {"command": " ".join(sys.argv), "date": time.strftime("%Y-%m-%d"),
               "reference": {"bishop_morgenstern": 1.38, "griffiths_lane_fe": 1.4},
               "rows": rows, "richardson": extrapolated}
        Path(args.json).write_text(json.dumps(doc, indent=2))


def plot(path, records):
    """The factor against h and against the study's wall time, per basis, from the
    benchmark's records (``rows``) and single studies' records (one point each)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    points = {}
    for record in records:
        doc = json.loads(Path(record).read_text())
        for r in doc.get("rows", [doc]):
            seconds = r.get("seconds", r.get("wall_seconds"))
            points.setdefault(r["basis"], {})[r["h"]] = (r["factor_of_safety"], seconds)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    limits = []
    for basis, by_h in sorted(points.items()):
        hs = sorted(by_h, reverse=True)
        F = [by_h[h][0] for h in hs]
        rich = richardson(F)
        if rich is not None:
            limits.append((abs(F[-1] - F[-2]), rich[1]))
        label = basis + ("" if rich is None else
                         f" (order {rich[0]:.2f}, Richardson {rich[1]:.3f})")
        a1.plot(hs, F, "o-", label=label)
        a2.plot([by_h[h][1] for h in hs], F, "o-", label=label)
    if limits:
        ref = min(limits)[1]
        for ax in (a1, a2):
            ax.axhspan(0.98 * ref, 1.02 * ref, color="0.88",
                       label=f"2% of {ref:.3f} (the least-moving basis' extrapolation)")
    for ax in (a1, a2):
        ax.set_ylabel("factor of safety")
        ax.legend(fontsize=7)
    a1.set(xscale="log", xlabel="h (m)", title="the factor against the mesh")
    hs = sorted({h for by_h in points.values() for h in by_h})
    a1.set_xticks(hs, [f"{h:g}" for h in hs])
    a1.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
    a2.set(xscale="log", xlabel="the study's wall time, two cores (s)",
           title="against the cost")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
