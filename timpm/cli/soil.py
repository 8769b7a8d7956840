"""The soil commands of ``timpm``: ``timpm run biaxial-mc|triaxial-mc`` (an element test of
a soil law, :mod:`timpm.studies.element_test`) and ``timpm study factor-of-safety FILE.toml``
(a slope's factor of safety by strength reduction, :mod:`timpm.studies.factor_of_safety`).
Each checks its outputs before any work, prints ``timpm: error: ...`` and returns 2 on a
bad input, and writes its record before its plot."""
import argparse
import sys
import time

from ..platform import interrupt, runtime
from ..platform.errors import SimulationError
from ..platform.files import check_distinct, check_output, write_json
from ..studies import element_test as elements
from ..studies import factor_of_safety as fos

__all__ = ["element_test", "factor_of_safety", "infinite_slope", "monte_carlo", "listing"]


def listing() -> list:
    """``timpm list``'s lines of the element tests."""
    lines = ["element tests of a soil law (timpm run TEST [--law drucker-prager] --param "
             "NAME=VALUE --json F --plot P.png):"]
    for name, dim in elements.ELEMENT_TESTS.items():
        lines.append(f"  {name:16s} drained {'plane-strain biaxial' if dim == 2 else 'triaxial'}"
                     f" compression ({dim}D)")
    lines.append(f"  {'':16s} parameters: "
                 + ", ".join(f"{k}={v:g}" for k, v in elements.DEFAULTS.items()))
    return lines


def _check_outputs(args, inputs=None):
    """--json and --plot (a PNG) writable and distinct from each other and the inputs."""
    if args.json is not None:
        check_output(args.json, "--json")
    if args.plot is not None:
        check_output(args.plot, "--plot", ("png",))
    check_distinct({"--json": args.json, "--plot": args.plot}, inputs)


def _init(args, precision):
    """Taichi at ``precision`` with the study's --threads and --arch (TIMPM_THREADS and
    TIMPM_ARCH without them); a backend the machine lacks is a ValueError (printed as the
    other argument errors)."""
    try:
        runtime.init(threads=args.threads, arch=args.arch, precision=precision)
    except runtime.BackendUnavailable as exc:
        raise ValueError(str(exc)) from None


def _error(exc) -> int:
    print(f"timpm: error: {exc}", file=sys.stderr)
    return 2


def element_test(argv) -> int:
    """``timpm run biaxial-mc|triaxial-mc [--param NAME=VALUE ...] [--json F] [--plot P]``."""
    from ..platform.argtypes import param

    ap = argparse.ArgumentParser(prog=f"timpm run {argv[0] if argv else 'biaxial-mc'}",
                                 description="an element test of a soil law (Mohr-Coulomb, "
                                 "Drucker-Prager): drained compression under a confining "
                                 "pressure")
    ap.add_argument("test", choices=list(elements.ELEMENT_TESTS))
    ap.add_argument("--param", type=param, action="append", default=[], metavar="NAME=VALUE",
                    help="one of " + ", ".join(f"{k} (default {v:g})"
                                               for k, v in elements.DEFAULTS.items()))
    ap.add_argument("--law", default="mohr-coulomb", choices=elements.LAWS,
                    help="the soil law (default mohr-coulomb)")
    ap.add_argument("--json", metavar="FILE", help="write the record as JSON")
    ap.add_argument("--plot", metavar="FILE.png", help="draw the deviator and the volume")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                    help="progress bar (default: on a terminal, for tests over 2 s)")
    args = ap.parse_args(argv)
    try:
        _check_outputs(args)
        runtime.init(precision="f64")
        progress = _ElementProgress(args)
        with interrupt.deferred_sigint():  # a signal: the increments done kept
            try:
                record = elements.run_element_test(args.test, law=args.law,
                                                   progress=progress, **dict(args.param))
            finally:
                progress.close()
    except (ValueError, RuntimeError) as exc:
        return _error(exc)
    if not args.quiet:
        print(elements.summary(record))
    try:
        if args.json:
            write_json(args.json, {"command": "run", "problem": args.test, "runs": [record]})
        if args.plot:
            elements.plot_element_test(record, args.plot)
    except OSError as exc:
        return _error(exc)
    if "interrupted" in record:
        kept = f"; the increments done in {args.json}" if args.json else ""
        print(f"timpm: {record['interrupted']}{kept}", file=sys.stderr)
        return interrupt.exit_code()
    return 0


class _ElementProgress:
    """An element test's progress: after its first second, the time the whole test will
    take where that is over 10 s (a line on stderr, unless --quiet), then the bar."""

    def __init__(self, args):
        self.args, self.bar, self.said = args, None, False
        self.start = time.perf_counter()

    def __call__(self, done, n):
        from ..platform.progress import Progress

        if self.bar is None:
            self.bar = Progress(n, False if self.args.quiet else self.args.progress)
        elapsed = time.perf_counter() - self.start
        if not self.said and elapsed > 1.0 and done < n:
            self.said = True
            total = elapsed / done * n
            if total > 10.0 and not self.args.quiet:
                print(f"timpm: {self.args.test}: {n} increments take about {total:.0f} s "
                      f"({1e3 * elapsed / done:.2g} ms each); Ctrl-C stops the test and keeps "
                      "the increments done", file=sys.stderr, flush=True)
        self.bar.update(done)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _read_record(path):
    """A JSON record (``--resume``), or a ValueError naming the file."""
    import json

    try:
        with open(path) as f:
            return json.load(f)
    except OSError as exc:
        raise ValueError(f"--resume {path}: {exc.strerror}") from None
    except ValueError as exc:
        raise ValueError(f"--resume {path}: not a JSON record ({exc})") from None


#: the outputs of a scene's run that the study, many runs, does not write
NOT_WRITTEN = {"gif": "movie", "vtk": "field files", "npz": "field files",
               "landslide": "run-out measure"}


def _scene_outputs(args, scene, study="factor-of-safety"):
    """The scene's ``[output]`` in the study: its ``json`` is the study's record where
    --json is not given (checked as --json is); a movie, field files or a landslide
    measure, outputs of one run, are refused naming the key (the study runs many)."""
    from ..output.fields import check_output_file
    from ..platform.files import check_distinct

    for key, what in NOT_WRITTEN.items():
        if scene.output.get(key) is not None:
            raise scene.error(("output", key), f"the {study} study runs the scene many "
                              f"times and writes no {what}: only its record (--json, else "
                              "the scene's output.json) and its plots (--plot); "
                              f"remove output.{key} from the scene, or drop it for the "
                              f"study with --set output.{key}=")
    if args.json is None and scene.output.get("json") is not None:
        try:
            check_output_file(scene.output["json"], "output.json")
            check_distinct({"output.json": scene.output["json"], "--plot": args.plot},
                           {"the scene file": args.scene})
        except ValueError as err:
            raise scene.error(("output", "json"), str(err)) from None
        args.json = scene.output["json"]


def _interrupted(args, overrides, stop, what, study) -> int:
    """An interrupted study (``stop.partial``: its record so far): the record written to
    --json where given, with how to resume it, one line said; the interrupt's exit code."""
    stop.partial["scene"] = args.scene
    if overrides:
        stop.partial["overrides"] = overrides
    kept = ""
    if args.json:
        try:
            write_json(args.json, stop.partial)
            kept = (f"; the {what} so far in {args.json} (timpm study {study} "
                    f"{args.scene} --resume {args.json} ...)")
        except (OSError, ValueError) as exc:
            kept = f"; the record could not be written: {exc}"
    print(f"timpm: {stop}{kept}", file=sys.stderr)
    return interrupt.exit_code()


def factor_of_safety(args) -> int:
    """``timpm study factor-of-safety FILE.toml``: the bisection, its record and plot."""
    from ..scenefile import load_scene

    try:
        fos.check_settings(args.bracket[0], args.bracket[1], args.tolerance, args.creep)
        _check_outputs(args, {"the scene file": args.scene})
        overrides = dict(args.settings)
        scene = load_scene(args.scene, overrides or None)
        if scene.world is None:
            raise ValueError(f"{args.scene}: the factor of safety takes a world (a slope), "
                             "not a [problem]")
        _scene_outputs(args, scene)
        try:
            fos.check_reduced(scene.world, args.bracket[0], args.bracket[1])
        except ValueError as err:
            raise ValueError(f"{args.scene}: {err}") from None
        resume = None
        if args.resume:
            resume = _read_record(args.resume)
        _init(args, scene.precision)
        record, failed = fos.factor_of_safety(
            scene.world, scene.t_end, low=args.bracket[0], high=args.bracket[1],
            tolerance=args.tolerance, creep=args.creep, mode=scene.mode, resume=resume,
            workers=fos.workers_for(args.workers, scene.world),
            progress=None if args.quiet else lambda m: print(m, file=sys.stderr, flush=True))
    except fos.StudyInterrupted as stop:  # the trials so far, resumable
        return _interrupted(args, overrides, stop, "trials", "factor-of-safety")
    except (ValueError, SimulationError) as exc:
        return _error(exc)
    record["scene"] = args.scene
    if overrides:
        record["overrides"] = overrides
    print(f"factor of safety {record['factor_of_safety']:.4f} (bracket "
          f"{record['bracket'][0]:.4f} to {record['bracket'][1]:.4f}, {len(record['trials'])} "
          f"runs, {record['wall_seconds']:.1f} s)")
    try:
        if args.json:
            write_json(args.json, record)
        if args.plot:
            fos.plot_mechanism(scene.world, failed, record, args.plot)
    except (OSError, ValueError) as exc:  # the record is written first: it is kept
        return _error(exc)
    return 0


def monte_carlo(args) -> int:
    """``timpm study monte-carlo FILE.toml``: the realisations, their record and plots."""
    from ..scenefile import load_scene
    from ..studies import monte_carlo as mc

    overrides = dict(args.settings)
    try:
        fos.check_settings(args.bracket[0], args.bracket[1], args.tolerance, args.creep)
        mc.check_numbers(args.realisations, args.factor, args.width)
        _check_outputs(args, {"the scene file": args.scene})
        if args.field is not None:
            check_output(args.field, "--field", ("png",))
            check_distinct({"--json": args.json, "--plot": args.plot, "--field": args.field},
                           {"the scene file": args.scene})
        scene = load_scene(args.scene, overrides or None)
        if scene.world is None:
            raise ValueError(f"{args.scene}: a Monte Carlo study takes a world (a slope), "
                             "not a [problem]")
        _scene_outputs(args, scene, "Monte Carlo")
        resume = _read_record(args.resume) if args.resume else None
        if args.dask is not None and args.threads is None:
            args.threads = 1  # (the workers take this process's settings: one thread each)
        _init(args, scene.precision)
        workers = 1 if args.dask is not None else fos.workers_for(args.workers, scene.world)
        record = mc.monte_carlo(
            scene.world, scene.t_end, args.realisations, factor=args.factor, creep=args.creep,
            mode=scene.mode, factor_of_safety=args.factor_of_safety,
            bracket=tuple(args.bracket), tolerance=args.tolerance, run_on=args.run_on,
            width=args.width, workers=workers, dask=args.dask, resume=resume,
            progress=None if args.quiet else lambda m: print(m, file=sys.stderr, flush=True))
    except mc.MonteCarloInterrupted as stop:  # the realisations so far, resumable
        return _interrupted(args, overrides, stop, "realisations", "monte-carlo")
    except (ValueError, SimulationError, RuntimeError) as exc:
        return _error(exc)
    record["scene"] = args.scene
    if overrides:
        record["overrides"] = overrides
    lo, hi = record["wilson_95"]
    print(f"probability of failure {record['probability_of_failure']:.4f} "
          f"({record['failures']} of {record['realisations']} realisations; Wilson 95% "
          f"[{lo:.4f}, {hi:.4f}]; {record['wall_seconds']:.1f} s)")
    try:
        if args.json:
            write_json(args.json, record)
        if args.plot:
            mc.plot_study(record, args.plot)
        if args.field:
            mc.plot_field(scene.world, args.field)
    except (OSError, ValueError) as exc:  # the record is written first: it is kept
        return _error(exc)
    return 0


def infinite_slope(args) -> int:
    """``timpm study infinite-slope``: the bisection against the closed form."""
    from ..studies.infinite_slope import InfiniteSlope

    try:
        fos.check_settings(args.bracket[0], args.bracket[1], args.tolerance, 1e-3)
        _check_outputs(args, {})
        slope = InfiniteSlope(beta=args.beta, friction_angle=args.phi, water=args.water,
                              dilation_angle=args.psi)
        _init(args, "f64")
        record = slope.factor_of_safety(
            low=args.bracket[0], high=args.bracket[1], tolerance=args.tolerance,
            progress=None if args.quiet else lambda m: print(m, file=sys.stderr, flush=True))
    except (ValueError, SimulationError) as exc:
        return _error(exc)
    print(f"infinite slope ({record['water']}): factor of safety "
          f"{record['factor_of_safety']:.4f} (bracket {record['bracket'][0]:.4f} to "
          f"{record['bracket'][1]:.4f}), closed form {record['exact']:.4f}, error "
          f"{100 * record['relative_error']:+.2f} %, {record['wall_seconds']:.1f} s")
    try:
        if args.json:
            write_json(args.json, record)
    except (OSError, ValueError) as exc:
        return _error(exc)
    return 0
