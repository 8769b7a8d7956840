"""What a user waits for: whole commands, end to end, compilation included, side by side.

    python benchmarks/convergence_e2e.py [--repeats 3] [--speed-error] [--json out.json]

1. ``timpm convergence vibrating-string`` (Table 3.2, the main job) against
   ``benchmarks/numpy_table_3_2.py`` (the same five runs in plain NumPy), alternating,
   each a fresh process (Python start, imports and Taichi's start counted); the fastest
   of ``--repeats`` and the ratio, with the compile and stepping seconds timpm reports
   per mesh (``--json`` of the command).
2. ``--speed-error``: ``timpm study speed-error vibrating-string`` and
   ``timpm study speed-error soil-column`` (defaults), end to end (the fastest of
   ``--speed-error-repeats``), with the compilation and the stepping the study reports.

Timings depend on the machine and on Taichi's offline kernel cache (warm after the first
run of a command: ``--cold`` points Taichi at an empty cache for every run).  The commands
run with Python's bytecode cache on (``PYTHONDONTWRITEBYTECODE`` unset), as after
``pip install``.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

HERE = Path(__file__).resolve().parent


def timed(cmd, env):
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    return wall


def environment(cold):
    env = dict(os.environ)
    # byte-compiled modules, as on a usual installation (pip compiles the package when it
    # installs it; an editable one is compiled at its first import): a machine that sets
    # PYTHONDONTWRITEBYTECODE would compile timpm's ~60 modules from source in every
    # process (0.05-0.1 s), NumPy's and Taichi's not (pip compiled them)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if cold:
        env["TI_OFFLINE_CACHE_FILE_PATH"] = tempfile.mkdtemp(prefix="timpm-cold-cache-")
    return env


def convergence(repeats, cold):
    out = {"timpm": [], "numpy": [], "runs": None}
    with tempfile.TemporaryDirectory() as tmp:
        doc = Path(tmp) / "table.json"
        for _ in range(repeats):
            env = environment(cold)
            out["timpm"].append(timed(["timpm", "convergence", "vibrating-string", "--quiet",
                                       "--json", str(doc)], env))
            out["numpy"].append(timed([sys.executable, str(HERE / "numpy_table_3_2.py")], env))
        runs = json.loads(doc.read_text())["runs"]
    out["runs"] = [{k: r[k] for k in ("elements", "rms_error", "compile_seconds",
                                      "wall_seconds", "build_seconds")} for r in runs]
    return out


def speed_error(problem, cold, repeats):
    """The fastest of ``repeats`` runs of the study, each a fresh process."""
    best = None
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            doc = Path(tmp) / "study.json"
            wall = timed(["timpm", "study", "speed-error", problem, "--quiet", "--json",
                          str(doc)], environment(cold))
            study = json.loads(doc.read_text())
        runs = study["runs"]
        # all the kernel compilation the study caused (runtime.compile_clock): the step
        # kernels, state uploads and saves, readers and the scenes' stencils
        compile_s = study["compile_seconds"]
        stepping = sum(r["wall_seconds"] for r in runs)
        if best is None or wall < best["end_to_end_seconds"]:
            best = {"problem": problem, "end_to_end_seconds": wall,
                    "compile_seconds": compile_s, "stepping_seconds": stepping,
                    "runs": len(runs), "repeats": repeats}
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--speed-error", action="store_true")
    ap.add_argument("--speed-error-repeats", type=int, default=3,
                    help="runs of each study, the fastest kept (default 3)")
    ap.add_argument("--cold", action="store_true", help="an empty Taichi cache for every run")
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    doc = {"date": date.today().isoformat(), "command": " ".join(sys.argv), "cold": args.cold}
    conv = convergence(args.repeats, args.cold)
    doc["convergence"] = conv
    t, n = min(conv["timpm"]), min(conv["numpy"])
    print(f"timpm convergence vibrating-string: {t:.2f} s end to end (fastest of "
          f"{args.repeats}); NumPy script: {n:.2f} s; ratio {t / n:.2f}")
    print("  per mesh (last run): " + ", ".join(
        f"{r['elements']} el: compile {r['compile_seconds']:.3f} s, stepping "
        f"{r['wall_seconds']:.4f} s" for r in conv["runs"]))
    if args.speed_error:
        doc["speed_error"] = []
        for problem in ("vibrating-string", "soil-column"):
            r = speed_error(problem, args.cold, args.speed_error_repeats)
            doc["speed_error"].append(r)
            print(f"timpm study speed-error {problem}: {r['end_to_end_seconds']:.1f} s end to "
                  f"end, compilation {r['compile_seconds']:.1f} s "
                  f"({100 * r['compile_seconds'] / r['end_to_end_seconds']:.0f} %), stepping "
                  f"{r['stepping_seconds']:.2f} s, {r['runs']} runs")
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
