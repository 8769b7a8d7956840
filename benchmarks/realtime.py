"""Simulated seconds per wall second of every demo and every example scene file, as a user
runs them: the whole default run from the command line.

    python benchmarks/realtime.py [--json docs/realtime.json]

Each command is a fresh process in an empty working folder (``timpm demo NAME`` with no
movie, ``timpm run examples/FILE.toml`` with its own outputs), Taichi's offline cache as
it is; the figures are the command's own ``--json`` record: particles, steps, the
simulated time over the stepping's wall time (compilation and rendering apart, both
reported), and the run's end to end wall time.
"""
import argparse
import json
import sys
from datetime import date
from pathlib import Path

from harness.cli_run import ROOT, run_cli

def _demos():
    sys.path.insert(0, str(ROOT))
    from timpm.scenarios.demos import DEMOS
    return tuple(DEMOS)


def run(args):
    wall, doc = run_cli(args)
    t_end = doc["t_end"]
    return {"command": "timpm " + " ".join(args), "particles": doc["particles"],
            "steps": doc["steps"], "t_end": t_end,
            "simulated_per_wall_second": t_end / doc["simulation_seconds"],
            "simulation_seconds": doc["simulation_seconds"],
            "compile_seconds": doc["compile_seconds"],
            "render_seconds": doc.get("render_seconds", 0.0), "end_to_end_seconds": wall}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    commands = [["demo", name] for name in _demos()]
    commands += [["run", str(p)] for p in sorted((ROOT / "examples").glob("*.toml"))]
    rows = []
    for cmd in commands:
        r = run(cmd)
        rows.append(r)
        print(f"{r['command'].replace(str(ROOT) + '/', ''):45s} {r['particles']:7d} particles "
              f"{r['steps']:6d} steps  {r['simulated_per_wall_second']:7.3f} simulated s / "
              f"wall s  (compile {r['compile_seconds']:.2f} s, end to end "
              f"{r['end_to_end_seconds']:.1f} s)", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps({"date": date.today().isoformat(),
                                               "command": " ".join(sys.argv), "runs": rows},
                                              indent=1))


if __name__ == "__main__":
    main()
