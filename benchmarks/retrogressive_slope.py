"""The sensitive clay cut of examples/retrogressive_clay_slope.toml: softening against its
two perfectly plastic bounds.

    python benchmarks/retrogressive_slope.py [--cells 200] [--json F] [--plot F.png]

Three runs of the example scene: the softening clay (s_u 30 kPa to 6 kPa), and the same
cut of perfectly plastic Mohr-Coulomb clay at the peak and at the residual strength (the
tension cut-off s_u / 2 of each).  Each record is the scene's landslide measure (run-out
beyond the toe, the scarp's retreat, the retrogressions) and the wall time; the plot shows
the softening run's particles at four of its frames, coloured by the plastic strain.
"""
import argparse
import json
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "retrogressive_clay_slope.toml"


def _clay(cohesion):
    return {"type": "mohr-coulomb", "E": 1e7, "nu": 0.3, "density": 1834.862385321101,
            "friction_angle": 0.0, "cohesion": cohesion, "tensile_strength": cohesion / 2}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=200, help="cells along the 100 m domain")
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--plot", metavar="FILE.png")
    args = ap.parse_args(argv)
    import numpy as np

    import timpm
    from timpm.scenefile import load_scene, run_scene

    timpm.init(threads=2)
    rows, shots = [], []
    with tempfile.TemporaryDirectory() as frames:
        for name, changes in (("softening", {"output.npz": frames}),
                              ("peak strength", {"material.clay": _clay(30e3)}),
                              ("residual strength", {"material.clay": _clay(6e3)})):
            scene = load_scene(SCENE, {"domain.cells": args.cells, "output.gif": None,
                                       "output.json": None, **changes})
            t0 = time.perf_counter()
            result = run_scene(scene)
            wall = time.perf_counter() - t0
            slide = result.summary["landslide"]
            rows.append({"run": name, **slide, "particles": result.particles,
                         "steps": result.steps, "wall_seconds": wall})
            print(f"{name:18s} run-out {slide['runout']:5.1f} m ({slide['runout_over_H']:.2f} "
                  f"H), scarp {slide['scarp_retreat']:5.1f} m back, {slide['retrogressions']} "
                  f"retrogression(s); {wall:.1f} s", flush=True)
        # the softening run's frames at four times (frames evenly spaced to t_end)
        files = sorted(Path(frames).glob("*.npz"))
        for k in (len(files) // 12, len(files) // 4, len(files) // 2, len(files) - 1):
            with np.load(files[k]) as f:
                shots.append((float(f["t"]), f["position"], f["plastic_strain"]))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"date": date.today().isoformat(), "command": " ".join(sys.argv),
                       "cells": args.cells, "rows": rows}, f, indent=1)
    if args.plot:
        _plot(shots, args.plot, np)


def _plot(shots, path, np):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(shots), 1, figsize=(9, 1.35 * len(shots) + 0.6), sharex=True,
                             layout="constrained")
    for ax, (t, x, plastic) in zip(axes, shots):
        im = ax.scatter(x[:, 0], x[:, 1], c=np.minimum(plastic, 1.0), s=0.6, cmap="viridis",
                        vmin=0.0, vmax=1.0)
        ax.set_aspect("equal")
        ax.set_xlim(0, 100)
        ax.set_ylim(0, 12)
        ax.set_ylabel("y [m]")
        ax.set_title(f"t = {t:.3g} s", fontsize=9, loc="left")
    axes[-1].set_xlabel("x [m]")
    fig.colorbar(im, ax=axes, label="plastic strain", shrink=0.8)
    fig.suptitle("sensitive clay cut (s_u 30 to 6 kPa, H = 10 m): retrogressive failure",
                 fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
