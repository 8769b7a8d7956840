"""timpm on a GPU backend, side by side with Taichi's own mpm88 on the same backend:

    python benchmarks/gpu.py [--arch cuda] [--counts 8192 131072 1048576] [--json FILE]

For each particle count: Taichi's mpm88 example run headless (float32, its own code) and
timpm's mpm88 physics (:func:`timpm.scenarios.mpm88.mpm88_world`; float32 and float64,
atomic scatter, one launch per pass), particle-substeps per second, both timed alike
(``--frames`` frames of 50 substeps, each ending with the positions on the host and the
device finished, the fastest after the first: the same states of the falling fluid;
before 2026-11-28 timpm was timed in chunks of about 0.1 s, thousands of steps further
on), the first step's seconds (compilation), and the largest difference of timpm's
positions from mpm88's after its first frame (50 substeps from mpm88's own initial
particles).  Then the same on this machine's CPU (all its
threads, timpm's private scatter), and the study's Table 3.2 end to end, ``timpm
convergence vibrating-string --arch ARCH`` against ``--arch cpu`` (fresh processes, Python
start and compilation counted), with the RMS errors of both.

Each measurement runs in its own process (Taichi fixes the backend at its start).
"""
import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from harness.bench import _spawn
from harness.mpm88 import run_mpm88


def _mpm88_pair(arch, counts, frames, cpu_threads, progress):
    """Taichi's mpm88 and timpm's mpm88 physics on ``arch`` ("cpu" or a GPU backend)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        x0_file = os.path.join(tmp, "mpm88_states.npz")
        states = {}
        for n in counts:
            progress(f"mpm88 (Taichi's example) on {arch}, {n} particles")
            ref = run_mpm88(n, frames=frames, arch="x64" if arch == "cpu" else arch,
                            threads=cpu_threads if arch == "cpu" else None)
            states[f"x0_{n}"], states[f"x1_{n}"] = ref.pop("x0"), ref.pop("x1")
            rows.append({**ref, "taichi_arch": ref["arch"], "code": "mpm88", "arch": arch,
                         "precision": "f32"})
        np.savez(x0_file, **states)
        scatter = "private" if arch == "cpu" else "atomic"
        for precision in ("f32", "f64"):
            progress(f"timpm, mpm88's physics on {arch}, {precision}")
            res = _spawn({"task": "mpm88", "threads": cpu_threads if arch == "cpu" else None,
                          "precision": precision, "arch": arch, "counts": list(counts),
                          "strategies": [scatter], "x0_file": x0_file,
                          "frames": frames})
            for r in res["runs"]:
                # the agreement runs compiled the kernels before the timed runs
                rows.append({**r, "code": "timpm", "arch": arch,
                             "first_step_seconds": res["compile_seconds"],
                             "agreement": res["agreement"].get(str(r["particles"]))})
    return rows


def _table_3_2(arch):
    """``timpm convergence vibrating-string --arch ARCH``, end to end in a fresh process."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "table.json")
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "timpm", "convergence", "vibrating-string",
                               "--arch", arch, "--quiet", "--json", out],
                              capture_output=True, text=True, timeout=900)
        seconds = time.perf_counter() - t0
        if proc.returncode != 0:
            raise RuntimeError(f"timpm convergence --arch {arch} failed:\n{proc.stderr[-3000:]}")
        with open(out) as f:
            doc = json.load(f)
    runs = doc["runs"]
    return {"arch": arch, "end_to_end_seconds": seconds,
            "compile_seconds": sum(r.get("compile_seconds") or 0.0 for r in runs),
            "stepping_seconds": sum(r["wall_seconds"] for r in runs),
            "rms_error": [r["rms_error"] for r in runs], "rates": doc.get("rates")}


def markdown(res) -> str:
    lines = [f"GPU benchmark, {res['date']}: `{res['command']}`", "",
             f"device: {res['device']}", "",
             "| code | arch | precision | particles | Mpss | compile s (mpm88: first frame) | "
             "max abs(x - x_mpm88) |",
             "|---|---|---|---:|---:|---:|---:|"]
    for r in res["mpm88"]:
        first = r.get("first_step_seconds", r.get("first_frame_seconds"))
        agree = r.get("agreement")
        lines.append(f"| {r['code']} | {r['arch']} | {r['precision']} | {r['particles']} | "
                     f"{r['mpss']:.1f} | {first:.2f} | "
                     f"{'-' if agree is None else f'{agree:.1e}'} |")
    lines += ["", "| timpm / mpm88, same backend, f32 | particles | ratio |", "|---|---:|---:|"]
    for arch in sorted({r["arch"] for r in res["mpm88"]}):
        for n in sorted({r["particles"] for r in res["mpm88"]}):
            pick = {(r["code"], r["precision"]): r["mpss"] for r in res["mpm88"]
                    if r["arch"] == arch and r["particles"] == n}
            if ("mpm88", "f32") in pick and ("timpm", "f32") in pick:
                ratio = pick["timpm", "f32"] / pick["mpm88", "f32"]
                lines.append(f"| {arch} | {n} | {ratio:.2f} |")
    lines += ["", "| Table 3.2, `timpm convergence vibrating-string` | end to end s | compile s | "
              "stepping s | e_RMS at 4 ... 64 elements |", "|---|---:|---:|---:|---|"]
    for t in res["table_3_2"]:
        errs = " ".join(f"{e:.4e}" for e in t["rms_error"])
        lines.append(f"| --arch {t['arch']} | {t['end_to_end_seconds']:.2f} | "
                     f"{t['compile_seconds']:.2f} | {t['stepping_seconds']:.3f} | {errs} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--arch", default="cuda", choices=["cuda", "vulkan", "metal"])
    p.add_argument("--counts", type=int, nargs="+", default=[8192, 131072, 1048576])
    p.add_argument("--frames", type=int, default=8, help="frames of 50 substeps each code runs, the first compiling")
    p.add_argument("--cpu-threads", type=int, default=os.cpu_count(),
                   help="threads of the CPU comparison (default: all)")
    p.add_argument("--no-cpu", action="store_true", help="the GPU backend only")
    p.add_argument("--no-table", action="store_true", help="without Table 3.2 end to end")
    p.add_argument("--json", metavar="FILE")
    p.add_argument("--md", metavar="FILE")
    args = p.parse_args(argv)

    def progress(msg):
        print(msg, file=sys.stderr, flush=True)

    import taichi as ti
    from taichi.lang.misc import is_arch_supported

    if not is_arch_supported(getattr(ti, args.arch)):
        print(f"gpu.py: error: Taichi finds no {args.arch} backend on this machine",
              file=sys.stderr)
        return 2
    device = subprocess.run(["nvidia-smi", "--query-gpu=name,driver_version",
                             "--format=csv,noheader"], capture_output=True, text=True)
    res = {"date": datetime.date.today().isoformat(),
           "command": "python benchmarks/gpu.py " + " ".join(argv or sys.argv[1:]),
           "device": (device.stdout.strip() or args.arch) + f"; CPU: {os.cpu_count()} cores",
           "taichi": ti.__version__, "mpm88": [], "table_3_2": []}
    archs = [args.arch] + ([] if args.no_cpu else ["cpu"])
    for arch in archs:
        res["mpm88"] += _mpm88_pair(arch, args.counts, args.frames, args.cpu_threads, progress)
    for arch in ([] if args.no_table else archs):
        progress(f"Table 3.2 end to end on {arch}")
        res["table_3_2"].append(_table_3_2(arch))
    text = markdown(res)
    print(text)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)
    if args.md:
        with open(args.md, "w") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
