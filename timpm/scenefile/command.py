"""The command ``timpm run FILE.toml [options]``: its options made key overrides, the scene
loaded, Taichi started and the scene run; errors print ``timpm: error: ...``.  And
``timpm resume`` of a world run's checkpoint (:func:`resume`)."""
import argparse
import os
import sys

from ..platform.interrupt import RunInterrupted, deferred_sigint
from ..output.fields import check_output_file
from ..problems import PROBLEMS
from .build import load_scene
from .reader import read_toml
from .runner import run_scene
from .schema import MODES


def is_scene_argument(argv) -> bool:
    """Whether ``timpm run`` arguments ``argv`` (after ``run``) name a scene file: the first
    argument, the run's subject, ends in ``.toml`` or names an existing file that is not a
    problem's name (an option's value ending in ``.toml``, ``--json out.toml``, does not)."""
    if not argv or argv[0].startswith("-"):
        return False
    return argv[0].endswith(".toml") or (argv[0] not in PROBLEMS and os.path.isfile(argv[0]))


def _parser():
    from ..platform.argtypes import (add_runtime_arguments, positive_float, positive_int,
                                     scene_setting)

    p = argparse.ArgumentParser(prog="timpm run", description="Run a scene file (TOML): a "
                                "world of bodies or a benchmark problem; see "
                                "docs/scene_files.md.")
    p.add_argument("file", help="the scene file")
    p.add_argument("--t-end", type=positive_float, help="end time [s] (the file's t_end)")
    p.add_argument("--dt", type=positive_float, help="time step [s] (the file's dt)")
    p.add_argument("--mode", choices=MODES, help="how the steps run (the file's mode)")
    p.add_argument("--frames", type=positive_int, help="output frames (output.frames)")
    p.add_argument("--vtk", metavar="DIR", help="ParaView field files (replaces the file's "
                   "vtk / npz)")
    p.add_argument("--npz", metavar="DIR", help="NumPy field files (replaces the file's "
                   "vtk / npz)")
    p.add_argument("--gif", metavar="FILE.gif", help="animated GIF (output.gif)")
    p.add_argument("--json", metavar="FILE", help="the run as JSON (output.json)")
    p.add_argument("--checkpoint", metavar="FILE", help="save the whole state and how to "
                   "rebuild the scene (the file's path, these options) to FILE (.npz) at "
                   "the end and on Ctrl-C; continue with: timpm resume FILE --t-end T")
    p.add_argument("--allow-many-steps", action="store_true",
                   help="run more than 1e8 steps (refused by default)")
    p.add_argument("--set", type=scene_setting, action="append", default=[], metavar="KEY=VALUE",
                   dest="settings", help="set any key, e.g. domain.cells=64, body[0].ppc=3, "
                   "simulation.transfer=musl; KEY= removes it")
    add_runtime_arguments(p)
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar (default: on a terminal, for runs over 2 s)")
    p.add_argument("--quiet", action="store_true", help="no summary on stdout")
    return p


def _command_line_overrides(args, form):
    """The key paths the options set (after ``--set``, so they win)."""
    out = dict(args.settings)
    for option in ("t_end", "dt", "mode"):
        if getattr(args, option) is not None:
            out[f"{form}.{option}"] = getattr(args, option)
    if args.vtk and args.npz:
        raise ValueError("--vtk and --npz: choose one field format")
    for fmt, other in (("vtk", "npz"), ("npz", "vtk")):
        if getattr(args, fmt):
            out[f"output.{fmt}"], out[f"output.{other}"] = getattr(args, fmt), None
    for option in ("frames", "gif", "json"):
        if getattr(args, option) is not None:
            out[f"output.{option}"] = getattr(args, option)
    return out


def main(argv) -> int:
    """``timpm run FILE.toml [options]``: load, check and run the scene, print a summary;
    an error prints ``timpm: error: ...`` and returns 2."""
    from ..platform import runtime
    from ..simulation.solver import SimulationError

    args = _parser().parse_args(argv)
    try:
        document = read_toml(args.file)  # read once: its form names the overrides' table
        form = "problem" if "problem" in document[1] else "simulation"
        overrides = _command_line_overrides(args, form)
        scene = load_scene(args.file, overrides, document)
        if args.checkpoint:
            check_output_file(args.checkpoint, "--checkpoint")
            if os.path.realpath(args.checkpoint) == os.path.realpath(args.file):
                raise ValueError(f"--checkpoint {args.checkpoint} names the scene file: give "
                                 "the checkpoint its own file")
        runtime.init(threads=args.threads, arch=args.arch,
                     precision=scene.precision or "f64")
        with deferred_sigint():
            result = run_scene(scene, progress=args.progress, checkpoint=args.checkpoint,
                               overrides=overrides, allow_many_steps=args.allow_many_steps)
    except RunInterrupted as stop:
        saved = f"; state saved to {stop.checkpoint}" if stop.checkpoint else ""
        record = getattr(stop, "record", None)  # only a record that was written
        print(f"timpm: {stop}{saved}"
              + (f"; partial record {record}" if record else ""), file=sys.stderr)
        return stop.exit_code
    except (ValueError, SimulationError, runtime.BackendUnavailable, OSError) as exc:
        print(f"timpm: error: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(result.report())
    return 0


def resume(args, saved, fields) -> int:
    """``timpm resume FILE --t-end T`` of a scene file's world run (``saved``: the loaded
    checkpoint, ``fields``: the --vtk / --npz writer): the summary, --json the run's
    document; Ctrl-C (SIGTERM, SIGHUP) saves again and returns 128 + the signal."""
    from ..platform import runtime
    from ..platform.files import write_json
    from .runner import resume_scene

    for option in ("plot", "csv", "checkpoint_every"):
        if getattr(args, option, None):
            raise ValueError(f"--{option.replace('_', '-')}: a scene file's world run keeps "
                             "its energies in --json and saves its checkpoint at the end and "
                             "on Ctrl-C only")
    try:
        runtime.init(threads=args.threads, arch=args.arch,
                     precision=saved["fingerprint"]["precision"])
    except runtime.BackendUnavailable as exc:  # printed as the other argument errors
        raise ValueError(str(exc)) from None
    try:
        with deferred_sigint():
            result = resume_scene(saved, args.t_end, mode=args.mode, fields=fields,
                                  frames=args.frames or 20, checkpoint=args.checkpoint,
                                  allow_many_steps=args.allow_many_steps)
    except RunInterrupted as stop:
        if args.json and stop.result is not None:
            write_json(args.json, stop.result.document())
        print(f"timpm: {stop}; state saved to {stop.checkpoint}", file=sys.stderr)
        return stop.exit_code
    if args.json:
        write_json(args.json, result.document())
    if not args.quiet:
        print(result.report())
    return 0
