"""Griffiths & Lane's (1999) example 1 by strength reduction on finer and finer grids,
per basis: how the factor of safety converges (Bishop & Morgenstern 1.38, Griffiths &
Lane's finite elements 1.4).

    python benchmarks/factor_of_safety.py [--cells 60 120 240] [--bases linear bspline2]
        [--tolerance 0.02] [--json docs/factor_of_safety.json]

Each row is `timpm study factor-of-safety examples/slope_griffiths_lane.toml` with the
grid and basis changed (cells along the 60 m domain: h = 60 / cells), its factor, bracket,
particles and wall time.
"""
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
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args()

    import timpm
    from timpm.scenefile import load_scene
    from timpm.studies.factor_of_safety import factor_of_safety

    timpm.init(precision="f64")
    rows = []
    for basis in args.bases:
        for cells in args.cells:
            scene = load_scene(ROOT / "examples" / "slope_griffiths_lane.toml",
                               overrides={"domain.cells": cells, "simulation.basis": basis})
            t0 = time.perf_counter()
            record, _ = factor_of_safety(scene.world, scene.t_end, *args.bracket,
                                         tolerance=args.tolerance, mode=scene.mode)
            row = {"basis": basis, "cells": cells, "h": scene.world.h,
                   "particles": scene.world.model.n_particles,
                   "factor_of_safety": record["factor_of_safety"], "bracket": record["bracket"],
                   "runs": len(record["trials"]), "seconds": time.perf_counter() - t0}
            rows.append(row)
            print(f"{basis:10s} h = {row['h']:5.3f} m  {row['particles']:6d} particles  F = "
                  f"{row['factor_of_safety']:.3f} [{row['bracket'][0]:.3f}, "
                  f"{row['bracket'][1]:.3f}]  {row['seconds']:6.1f} s", flush=True)
    if args.json:
        doc = {"command": " ".join(sys.argv), "date": time.strftime("%Y-%m-%d"),
               "reference": {"bishop_morgenstern": 1.38, "griffiths_lane_fe": 1.4},
               "rows": rows}
        Path(args.json).write_text(json.dumps(doc, indent=2))


if __name__ == "__main__":
    main()
