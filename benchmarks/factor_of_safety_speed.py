"""What a user waits for: `timpm study factor-of-safety examples/slope_griffiths_lane.toml`
end to end, an older checkout beside this one (issue 46 item 3).

    python benchmarks/factor_of_safety_speed.py [--engines /tmp/timpm-old .]
        [--workers auto 1] [--rounds 2] [--json docs/factor_of_safety_speed.json]

Each engine (a checkout: this one, or a ``git worktree`` of an older commit) runs the
study as a whole process with ``--quiet --json``, cold (an empty Taichi cache made for the
run: ``TI_OFFLINE_CACHE_FILE_PATH``) and warm (that engine's cache filled by a run
before), alternating engine after engine, round after round; the fastest of each counts
(a shared machine only slows a run down).  This checkout runs once per ``--workers``
value (an older one without the option runs as it is).  Reported: the wall time of the
process, the study's own (``wall_seconds``: the trials), the factor, its bracket and the
trials run.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "slope_griffiths_lane.toml"


def run_study(engine, workers, cache):
    """One study as a process of ``engine``'s timpm: wall time and its record."""
    with tempfile.TemporaryDirectory() as tmp:
        record = Path(tmp) / "fos.json"
        cmd = [sys.executable, "-m", "timpm", "study", "factor-of-safety", str(SCENE),
               "--quiet", "--json", str(record)]
        if workers is not None:
            cmd += ["--workers", workers]
        env = dict(os.environ, PYTHONPATH=str(Path(engine).resolve()),
                   TI_OFFLINE_CACHE_FILE_PATH=cache)
        t0 = time.perf_counter()
        done = subprocess.run(cmd, env=env, cwd=tmp, capture_output=True, text=True,
                              timeout=1800)
        wall = time.perf_counter() - t0
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} (in {engine}) failed:\n{done.stderr}")
        rec = json.loads(record.read_text())
    return {"wall_seconds": wall, "study_seconds": rec["wall_seconds"],
            "factor_of_safety": rec["factor_of_safety"], "bracket": rec["bracket"],
            "trials": len(rec["trials"]), "workers": rec.get("workers", 1)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engines", nargs="+", default=["."])
    ap.add_argument("--workers", nargs="+", default=["auto", "1"],
                    help="--workers values for this checkout")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args()

    here = ROOT.resolve()
    configs = []  # (label, engine, --workers or None)
    for engine in args.engines:
        if Path(engine).resolve() == here:
            configs += [(f"this checkout --workers {w}", engine, w) for w in args.workers]
        else:
            configs.append((f"{engine} (as it is)", engine, None))
    warm = {label: tempfile.mkdtemp(prefix="fos-warm-") for label, _, _ in configs}
    for label, engine, workers in configs:  # fill each warm cache
        run_study(engine, workers, warm[label])
    best = {}
    for r in range(args.rounds):
        for label, engine, workers in configs:
            for kind in ("cold", "warm"):
                cache = tempfile.mkdtemp(prefix="fos-cold-") if kind == "cold" else warm[label]
                row = run_study(engine, workers, cache)
                key = (label, kind)
                if key not in best or row["wall_seconds"] < best[key]["wall_seconds"]:
                    best[key] = dict(row, config=label, cache=kind)
                print(f"round {r + 1}: {label:34s} {kind}: {row['wall_seconds']:6.1f} s wall, "
                      f"{row['study_seconds']:6.1f} s study, F = "
                      f"{row['factor_of_safety']:.4f}, {row['trials']} trials", flush=True)
    print(f"\nfastest of {args.rounds} (2 cores, {time.strftime('%Y-%m-%d')}):")
    print(f"{'':34s} {'cache':5s} {'wall s':>7s} {'study s':>8s} {'F':>7s} {'bracket':>17s} "
          f"trials")
    for row in best.values():
        lo, hi = row["bracket"]
        print(f"{row['config']:34s} {row['cache']:5s} {row['wall_seconds']:7.1f} "
              f"{row['study_seconds']:8.1f} {row['factor_of_safety']:7.4f} "
              f"{lo:8.4f}-{hi:8.4f} {row['trials']:6d}")
    if args.json:
        doc = {"command": " ".join([Path(sys.argv[0]).as_posix()] + sys.argv[1:]),
               "date": time.strftime("%Y-%m-%d"), "cores": os.cpu_count(),
               "rounds": args.rounds, "rows": list(best.values())}
        Path(args.json).write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    main()
