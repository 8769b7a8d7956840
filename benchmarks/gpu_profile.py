"""Where a GPU step goes, task by task: Taichi's kernel profiler on Taichi's mpm88 and on
timpm's mpm88 physics, the same backend, particles and precision (float32):

    python benchmarks/gpu_profile.py [--arch cuda] [--counts 131072 1048576] [--steps 200]
                                     [--json FILE]

Each Taichi kernel launch runs as one device kernel per top-level loop ("task"; a serial
task computes loop bounds read from fields).  For each code and count, in its own process
with ``TI_KERNEL_PROFILER=1``: the device time of every task summed over ``--steps``
substeps after a warm-up, three times (mpm88: its frames of 50 substeps, the frame's
``to_numpy`` included, as mpm88 does), per substep, and the wall time per substep of the
fastest of the three (the profiler's events cost some of it: ``--wall`` runs without the
profiler, for the wall time alone).  Compare the per-task rows of the two codes:
the gap between them is what the tasks differ in.
"""
import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCHMARKS))


PROFILING = os.environ.get("TI_KERNEL_PROFILER") == "1"

#: timed chunks of ``--steps`` substeps each (mpm88: frames); the fastest gives the wall time
CHUNKS = 3


def _clear_profile():
    import taichi as ti

    if PROFILING:
        ti.profiler.clear_kernel_profiler_info()


def _profile_records():
    """Per-task rows of Taichi's kernel profiler: name, launches, device ms in all."""
    from taichi.profiler.kernel_profiler import get_default_kernel_profiler

    if not PROFILING:
        return []

    prof = get_default_kernel_profiler()
    prof._update_records()
    prof._count_statistics()
    return [{"task": r.name, "launches": r.counter, "ms": r.total_time}
            for r in prof._statistical_results.values()]


def _timpm_child(n, steps, out):
    import taichi as ti

    import timpm
    from harness.numpy_mpm import mpm88_initial
    from timpm.scenarios.mpm88 import mpm88_world
    from timpm.simulation.solver import Solver

    timpm.init(precision="f32")
    world, _ = mpm88_world(mpm88_initial(n)[0])
    s = Solver(world, energies=False, mode="parallel", scatter="atomic")
    s.compile()
    s.run(n_steps=20)
    ti.sync()
    _clear_profile()
    walls = []
    for _ in range(CHUNKS):
        t0 = time.perf_counter()
        s.run(n_steps=steps)
        ti.sync()
        walls.append(time.perf_counter() - t0)
    json.dump({"wall_s": min(walls), "substeps": steps, "chunks": CHUNKS,
               "tasks": _profile_records()}, open(out, "w"))


def _mpm88_child(n, steps, out):
    from harness import mpm88 as harness

    import numpy as np
    import taichi as ti

    per_chunk = max(1, steps // harness.SUBSTEPS_PER_FRAME)
    frames = CHUNKS * per_chunk + 1
    state = {"frames": 0, "walls": []}

    class HeadlessGUI:
        ESCAPE = "Escape"

        def __init__(self, *args, **kwargs):
            pass

        @property
        def running(self):
            return state["frames"] < frames

        def get_event(self, *args):
            return False

        def clear(self, *args, **kwargs):
            pass

        def circles(self, pos, *args, **kwargs):
            np.asarray(pos)

        def show(self, *args, **kwargs):
            ti.sync()
            state["frames"] += 1
            if state["frames"] == 1:  # the first frame compiled: profile the rest
                _clear_profile()
                state["t0"] = time.perf_counter()
            elif (state["frames"] - 1) % per_chunk == 0:
                state["walls"].append(time.perf_counter() - state["t0"])
                state["t0"] = time.perf_counter()

    ti.GUI = HeadlessGUI
    namespace = {"__name__": "__mpm88__"}
    exec(compile(harness._source(n), str(harness.mpm88_path()), "exec"), namespace)
    json.dump({"wall_s": min(state["walls"]), "chunks": CHUNKS,
               "substeps": per_chunk * harness.SUBSTEPS_PER_FRAME,
               "tasks": _profile_records()}, open(out, "w"))


def profile(code, n, steps, arch, profiler=True):
    """Run one code in a fresh process under the kernel profiler (or without it: the wall
    time alone); its per-task rows."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "profile.json")
        child = "_mpm88_child" if code == "mpm88" else "_timpm_child"
        cmd = [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(BENCHMARKS)!r}); "
               f"import gpu_profile; gpu_profile.{child}({int(n)}, {int(steps)}, {out!r})"]
        env = dict(os.environ, TI_KERNEL_PROFILER="1" if profiler else "0", TIMPM_ARCH=arch,
                   TI_ARCH="x64" if arch == "cpu" else arch)
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900)
        if proc.returncode != 0:
            raise RuntimeError(f"{code} at {n} failed:\n{proc.stderr[-3000:]}")
        res = json.load(open(out))
    k = res["substeps"] * res["chunks"]
    rows = sorted(res["tasks"], key=lambda r: -r["ms"])
    for r in rows:
        r["us_per_substep"] = 1e3 * r["ms"] / k
    return {"code": code, "particles": n, "substeps": k,
            "wall_us_per_substep": 1e6 * res["wall_s"] / res["substeps"],
            "mpss": n * res["substeps"] / res["wall_s"] / 1e6, "profiler": profiler,
            "device_us_per_substep": sum(r["us_per_substep"] for r in rows), "tasks": rows}


def markdown(results):
    lines = []
    for r in results:
        lines += [f"{r['code']}, {r['particles']} particles: {r['wall_us_per_substep']:.1f} us "
                  f"wall ({r['mpss']:.1f} Mpss), {r['device_us_per_substep']:.1f} us in tasks "
                  f"per substep ({r['substeps']} substeps)", "",
                  "| task | launches per substep | us per substep |", "|---|---:|---:|"]
        for t in r["tasks"]:
            lines.append(f"| {t['task']} | {t['launches'] / r['substeps']:.2f} | "
                         f"{t['us_per_substep']:.2f} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--arch", default="cuda")
    p.add_argument("--counts", type=int, nargs="+", default=[131072, 1048576])
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--codes", nargs="+", default=["mpm88", "timpm"])
    p.add_argument("--wall", action="store_true",
                   help="without the profiler: the wall time per substep alone")
    p.add_argument("--json", metavar="FILE")
    args = p.parse_args(argv)
    results = []
    for n in args.counts:
        for code in args.codes:
            print(f"profiling {code} at {n} particles on {args.arch}", file=sys.stderr,
                  flush=True)
            results.append(profile(code, n, args.steps, args.arch, not args.wall))
    text = markdown(results)
    print(text)
    if args.json:
        json.dump({"date": datetime.date.today().isoformat(),
                   "command": "python benchmarks/gpu_profile.py " + " ".join(argv or sys.argv[1:]),
                   "results": results}, open(args.json, "w"), indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
