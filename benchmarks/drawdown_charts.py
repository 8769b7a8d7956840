"""Slopes after a drawdown, beside published results: timpm's strength reduction (drained,
effective stress) and Bishop's simplified method on the same pore pressures
(timpm.studies.limit_equilibrium), against

1. Griffiths & Lane (1999), their example 5 (Figs 12-15): the slope of their example 1
   (2:1, c' / (gamma H) = 0.05, phi' = 20 degrees, one unit weight 20 kN/m^3 above and
   below the water) with the still water at a depth L below the crest, outside the slope
   and inside it (a slow drawdown: the table in the soil follows the reservoir), L / H
   from 0 (submerged to the crest) to 1 (drawn down to the toe).  Their finite elements'
   factors as read off their Fig. 15 by the verification pages of XSLOPE
   (github.com/njones61/xslope, docs/verification/ssrm.md: "every comparison value above is
   read from the paper's Fig. 15"; the paper states the minimum, about 1.3 at L / H =
   0.7, and prints Morgenstern's 1.85 at L / H = 0 and Bishop & Morgenstern's 1.4 at 1).
   The scene: examples/slope_griffiths_lane_submerged.toml with ``water.level`` = H - L.
2. Morgenstern's (1963) rapid-drawdown charts, the problem of Rocscience Slide's
   verification problems #100 and #101 (3:1, c' / (gamma H) = 0.025, phi' = 30 degrees,
   gamma = 2 gamma_w, B-bar = 1; as XSLOPE's docs/verification/rocscience.md transcribes
   them): 1.20 after a complete drawdown, 1.41 after a drawdown to mid-height.  The scene:
   examples/slope_morgenstern_drawdown.toml (the table at the ground surface; at mid-height
   the table at max(ground, H / 2) and the free water at H / 2).

    python benchmarks/drawdown_charts.py [--cells 120] [--tolerance 0.02] [--workers 2]
        [--only griffiths-lane|morgenstern] [--json docs/drawdown_charts.json]
        [--plot docs/drawdown_charts.png]

``--only`` with an existing ``--json`` record runs that part again and keeps the other.
"""
import argparse
import json
import sys
import time
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

H = 10.0
#: their finite elements' factor against L / H, read off their Fig. 15 (XSLOPE's
#: transcription, above)
GL_FIG15 = {-0.2: 1.85, 0.0: 1.85, 0.2: 1.60, 0.4: 1.40, 0.5: 1.35, 0.7: 1.30, 0.9: 1.35,
            1.0: 1.40}
#: the drawdown ratios run
GL_RATIOS = (0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
#: Morgenstern's problem (examples/slope_morgenstern_drawdown.toml)
M_SLOPE = [[0.0, 0.0], [45.0, 0.0], [15.0, 10.0], [0.0, 10.0]]
M_CHART = {1.0: 1.20, 0.5: 1.41}
M_TABLES = {1.0: [[0.0, 10.0], [15.0, 10.0], [45.0, 0.0], [60.0, 0.0]],
            0.5: [[0.0, 10.0], [15.0, 10.0], [30.0, 5.0], [60.0, 5.0]]}


def _study(file, overrides, bracket, args):
    from timpm.scenefile import load_scene
    from timpm.studies.factor_of_safety import factor_of_safety

    scene = load_scene(ROOT / "examples" / file,
                       overrides={"domain.cells": args.cells, **overrides})
    record, _ = factor_of_safety(scene.world, scene.t_end, low=bracket[0], high=bracket[1],
                                 tolerance=args.tolerance, workers=args.workers)
    return {"factor_of_safety": record["factor_of_safety"], "bracket": record["bracket"],
            "particles": record["particles"], "h": record["h"], "basis": record["basis"],
            "seconds": record["wall_seconds"], "trials": len(record["trials"])}


def griffiths_lane(args):
    from timpm.studies.limit_equilibrium import bishop_search
    from water_slopes import SLOPE as GL_SLOPE  # Griffiths & Lane's slope, as there

    rows = []
    for ratio in GL_RATIOS:
        level = round(H * (1.0 - ratio), 9)
        t0 = time.perf_counter()
        bishop = bishop_search(GL_SLOPE, 10e3, 20.0, 20e3,
                               water_table=level if level > 0.0 else None)[0]
        le_seconds = time.perf_counter() - t0
        # drawn down to the toe the slope is dry (a level at the grid's bottom is refused:
        # it holds no water): the dry scene file, the same slope and soil
        file, overrides = (("slope_griffiths_lane.toml", {}) if level <= 0.0 else
                           ("slope_griffiths_lane_submerged.toml", {"water.level": level}))
        row = {"L_over_H": ratio, "level": level, "scene": f"examples/{file}",
               "bishop": bishop, "bishop_seconds": le_seconds,
               "griffiths_lane_fig15": GL_FIG15.get(ratio),
               **_study(file, overrides, (1.0, 2.5), args)}
        print(row, flush=True)
        rows.append(row)
    return rows


def morgenstern(args):
    from timpm import Water
    from timpm.studies.limit_equilibrium import bishop_search

    rows = []
    for ratio, table in M_TABLES.items():
        t0 = time.perf_counter()
        phreatic = Water("drained", phreatic=table)  # the scene's table, as the engine reads it
        bishop = bishop_search(M_SLOPE, 4905.0, 30.0, 19.62e3, water_table=phreatic.table)[0]
        le_seconds = time.perf_counter() - t0
        # psi = 0 (the file's) and associated flow, psi = phi' (the limit equilibrium's
        # tacit assumption: at phi' = 30 degrees a non-associated law's factor falls below
        # it, as Davis's for the infinite slope, docs/results.md)
        for psi in (0.0, 30.0):
            row = {"L_over_H": ratio, "scene": "examples/slope_morgenstern_drawdown.toml",
                   "phreatic": table, "dilation_angle": psi, "bishop": bishop,
                   "bishop_seconds": le_seconds, "morgenstern_chart": M_CHART[ratio],
                   **_study("slope_morgenstern_drawdown.toml",
                            {"water.phreatic": table, "material.soil.dilation_angle": psi},
                            (0.8, 2.2), args)}
            print(row, flush=True)
            rows.append(row)
    return rows


def plot(out, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    rows = out.get("griffiths_lane", [])
    if rows:
        r = [row["L_over_H"] for row in rows]
        lo = [row["bracket"][0] for row in rows]
        hi = [row["bracket"][1] for row in rows]
        ax.fill_between(r, lo, hi, color="C0", alpha=0.3, lw=0)
        ax.plot(r, [row["factor_of_safety"] for row in rows], "o-", color="C0",
                label=f"timpm, drained strength reduction (h = {rows[0]['h']:g} m)")
        ax.plot(r, [row["bishop"] for row in rows], "s--", color="C1", mfc="none",
                label="Bishop's simplified method, the same pore pressures")
        fig15 = sorted((k, v) for k, v in GL_FIG15.items() if k >= 0.0)
        ax.plot(*zip(*fig15), "k^", label="Griffiths & Lane (1999) Fig. 15, FE (read off)")
    labelled = set()
    for row in out.get("morgenstern", []):
        psi = row.get("dilation_angle", 0.0)
        key = ("timpm", psi)
        ax.plot(row["L_over_H"], row["factor_of_safety"], "D" if psi == 0.0 else "P",
                color="C2" if psi == 0.0 else "C4",
                label=(f"timpm, Morgenstern's problem (3:1, B = 1), psi = {psi:g}"
                       if key not in labelled else None))
        labelled.add(key)
        ax.plot(row["L_over_H"], row["morgenstern_chart"], "x", color="C3", ms=9,
                label="Morgenstern's (1963) charts" if "chart" not in labelled else None)
        labelled.add("chart")
    ax.set_xlabel("drawdown ratio L / H (L: the water's depth below the crest)")
    ax.set_ylabel("factor of safety")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7.5)
    ax.set_title("Slopes after a drawdown: slow (G&L's example 5) and rapid (Morgenstern)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, default=120, help="cells along the 60 m domain")
    ap.add_argument("--tolerance", type=float, default=0.02)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--only", choices=("griffiths-lane", "morgenstern"))
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--plot", metavar="PNG")
    ap.add_argument("--replot", metavar="JSON", help="draw --plot from a record, run nothing")
    args = ap.parse_args()
    if args.replot:
        plot(json.loads(Path(args.replot).read_text()), args.plot)
        return

    import timpm

    timpm.init(precision="f64")
    out = {"command": "python benchmarks/drawdown_charts.py " + " ".join(sys.argv[1:]),
           "date": str(date.today())}
    if args.only and args.json and Path(args.json).exists():  # the other part kept
        kept = json.loads(Path(args.json).read_text())
        kept.pop("wall_seconds", None)
        out = {**kept, **out, "earlier": {k: kept[k] for k in ("command", "date")
                                          if k in kept}}
    t0 = time.perf_counter()
    if args.only in (None, "griffiths-lane"):
        out["griffiths_lane"] = griffiths_lane(args)
    if args.only in (None, "morgenstern"):
        out["morgenstern"] = morgenstern(args)
    out["wall_seconds"] = time.perf_counter() - t0
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n")
    if args.plot:
        plot(out, args.plot)


if __name__ == "__main__":
    main()
