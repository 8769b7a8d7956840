"""Speed of the 1D timpm engine: study timings, large runs and launch overhead.

Run from the repository root:

    python benchmarks/bench_1d.py [--quick] [--json out.json] [--threads N]

``--quick`` is a fast smoke version (no 1e6-particle run, fewer steps).  Three tables:

1. the Table 3.2 convergence study of the vibrating string (4..64 elements), with
   stepping time apart from kernel compilation;
2. large runs (1e5 and 1e6 particles) in serial and parallel mode, side by side;
3. launch overhead of a tiny problem: serial (many steps fused in one kernel launch)
   against parallel (one launch per step);
4. every basis (and mass) on 1e5 particles: particle-steps per second side by side, each
   basis compiled into its own specialised kernels.

Timings are informative only: the ratios are measured side by side in one process on
a possibly shared machine and vary from run to run.  Nothing here is an assertion.
"""
import argparse
import json
import os
import time

import taichi as ti

import timpm
from timpm.problems import get_problem
from timpm.studies.study import convergence

PROBLEM = "vibrating-string"
STUDY_ELEMENTS = (4, 8, 16, 32, 64)      # Table 3.2
PPC = 4                                   # particles per element
DT_FRACTION = 0.5                         # dt = DT_FRACTION * h / c for the large runs
LARGE_PARTICLES = (100_000, 1_000_000)    # the second is skipped with --quick
TARGET_PARTICLE_STEPS = 5e7               # per measured run: about 0.5-5 s per measurement
QUICK_PARTICLE_STEPS = 3e7
MIN_STEPS = 10
TINY_ELEMENTS = 16                        # launch-overhead problem: 64 particles
TINY_STEPS = 5000
MODES = ("serial", "parallel")
BASIS_RUNS = (("linear", "lumped"), ("bspline2", "lumped"), ("bspline3", "lumped"),
              ("uniform-bspline2", "lumped"), ("linear", "consistent"),
              ("bspline2", "consistent"), ("bspline3", "consistent"),
              ("lagrange2", "consistent"))
BASIS_PARTICLES = 100_000


def table(title, header, rows):
    """Print rows (lists of already formatted strings) as a plain-text table."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    print(f"\n{title}")
    print("  ".join(h.rjust(w) for h, w in zip(header, widths)))
    print("  ".join("-" * w for w in widths))
    for r in rows:
        print("  ".join(c.rjust(w) for c, w in zip(r, widths)))


def study():
    doc = convergence(PROBLEM, elements=STUDY_ELEMENTS, progress=False)
    rows, out = [], []
    for r in doc["runs"]:
        rate = r["steps"] / r["wall_seconds"]
        rec = {k: r[k] for k in ("elements", "particles", "steps", "rms_error", "wall_seconds",
                                 "compile_seconds", "build_seconds", "mode")}
        rec.update(steps_per_second=rate, particle_steps_per_second=rate * r["particles"])
        out.append(rec)
        rows.append([str(r["elements"]), str(r["particles"]), str(r["steps"]),
                     f"{r['rms_error']:.3e}", f"{r['wall_seconds']:.4f}",
                     f"{r['compile_seconds']:.3f}", f"{rate:.4g}",
                     f"{rate * r['particles']:.4g}", r["mode"]])
    table(f"Table 3.2 study ({PROBLEM}, ppc={PPC}, default dt and t_end)",
          ["elements", "particles", "steps", "rms_error", "wall_s", "compile_s",
           "steps/s", "particle-steps/s", "mode"], rows)
    print("(wall_s includes recording the monitored particle and the energies every step)")
    return out


def timed(scene, mode, steps):
    """Compile, then two runs of ``steps`` steps; the second gives the rates."""
    solver = timpm.Solver(scene, track=(), energies=False, mode=mode)
    try:
        t0 = time.perf_counter()
        solver.run(n_steps=steps, progress=False)
        first = time.perf_counter() - t0 - solver.compile_seconds
        t0 = time.perf_counter()
        solver.run(n_steps=steps, progress=False)
        second = time.perf_counter() - t0
        rate = steps / second
        return {"mode": solver.mode, "particles": scene.n_particles, "steps": steps,
                "compile_seconds": solver.compile_seconds, "first_run_seconds": first,
                "wall_seconds": second, "steps_per_second": rate,
                "particle_steps_per_second": rate * scene.n_particles}
    finally:
        solver.release()


def large(quick):
    prob = get_problem(PROBLEM)
    c = prob.material.wave_speed
    sizes = LARGE_PARTICLES[:1] if quick else LARGE_PARTICLES
    budget = QUICK_PARTICLE_STEPS if quick else TARGET_PARTICLE_STEPS
    rows, out = [], []
    for n in sizes:
        elements = n // PPC
        h = prob.domain_length() / elements
        scene = prob.scene(elements=elements, ppc=PPC, dt=DT_FRACTION * h / c)
        steps = max(MIN_STEPS, int(budget / scene.n_particles))
        recs = {mode: timed(scene, mode, steps) for mode in MODES}
        ratio = recs["parallel"]["steps_per_second"] / recs["serial"]["steps_per_second"]
        for mode in MODES:
            r = recs[mode]
            r["parallel_over_serial"] = ratio
            out.append(r)
            rows.append([str(r["particles"]), mode, str(steps), f"{r['compile_seconds']:.3f}",
                         f"{r['first_run_seconds']:.3f}", f"{r['wall_seconds']:.3f}",
                         f"{r['steps_per_second']:.4g}", f"{r['particle_steps_per_second']:.4g}",
                         f"{ratio:.2f}" if mode == "parallel" else ""])
    table(f"Large runs ({PROBLEM}, ppc={PPC}, dt={DT_FRACTION} h/c; rates from the second run)",
          ["particles", "mode", "steps", "compile_s", "run1_s", "run2_s", "steps/s",
           "particle-steps/s", "parallel/serial"], rows)
    return out


def launch_overhead():
    scene = get_problem(PROBLEM).scene(elements=TINY_ELEMENTS, ppc=PPC)
    recs = {mode: timed(scene, mode, TINY_STEPS) for mode in MODES}
    ratio = recs["serial"]["steps_per_second"] / recs["parallel"]["steps_per_second"]
    rows = [[str(r["particles"]), m, str(r["steps"]), f"{r['compile_seconds']:.3f}",
             f"{r['wall_seconds']:.4f}", f"{r['steps_per_second']:.4g}",
             f"{1e6 / r['steps_per_second']:.2f}"] for m, r in recs.items()]
    table(f"Launch overhead ({TINY_ELEMENTS} elements x {PPC} ppc; serial fuses steps in one "
          f"launch, parallel launches once per step)",
          ["particles", "mode", "steps", "compile_s", "wall_s", "steps/s", "us/step"], rows)
    print(f"serial / parallel steps/s: {ratio:.1f}x (auto mode picks serial here)")
    return {"modes": recs, "serial_over_parallel": ratio}


def per_basis(quick):
    prob = get_problem(PROBLEM)
    elements = BASIS_PARTICLES // PPC
    budget = QUICK_PARTICLE_STEPS if quick else TARGET_PARTICLE_STEPS
    rows, out = [], []
    base_rate = None
    for basis, mass in BASIS_RUNS:
        h = prob.domain_length() / elements
        # a step safely below every basis' critical step, the same for all: a fair race
        scene = prob.scene(elements=elements, ppc=PPC, basis=basis, mass=mass,
                           dt=0.1 * h / prob.material.wave_speed)
        steps = max(MIN_STEPS, int(budget / scene.n_particles / 2))
        mode = "serial" if mass == "consistent" else "parallel"  # the banded solve is serial
        r = timed(scene, mode, steps)
        r.update(basis=basis, mass=mass)
        base_rate = base_rate or r["particle_steps_per_second"]
        r["relative_to_linear"] = r["particle_steps_per_second"] / base_rate
        out.append(r)
        rows.append([basis, mass, r["mode"], str(steps), f"{r['compile_seconds']:.3f}",
                     f"{r['particle_steps_per_second']:.4g}", f"{r['relative_to_linear']:.2f}"])
    table(f"Per basis ({PROBLEM}, {BASIS_PARTICLES} particles, ppc={PPC}, dt=0.1 h/c)",
          ["basis", "mass", "mode", "steps", "compile_s", "particle-steps/s", "vs linear"], rows)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fast smoke version")
    ap.add_argument("--json", metavar="FILE", help="write the results to FILE")
    ap.add_argument("--threads", type=int, help="CPU threads for parallel mode")
    args = ap.parse_args()
    timpm.init(threads=args.threads)  # None: TIMPM_THREADS or all cores
    threads = ti.lang.impl.current_cfg().cpu_max_num_threads
    version = ".".join(map(str, ti.__version__))
    print(f"timpm {timpm.__version__}, taichi {version}, {threads} threads, "
          f"{os.cpu_count()} cores{', quick' if args.quick else ''}")
    t0 = time.perf_counter()
    results = {"quick": args.quick, "threads": threads, "cpu_count": os.cpu_count(),
               "study": study(), "large": large(args.quick), "launch": launch_overhead(),
               "bases": per_basis(args.quick)}
    results["total_seconds"] = time.perf_counter() - t0
    print(f"\ntotal {results['total_seconds']:.1f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2, default=float)
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
