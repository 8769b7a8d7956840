"""The excess pore pressure an undrained drawdown leaves in Griffiths & Lane's slope, down
the column of particles at x = 10 m (10 m behind the crest's edge), beside Morgenstern's
B = 1 state rho_w g (y_s - max(L, y)); the same soil as a level layer for comparison
(docs/results.md, "Why the undrained drawdown of a slope is not the B = 1 state").

The scene is examples/slope_griffiths_lane_submerged.toml, undrained, elastic (cohesion
1e8 Pa), the level from 12 m to 0 in 2 s, the PIC share 0.05, run to 2.5 s.

    python benchmarks/drawdown_profile.py [--layer] [--basis bspline2|linear]
        [--bulk-modulus 2.2e9] [--smoothing none|cell]
"""
import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

GAMMA_W = 1000.0 * 9.81


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--layer", action="store_true", help="a level 10 m layer, no face")
    ap.add_argument("--basis", default="bspline2")
    ap.add_argument("--bulk-modulus", type=float, default=2.2e9, help="K_w (Pa)")
    ap.add_argument("--smoothing", default="none")
    args = ap.parse_args()

    import timpm  # noqa: F401  (Taichi started by the package)
    from timpm.scenefile import load_scene
    from timpm.simulation.solver import Solver

    level, final, duration = 12.0, 0.0, 2.0
    overrides = {"water.analysis": "undrained", "water.smoothing": args.smoothing,
                 "water.final_level": final, "water.drawdown_time": duration,
                 "simulation.basis": args.basis, "simulation.pic_fraction": 0.05,
                 "material.soil.cohesion": 1e8,
                 "body[0].water": {"porosity": 0.4, "conductivity": 1e-6,
                                   "bulk_modulus": args.bulk_modulus}}
    if args.layer:
        overrides["body[0].vertices"] = [[0.0, 0.0], [60.0, 0.0], [60.0, 10.0], [0.0, 10.0]]
    scene = load_scene(ROOT / "examples" / "slope_griffiths_lane_submerged.toml",
                       overrides=overrides)
    solver = Solver(scene.world, energies=False)
    x0 = solver.positions()
    column = np.flatnonzero(np.abs(x0[:, 0] - 10.125) < 1e-6)
    column = column[np.argsort(x0[column, 1])]
    ground = solver.read("ground")[column]
    print(f"{'case':>8} {'t (s)':>6} {'L (m)':>6}  p_e / B = 1 (kPa) at y = "
          + " ".join(f"{y:.2f}" for y in x0[column, 1][::4]))
    for t in (0.5, 1.0, 1.5, 2.5):
        solver.run(t_end=t)
        L = level + (final - level) * min(t / duration, 1.0)
        y = solver.positions()[column, 1]
        pw = solver.read("pw")[column]
        exact = GAMMA_W * np.maximum(np.minimum(level, ground) - np.maximum(L, y), 0.0)
        print(f"{'layer' if args.layer else 'slope':>8} {t:6.2f} {L:6.2f}  "
              + " ".join(f"{p / 1e3:.0f}/{e / 1e3:.0f}" for p, e in
                         list(zip(pw, exact))[::4]))


if __name__ == "__main__":
    main()
