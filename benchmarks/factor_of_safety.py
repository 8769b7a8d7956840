"""Griffiths & Lane's (1999) example 1 by strength reduction on finer and finer grids,
per basis: how the factor of safety converges (Bishop & Morgenstern 1.38, Griffiths &
Lane's finite elements 1.4).

    python benchmarks/factor_of_safety.py [--cells 60 120 240] [--bases linear bspline2]
        [--tolerance 0.02] [--workers auto] [--json docs/factor_of_safety.json]

Each row is `timpm study factor-of-safety examples/slope_griffiths_lane.toml` with the
grid and basis changed (cells along the 60 m domain: h = 60 / cells), its factor, bracket,
particles and wall time (the study's trials on ``--workers``, as the command runs them).
Per basis, where three meshes halve h and the factors fall monotonically, Richardson's
extrapolation: the observed order p = log2((F1 - F2) / (F2 - F3)) and F* = F3 - (F2 -
F3) / (2^p - 1).
"""
import math
import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[60, 120, 240])
    ap.add_argument("--bases", nargs="+", default=["linear", "bspline2"])
    ap.add_argument("--tolerance", type=float, default=0.02)
    ap.add_argument("--bracket", type=float, nargs=2, default=(1.0, 2.0))
    ap.add_argument("--workers", default="auto", help="trials at once (N or auto)")
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args()

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
            F1, F2, F3 = (r["factor_of_safety"] for r in mine[-3:])
            if (F1 - F2) * (F2 - F3) > 0 and abs(F1 - F2) > abs(F2 - F3):
                p = math.log2((F1 - F2) / (F2 - F3))
                extrapolated[basis] = {"order": p,
                                       "factor_of_safety": F3 - (F2 - F3) / (2 ** p - 1)}
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


if __name__ == "__main__":
    main()
