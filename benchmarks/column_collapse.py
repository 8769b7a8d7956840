"""Granular column collapse: run-out against the aspect ratio, compared with Lube et al.

    python benchmarks/column_collapse.py [--cells 17 34] [--aspects 0.5 1 2 4]
                                         [--json docs/column_runout.json] [--plot docs/column_runout.png]

Runs the ``column-collapse`` demo (Drucker-Prager sand, phi = 30 deg, floor friction
tan 30 deg) for each aspect ratio a = H0 / L0 and resolution (cells across the column),
to rest, and prints (L_inf - L0) / L0 against Lube et al. (2005): 1.2 a for small a and
1.9 a^(2/3) for tall columns, with the relative error.
"""
import argparse
import json
import time

import timpm
from timpm.output.viz import plot_runout
from timpm.scenarios import run_demo


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--aspects", type=float, nargs="+", default=[0.5, 1.0, 2.0, 4.0])
    ap.add_argument("--cells", type=int, nargs="+", default=[17, 34],
                    help="cells across the column (34: the demo's default)")
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--json", default="docs/column_runout.json")
    ap.add_argument("--plot", default="docs/column_runout.png")
    args = ap.parse_args(argv)
    timpm.init(threads=args.threads)
    rows = []
    print(f"{'cells':>5} {'a':>5} {'particles':>9} {'run-out':>8} {'Lube':>6} {'rel.err':>8} "
          f"{'Lajeun.':>7} {'rel.err':>8} {'tip':>6} {'H_inf/L0':>8} {'settled':>7} {'wall [s]':>8}")
    for cells in args.cells:
        for a in args.aspects:
            t0 = time.perf_counter()
            r = run_demo("column-collapse", frames=20, aspect=a, cells_per_width=cells)
            s = r.summary
            row = {"cells": cells, "particles": r.particles, "steps": r.steps,
                   "t_end": r.t_end, "wall_seconds": time.perf_counter() - t0, **s}
            rows.append(row)
            print(f"{cells:5d} {a:5.2f} {r.particles:9d} {s['runout']:8.3f} {s['lube_runout']:6.2f} "
                  f"{100 * s['relative_error']:7.1f}% {s['lajeunesse_runout']:7.2f} "
                  f"{100 * s['lajeunesse_relative_error']:7.1f}% {s['tip_runout']:6.2f} "
                  f"{s['final_height']:8.3f} {str(s['settled']):>7} {row['wall_seconds']:8.1f}",
                  flush=True)
    with open(args.json, "w") as fh:
        json.dump({"source": "Lube et al. 2005, PRE 72 041301, as quoted by Lagree, Staron & "
                             "Popinet 2011 (JFM 686), Eq. 3.1 (with Lajeunesse et al. 2005 beside)", "runs": rows}, fh, indent=2)
    finest = max(args.cells)
    plot_runout([r for r in rows if r["cells"] == finest], args.plot)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
