"""Time of each pass of timpm's mpm88 step (P2G, grid, G2P) from Taichi's kernel profiler.

    python benchmarks/profile_mpm88.py [--particles 131072] [--threads 1] [--scatter private]
                                       [--precision f32] [--steps 100]

Taichi's table: one line per offloaded task (the step kernel's kernel_0 is P2G, kernel_1
the grid pass, kernel_2 G2P, kernel_3 the counters) with its count and min / average / max
milliseconds.  Run it with --threads 1 and 2 to see how
each pass scales; the minimum is the figure least disturbed by a shared machine.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--particles", type=int, default=131072)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--scatter", default="private", choices=["atomic", "serial", "private"])
    ap.add_argument("--precision", default="f32", choices=["f32", "f64"])
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--no-pin", action="store_true",
                    help="leave Taichi's workers unpinned (timpm.init pins them)")
    args = ap.parse_args(argv)

    import taichi as ti

    from timpm.platform import runtime

    # the profiler must be on from the start: Taichi is initialised here, not by timpm
    ti.init(arch=ti.cpu, default_fp=ti.f32 if args.precision == "f32" else ti.f64,
            cpu_max_num_threads=args.threads, log_level=ti.WARN, kernel_profiler=True)
    runtime._state["settings"] = dict(threads=args.threads, debug=False,
                                      precision=args.precision, pin=not args.no_pin)
    pinned = [] if args.no_pin else runtime.pin_workers()
    from harness.numpy_mpm import mpm88_initial
    from timpm.scenarios.mpm88 import mpm88_world
    from timpm.simulation.solver import Solver

    world, _ = mpm88_world(mpm88_initial(args.particles)[0])
    s = Solver(world, energies=False, mode="parallel", scatter=args.scatter)
    s.run(n_steps=20)  # compiled and warm
    ti.profiler.clear_kernel_profiler_info()
    s.run(n_steps=args.steps)
    print(f"{args.particles} particles, {args.threads} thread(s), {s.scatter} scatter, "
          f"{args.precision}, {len(pinned)} workers pinned; per step:")
    ti.profiler.print_kernel_profiler_info("count")


if __name__ == "__main__":
    main()
