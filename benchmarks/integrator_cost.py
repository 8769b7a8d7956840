"""The integrators' cost per step side by side: Euler-Cromer, rk4 and midpoint on the
stability audit's string (16 elements, 4 particles per element, the exactly integrated
law), at 0.5x and 0.9x of each one's critical step, one thread (fused serial mode).

Each configuration is compiled and run once first; then the three integrators are timed
in turn, ``--repeats`` times, and the fastest run of each is kept (the machine is shared:
compare the ratios of one run)::

    python benchmarks/integrator_cost.py --steps 20000 --json docs/integrator_cost.json
"""
import argparse
import json
import sys
import time

ROWS = [("linear", "lumped"), ("bspline2", "lumped"), ("bspline3", "consistent")]
INTEGRATORS = ("euler-cromer", "rk4", "midpoint")


def _solver(basis, mass, integrator, factor):
    from timpm import Solver
    from timpm.problems import get_problem

    problem = get_problem("vibrating-string")
    kw = dict(elements=16, ppc=4, basis=basis, mass=mass, stress_update="study-exact",
              integrator=integrator)
    critical = problem.scene(dt=1e-9, **kw).critical_dt
    scene = problem.scene(dt=factor * critical, **kw)
    return Solver(scene, mode="serial", energies=False)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20_000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    results = []
    for basis, mass in ROWS:
        for factor in (0.5, 0.9):
            best = {}
            for integrator in INTEGRATORS:  # compile and warm up
                solver = _solver(basis, mass, integrator, factor)
                solver.run(n_steps=10)
                solver.release()
            for _ in range(args.repeats):
                for integrator in INTEGRATORS:
                    solver = _solver(basis, mass, integrator, factor)
                    solver.run(n_steps=1)
                    t0 = time.perf_counter()
                    solver.run(n_steps=args.steps)
                    seconds = time.perf_counter() - t0
                    solver.release()
                    best[integrator] = min(best.get(integrator, seconds), seconds)
            us = {k: 1e6 * v / args.steps for k, v in best.items()}
            row = dict(basis=basis, mass=mass, factor=factor, us_per_step=us,
                       rk4_over_ec=us["rk4"] / us["euler-cromer"],
                       midpoint_over_ec=us["midpoint"] / us["euler-cromer"])
            results.append(row)
            print(f"{basis:9s} {mass:10s} {factor}: " + ", ".join(
                f"{k} {v:.1f} us" for k, v in us.items())
                + f"; rk4 / EC {row['rk4_over_ec']:.1f}, midpoint / EC "
                  f"{row['midpoint_over_ec']:.1f}", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"date": time.strftime("%Y-%m-%d"),
                       "command": "python benchmarks/integrator_cost.py "
                                  + " ".join(argv or sys.argv[1:]), "rows": results},
                      fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
