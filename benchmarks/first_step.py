"""Time to the first step: the commands a user waits for, cold and warm, this checkout
against another, side by side.

    git worktree add --detach /tmp/timpm-old <commit>
    python benchmarks/first_step.py [--old /tmp/timpm-old] [--forge VENV/bin/python]
        [--commands cube demo study table] [--repeats 2] [--json docs/first_step.json]

Each run is a fresh process, ``python -m timpm ...`` with ``PYTHONPATH`` choosing the
engine (this checkout, or ``--old``), in an empty working folder.  ``--forge`` adds this
checkout run by another interpreter, one whose environment has taichi-forge and not
taichi (timpm/platform/taichi_backend.py).  *Cold*: an empty Taichi
offline cache (``TI_OFFLINE_CACHE_FILE_PATH`` a new folder) for every run; *warm*: one
cache per engine, filled by a first run that is not counted.  The engines alternate, each
figure is the fastest of ``--repeats``.  Per command: the wall time end to end, the
compilation the command reports (``compile_seconds``: every kernel build it caused and
that build's first launch, ``timpm.platform.runtime.compile_clock``) and its stepping.

The commands (``--commands``):

- ``cube``: ``timpm run examples/cube_drop_3d.toml`` (3D, 1,000 particles, APIC);
- ``demo``: ``timpm demo column-collapse`` (2D sand, 20k particles, two threads);
- ``study``: ``timpm study speed-error vibrating-string`` (30 runs, 6 programs);
- ``table``: ``timpm convergence vibrating-string`` (the study's Table 3.2).
"""
import argparse
import json
import sys
import tempfile
from datetime import date
from pathlib import Path

from harness.cli_run import ROOT, run_cli

COMMANDS = {
    "cube": ["run", str(ROOT / "examples" / "cube_drop_3d.toml")],
    "demo": ["demo", "column-collapse", "--out", "out.gif"],
    "study": ["study", "speed-error", "vibrating-string", "--quiet"],
    "table": ["convergence", "vibrating-string", "--quiet"],
}


def _reported(doc):
    """(compile, stepping) seconds of a command's JSON record."""
    if "runs" in doc and "simulation_seconds" not in doc:  # convergence and studies
        stepping = sum(r["wall_seconds"] for r in doc["runs"])
        compile_s = doc.get("compile_seconds", sum(r["compile_seconds"] for r in doc["runs"]))
        return compile_s, stepping
    return doc["compile_seconds"], doc["simulation_seconds"]


def run_once(engine, command, cache):
    """One fresh process: (end to end, compile, stepping) seconds; ``cache``: Taichi's
    offline cache ("cold": an empty one)."""
    python, path = engine
    wall, doc = run_cli(COMMANDS[command], engine=path, python=python, cache=cache)
    compile_s, stepping = _reported(doc)
    return {"end_to_end": wall, "compile": compile_s, "stepping": stepping}


def fastest(runs):
    return {k: min(r[k] for r in runs) for k in runs[0]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", metavar="CHECKOUT", help="the other engine (its repository root)")
    ap.add_argument("--forge", metavar="PYTHON",
                    help="an interpreter with taichi-forge (and no taichi): runs this checkout")
    ap.add_argument("--commands", nargs="+", choices=tuple(COMMANDS), default=list(COMMANDS))
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--no-warm", action="store_true", help="cold runs only")
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    engines = {"new": (sys.executable, ROOT)}
    if args.old:
        engines["old"] = (sys.executable, Path(args.old).resolve())
    if args.forge:
        engines["forge"] = (args.forge, ROOT)
    doc = {"date": date.today().isoformat(), "command": " ".join(sys.argv),
           "engines": {k: f"{py} with {path}" for k, (py, path) in engines.items()},
           "results": {}}
    keep = tempfile.TemporaryDirectory(prefix="timpm-warm-")
    warm_caches = {name: Path(keep.name) / name for name in engines}
    for command in args.commands:
        result = {}
        for temperature in ("cold",) + (() if args.no_warm else ("warm",)):
            runs = {name: [] for name in engines}
            if temperature == "warm":
                for name, engine in engines.items():  # fill the cache, not counted
                    run_once(engine, command, warm_caches[name])
            for _ in range(args.repeats):
                for name, engine in engines.items():  # alternating
                    cache = "cold" if temperature == "cold" else warm_caches[name]
                    runs[name].append(run_once(engine, command, cache))
            result[temperature] = {name: fastest(r) for name, r in runs.items()}
            for name, best in result[temperature].items():
                print(f"{command:6s} {temperature}  {name}: end to end {best['end_to_end']:6.2f} s,"
                      f" compilation {best['compile']:6.2f} s, stepping {best['stepping']:6.3f} s",
                      flush=True)
        doc["results"][command] = result
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
