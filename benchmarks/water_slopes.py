"""Slopes with water by strength reduction, beside their references: the infinite slope
(dry, submerged, seepage parallel to the slope) against its closed forms, and Griffiths &
Lane's slope dry, submerged and after rapid drawdown against Bishop's simplified method on
the same pore pressures (timpm.studies.limit_equilibrium).

    python benchmarks/water_slopes.py [--cells 120] [--tolerance 0.01]
        [--json docs/water_slopes.json]
"""
import argparse
import json
import sys
import time
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

SLOPE = [[0.0, 0.0], [40.0, 0.0], [20.0, 10.0], [0.0, 10.0]]
CASES = {"dry": ("slope_griffiths_lane.toml", None, (1.0, 2.0)),
         "submerged": ("slope_griffiths_lane_submerged.toml", 12.0, (1.0, 3.0)),
         "drawdown": ("slope_griffiths_lane_drawdown.toml", "surface", (0.5, 2.0))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, default=120, help="cells along the 60 m domain")
    ap.add_argument("--tolerance", type=float, default=0.01)
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args()

    import timpm
    from timpm.scenefile import load_scene
    from timpm.studies.factor_of_safety import factor_of_safety
    from timpm.studies.infinite_slope import WATERS, InfiniteSlope
    from timpm.studies.limit_equilibrium import ground_surface, bishop_search

    timpm.init(precision="f64")
    out = {"command": "python benchmarks/water_slopes.py " + " ".join(sys.argv[1:]),
           "date": str(date.today()), "infinite_slope": [], "griffiths_lane": []}
    for water in WATERS:
        r = InfiniteSlope(water=water).factor_of_safety(tolerance=args.tolerance / 2)
        row = {k: r[k] for k in ("water", "factor_of_safety", "bracket", "exact",
                                 "relative_error", "wall_seconds")}
        print(row, flush=True)
        out["infinite_slope"].append(row)
    for case, (name, table, bracket) in CASES.items():
        t0 = time.perf_counter()
        water = ground_surface(SLOPE) if table == "surface" else table
        bishop, centre, radius = bishop_search(SLOPE, 10e3, 20.0, 20e3, water_table=water)
        le_seconds = time.perf_counter() - t0
        scene = load_scene(ROOT / "examples" / name, overrides={"domain.cells": args.cells})
        record, _ = factor_of_safety(scene.world, scene.t_end, low=bracket[0],
                                     high=bracket[1], tolerance=args.tolerance)
        row = {"case": case, "scene": f"examples/{name}", "h": 60.0 / args.cells,
               "basis": record["basis"], "particles": record["particles"],
               "factor_of_safety": record["factor_of_safety"], "bracket": record["bracket"],
               "bishop": bishop, "bishop_circle": {"centre": centre, "radius": radius},
               "relative_to_bishop": record["factor_of_safety"] / bishop - 1.0,
               "seconds": record["wall_seconds"], "bishop_seconds": le_seconds}
        print(row, flush=True)
        out["griffiths_lane"].append(row)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
