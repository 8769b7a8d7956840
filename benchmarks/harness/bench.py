"""The throughput benchmark: timpm side by side with Taichi's mpm88 and NumPy, and the limits.

Run it as ``python benchmarks/throughput.py [--size full|quick|tiny]``.

Everything is measured in one run on this machine; each thread count runs in its own
process (Taichi fixes the thread count at start-up).  Reported:

* the machine: a STREAM-like triad (GB/s) and a compute-bound kernel (GFLOP/s), both
  Taichi kernels on 1 and 2 threads;
* mpm88's physics (2D, quadratic B-splines, MLS-MPM, J-fluid, 128^2 grid, dt 2e-4): the
  installed mpm88 example (headless), the NumPy step (:mod:`harness.numpy_mpm`) and timpm in
  float32 and float64, with every scatter strategy (and fused steps on one thread, a team
  on two), for 1e3..1e6 particles; agreement of the positions after 50 substeps from
  mpm88's own initial state;
* particle-substeps per second for 1D, 2D and 3D and each basis;
* the Table 3.2 study warm against a NumPy implementation of the same algorithm, and the
  steps per second of a 64-particle run;
* compile time cold (no offline cache) and cached;
* timpm's fraction of the compute and memory bounds.

Output: ``OUT.json``, ``OUT.md`` (tables) and ``OUT.png`` (throughput against particles).
Timings vary from run to run on a shared machine: compare the ratios of one run.
"""
import argparse
import json
import importlib
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

# taichi, or taichi-forge where only that is installed (timpm picks it as it loads: its
# platform's taichi_backend); the harness measures other checkouts too, through the names
# ``timpm`` exports (timpm.Solver, timpm.init, ...), which every engine has
importlib.import_module("timpm")

from . import BENCHMARKS

__all__ = ["main", "bench"]

#: substeps of the agreement check (one mpm88 frame)
AGREE_STEPS = 50

#: timed chunks per throughput measurement (the fastest counts; mpm88: its frames)
CHUNKS = 5


# ---- measurements that run inside a worker process -----------------------------------
def _best_rate(step, n_items, seconds, chunks=CHUNKS, k=None):
    """Items per second of ``step(k)`` (k steps of n_items each): about ``seconds`` of
    stepping in ``chunks`` timed chunks (or chunks of ``k`` steps where given), the fastest
    chunk counted (``mean``: all of them).  A shared machine only ever slows a chunk down,
    so the fastest is the estimate least disturbed by the neighbours; mpm88 and NumPy are
    timed the same way."""
    if k is None:
        t0 = time.perf_counter()
        step(1)
        once = max(time.perf_counter() - t0, 1e-7)
        k = max(1, int(seconds / chunks / once))
    walls = []
    for _ in range(chunks):
        t0 = time.perf_counter()
        step(k)
        walls.append(time.perf_counter() - t0)
    return {"steps": k * chunks, "seconds": sum(walls),
            "mpss": n_items * k / min(walls) / 1e6,
            "mpss_mean": n_items * k * chunks / sum(walls) / 1e6}


def _timed_run(solver, seconds=0.6):
    """Particle-substeps per second of ``solver`` (compiled and warmed up first; on a GPU
    each chunk ends when the device has finished it)."""
    import taichi as ti

    def step(k):
        solver.run(n_steps=k)
        ti.sync()

    solver.run(n_steps=2)
    return _best_rate(step, solver.n_particles, seconds)


def _frame_rate(solver, frames, per_frame=AGREE_STEPS):
    """Particle-substeps per second timed as Taichi's mpm88 example times itself (see
    :func:`harness.mpm88.run_mpm88`): frames of ``per_frame`` substeps, each ending with the
    positions copied to the host (mpm88 hands them to its GUI) and the device finished;
    the first frame (the compiling one) completed untimed, the fastest of the others
    counted.  The two codes are then timed over the same states of the falling fluid (it
    steps slower once it packs against the floor)."""
    import taichi as ti

    def frame(k):
        solver.run(n_steps=k)
        solver.read("x")
        ti.sync()

    solver.run(n_steps=max(per_frame - solver.step, 0))  # the rest of the first frame
    ti.sync()
    return _best_rate(frame, solver.n_particles, None, chunks=frames - 1, k=per_frame)


def _probes(threads):
    """STREAM-like triad a = b + s c (f64, 3 x 128 MiB) and a compute-bound kernel (eight
    independent multiply-add chains per item, f64): the machine's bounds for this thread
    count, measured with the same compiler as the simulation kernels."""
    import taichi as ti

    n = 1 << 24
    a, b, c = (ti.field(ti.f64, n) for _ in range(3))
    b.fill(1.0)
    c.fill(2.0)

    @ti.kernel
    def triad(s: ti.f64):
        for i in range(n):
            a[i] = b[i] + s * c[i]

    items, reps, chains = 1 << 14, 2048, 8
    out = ti.field(ti.f64, items)

    @ti.kernel
    def fma(m: ti.f64):
        for i in range(items):
            x = ti.Vector([ti.cast(i + k, ti.f64) * 1e-9 for k in range(chains)])
            for _ in range(reps):
                x = x * m + 1e-3
            out[i] = x.sum()

    def fastest(kernel, arg, repeats):
        kernel(arg)  # compile
        best = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            kernel(arg)
            ti.sync()
            best = min(best, time.perf_counter() - t0)
        return best

    gbs = 3 * 8 * n / fastest(triad, 3.0, 5) / 1e9
    gflops = 2.0 * items * reps * chains / fastest(fma, 0.999, 3) / 1e9
    return {"threads": threads, "triad_gb_s": gbs, "compute_gflop_s": gflops}


def _mpm88_timpm(counts, strategies, threads, precision, x0_file=None, frames=None):
    """timpm's mpm88 physics per count and strategy: compile seconds and throughput (in
    chunks of about half a second, or with ``frames`` as mpm88 times itself:
    :func:`_frame_rate`), and the agreement with mpm88's positions from ``x0_file``."""
    import taichi as ti

    from timpm.scenarios.mpm88 import mpm88_world
    from timpm import Solver

    from .numpy_mpm import mpm88_initial

    out = []
    agree = {}
    compiled = None
    if x0_file:
        ref = dict(np.load(x0_file))
        for key in [k for k in ref if k.startswith("x0_")]:
            n = int(key[3:])
            world, shift = mpm88_world(ref[key])
            t0 = time.perf_counter()
            s = Solver(world, energies=False)
            s.compile()
            ti.sync()
            compiled = compiled or time.perf_counter() - t0  # the first solver compiles
            s.run(n_steps=AGREE_STEPS)
            agree[n] = float(np.abs(s.positions() + shift - ref[f"x1_{n}"]).max())
            s.release()
    for n in counts:
        world, _ = mpm88_world(mpm88_initial(n)[0])
        for scatter in strategies:
            if scatter == "fused":  # many steps per launch, every loop on this thread
                s = Solver(world, energies=False, mode="serial")
            elif scatter == "team":  # many steps per launch, each thread a block
                s = Solver(world, energies=False, mode="team")
            else:
                s = Solver(world, energies=False, mode="parallel", scatter=scatter)
            t0 = time.perf_counter()
            s.compile()
            s.run(n_steps=1)
            ti.sync()
            compile_s = time.perf_counter() - t0
            rec = (_frame_rate(s, frames) if frames else
                   _timed_run(s, seconds=0.5 if n < 500_000 else 1.5))
            mem = s.memory()
            rec.update(particles=n, scatter=_strategy(s), threads=threads, precision=precision,
                       first_step_seconds=compile_s, particle_bytes=mem["particle_bytes"],
                       node_bytes=mem["node_bytes"], nodes=mem["nodes"],
                       scatter_node_bytes=mem["scatter_node_bytes"])
            out.append(rec)
            s.release()
    return {"runs": out, "agreement": agree, "compile_seconds": compiled}


def _strategy(solver) -> str:
    """How the solver runs: ``fused`` (mode serial), ``team`` or its scatter strategy."""
    return "fused" if solver.mode == "serial" else "team" if solver.team else solver.scatter


def _block_world(dim, basis, n_target):
    """A Neo-Hookean block falling onto a slip floor, about ``n_target`` particles (2 per
    cell and axis), MUSL transfer: the per-basis and per-dimension comparison scene."""
    from timpm.materials import NeoHookean
    from timpm import Body, Box, World

    ppc = 2
    cells_in_block = max(2, round((n_target / ppc ** dim) ** (1.0 / dim)))
    cells = 2 * cells_in_block
    h = 1.0 / cells
    block = Box((0.25,) * dim, (0.25 + cells_in_block * h,) * dim)
    solid = NeoHookean(E=1e5, nu=0.3, density=1e3)
    return World(domain=(1.0,) * dim, cells=cells, basis=basis, transfer="musl",
                 bodies=[Body(block, solid, ppc=ppc)], courant=0.4)


def _per_basis(cases, threads):
    from timpm.problems import get_problem
    from timpm import Solver

    out = []
    for dim, basis, n in cases:
        if dim == 1:
            prob = get_problem("vibrating-string")
            elements = n // 4
            h = prob.domain_length() / elements
            scene = prob.scene(elements=elements, ppc=4, basis=basis,
                               dt=0.1 * h / prob.material.wave_speed)
        else:
            scene = _block_world(dim, basis, n)
        s = Solver(scene, energies=False, track_crossings=False)  # auto: fused on one thread
        t0 = time.perf_counter()
        s.compile()
        s.run(n_steps=1)
        first = time.perf_counter() - t0
        rec = _timed_run(s, seconds=0.6)
        rec.update(dim=dim, basis=basis, particles=scene.n_particles, threads=threads,
                   scatter=_strategy(s), first_step_seconds=first,
                   particle_bytes=s.memory()["particle_bytes"])
        out.append(rec)
        s.release()
    return out


#: the meshes of Table 3.2
STUDY_ELEMENTS = (4, 8, 16, 32, 64)


def _study_1d(elements=STUDY_ELEMENTS, tiny_steps=200_000):
    """Table 3.2 (vibrating string, 4..64 elements) three times in one process: the meshes
    side by side (a Batch, solvers kept between studies) recording what the table reports,
    and one after another recording the figures' series and energies as the CLI does; and
    the steps per second of a 64-particle run with everything fused in one launch."""
    from timpm.problems import get_problem
    from timpm import Solver
    from timpm.studies.study import clear_solvers, convergence

    study = {}
    for name, options in (("batch", dict(batch=True, energies=False, series=False)),
                          ("sequential", dict(batch=False))):
        runs = []
        for label in ("cold", "second", "warm"):
            t0 = time.perf_counter()
            doc = convergence("vibrating-string", elements=elements, progress=False, **options)
            total = time.perf_counter() - t0
            walls = [r["wall_seconds"] for r in doc["runs"]]
            runs.append({"label": label, "total_seconds": total,
                         # a batch's runs share its wall time
                         "stepping_seconds": walls[0] if options["batch"] else sum(walls),
                         "steps": [r["steps"] for r in doc["runs"]],
                         "rms_error": [r["rms_error"] for r in doc["runs"]]})
        study[name] = runs
        clear_solvers()
    scene = get_problem("vibrating-string").scene(elements=16, ppc=4)
    tiny = {}
    # with the grid-crossing counter (on by default in 1D) and without it
    for key, crossings in (("tiny", True), ("tiny_no_crossings", False)):
        s = Solver(scene, energies=False, mode="serial", track_crossings=crossings)
        s.run(n_steps=100)
        steps = int(tiny_steps)
        best = float("inf")
        for _ in range(CHUNKS):
            t0 = time.perf_counter()
            s.run(n_steps=steps // CHUNKS, progress=False)
            best = min(best, time.perf_counter() - t0)
        tiny[key] = {"particles": scene.n_particles, "steps": steps // CHUNKS, "seconds": best,
                     "steps_per_second": (steps // CHUNKS) / best}
        s.release()
    return {"study": study, **tiny}


def _compile_probe():
    """First-step time (compile + one step) of the mpm88 scene in this process."""
    from timpm.scenarios.mpm88 import mpm88_world
    from timpm import Solver

    from .numpy_mpm import mpm88_initial

    world, _ = mpm88_world(mpm88_initial(8192)[0])
    s = Solver(world, energies=False)
    t0 = time.perf_counter()
    s.compile()
    s.run(n_steps=1)
    return {"seconds": time.perf_counter() - t0}


def _worker(spec):
    import timpm

    timpm.init(threads=spec["threads"], precision=spec.get("precision", "f64"),
                 arch=spec.get("arch", "cpu"))
    task = spec["task"]
    if task == "probes":
        return _probes(spec["threads"])
    if task == "mpm88":
        return _mpm88_timpm(spec["counts"], spec["strategies"], spec["threads"],
                            spec.get("precision", "f64"), spec.get("x0_file"),
                            spec.get("frames"))
    if task == "bases":
        return _per_basis(spec["cases"], spec["threads"])
    if task == "study":
        return _study_1d(tuple(spec["elements"]), spec["tiny_steps"])
    if task == "compile":
        return _compile_probe()
    raise ValueError(f"unknown bench task {task!r}")


def _spawn(spec, env=None, timeout=1800):
    """Run one measurement in a fresh process; returns its JSON result."""
    cmd = [sys.executable, "-c", f"import json, sys; sys.path.insert(0, {str(BENCHMARKS)!r}); "
           "from harness.bench import _worker; "
           "print('@@' + json.dumps(_worker(json.loads(sys.argv[1]))))", json.dumps(spec)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, **(env or {})))
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("@@")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"bench task {spec['task']} failed:\n{proc.stderr[-3000:]}")
    return json.loads(lines[-1][2:])


# ---- the driver -----------------------------------------------------------------------
def _numpy_mpm88(counts, seconds=0.6):
    from .numpy_mpm import mpm88_initial, mpm88_step

    out = []
    for n in counts:
        x, v, C, J = mpm88_initial(n)
        mpm88_step(x, v, C, J)

        def step(k):
            for _ in range(k):
                mpm88_step(x, v, C, J)

        out.append({"particles": n, **_best_rate(step, n, seconds)})
    return out


def _numpy_study(elements=STUDY_ELEMENTS):
    """The Table 3.2 runs with :class:`harness.numpy_mpm.Numpy1D`: stepping alone, and the
    whole study as timpm's is timed (scenes built, runs, RMS errors), fastest of three."""
    from timpm.problems import get_problem
    from timpm.studies.analysis import rms_error

    from .numpy_mpm import Numpy1D

    prob = get_problem("vibrating-string")
    stepping, totals = [], []
    for _ in range(3):
        t_start = time.perf_counter()
        step_total = 0.0
        for e in elements:
            scene = prob.scene(elements=e, ppc=4)
            steps = int(round(prob.t_end / scene.dt))
            ref = Numpy1D(scene)
            t0 = time.perf_counter()
            ref.run(steps)
            step_total += time.perf_counter() - t0
            rms_error(ref.u, prob.displacement(scene.positions, steps * scene.dt))
        totals.append(time.perf_counter() - t_start)
        stepping.append(step_total)
    return {"seconds": min(stepping), "total_seconds": min(totals)}


def mpm88_flops_per_particle_substep(nodes_per_particle):
    """Floating-point operations of one mpm88 particle-substep, counted from the
    algorithm (quadratic stencil: 3 x 3 nodes) as written in :func:`numpy_mpm.mpm88_step`:
    P2G per node 19 (weight 1, dpos 4, affine dpos 6, momentum 4, mass 1, scatter 3) and
    per particle 38 (stencil 2 x 15, stress and affine 6, m v 2); G2P per node 19 (weight
    1, dpos 4, velocity 4, C 10) and per particle 38 (stencil 30, x 4, J 4); the grid 8
    per node (division 2, gravity 1, walls 4, mass test 1), times nodes per particle."""
    return 9 * 19 + 38 + 9 * 19 + 38 + 8 * nodes_per_particle


#: particle counts of the mpm88-physics sweep and per-basis cases, by run size
SIZES = {
    "full": [1000, 8192, 10_000, 100_000, 131072, 1_000_000],
    "quick": [1000, 8192, 131072],
    "tiny": [1024],  # the test of the script itself
}


def bench(out="docs/throughput", size="full", threads=(1, 2), progress=print):
    """Run every measurement; write OUT.json, OUT.md and OUT.png; return the results."""
    import taichi

    from .mpm88 import run_mpm88
    from .numpy_mpm import mpm88_run

    if size not in SIZES:
        raise ValueError(f"unknown bench size {size!r}: choose one of {', '.join(SIZES)}")
    quick = size != "full"
    t_start = time.perf_counter()
    counts = SIZES[size]
    strategies = ["atomic", "serial", "private"]
    res = {"quick": quick, "size": size, "threads": list(threads), "cpu_count": os.cpu_count()}
    res["taichi"] = ".".join(map(str, taichi.__version__))
    res["probes"] = []
    for t in threads:
        progress(f"machine probes, {t} thread(s)")
        res["probes"].append(_spawn({"task": "probes", "threads": t}))
    # Taichi's mpm88, headless; its initial states seed the agreement check
    res["mpm88"] = []
    x0 = {}
    for n in counts:
        for t in threads:
            progress(f"mpm88 (Taichi example), {n} particles, {t} thread(s)")
            frames = 1 + CHUNKS if n <= 131072 else 3
            # as timpm's workers are, and as Taichi leaves them: the better one counts
            for pin in ((False, True) if t > 1 else (False,)):
                r = run_mpm88(n, frames=frames, threads=t, pin=pin)
                if n in (8192, 131072, *SIZES["tiny"]) and t == threads[0]:
                    x0[f"x0_{n}"], x0[f"x1_{n}"] = r["x0"], r["x1"]
                res["mpm88"].append({k: v for k, v in r.items() if k not in ("x0", "x1")})
    with tempfile.TemporaryDirectory() as tmp:
        x0_file = os.path.join(tmp, "x0.npz")
        np.savez(x0_file, **x0)
        res["timpm"] = []
        res["agreement"] = {}
        for precision in ("f32", "f64"):
            for t in threads:
                progress(f"timpm on mpm88's physics, {precision}, {t} thread(s)")
                # fused and team: what timpm picks on one thread and on more (one launch
                # for many steps)
                r = _spawn({"task": "mpm88", "threads": t, "precision": precision,
                            "counts": counts, "x0_file": x0_file,
                            "strategies": strategies + (["fused"] if t == 1 else ["team"])})
                res["timpm"] += r["runs"]
                res["agreement"][precision] = r["agreement"]
    progress("numpy mpm88 step")
    res["numpy"] = _numpy_mpm88(counts)
    # agreement of numpy with mpm88 from mpm88's initial state
    res["agreement"]["numpy"] = {}
    for key in [k for k in x0 if k.startswith("x0_")]:
        n = int(key[3:])
        xn = mpm88_run(x0[key], np.tile([0.0, -1.0], (n, 1)), np.zeros((n, 2, 2)), np.ones(n),
                       AGREE_STEPS)[0]
        res["agreement"]["numpy"][str(n)] = float(np.abs(xn - x0[f"x1_{n}"]).max())
    cases = [(1, "linear", 100_000), (1, "bspline2", 100_000), (1, "bspline3", 100_000),
             (2, "linear", 100_000), (2, "uniform-bspline2", 100_000),
             (2, "uniform-bspline3", 100_000), (3, "linear", 100_000),
             (3, "uniform-bspline2", 100_000)]
    if not quick:
        cases.append((3, "uniform-bspline3", 100_000))
    if size == "tiny":
        cases = [(1, "linear", 1000), (2, "uniform-bspline2", 1000)]
    res["bases"] = []
    for t in threads:
        progress(f"per dimension and basis, {t} thread(s)")
        res["bases"] += _spawn({"task": "bases", "threads": t, "cases": cases})
    progress("1D: Table 3.2 study and a 64-particle run")
    elements = STUDY_ELEMENTS[:2] if size == "tiny" else STUDY_ELEMENTS
    res["study"] = _spawn({"task": "study", "threads": threads[-1], "elements": elements,
                           "tiny_steps": 2000 if size == "tiny" else 200_000})
    res["study"]["elements"] = list(elements)
    res["study"]["numpy"] = _numpy_study(elements)
    progress("compile time: cold (no offline cache) and cached")
    res["compile"] = {
        "cold": _spawn({"task": "compile", "threads": threads[-1]},
                       env={"TI_OFFLINE_CACHE": "0"})["seconds"],
        "cached": [_spawn({"task": "compile", "threads": threads[-1]})["seconds"]
                   for _ in range(2)][-1]}
    res["bounds"] = _bounds(res)
    res["total_seconds"] = time.perf_counter() - t_start
    write(res, out)
    return res


def _best(runs, **match):
    sel = [r for r in runs if all(r.get(k) == v for k, v in match.items())]
    return max(sel, key=lambda r: r["mpss"]) if sel else None


def _bounds(res):
    """timpm's best mpm88-physics throughput as a fraction of the compute bound (flops
    counted by :func:`mpm88_flops_per_particle_substep`) and of the memory bound (the
    particle state read in P2G and read and written in G2P: 3 x bytes per particle)."""
    out = []
    for probe in res["probes"]:
        t = probe["threads"]
        for n in sorted({r["particles"] for r in res["timpm"]} & {8192, 131072, *SIZES["tiny"]}):
            for precision in ("f32", "f64"):
                r = _best(res["timpm"], particles=n, threads=t, precision=precision)
                if r is None:
                    continue
                flops = mpm88_flops_per_particle_substep(r["nodes"] / n)
                compute = probe["compute_gflop_s"] * 1e3 / flops
                memory = probe["triad_gb_s"] * 1e3 / (3 * r["particle_bytes"])
                out.append({"threads": t, "particles": n, "precision": precision,
                            "scatter": r["scatter"], "mpss": r["mpss"],
                            "flops_per_particle_substep": flops,
                            "compute_bound_mpss": compute, "memory_bound_mpss": memory,
                            "fraction_of_compute": r["mpss"] / compute,
                            "fraction_of_memory": r["mpss"] / memory})
    return out


def markdown(res) -> str:
    lines = [f"# timpm throughput ({res['size']} run)", "",
             f"taichi {res['taichi']}, {res['cpu_count']} cores; Mpss = million "
             "particle-substeps per second; each figure from one run of `benchmarks/throughput.py`, the fastest "
             f"of {CHUNKS} timed chunks (mpm88: its fastest frame of 50 substeps; the means are in "
             "the JSON).", ""]
    lines += ["## Machine", "", "| threads | triad GB/s | compute GFLOP/s (f64 FMA chains) |",
              "|---|---|---|"]
    for p in res["probes"]:
        lines.append(f"| {p['threads']} | {p['triad_gb_s']:.1f} | {p['compute_gflop_s']:.1f} |")
    lines += ["", "## mpm88's physics: Taichi's mpm88, NumPy and timpm", "",
              "timpm: best strategy per row (all of them in the JSON; fused: many steps per "
              "launch, every loop on the calling thread, the mode timpm picks on one thread; team: "
              "many steps per launch, each thread a block of particles and nodes, what it "
              "picks on two).",
              "",
              "| particles | threads | mpm88 (f32) | numpy (f64) | timpm f32 | timpm f64 | "
              "f32 / mpm88 | f32 / numpy | f64 / mpm88 |", "|---|---|---|---|---|---|---|---|---|"]
    for n in sorted({r["particles"] for r in res["timpm"]}):
        np_run = next((r for r in res["numpy"] if r["particles"] == n), None)
        for t in res["threads"]:
            m88 = _best(res["mpm88"], particles=n, threads=t)
            f32 = _best(res["timpm"], particles=n, threads=t, precision="f32")
            f64 = _best(res["timpm"], particles=n, threads=t, precision="f64")
            cell = lambda r: f"{r['mpss']:.2f}" if r else "-"  # noqa: E731
            ratio = lambda a, b: f"{a['mpss'] / b['mpss']:.1f}x" if a and b else "-"  # noqa: E731
            lines.append(f"| {n} | {t} | {cell(m88)} | {cell(np_run)} | "
                         f"{cell(f32)} ({f32['scatter'] if f32 else ''}) | "
                         f"{cell(f64)} ({f64['scatter'] if f64 else ''}) | {ratio(f32, m88)} | "
                         f"{ratio(f32, np_run)} | {ratio(f64, m88)} |")
    ag = res["agreement"]
    lines += ["", f"Agreement after {AGREE_STEPS} substeps from mpm88's initial state "
              "(max |x - x_mpm88|, domain [0, 1]; mpm88 runs in float32):", ""]
    for key, vals in ag.items():
        lines.append(f"- {key}: " + ", ".join(f"{n} particles {d:.2e}" for n, d in vals.items()))
    lines += ["", "## Scatter strategies (timpm, mpm88's physics, Mpss)", "",
              "| particles | threads | precision | atomic | serial | private | fused | team |",
              "|---|---|---|---|---|---|---|---|"]
    for n in sorted({r["particles"] for r in res["timpm"]}):
        for t in res["threads"]:
            for prec in ("f32", "f64"):
                row = [next((f"{r['mpss']:.2f}" for r in res["timpm"] if r["particles"] == n
                             and r["threads"] == t and r["precision"] == prec
                             and r["scatter"] == s), "-") for s in ("atomic", "serial", "private", "fused", "team")]
                lines.append(f"| {n} | {t} | {prec} | " + " | ".join(row) + " |")
    lines += ["", "## Per dimension and basis (f64, MUSL, auto mode and scatter)", "",
              "| dim | basis | particles | threads | scatter | Mpss | first step s |",
              "|---|---|---|---|---|---|---|"]
    for r in res["bases"]:
        lines.append(f"| {r['dim']} | {r['basis']} | {r['particles']} | {r['threads']} | "
                     f"{r['scatter']} | {r['mpss']:.2f} | {r['first_step_seconds']:.2f} |")
    st = res["study"]
    npy = st["numpy"]
    lines += ["", "## 1D: the Table 3.2 study", "",
              f"{len(st['elements'])} runs ({sum(st['study']['batch'][-1]['steps'])} steps of "
              f"{4 * min(st['elements'])}-{4 * max(st['elements'])} particles), "
              "three times in one process (cold, second, warm).  *batch*: the meshes side "
              "by side, one thread each (`convergence(..., batch=True, energies=False, "
              "series=False)`: what the table reports), solvers kept between studies; "
              "*sequential*: one run after another, recording the monitored particle and the "
              "energies every step as `timpm study` does.  NumPy (`Numpy1D`, the same "
              f"algorithm, no recording, fastest of three): stepping {npy['seconds']:.3f} s, "
              f"whole study (scenes, runs, errors) {npy['total_seconds']:.3f} s.", "",
              "| driver | study | whole study s | stepping s | NumPy / timpm, whole | "
              "NumPy / timpm, stepping |", "|---|---|---|---|---|---|"]
    for name, runs in st["study"].items():
        for r in runs:
            lines.append(f"| {name} | {r['label']} | {r['total_seconds']:.4f} | "
                         f"{r['stepping_seconds']:.4f} | "
                         f"{npy['total_seconds'] / r['total_seconds']:.1f}x | "
                         f"{npy['seconds'] / r['stepping_seconds']:.1f}x |")
    lines += ["",
              f"- {st['tiny']['particles']}-particle run, fused serial steps: "
              f"{st['tiny']['steps_per_second']:.3g} steps/s with the grid-crossing counter "
              f"(the 1D default), {st['tiny_no_crossings']['steps_per_second']:.3g} without.",
              f"- Compile (mpm88 scene, first step included): cold {res['compile']['cold']:.2f} s, "
              f"from Taichi's offline cache {res['compile']['cached']:.2f} s."]
    lines += ["", "## Fraction of the machine's bounds (best timpm row)", "",
              "Flops are those of mpm88's formulation (`mpm88_flops_per_particle_substep`); "
              "timpm's factored stencil (column adds for the affine terms) executes, by a hand "
              "count, about a fifth fewer, so a fraction near 100% means as fast as a scalar "
              "code of mpm88's formulation can be.  `benchmarks/mpm88_ceiling.py` measures "
              "that ceiling directly.", "",
              "| threads | particles | precision | Mpss | mpm88 flops/particle-substep | "
              "compute bound Mpss | memory bound Mpss | of compute | of memory |",
              "|---|---|---|---|---|---|---|---|---|"]
    for b in res["bounds"]:
        lines.append(f"| {b['threads']} | {b['particles']} | {b['precision']} | {b['mpss']:.2f} | "
                     f"{b['flops_per_particle_substep']:.0f} | {b['compute_bound_mpss']:.1f} | "
                     f"{b['memory_bound_mpss']:.0f} | {b['fraction_of_compute']:.0%} | "
                     f"{b['fraction_of_memory']:.0%} |")
    lines += ["", f"Total benchmark time {res['total_seconds']:.0f} s.", ""]
    return "\n".join(lines)


def plot(res, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    styles = {1: "--", 2: "-"}
    for t in res["threads"]:
        ns = sorted({r["particles"] for r in res["mpm88"] if r["threads"] == t})
        ax.plot(ns, [_best(res["mpm88"], particles=n, threads=t)["mpss"] for n in ns],
                styles.get(t, "-"), color="tab:red", marker="s", label=f"Taichi mpm88, {t} thr")
        for prec, color in (("f32", "tab:blue"), ("f64", "tab:green")):
            ns = sorted({r["particles"] for r in res["timpm"]})
            best = [_best(res["timpm"], particles=n, threads=t, precision=prec) for n in ns]
            ax.plot(ns, [b["mpss"] for b in best], styles.get(t, "-"), color=color, marker="o",
                    label=f"timpm {prec}, {t} thr")
    sel = sorted(res["numpy"], key=lambda r: r["particles"])
    ax.plot([r["particles"] for r in sel], [r["mpss"] for r in sel], ":", color="k", marker="^",
            label="NumPy (f64, 1 thr)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("particles")
    ax.set_ylabel("million particle-substeps per second")
    ax.set_title("mpm88's physics (2D, quadratic, MLS-MPM, 128² grid)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write(res, out):
    os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
    with open(out + ".json", "w") as fh:
        json.dump(res, fh, indent=1, default=float)
    with open(out + ".md", "w") as fh:
        fh.write(markdown(res))
    plot(res, out + ".png")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python benchmarks/throughput.py",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="docs/throughput",
                    help="output prefix: OUT.json, OUT.md, OUT.png (default docs/throughput)")
    ap.add_argument("--size", choices=list(SIZES), default="full",
                    help="full: 1e3..1e6 particles, every basis; quick: 1e3, 8k and 128k, no "
                    "3D cubic; tiny: a smoke test of the script")
    ap.add_argument("--threads", default="1,2", help="thread counts, comma separated")
    args = ap.parse_args(argv)
    threads = tuple(int(t) for t in args.threads.split(","))
    res = bench(args.out, size=args.size, threads=threads,
                progress=lambda msg: print(f"[bench] {msg}", file=sys.stderr, flush=True))
    print(markdown(res))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
