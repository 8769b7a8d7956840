"""The ``timpm`` command: run the study's benchmarks and convergence studies.

The top layer: it may import every other module of the package (``tests/test_layers.py``).
The throughput benchmark is not part of the package: ``python benchmarks/throughput.py``.
"""
import argparse
import os
import sys

import numpy as np

from ..platform.version import __version__
from ..platform import interrupt
from ..platform.argtypes import (add_runtime_arguments, numbers_as_values, param, positive_float,
                                 positive_int, setting)
from ..bases import BASES, basis_argument, get_basis
from ..platform.checks import MAX_STEPS, step_count
from ..engine.features import MODES
from ..platform.files import replacing, write_json as _write_json
from ..model.model import INTEGRATORS, TRANSFERS
from ..schemes import scheme_params
from ..output.tables import run_table, scheme_line
from ..problems import PROBLEMS, get_problem
from ..platform.runtime import exit_process
from ..model.scene import PLACEMENTS, PROJECTIONS, STRESS_UPDATES
from ..simulation.solver import SimulationError
from . import soil as soil_commands
from ..studies import factor_of_safety, infinite_slope, monte_carlo, speed_error, sweep

__all__ = ["main", "entry", "demo_script"]


def _add_common(p):
    p.add_argument("problem", help=f"one of: {', '.join(PROBLEMS)}")
    p.add_argument("--ppc", type=positive_int,
                   help="particles per element (default: the problem's)")
    p.add_argument("--basis", default="linear", type=basis_argument,
                   help=f"one of: {', '.join(BASES)}, bsplineN, uniform-bsplineN")
    p.add_argument("--mass", choices=["lumped", "consistent"],
                   help="mass matrix (default: the problem's, lumped but for mms-1d)")
    p.add_argument("--dt", type=positive_float, help="time step [s] (default: the problem's)")
    p.add_argument("--t-end", type=positive_float,
                   help="end time [s] (default: the problem's)")
    p.add_argument("--placement", choices=list(PLACEMENTS),
                   help="particle positions in an element (default: the problem's; the "
                        "study's problems: study, (k+1)/(ppc+1); mms-*: gauss)")
    p.add_argument("--stress-update", default="study", choices=list(STRESS_UPDATES),
                   help="study: sigma += (E - sigma) d_eps (2.2.4); small: sigma += E d_eps; "
                        "*-exact: the same law integrated exactly over each step (no "
                        "drifting mean stress on long runs; strain energy W(F) V0)")
    p.add_argument("--damping", type=float, help="local damping factor alpha (A.4)")
    p.add_argument("--pic-fraction", type=float, metavar="B",
                   help="PIC share b of the musl velocity update, v_p = (1-b) FLIP + b PIC "
                        "(default: the problem's, 0 but for the oedometer)")
    p.add_argument("--projection", choices=list(PROJECTIONS),
                   help="mls: velocity, density and stress reconstructed by moving least "
                        "squares, forces at Gauss points (4.4); beyond the linear basis "
                        "with lumped mass (and in 2D), the stress only (default: the "
                        "problem's, standard but for mms-1d and mms-2d)")
    p.add_argument("--integrator", choices=list(INTEGRATORS),
                   help="euler-cromer: the study's; rk4: Runge-Kutta on the particles' "
                        "equations, four grid solves a step; midpoint: energy-conserving, "
                        "the step iterated on one thread; rk4 and midpoint for laws with "
                        "sigma(F) (default: the problem's, euler-cromer but for mms-1d)")
    p.add_argument("--transfer", default="musl", choices=list(TRANSFERS),
                   help="musl: the study's scheme (2.2.4); apic, mls-mpm: the affine "
                        "transfers (linear and uniform-bsplineN bases); the schemes' own "
                        "parameters: --transfer-param")
    _add_transfer_params(p)
    p.add_argument("--param", type=param, action="append", default=[], metavar="NAME=VALUE",
                   help="override a physical parameter of the problem, e.g. p0=2e4")
    p.add_argument("--allow-unstable-dt", action="store_true",
                   help="run even if dt exceeds the critical time step of Eq. 2.4")
    _add_allow_many_steps(p)
    p.add_argument("--mode", default="auto", choices=list(MODES),
                   help="serial: fused steps on one thread; parallel: one launch per step; "
                        "team: many steps per launch on every thread (private scatter)")
    add_runtime_arguments(p)
    p.add_argument("--json", metavar="FILE", help="write the records as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="draw a plot")
    p.add_argument("--quiet", action="store_true", help="no table on stdout")


def _add_transfer_params(p):
    p.add_argument("--transfer-param", type=param, action="append", default=[],
                   metavar="NAME=VALUE", dest="transfer_params",
                   help="a parameter of the transfer scheme, repeatable: "
                        + "; ".join(f"{name} ({', '.join(params)})" for name, params in
                                    ((t, scheme_params(t)) for t in TRANSFERS) if params))


def _add_allow_many_steps(p):
    p.add_argument("--allow-many-steps", action="store_true",
                   help=f"run even if the run takes more than {MAX_STEPS:.0e} steps")


#: the field files a run writes with --vtk or --npz and no --frames
FIELD_FRAMES = 20


def _add_fields(p, frames_help=None):
    p.add_argument("--vtk", metavar="DIR", help="write the particle fields as a ParaView "
                   "time series: DIR/particles.pvd and one .vtu per frame")
    p.add_argument("--npz", metavar="DIR", help="write the particle fields as one NumPy "
                   ".npz per frame")
    p.add_argument("--grid", action="store_true", help="with --vtk or --npz: also the grid's "
                   "nodal mass and velocity at each frame (--vtk: DIR/grid.pvd, .vti images)")
    if frames_help:
        p.add_argument("--frames", type=positive_int, default=None, help=frames_help)


def _add_checkpoint(p):
    p.add_argument("--checkpoint", metavar="FILE", help="save the whole state and the run's "
                   "description to FILE (.npz) at the end, every --checkpoint-every steps "
                   "and on Ctrl-C; continue with: timpm resume FILE --t-end T")
    p.add_argument("--checkpoint-every", type=positive_int, metavar="STEPS",
                   help="also save the checkpoint every STEPS steps")


def _field_writer(args):
    """The FieldWriter of --vtk / --npz (checked before any work), or None."""
    if args.vtk and args.npz:
        raise ValueError("--vtk and --npz: choose one field format")
    if not (args.vtk or args.npz):
        if args.grid:
            raise ValueError("--grid writes the grid beside the particle fields: give --vtk "
                             "DIR or --npz DIR too")
        if getattr(args, "command", None) != "demo" and getattr(args, "frames", None):
            raise ValueError(f"--frames {args.frames} spaces the field files: give --vtk DIR "
                             "or --npz DIR too (or leave --frames out)")
        return None
    from ..output.fields import FieldWriter

    return FieldWriter(args.vtk or args.npz, "vtk" if args.vtk else "npz", grid=args.grid)


def _time_series(result) -> dict:
    """The run's recorded series on one time base: the monitored particle's (``u``, ``v``,
    ``stress``, and the exact ``u_exact``, ``v_exact``) and the energies
    (``energy_kinetic``, ...)."""
    out = {k: np.asarray(v) for k, v in result.series.items() if np.ndim(v) == 1}
    if result.energies is not None:
        times = np.asarray(result.energies["t"])
        if "t" not in out or np.array_equal(out["t"], times):
            out["t"] = times
            out.update({f"energy_{k}": np.asarray(v) for k, v in result.energies.items()
                        if k != "t"})
    return out


def _check_output_files(args, inputs=None):
    """--json, --csv, --plot, --out, --checkpoint: each writable (its directory probed, the
    plot's format known), no two naming one file or an input (``inputs``: what -> path),
    before any work."""
    from ..platform.files import PLOT_FORMATS, check_distinct, check_output, check_output_dir

    outputs = {}
    for flag in ("json", "csv", "plot", "out", "checkpoint"):
        value = getattr(args, flag, None)
        if value is not None:
            check_output(value, f"--{flag}", PLOT_FORMATS if flag == "plot" else None)
            outputs[f"--{flag}"] = value
    for flag in ("vtk", "npz", "png_dir"):
        value = getattr(args, flag, None)
        if value is not None and not value:
            raise ValueError(f"--{flag.replace('_', '-')} needs a directory name, got an "
                             "empty one")
        if value:
            outputs[f"--{flag.replace('_', '-')}"] = value
    if getattr(args, "png_dir", None):
        check_output_dir(args.png_dir, "--png-dir")
    inputs = dict(inputs or {})
    if "the checkpoint resumed" in inputs and outputs.get("--checkpoint") is not None:
        # a resume may save its state back over the checkpoint it read whole
        same = os.path.realpath(outputs["--checkpoint"]) == os.path.realpath(
            inputs["the checkpoint resumed"])
        if same:
            outputs.pop("--checkpoint")
    check_distinct(outputs, inputs)


def _refuse_early(problem, elements, ppc, dt=None, t_end=None, allow_many_steps=False):
    """The sizes of these meshes and, with dt given, the step count, checked before Taichi
    starts (the runs check them again)."""
    for n in elements:
        problem.check_size(problem.elements if n is None else n,
                           problem.ppc if ppc is None else ppc)
    if dt is not None:
        step_count(problem.t_end if t_end is None else t_end, dt, allow_many_steps)


def _start_taichi(args):
    """Taichi with ``--threads`` and ``--arch``; without them, as it runs already where it
    was started (a notebook or a test calling ``main``: no restart, no recompilation),
    else the defaults."""
    from ..platform import runtime

    threads, arch = getattr(args, "threads", None), getattr(args, "arch", None)
    try:
        if threads is None and arch is None:
            runtime.ensure_init()
        else:
            runtime.init(threads=threads, arch=arch)
    except runtime.BackendUnavailable as exc:  # printed as the other argument errors
        raise ValueError(str(exc)) from None


def _write_csv(path, series):
    names = list(series)
    table = np.column_stack([series[k] for k in names])
    with replacing(path) as tmp:
        np.savetxt(tmp, table, delimiter=",", header=",".join(names), comments="", fmt="%.17g")


def _parser():
    ap = argparse.ArgumentParser(prog="timpm", description="High-order material point method "
                                 "in Taichi: the study's 1D benchmarks and convergence studies.",
                                 epilog="The throughput benchmark (Taichi's mpm88, NumPy, the "
                                 "machine's bounds): python benchmarks/throughput.py --help")
    ap.add_argument("--version", action="version", version=f"timpm {__version__}")
    sub = ap.add_subparsers(dest="command", required=True)
    about = ("run one benchmark and compare with its exact solution, or a scene file: "
             "timpm run FILE.toml (timpm run FILE.toml --help)")
    run = sub.add_parser("run", help=about, description=about)
    _add_common(run)
    run.add_argument("--elements", type=positive_int, help="number of elements over the body")
    _add_fields(run, "field frames over the run, with --vtk or --npz (default 20)")
    run.add_argument("--csv", metavar="FILE", help="write the recorded time series (the "
                     "monitored particle, the energies) as a table")
    _add_checkpoint(run)
    resume = sub.add_parser("resume", help="continue a run saved by --checkpoint (or by "
                            "Ctrl-C) to a later time, bit for bit as if never stopped")
    resume.add_argument("saved", metavar="FILE", help="a checkpoint file (.npz)")
    resume.add_argument("--t-end", type=positive_float, required=True, help="end time [s]")
    _add_allow_many_steps(resume)
    resume.add_argument("--mode", choices=list(MODES),
                        help="run mode (default: the saved run's)")
    add_runtime_arguments(resume)
    resume.add_argument("--json", metavar="FILE", help="write the records as JSON")
    resume.add_argument("--plot", metavar="FILE.png", help="draw a plot")
    resume.add_argument("--quiet", action="store_true", help="no table on stdout")
    resume.add_argument("--csv", metavar="FILE", help="write the recorded time series")
    _add_fields(resume, "field frames over the resumed part, with --vtk or --npz "
                "(default 20)")
    _add_checkpoint(resume)
    conv = sub.add_parser("convergence", help="RMS error and observed rates over meshes")
    _add_common(conv)
    conv.add_argument("--elements", type=positive_int, nargs="+", default=[4, 8, 16, 32, 64],
                      help="numbers of elements (default: 4 8 16 32 64)")
    sweep.add_arguments(conv)
    cmp = sub.add_parser("compare-ulfem", help="MPM against updated-Lagrangian FEM on the "
                         "large-deformation column of A.5")
    cmp.add_argument("--elements", type=positive_int, default=30)
    cmp.add_argument("--ppc", type=positive_int, default=50)
    cmp.add_argument("--dt", type=positive_float, default=1e-3)
    cmp.add_argument("--t-end", type=positive_float, default=3.0)
    cmp.add_argument("--basis", default="linear", type=basis_argument)
    _add_allow_many_steps(cmp)
    cmp.add_argument("--json", metavar="FILE")
    cmp.add_argument("--plot", metavar="FILE.png")
    sub.add_parser("list", help="list problems, bases and demos")
    demo = sub.add_parser("demo", help="run a 2D demo scene and write it to an animated GIF")
    from ..scenarios.demos import DEMOS

    demo.add_argument("name", help=f"one of: {', '.join(DEMOS)}")
    demo.add_argument("--out", metavar="FILE.gif", help="animated GIF to write")
    demo.add_argument("--frames", type=positive_int, default=60, help="frames (default 60)")
    demo.add_argument("--fps", type=positive_int, default=None,
                      help="GIF frames per second (default 20; with --out)")
    demo.add_argument("--width", type=positive_int, default=None,
                      help="frame width [px], 320 to 8192 (default 640)")
    demo.add_argument("--color", help="colour by: speed, pressure, plastic, von-mises, body")
    demo.add_argument("--png-dir", metavar="DIR", help="also write every frame as PNG")
    _add_fields(demo)
    demo.add_argument("--t-end", type=positive_float, help="end time [s] (default: the demo's)")
    _add_allow_many_steps(demo)
    demo.add_argument("--param", type=setting, action="append", default=[], metavar="NAME=VALUE",
                      help="override a demo parameter, e.g. aspect=1, cells=40, transfer=musl")
    _add_transfer_params(demo)
    demo.add_argument("--mode", default="auto", choices=list(MODES))
    add_runtime_arguments(demo)
    demo.add_argument("--plot", metavar="FILE.png", help="plot the demo's diagnostic")
    demo.add_argument("--json", metavar="FILE", help="write times, summary and series as JSON")
    demo.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                      help="progress bar (default: on a terminal, for runs over 2 s)")
    study = sub.add_parser("study", help="studies over many runs: speed-error, "
                           "factor-of-safety, infinite-slope, monte-carlo")
    studies = study.add_subparsers(dest="study", required=True)
    speed_error.add_parser(studies).set_defaults(func=_speed_error)
    factor_of_safety.add_parser(studies).set_defaults(func=soil_commands.factor_of_safety)
    infinite_slope.add_parser(studies).set_defaults(func=soil_commands.infinite_slope)
    monte_carlo.add_parser(studies).set_defaults(func=soil_commands.monte_carlo)
    for parser in (ap, *sub.choices.values(), *studies.choices.values()):
        numbers_as_values(parser)
    return ap


def _listing() -> str:
    """``timpm list``: the problems with their defaults and parameters (--param), the
    bases, the demos with their parameters."""
    from dataclasses import fields

    from ..bases import MAX_BSPLINE_DEGREE
    from ..scenarios.demos import DEMOS

    def params(obj):
        shown = {f.name: getattr(obj, f.name) for f in fields(obj)}
        return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                         for k, v in shown.items())

    lines = ["problems (timpm run PROBLEM --param NAME=VALUE):"]
    for name, cls in PROBLEMS.items():
        p = cls()
        lines.append(f"  {name:16s} {p.title}; defaults: {p.elements} elements, {p.ppc} PPC, "
                     f"dt = {p.dt_rule}, t_end = {p.t_end:g} s")
        lines.append(f"  {'':16s} parameters: {params(p)}")
        linear, higher = (p.scheme(get_basis(b)) for b in ("linear", "bspline3"))
        if higher != linear:  # a scheme of its own beyond the linear basis (mms-1d, 2d)
            lines.append(f"  {'':16s} scheme: {', '.join(higher)} beyond the linear basis, "
                         f"{', '.join(linear)} with it (mass, projection, integrator)")
    lines += soil_commands.listing()
    lines.append("bases (--basis): " + ", ".join(BASES) + f"; bsplineN and uniform-bsplineN "
                 f"for degree N = 1 to {MAX_BSPLINE_DEGREE} (clamped, padded uniform)")
    lines.append("demos (timpm demo NAME --out FILE.gif --param NAME=VALUE):")
    for name, cls in DEMOS.items():
        lines.append(f"  {name:16s} parameters: {params(cls())}")
    return "\n".join(lines)


def _compare(args):
    from ..output.viz import plot_comparison
    from ..studies.study import compare_large_column

    cmp = compare_large_column(elements=args.elements, ppc=args.ppc, dt=args.dt,
                               t_end=args.t_end, basis=args.basis,
                               allow_many_steps=args.allow_many_steps)
    print(f"{'':8} {'period [s]':>11} {'study [s]':>10}")
    for key in ("mpm", "ulfem"):
        print(f"{key.upper():8} {cmp[key]['period']:11.4f} {cmp['study_periods'][key]:10.3f}")
    if args.json:
        doc = {k: {"period": cmp[k]["period"], "t": list(map(float, cmp[k]["t"])),
                   "position": list(map(float, cmp[k]["position"]))} for k in ("mpm", "ulfem")}
        doc["mpm"]["record"] = cmp["mpm"]["record"]
        doc["study_periods"] = cmp["study_periods"]
        _write_json(args.json, doc)
    if args.plot:
        plot_comparison(cmp, args.plot)
    return 0


def _run(args, start):
    """``timpm run`` / ``timpm resume``: ``start(**outputs)`` runs; print the table, write the
    outputs; returns the JSON document, or None when Ctrl-C stopped the run (then the
    checkpoint and the partial record are written and one line says where)."""
    from ..output.viz import plot_series

    try:
        with interrupt.deferred_sigint():
            result = start(fields=_field_writer(args), frames=args.frames or FIELD_FRAMES,
                           checkpoint=args.checkpoint, checkpoint_every=args.checkpoint_every,
                           interrupted_to=args.checkpoint or interrupt.INTERRUPTED_CHECKPOINT)
    except OSError as exc:  # an output failed after the run: the record is written still
        kept = getattr(exc, "result", None)
        if kept is not None and args.json:
            _write_json(args.json, {"command": args.command, "problem": kept.record["problem"],
                                    "runs": [kept.record]})
            from ..platform.files import OutputError
            raise OutputError(exc.errno, f"{exc.strerror}; the record is in {args.json}",
                              exc.filename) from None
        raise
    except SimulationError as exc:  # a physics failure: its record is kept all the same
        kept = getattr(exc, "result", None)
        if kept is None or not args.json:
            raise
        _write_json(args.json, {"command": args.command, "problem": kept.record["problem"],
                                "runs": [kept.record]})
        raise SimulationError(f"{exc}; the record of the run to there is in {args.json}",
                              exc.code, exc.step, exc.particle, exc.node) from None
    except interrupt.RunInterrupted as stop:
        doc = {"command": args.command, "runs": [stop.result.record]} if stop.result else None
        if doc and args.json:
            _write_json(args.json, doc)
        where = (f"; saved to {stop.checkpoint} (timpm resume {stop.checkpoint} --t-end T)"
                 if stop.checkpoint else "")
        print(f"timpm: {stop}{where}"
              + (f"; partial record {args.json}" if doc and args.json else ""),
              file=sys.stderr)
        return None
    doc = {"command": args.command, "problem": result.record["problem"],
           "runs": [result.record]}
    if not args.quiet:
        print(scheme_line(result.record))
        print(run_table(doc["runs"]))
        extra = {k: v for k, v in result.record.items() if k in
                 ("strain", "exact_strain", "strain_relative_error", "energy_drift")}
        if extra:
            print("  ".join(f"{k} = {v:.6g}" for k, v in extra.items() if v is not None))
    series = _time_series(result)
    doc["runs"][0]["series"] = {k: v.tolist() for k, v in series.items()}
    if args.json:  # the result first: a failing plot loses nothing else
        _write_json(args.json, doc)
    if args.csv:
        _write_csv(args.csv, series)
    if args.plot:
        plot_series(result, args.plot)
    return doc


def _options(args):
    return dict(ppc=args.ppc, basis=args.basis, mass=args.mass, dt=args.dt, t_end=args.t_end,
                placement=args.placement, stress_update=args.stress_update,
                damping=args.damping, pic_fraction=args.pic_fraction,
                allow_unstable_dt=args.allow_unstable_dt,
                allow_many_steps=args.allow_many_steps,
                projection=args.projection, transfer=args.transfer,
                transfer_params=dict(args.transfer_params) or None,
                integrator=args.integrator, mode=args.mode, params=dict(args.param))


def _demo(args):
    from ..output.render import Movie
    from ..scenarios.demos import run_demo

    params = dict(args.param)
    if args.t_end is not None:
        params["t_end"] = args.t_end
    if args.transfer_params:
        params["transfer_params"] = dict(args.transfer_params)
    _check_output_files(args)
    movie = None
    unused = [flag for flag, value in (("--fps", args.fps), ("--width", args.width),
                                       ("--png-dir", args.png_dir)) if value is not None]
    if unused and not args.out:
        raise ValueError(f"{', '.join(unused)} shape{'s' * (len(unused) == 1)} the GIF: give "
                         "--out FILE.gif too (or leave "
                         f"{'it' if len(unused) == 1 else 'them'} out)")
    if args.out:
        movie = Movie(args.out, fps=args.fps or 20, width=args.width or 640,
                      png_dir=args.png_dir, frames=args.frames + 1)
    _start_taichi(args)
    fields = _field_writer(args)
    with interrupt.deferred_sigint():  # a signal: the GIF and the JSON of the run so far
        result = run_demo(args.name, movie=movie, frames=args.frames, color=args.color,
                          progress=args.progress, mode=args.mode, fields=fields,
                          allow_many_steps=args.allow_many_steps, **params)
    print(result.report())
    if args.json:
        doc = {k: getattr(result, k) for k in ("name", "out", "frames", "particles", "steps",
                                               "t_end", "dt", "compile_seconds",
                                               "simulation_seconds", "render_seconds",
                                               "summary", "memory")}
        doc["simulated_per_wall_second"] = result.simulated_per_wall_second
        doc["series"] = {k: v.tolist() for k, v in result.series.items()}
        if result.interrupted is not None:
            doc["interrupted"] = True
        _write_json(args.json, doc)
    if args.plot:
        from ..output.viz import plot_demo

        plot_demo(result, args.plot)
    if result.interrupted is not None:
        kept = [f for f in (result.out, args.json) if f]
        print(f"timpm: {result.interrupted}"
              + (f"; the run so far in {', '.join(kept)}" if kept else ""), file=sys.stderr)
        return result.interrupted.exit_code
    return 0


def _partial_sweep(args, stop) -> int:
    """An interrupted sweep (Ctrl-C, SIGTERM, SIGHUP): the record of its runs done written to
    --json, marked interrupted; 128 + the signal."""
    kept = f"; partial record {args.json}" if args.json and stop.done else ""
    try:
        if kept:
            _write_json(args.json, stop.partial)
    except OSError as exc:
        kept = f"; the partial record was not written: {exc}"
    print(f"timpm: {stop}{kept}", file=sys.stderr)
    return interrupt.exit_code()


def _speed_error(args) -> int:
    """``timpm study speed-error``: run the sweep, print the report, write plot and JSON."""
    from ..output.viz import plot_speed_error

    def progress(msg):
        print(msg, file=sys.stderr, flush=True)

    try:
        problem = get_problem(args.problem, **dict(args.param))
        _refuse_early(problem, [max(args.elements)], max(args.ppc or [problem.ppc]))
        _check_output_files(args)
        _start_taichi(args)
        doc = speed_error.speed_error_study(
            args.problem, bases=args.bases, masses=args.masses, stress_update=args.stress_update,
            params=dict(args.param), elements=args.elements, ppcs=args.ppc,
            placement=args.placement, t_end=args.t_end, dt_tolerance=args.dt_tolerance,
            max_halvings=args.max_halvings, repeats=args.repeats, mode=args.mode,
            progress=None if args.quiet else progress, workers=args.workers, dask=args.dask)
    except sweep.SweepInterrupted as stop:
        return _partial_sweep(args, stop)
    except (ValueError, SimulationError, sweep.SweepError) as exc:
        print(f"timpm: error: {exc}", file=sys.stderr)
        return 2
    if not doc["runs"]:
        skipped = doc["skipped"]
        reasons = "; ".join(f"{c['basis']}/{c['mass']}/{c['elements']} elements: {c['reason']}"
                            for c in skipped[:3])
        print(f"timpm: error: every one of the {len(skipped)} configurations was skipped, "
              f"nothing to report ({reasons}{'; ...' if len(skipped) > 3 else ''})",
              file=sys.stderr)
        return 2
    targets = args.targets or speed_error.default_targets(doc["runs"])
    answers = speed_error.cheapest_for(doc["runs"], targets)
    doc["targets"] = answers
    print(speed_error.format_report(doc, answers))
    try:
        if args.json:
            _write_json(args.json, doc)
        if args.plot:
            plot_speed_error(doc, args.plot)
    except OSError as exc:
        print(f"timpm: error: {exc}", file=sys.stderr)
        return 2
    return 0


def entry():
    """The ``timpm`` command (console script and ``python -m timpm``): :func:`main`, then
    the process ends without the interpreter's teardown (:func:`timpm.platform.runtime.exit_process`;
    an uncaught error exits as usual, with its traceback)."""
    exit_process(main() or 0)


def main(argv=None):
    try:
        with interrupt.termination_as_interrupt():  # SIGTERM, SIGHUP: as Ctrl-C
            return _main(argv)
    except KeyboardInterrupt:  # outside a run's deferred Ctrl-C (a demo, a study)
        print("timpm: interrupted", file=sys.stderr)
        return interrupt.exit_code()


def _main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["run"]:  # scene files: their reader imported where one may be run
        from ..scenefile import is_scene_argument, main as run_scene_file

        if is_scene_argument(argv[1:]):
            return run_scene_file(argv[1:])
        from ..studies.element_test import ELEMENT_TESTS

        if argv[1:2] and argv[1] in ELEMENT_TESTS:  # a soil law's element test
            return soil_commands.element_test(argv[1:])
    args = _parser().parse_args(argv)
    if args.command == "study":
        return args.func(args)
    if args.command == "demo":
        try:
            return _demo(args)
        except (ValueError, SimulationError, OSError) as exc:
            print(f"timpm: error: {exc}", file=sys.stderr)
            return 2
    if args.command == "list":
        print(_listing())
        print("scene files: timpm run FILE.toml (examples/, docs/scene_files.md)")
        return 0
    from ..output.viz import plot_convergence
    from ..studies.study import convergence, run_problem

    try:
        if args.command == "compare-ulfem":
            _check_output_files(args)
            _refuse_early(get_problem("large-column"), [args.elements], args.ppc, args.dt,
                          args.t_end, args.allow_many_steps)
            return _compare(args)
        if args.command == "resume":
            from ..simulation.checkpoint import load_checkpoint
            from ..studies.study import resume_problem

            _check_output_files(args, {"the checkpoint resumed": args.saved})
            saved = load_checkpoint(args.saved)
            if (saved["run"] or {}).get("scene_file") is not None:  # a world's scene file
                from ..scenefile.command import resume

                return resume(args, saved, _field_writer(args))
            _start_taichi(args)
            mode = {} if args.mode is None else {"mode": args.mode}
            doc = _run(args, lambda **out: resume_problem(
                args.saved, args.t_end, saved=saved, allow_many_steps=args.allow_many_steps,
                **mode, **out))
            return interrupt.exit_code() if doc is None else 0
        problem = get_problem(args.problem, **dict(args.param))
        meshes = args.elements if args.command == "convergence" else [args.elements]
        _refuse_early(problem, meshes, args.ppc, args.dt, args.t_end, args.allow_many_steps)
        _check_output_files(args)
        _start_taichi(args)
        opts = _options(args)
        if args.command == "run":
            doc = _run(args, lambda **out: run_problem(args.problem, elements=args.elements,
                                                       **opts, **out))
            if doc is None:
                return interrupt.exit_code()
        else:
            doc = convergence(args.problem, elements=args.elements, workers=args.workers,
                              dask=args.dask, **opts)
            doc["command"] = "convergence"
            if not args.quiet:
                print(scheme_line(doc["runs"][0]))
                print(run_table(doc["runs"], doc.get("rates")))
            if args.json:
                _write_json(args.json, doc)
            if args.plot:
                plot_convergence(doc, args.plot)
    except sweep.SweepInterrupted as stop:
        return _partial_sweep(args, stop)
    except (ValueError, SimulationError, sweep.SweepError, OSError) as exc:  # OSError: output
        print(f"timpm: error: {exc}", file=sys.stderr)
        return 2
    return 0


def demo_script(name, argv=None):
    """Entry of the scripts in demos/: ``timpm demo NAME`` writing NAME.gif and NAME.png
    (underscores for dashes) unless ``--out`` / ``--plot`` are given."""
    args = list(sys.argv[1:] if argv is None else argv)
    stem = name.replace("-", "_")
    if "--out" not in args:
        args += ["--out", f"{stem}.gif"]
    if "--plot" not in args:
        args += ["--plot", f"{stem}.png"]
    return main(["demo", name, *args])


if __name__ == "__main__":
    entry()
