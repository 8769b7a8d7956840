"""Checkpoint files: the whole state of a run, to go on later in another process.

A checkpoint is one NumPy ``.npz`` (no pickled objects: it loads with
``allow_pickle=False``) holding the solver's state blocks (particles, grid, time, step),
its records so far, and a JSON header: the format version, the solver's fingerprint (what
the restoring solver must match) and, when a driver knows it, the description of the run
(``run``: the arguments that rebuild its scene, e.g. :func:`timpm.studies.study.run_problem`'s).

``save_checkpoint(path, solver, run=...)`` writes it whole (:func:`timpm.platform.files.replacing`);
``load_checkpoint(path)`` reads and checks it;
``solver.restore(checkpoint)`` continues from it bit for bit (one thread, the same mode).
"""
import datetime
import json
import os
import zipfile

import numpy as np

from ..platform.files import replacing

__all__ = ["save_checkpoint", "load_checkpoint", "FORMAT", "VERSION"]

FORMAT = "timpm-checkpoint"
#: 2: the fingerprint holds the run-time physics (material constants, damping, loads ...)
VERSION = 2
#: what a version-2 header holds besides format and version
HEADER_KEYS = ("step", "t", "fingerprint", "columns", "energy_input", "run_seconds")


def save_checkpoint(path, solver, run=None) -> str:
    """Write ``solver``'s state (and ``run``, a JSON-able description of how to rebuild its
    scene) to ``path``; returns the path."""
    from ..platform.version import __version__

    snap = solver.snapshot()
    header = {"format": FORMAT, "version": VERSION, "timpm": __version__,
              "created": datetime.datetime.now().isoformat(timespec="seconds"),
              "step": solver.step, "t": solver.t, "fingerprint": snap["fingerprint"],
              "columns": snap["columns"], "energy_input": snap["energy_input"],
              "run_seconds": snap["run_seconds"], "run": run}
    try:
        text = json.dumps(header)
    except TypeError as exc:
        raise ValueError(f"checkpoint {path}: the run description cannot be written as "
                         f"JSON ({exc})") from None
    arrays = {f"state/{k}": v for k, v in snap["arrays"].items()}
    arrays.update({f"history/{k}": v for k, v in snap["history"].items()})
    arrays["header"] = np.array(text)
    with replacing(path) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
    return str(path)


def load_checkpoint(path) -> dict:
    """The checkpoint at ``path`` as :meth:`Solver.snapshot`'s dict plus ``run``, ``step``,
    ``t`` and ``header``; a clear error for a missing, foreign, older or newer file."""
    if not os.path.isfile(path):
        raise ValueError(f"checkpoint {path}: no such file")
    try:
        with np.load(path, allow_pickle=False) as data:
            contents = {k: data[k] for k in data.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise ValueError(f"checkpoint {path}: not a timpm checkpoint (an .npz file "
                         f"written by --checkpoint): {exc}") from None
    try:
        header = json.loads(str(contents.pop("header")))
    except (KeyError, ValueError):
        header = None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ValueError(f"checkpoint {path}: not a timpm checkpoint (no timpm header)")
    if header.get("version") == 1:
        raise ValueError(f"checkpoint {path}: written by an older timpm (format version 1) "
                         "whose checkpoints do not record the run-time physics (material "
                         "constants, damping, loads ...) that this scene must match; rerun "
                         "from the start")
    if header.get("version") != VERSION:
        raise ValueError(f"checkpoint {path}: format version {header.get('version')!r}, "
                         f"this timpm reads version {VERSION}")
    missing = [k for k in HEADER_KEYS if k not in header]
    if missing:
        raise ValueError(f"checkpoint {path}: its header lacks {', '.join(missing)} (a damaged "
                         "or hand-edited file)")
    state = {k.split("/", 1)[1]: v for k, v in contents.items() if k.startswith("state/")}
    history = {k.split("/", 1)[1]: v for k, v in contents.items()
               if k.startswith("history/")}
    return {"arrays": state, "history": history, "fingerprint": header["fingerprint"],
            "columns": header["columns"], "energy_input": header["energy_input"],
            "run_seconds": header["run_seconds"], "run": header.get("run"),
            "step": header["step"], "t": header["t"], "header": header}
