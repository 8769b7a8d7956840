"""Taichi's own ``mpm88`` example run headless.

:func:`run_mpm88` executes ``examples/simulation/mpm88.py`` of the installed taichi
package in a fresh process, its code unchanged except for the particle count (a
constant of the script, for the 128k runs): only ``ti.GUI`` is replaced by a headless
stand-in that times the frames (50 substeps each) and records the particles.  The
backend (the CPU unless asked) and the thread count come from Taichi's own environment
variables (``TI_ARCH``, ``TI_CPU_MAX_NUM_THREADS``), so ``ti.init`` in the script is
untouched.

The same physics in timpm is :func:`timpm.scenarios.mpm88.mpm88_world`.
"""
import importlib
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# taichi, or taichi-forge where only that is installed (timpm picks it as it loads: its
# platform's taichi_backend); the harness measures other checkouts too, through the names
# ``timpm`` exports (timpm.Solver, timpm.init, ...), which every engine has
importlib.import_module("timpm")

from . import BENCHMARKS

__all__ = ["mpm88_path", "run_mpm88"]

SUBSTEPS_PER_FRAME = 50


def mpm88_path() -> Path:
    import taichi

    path = Path(taichi.__file__).parent / "examples" / "simulation" / "mpm88.py"
    if not path.is_file():
        raise FileNotFoundError(f"Taichi's mpm88 example is not installed at {path}")
    return path


def _source(n_particles):
    src = mpm88_path().read_text()
    if n_particles != 8192:
        src, k = re.subn(r"^n_particles = 8192$", f"n_particles = {int(n_particles)}", src,
                         flags=re.M)
        if k != 1:
            raise RuntimeError("mpm88.py no longer sets n_particles = 8192 on one line")
    return src


def _worker(n_particles, frames, out, pin=False):
    """Run mpm88 for ``frames`` frames with a headless GUI; save timings and particles
    (``pin``: bind Taichi's workers one per core once the script has started Taichi)."""
    import taichi as ti

    from timpm.platform.runtime import pin_workers

    record = {"frame_times": []}
    namespace = {"__name__": "__mpm88__"}

    class HeadlessGUI:
        ESCAPE = "Escape"

        def __init__(self, *args, **kwargs):
            self.frames = 0
            record["pinned"] = len(pin_workers()) if pin else 0

        @property
        def running(self):
            return self.frames < frames

        def get_event(self, *args):
            if "x0" not in record:  # before the first substep
                record["x0"] = namespace["x"].to_numpy()
                record["t_start"] = time.perf_counter()
            return False

        def clear(self, *args, **kwargs):
            pass

        def circles(self, pos, *args, **kwargs):
            if self.frames == 0:
                record["x1"] = np.array(pos)  # after the first SUBSTEPS_PER_FRAME substeps

        def show(self, *args, **kwargs):
            ti.sync()
            record["frame_times"].append(time.perf_counter())
            self.frames += 1

    ti.GUI = HeadlessGUI
    code = compile(_source(n_particles), str(mpm88_path()), "exec")
    exec(code, namespace)
    cfg = ti.lang.impl.current_cfg()
    np.savez(out, x0=record["x0"], x1=record["x1"],
             frame_times=np.array([record["t_start"]] + record["frame_times"]),
             threads=cfg.cpu_max_num_threads, arch=str(cfg.arch),
             dtype=str(namespace["x"].dtype), pinned=record["pinned"])


def run_mpm88(n_particles=8192, frames=4, threads=None, pin=False, timeout=900,
              arch="x64") -> dict:
    """Run the installed mpm88 headless in a subprocess (``arch``: Taichi's backend name,
    the CPU by default, with ``threads`` threads; ``pin``: Taichi's workers bound one per
    core, as :func:`timpm.platform.runtime.init` does).

    Returns the particle-substeps per second of the fastest frame after the first (which
    compiles; ``mpss_mean``: over all of them), the initial positions and the positions
    after the first frame.
    """
    if int(frames) < 2:
        raise ValueError(f"frames must be at least 2 (the first compiles), got {frames!r}")
    env = dict(os.environ, TI_ARCH=arch)
    if threads:
        env["TI_CPU_MAX_NUM_THREADS"] = str(int(threads))
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "mpm88.npz")
        cmd = [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(BENCHMARKS)!r}); "
               f"from harness.mpm88 import _worker; "
               f"_worker({int(n_particles)}, {int(frames)}, {out!r}, {bool(pin)})"]
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
        if proc.returncode != 0:
            raise RuntimeError(f"mpm88 failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
        data = dict(np.load(out))
    times = data["frame_times"]
    timed = np.diff(times[1:])  # frame 1 onwards: compiled
    steps = SUBSTEPS_PER_FRAME * len(timed)
    seconds = float(times[-1] - times[1])
    return {"particles": int(n_particles), "threads": int(data["threads"]),
            "arch": str(data["arch"]), "dtype": str(data["dtype"]), "substeps": steps,
            "pinned_workers": int(data["pinned"]),
            "seconds": seconds, "mpss_mean": n_particles * steps / seconds / 1e6,
            # the fastest frame: a shared machine only ever slows a frame down
            "mpss": n_particles * SUBSTEPS_PER_FRAME / float(timed.min()) / 1e6,
            "first_frame_seconds": float(times[1] - times[0]),
            "x0": data["x0"], "x1": data["x1"]}
