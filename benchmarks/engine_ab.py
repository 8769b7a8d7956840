"""Step speed of two engines side by side: this checkout against another commit of timpm.

    git worktree add --detach /tmp/timpm-old <commit>
    python benchmarks/engine_ab.py /tmp/timpm-old [--sizes 8192 131072] [--threads 1 2]

Each measurement is a fresh process (``PYTHONPATH`` selects the engine) that builds
mpm88's physics (2D, quadratic B-splines, MLS-MPM, J-fluid, walls, f32) for n particles,
runs 50 steps to warm up, then times ``--steps`` steps in the mode ``auto`` picks; the two
engines alternate, ``--repeats`` times, and the fastest of each is kept.  Also the 1D
Table 3.2 stepping (fused, one thread), and a 3D MLS-MPM block of quadratic B-splines
(``--cells-3d``; 13,824 particles, f32) on each thread count.  Prints microseconds per
step and the ratio new / old (above 1: the new engine is slower).
"""
import argparse
import json
import os
import subprocess
import sys
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

WORKER = r"""
import json, sys, time
import numpy as np
import timpm
kind, n, steps, threads = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
if kind == "mpm88":
    timpm.init(threads=threads, precision="f32")
    try:
        from timpm.scenarios.mpm88 import mpm88_world
    except ImportError:
        from timpm.mpm88 import mpm88_world
    x0 = np.random.default_rng(0).random((n, 2)) * 0.4 + 0.2
    world, _ = mpm88_world(x0)
    s = timpm.Solver(world, energies=False)
    s.run(n_steps=50)
    t = time.perf_counter()
    s.run(n_steps=steps)
    wall = time.perf_counter() - t
    print(json.dumps({"us_per_step": 1e6 * wall / steps, "mode": s.mode}))
elif kind == "3d":
    # 3D MLS-MPM with quadratic B-splines: a neo-Hookean block, 8 particles a cell
    timpm.init(threads=threads, precision="f32")
    block = timpm.Body(timpm.Box((0.1, 0.1, 0.1), (0.6, 0.6, 0.6)),
                       timpm.NeoHookean(E=2e4, nu=0.3, density=1000.0), ppc=2)
    world = timpm.World(domain=(1.0, 1.0, 1.0), cells=n, basis="uniform-bspline2",
                        transfer="mls-mpm", bodies=[block], walls="slip", courant=0.4)
    s = timpm.Solver(world, energies=False)
    s.run(n_steps=5)
    best = 1e9
    for rep in range(3):
        t = time.perf_counter()
        s.run(n_steps=steps)
        best = min(best, time.perf_counter() - t)
    print(json.dumps({"us_per_step": 1e6 * best / steps, "mode": s.mode,
                      "particles": world.n_particles}))
else:
    timpm.init(threads=1)
    from timpm.problems import get_problem
    solvers = [timpm.Solver(get_problem("vibrating-string").scene(elements=e), energies=False,
                            mode="serial") for e in (4, 8, 16, 32, 64)]
    best = 1e9
    for s in solvers:
        s.run(n_steps=10)
    for rep in range(5):
        t = time.perf_counter()
        for s in solvers:
            s.run(n_steps=1000)
        best = min(best, time.perf_counter() - t)
    print(json.dumps({"us_per_step": 1e6 * best / 5000, "mode": "serial"}))
"""


def measure(path, kind, n, steps, threads):
    env = dict(os.environ, PYTHONPATH=str(path), TIMPM_THREADS=str(threads))
    proc = subprocess.run([sys.executable, "-c", WORKER, kind, str(n), str(steps),
                           str(threads)], capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-2000:])
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", help="a checkout of the other engine (its repository root)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[8192, 131072])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--cells-3d", type=int, default=24,
                    help="cells along each axis of the 3D case (24: 13,824 particles)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    cases = ([("mpm88", n, t) for t in args.threads for n in args.sizes] + [("table-3.2", 0, 1)]
             + [("3d", args.cells_3d, t) for t in args.threads])
    rows = []
    for kind, n, threads in cases:
        steps = 20 if kind == "3d" else 200 if n <= 16384 else 40
        best = {"old": None, "new": None}
        for _ in range(args.repeats):
            for name, path in (("old", Path(args.old).resolve()), ("new", ROOT)):
                r = measure(path, kind, n, steps, threads)
                if best[name] is None or r["us_per_step"] < best[name]["us_per_step"]:
                    best[name] = r
        ratio = best["new"]["us_per_step"] / best["old"]["us_per_step"]
        rows.append({"case": kind, "particles": n, "threads": threads, "old": best["old"],
                     "new": best["new"], "new_over_old": ratio})
        count = best["new"].get("particles", n)
        print(f"{kind:9s} {count:7d} particles {threads} thread(s): old "
              f"{best['old']['us_per_step']:9.1f} us/step ({best['old']['mode']}), new "
              f"{best['new']['us_per_step']:9.1f} ({best['new']['mode']}), new/old {ratio:.3f}",
              flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps({"date": date.today().isoformat(),
                                               "command": " ".join(sys.argv), "rows": rows},
                                              indent=1))


if __name__ == "__main__":
    main()
