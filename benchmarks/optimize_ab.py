"""Compile and step time with Taichi's control-flow optimisation on and off, side by side.

    python benchmarks/optimize_ab.py [--repeats 3] [--threads 1 2] [--json out.json]

``timpm.init(optimize=False)`` (``TIMPM_OPTIMIZE=0``, what the test processes run) turns
off Taichi's ``cfg_optimization``.  Each measurement is a fresh process with Taichi's
offline cache off (every kernel compiled) that times building one scene and its first 20
steps (mostly the compilation of every kernel a run launches: seconds) and then ``steps`` more
(microseconds per step); the two builds alternate, ``--repeats`` times, and the fastest
and the median of each are kept.  Cases: mpm88's physics at 8192 particles (f32, the
team), the 2D sand column of tests/test_scatter.py (MUSL, Drucker-Prager, friction floor,
1152 particles, parallel mode) and the five Table 3.2 meshes (fused serial, one thread).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
from datetime import date

WORKER = r"""
import json, sys, time
import numpy as np
import timpm
kind, threads, optimize = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1"
precision = "f32" if kind == "mpm88" else "f64"
timpm.init(threads=threads, precision=precision, optimize=optimize)
from timpm import Body, Box, World
from timpm.materials import DruckerPrager
t0 = time.perf_counter()
if kind == "mpm88":
    from timpm.scenarios.mpm88 import mpm88_world
    world, _ = mpm88_world(np.random.default_rng(0).random((8192, 2)) * 0.4 + 0.2)
    solvers, steps = [timpm.Solver(world, energies=False)], 400
elif kind == "sand":
    sand = DruckerPrager(E=2e5, nu=0.3, density=1500.0, friction_angle=30.0)
    world = World(domain=(1.2, 0.8), cells=24, walls={"bottom": "friction"}, courant=0.5,
                  transfer="musl", bodies=[Body(Box((0.0, 0.0), (0.3, 0.6)), sand, ppc=4)])
    solvers, steps = [timpm.Solver(world, mode="parallel", energies=False)], 400
else:
    from timpm.problems import get_problem
    solvers = [timpm.Solver(get_problem("vibrating-string").scene(elements=e),
                            energies=False, mode="serial") for e in (4, 8, 16, 32, 64)]
    steps = 2000
for s in solvers:
    s.run(n_steps=20)
first = time.perf_counter() - t0
t = time.perf_counter()
for s in solvers:
    s.run(n_steps=steps)
wall = time.perf_counter() - t
print(json.dumps({"compile_s": first, "us_per_step": 1e6 * wall / (steps * len(solvers))}))
"""

CASES = {"mpm88": "mpm88 physics, 8192 particles, f32", "sand": "2D sand column, MUSL, "
         "1152 particles, parallel", "table-3.2": "Table 3.2 meshes, fused, f64"}


def measure(kind, threads, optimize):
    env = dict(os.environ, TI_OFFLINE_CACHE="0", TIMPM_THREADS=str(threads))
    proc = subprocess.run([sys.executable, "-c", WORKER, kind, str(threads),
                           "1" if optimize else "0"], capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-2000:])
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    rows = []
    cases = [(k, t) for k in ("mpm88", "sand") for t in args.threads] + [("table-3.2", 1)]
    for kind, threads in cases:
        runs = {True: [], False: []}
        for _ in range(args.repeats):
            for optimize in (True, False):
                runs[optimize].append(measure(kind, threads, optimize))
        row = {"case": CASES[kind], "threads": threads}
        for optimize, name in ((True, "optimized"), (False, "fast_compile")):
            for key in ("compile_s", "us_per_step"):
                values = [r[key] for r in runs[optimize]]
                row[f"{name}_{key}"] = {"min": min(values), "median": statistics.median(values)}
        for key in ("compile_s", "us_per_step"):
            row[f"{key}_ratio"] = {m: row[f"fast_compile_{key}"][m] / row[f"optimized_{key}"][m]
                                   for m in ("min", "median")}
        rows.append(row)
        print(f"{row['case']}, {threads} thread(s): compile {row['optimized_compile_s']['min']:.2f}"
              f" s -> {row['fast_compile_compile_s']['min']:.2f} s "
              f"({row['compile_s_ratio']['min']:.2f}x); step "
              f"{row['optimized_us_per_step']['min']:.1f} -> "
              f"{row['fast_compile_us_per_step']['min']:.1f} us "
              f"(min {row['us_per_step_ratio']['min']:.3f}, median "
              f"{row['us_per_step_ratio']['median']:.3f})", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"date": date.today().isoformat(), "command": " ".join(sys.argv),
                       "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
