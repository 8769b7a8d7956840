"""Demo scenes: simulated seconds per wall second, throughput and bytes per particle.

    python benchmarks/demos.py [--threads 2] [--t-end 0.3] [--json docs/bench_demos.json]

Each demo at its default size runs ``--t-end`` seconds of physical time (after compiling,
which is reported apart) with no rendering; the table gives simulated seconds per wall
second (the real-time ratio), million particle-steps per second, and the bytes per
particle and per grid node of the fields the scene allocated.  Side by side in one run, the
column collapse also runs with each scatter strategy of the parallel mode (one launch per
step) and the fused one-thread mode; the defaults pick a team on two threads where the
transfer is affine.
"""
import argparse
import json
import time

import timpm
from timpm.scenarios import DEMOS, get_demo
from timpm.simulation.solver import Solver


def measure(name, t_end, mode="auto", scatter="auto"):
    world = get_demo(name).world()
    solver = Solver(world, mode=mode, scatter=scatter, energies=False)
    t0 = time.perf_counter()
    solver.compile()
    solver.run(n_steps=2)
    compile_s = time.perf_counter() - t0
    steps = max(1, int(round(t_end / world.dt)))
    t0 = time.perf_counter()
    solver.run(n_steps=steps)
    wall = time.perf_counter() - t0
    mem = solver.memory()
    mode = "team" if solver.team else solver.mode
    return {"demo": name, "mode": mode, "scatter": solver.scatter, "particles": world.n_particles,
            "nodes": mem["nodes"], "dt": world.dt, "steps": steps, "wall_seconds": wall,
            "compile_seconds": compile_s, "simulated_per_wall_second": steps * world.dt / wall,
            "wall_seconds_per_simulated_second": wall / (steps * world.dt),
            "mpss": world.n_particles * steps / wall / 1e6, "particle_bytes": mem["particle_bytes"],
            "node_bytes": mem["node_bytes"], "scatter_node_bytes": mem["scatter_node_bytes"],
            "particle_fields": mem["particle_fields"],
            "transfer": world.transfer, "basis": world.basis.name}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--t-end", type=float, default=0.3, help="physical time per run [s]")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    timpm.init(threads=args.threads)
    runs = [measure(name, args.t_end) for name in DEMOS]
    runs += [measure("column-collapse", args.t_end, mode="parallel", scatter=s)
             for s in ("atomic", "serial", "private")]
    runs += [measure("column-collapse", args.t_end, mode="serial")]
    print(f"threads: {args.threads}")
    print(f"{'demo':16} {'mode':8} {'scatter':7} {'particles':>9} {'sim s/wall s':>12} "
          f"{'wall s/sim s':>12} {'Mpss':>6} {'B/particle':>10} {'B/node':>6} {'+copies':>7} {'compile [s]':>11}")
    for r in runs:
        print(f"{r['demo']:16} {r['mode']:8} {r['scatter']:7} {r['particles']:9d} "
              f"{r['simulated_per_wall_second']:12.3f} {r['wall_seconds_per_simulated_second']:12.2f} "
              f"{r['mpss']:6.2f} {r['particle_bytes']:10d} {r['node_bytes']:6d} "
              f"{r['scatter_node_bytes']:7d} "
              f"{r['compile_seconds']:11.2f}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"threads": args.threads, "runs": runs}, fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
