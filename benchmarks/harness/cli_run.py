"""One ``timpm`` command as a user runs it: a fresh process in an empty working folder,
timed end to end, its ``--json`` record read back (benchmarks/first_step.py, realtime.py)."""
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from . import BENCHMARKS

__all__ = ["ROOT", "run_cli"]

#: the repository root: the engine a command runs unless told otherwise
ROOT = BENCHMARKS.parent


def run_cli(args, engine=ROOT, python=sys.executable, cache=None):
    """``python -m timpm ARGS --json out.json`` with ``PYTHONPATH=engine`` in an empty
    folder.  ``cache``: Taichi's offline cache, None for the environment's, "cold" for an
    empty one, or a folder.  Returns (end-to-end wall seconds, the command's JSON record);
    a failure raises with its stderr."""
    with tempfile.TemporaryDirectory(prefix="timpm-cli-run-") as work:
        env = dict(os.environ, PYTHONPATH=str(engine))
        if cache is not None:
            cache = Path(work) / "taichi-cache" if cache == "cold" else cache
            env["TI_OFFLINE_CACHE_FILE_PATH"] = str(cache)
        env.pop("PYTHONDONTWRITEBYTECODE", None)  # byte-compiled, as after pip install
        t0 = time.perf_counter()
        proc = subprocess.run([python, "-m", "timpm", *args, "--json", "out.json"],
                              cwd=work, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            raise RuntimeError(f"timpm {' '.join(args)} ({engine}) failed:\n"
                               f"{proc.stderr[-3000:]}")
        return wall, json.loads((Path(work) / "out.json").read_text())
