"""The Mohr-Coulomb soil step beside Taichi's mpm88, in one run (issue 46's first measure).

Griffiths & Lane's scene file (examples/slope_griffiths_lane.toml: Mohr-Coulomb, clamped
quadratic B-splines, MUSL, local damping, K0 start) with ``domain.cells`` raised (180, 540,
1740: 10,800, 97,200 and 1,009,200 particles), stepped in the mode timpm picks, against
Taichi's own mpm88 example at 131,072 particles (headless, its code unchanged but the
count: ``harness.mpm88``), on the same threads.  Each engine (this checkout and any other,
e.g. a ``git worktree`` of an older commit) and mpm88 run in fresh processes, alternating,
round after round; the fastest of each counts (a shared machine only slows a run down):

    python benchmarks/soil_vs_mpm88.py [--engines /tmp/timpm-old .] [--cells 180 540 1740]
        [--threads 2] [--rounds 3] [--json docs/soil_vs_mpm88.json]

Particle-steps per second of the stepping alone (the fastest chunk of steps after a
warm-up that compiles), and the cost per particle-step in ns; the ratio to mpm88's
particle-substeps per second.
"""
import argparse
import json
import os
import subprocess
import sys
import time
from datetime import date
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCHMARKS))


def soil_worker(engine, cells, seconds):
    """One engine's soil step at ``cells`` (a fresh process): the fastest chunk's rate."""
    sys.path.insert(0, str(Path(engine).resolve()))  # that checkout's timpm
    import timpm  # noqa: F401  (Taichi started by the package)
    from timpm.scenefile import load_scene
    from timpm.simulation.solver import Solver

    t0 = time.perf_counter()
    scene = load_scene(Path(engine) / "examples" / "slope_griffiths_lane.toml",
                       overrides={"domain.cells": cells})
    solver = Solver(scene.world, energies=False)
    solver.run(n_steps=5)  # compiles
    setup = time.perf_counter() - t0
    n = scene.world.n_particles
    chunk = max(5, int(2e6 / n))  # about 2 M particle-steps a chunk
    best, spent = float("inf"), 0.0
    while spent < seconds:
        t = time.perf_counter()
        solver.run(n_steps=chunk)
        wall = time.perf_counter() - t
        best, spent = min(best, wall), spent + wall
    return {"engine": str(engine), "cells": cells, "particles": n, "mode": solver.mode,
            "steps_per_chunk": chunk, "setup_seconds": setup,
            "mpss": n * chunk / best / 1e6, "ns_per_particle_step": best / (n * chunk) * 1e9}


def _spawn(args, threads):
    env = dict(os.environ, TIMPM_THREADS=str(threads))
    cmd = [sys.executable, __file__, "--worker", json.dumps(args)]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=3600)
    if out.returncode != 0:
        raise RuntimeError(f"{args} failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engines", nargs="+", default=["."], help="timpm checkouts")
    ap.add_argument("--cells", type=int, nargs="+", default=[180, 540, 1740])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=3.0, help="stepping per run")
    ap.add_argument("--mpm88", type=int, default=131072, help="mpm88's particles")
    ap.add_argument("--json")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        w = json.loads(args.worker)
        print(json.dumps(soil_worker(w["engine"], w["cells"], w["seconds"])))
        return

    from harness.mpm88 import run_mpm88

    best = {}
    for r in range(args.rounds):
        m = run_mpm88(args.mpm88, frames=12, threads=args.threads)
        key = ("mpm88", args.mpm88)
        if key not in best or m["mpss"] > best[key]["mpss"]:
            best[key] = {k: m[k] for k in ("particles", "threads", "mpss", "dtype")}
        print(f"round {r + 1}: mpm88 {args.mpm88}: {m['mpss']:.2f} Mpss", flush=True)
        for cells in args.cells:
            for engine in args.engines:
                row = _spawn({"engine": engine, "cells": cells, "seconds": args.seconds},
                             args.threads)
                key = (str(engine), cells)
                if key not in best or row["mpss"] > best[key]["mpss"]:
                    best[key] = row
                print(f"round {r + 1}: {engine} cells {cells} ({row['particles']} "
                      f"particles, {row['mode']}): {row['mpss']:.2f} Mpss, "
                      f"{row['ns_per_particle_step']:.0f} ns", flush=True)
    ref = best[("mpm88", args.mpm88)]["mpss"]
    rows = [dict(v, ratio_to_mpm88=v["mpss"] / ref) for k, v in best.items() if k[0] != "mpm88"]
    print(f"\nfastest of {args.rounds} rounds, {args.threads} threads; Taichi's mpm88 at "
          f"{args.mpm88} particles: {ref:.2f} Mpss")
    for row in rows:
        print(f"  {row['engine']:>16} {row['particles']:>9} particles: {row['mpss']:6.2f} "
              f"Mpss ({row['ns_per_particle_step']:4.0f} ns per particle-step), "
              f"{row['ratio_to_mpm88']:.2f}x mpm88")
    if args.json:
        record = {"command": "python benchmarks/soil_vs_mpm88.py " + " ".join(sys.argv[1:]),
                  "date": str(date.today()), "threads": args.threads, "rounds": args.rounds,
                  "mpm88": best[("mpm88", args.mpm88)], "soil": rows}
        Path(args.json).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
