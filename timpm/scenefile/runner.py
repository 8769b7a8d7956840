"""Running a checked scene: its output writers checked before any work, the world run frame
by frame (a GIF, field files) or the problem run, the summary and the JSON record; a world
run's checkpoint continued (:func:`resume_scene`)."""
import math
import os
import signal
import sys
from dataclasses import dataclass, field

import numpy as np

from ..simulation.checkpoint import save_checkpoint
from ..platform.files import OutputError, write_json
from ..platform.interrupt import INTERRUPTED_CHECKPOINT, RunInterrupted
from .build import SceneFile, load_scene


@dataclass
class SceneResult:
    """What a scene's run produced: sizes, times, the files written, and (a problem) the
    record of :func:`timpm.studies.study.run_problem`."""

    name: str
    path: str
    particles: int
    steps: int
    dt: float
    t_end: float
    compile_seconds: float
    simulation_seconds: float
    render_seconds: float = 0.0
    files: list = field(default_factory=list)
    record: dict | None = None
    series: dict = field(default_factory=dict)
    interrupted: bool = False
    #: what the run measured (``landslide``: its run-out and retrogressions)
    summary: dict = field(default_factory=dict)
    #: the bytes per particle and per node, the fields (``Solver.memory()``)
    memory: dict = field(default_factory=dict)

    @property
    def simulated_per_wall_second(self) -> float:
        """Simulated seconds per second of stepping."""
        return self.t_end / self.simulation_seconds if self.simulation_seconds > 0 else 0.0

    def report(self) -> str:
        rate = self.particles * self.steps / max(self.simulation_seconds, 1e-12) / 1e6
        lines = [f"{self.name} ({self.path}): {self.particles} particles, {self.steps} steps "
                 f"of dt = {self.dt:.3g} s to t = {self.t_end:.4g} s",
                 f"  compile {self.compile_seconds:.2f} s, simulation "
                 f"{self.simulation_seconds:.2f} s ({self.simulated_per_wall_second:.3g} "
                 f"simulated s per wall s, {rate:.2f} M particle-steps/s)"
                 + (f", rendering {self.render_seconds:.2f} s" if self.render_seconds else "")]
        if self.record is not None and self.record.get("rms_error") is not None:
            lines.append(f"  e_RMS = {self.record['rms_error']:.4e} ({self.record['elements']} "
                         f"elements, {self.record['ppc']} PPC, {self.record['basis']})")
        slide = self.summary.get("landslide")
        if slide is not None:
            lines.append(f"  landslide: run-out {slide['runout']:.3g} m beyond the toe "
                         f"({slide['runout_over_H']:.3g} H), scarp {slide['scarp_retreat']:.3g}"
                         f" m back, {slide['retrogressions']} retrogression(s)")
        if self.files:
            lines.append(f"  wrote {', '.join(self.files)}")
        return "\n".join(lines)

    def document(self) -> dict:
        """The JSON document of the run."""
        doc = {k: getattr(self, k) for k in ("name", "path", "particles", "steps", "dt",
                                            "t_end", "compile_seconds", "simulation_seconds",
                                            "render_seconds", "files")}
        doc["simulated_per_wall_second"] = self.simulated_per_wall_second
        if self.memory:
            doc["memory"] = self.memory
        if self.record is not None:
            doc["record"] = self.record
        if self.interrupted:
            doc["interrupted"] = True
        doc.update(self.summary)
        doc["series"] = {k: np.asarray(v).tolist() for k, v in self.series.items()}
        return doc


def _writers(scene, checkpoint=None):
    """The field writer and the movie of the scene's output, every output checked before
    any work: writable, and no two naming one file or the scene file."""
    from ..platform.files import check_distinct
    from ..output.fields import FieldWriter, check_output_file

    out = scene.output
    for key in ("json", "gif"):
        if out.get(key) is not None:
            try:
                check_output_file(out[key], f"output.{key}")
            except ValueError as err:
                raise scene.error(("output", key), str(err)) from None
    fields = {f"output.{fmt}": out.get(fmt) for fmt in ("vtk", "npz")}
    try:
        check_distinct({"output.json": out.get("json"), "output.gif": out.get("gif"),
                        **fields, "--checkpoint": checkpoint},
                       {"the scene file": getattr(scene, "path", None)})
    except ValueError as err:
        raise ValueError(f"{scene.path}: {err}") from None
    fields_writer = movie = None
    for fmt in ("vtk", "npz"):
        if out.get(fmt) is not None:
            try:
                fields_writer = FieldWriter(out[fmt], fmt)
            except ValueError as err:
                raise scene.error(("output", fmt), str(err)) from None
    if out.get("gif") is not None:
        from ..output.render import Movie

        movie = Movie(out["gif"], fps=out["fps"], width=out["width"])
    return fields_writer, movie


def _files(fields_writer, movie):
    files = []
    if fields_writer is not None:
        files.append(str(fields_writer.series if fields_writer.format == "vtk"
                         else fields_writer.directory))
    if movie is not None:
        files.append(movie.out)
    return files


def run_scene(scene, progress=None, checkpoint=None, overrides=None,
              allow_many_steps=False) -> SceneResult:
    """Run ``scene`` (a :class:`SceneFile` or a path), writing its outputs; returns the
    :class:`SceneResult` (its JSON document is written when ``output.json`` is set).
    ``checkpoint``: a file that gets the whole state at the end and at Ctrl-C, with the
    scene file's path and ``overrides`` (the key paths the file was run with) for
    ``timpm resume``."""
    from ..platform import runtime

    if not isinstance(scene, SceneFile):
        scene = load_scene(scene, overrides)
    if scene.precision is not None and scene.precision != runtime.precision():
        raise scene.error(("simulation", "precision"), f"the scene runs in {scene.precision} "
                          f"but Taichi was started in {runtime.precision()}: call "
                          f"timpm.init(precision={scene.precision!r}) first")
    fields_writer, movie = _writers(scene, checkpoint)
    try:
        result = (_run_problem(scene, fields_writer, progress, checkpoint, allow_many_steps)
                  if scene.problem is not None else
                  _run_world(scene, fields_writer, movie, progress, checkpoint,
                             {"scene_file": os.path.abspath(scene.path),
                              "overrides": dict(overrides or {})}, allow_many_steps))
    except RunInterrupted as stop:  # Ctrl-C: the partial record, then on to the caller
        if stop.result is not None and scene.output.get("json") is not None:
            write_json(scene.output["json"], stop.result.document())
            stop.record = scene.output["json"]  # (the command names only what it wrote)
        raise
    except OSError as err:  # an output failed after the run: the record is written still
        kept, record = getattr(err, "result", None), scene.output.get("json")
        if kept is not None and record is not None:
            kept.files = _files(fields_writer, movie) + [record]
            write_json(record, kept.document())
            raise OutputError(err.errno, f"{err.strerror}; the record is in {record}",
                              err.filename) from None
        raise
    result.files = _files(fields_writer, movie) + ([str(checkpoint)] if checkpoint else [])
    if scene.output.get("json") is not None:
        result.files.append(scene.output["json"])
        write_json(scene.output["json"], result.document())
    return result


def _run_problem(scene, fields_writer, progress, checkpoint, allow_many_steps=False
                 ) -> SceneResult:
    from ..studies.study import run_problem

    try:
        run = run_problem(**scene.problem, fields=fields_writer,
                          frames=scene.output["frames"], progress=progress,
                          checkpoint=checkpoint, allow_many_steps=allow_many_steps,
                          interrupted_to=checkpoint or INTERRUPTED_CHECKPOINT)
    except RunInterrupted as stop:
        stop.result = _problem_result(scene, stop.result)
        stop.result.interrupted = True
        raise
    return _problem_result(scene, run)


def _problem_result(scene, run) -> SceneResult:
    rec = run.record
    series = {k: v for k, v in run.series.items() if np.ndim(v) == 1}
    if run.energies is not None:
        series.update({f"energy_{k}": v for k, v in run.energies.items()})
    return SceneResult(name=scene.name, path=scene.path, particles=rec["particles"],
                       steps=rec["steps"], dt=rec["dt"], t_end=rec["t_end"],
                       compile_seconds=rec["compile_seconds"],
                       simulation_seconds=rec["wall_seconds"], record=rec, series=series)


class _WorldScales:
    """The colour scales of a scene file's world, as a demo gives them
    (:func:`timpm.scenarios.demos.color_range`): H the domain's height along gravity, v0
    the largest initial speed, rho and c the densest material's density and the fastest
    wave speed."""

    def __init__(self, world):
        gravity = np.asarray(world.model.gravity, dtype=float)
        g = float(np.linalg.norm(gravity))
        height = float(world.domain[int(np.argmax(np.abs(gravity))) if g > 0 else 0])
        v0 = float(np.max(np.linalg.norm(world.velocity, axis=1), initial=0.0))
        density = max(m.density for m in world.materials)
        wave = max(m.wave_speed for m in world.materials)
        self.speed = max(v0, np.sqrt(2.0 * g * height)) or 1.0
        self.stress = (density * g * height if g > 0 else density * wave * v0) or 1.0

    def speed_scale(self) -> float:
        """max(v0, sqrt(2 g H))."""
        return self.speed

    def stress_scale(self) -> float:
        """rho g H, or without gravity rho c v0."""
        return self.stress

    def strain_scale(self) -> float:
        return 1.0


def _color_range(world, color, output):
    """The GIF's colour range for the whole run, its label and unit: ``output.color_range``
    or the world's scales (:class:`_WorldScales`)."""
    from ..scenarios.demos import color_range

    value_range, label, unit = color_range(_WorldScales(world), color, len(world.bodies))
    if output.get("color_range") is not None:
        value_range = tuple(float(v) for v in output["color_range"])
    return value_range, label, unit


def _run_world(scene, fields_writer, movie, progress, checkpoint, run,
               allow_many_steps=False) -> SceneResult:
    from ..scenarios.demos import quantity
    from ..simulation.solver import Solver

    from ..platform.checks import step_count

    world, frames, t_end = scene.world, scene.output["frames"], scene.t_end
    color = scene.output["color"]
    # the step count before anything is compiled or launched: 0 steps or too many refused
    try:
        steps = step_count(t_end, world.dt, allow_many_steps)
    except ValueError as err:
        raise scene.error(("simulation", "t_end"), str(err)) from None
    if steps == 0:
        raise scene.error(("simulation", "t_end"), f"t_end = {t_end:g} s is shorter than half "
                          f"a step (dt = {world.dt:g} s): the run would take no step")
    if scene.grid == "window":  # refused before a gravity loading's work, naming the key
        from ..engine.features import grid_window_refusal
        from ..platform import runtime

        refusal = grid_window_refusal(world.model, scene.mode, runtime.on_cpu())
        if refusal is not None:
            raise scene.error(("simulation", "grid"), f"grid = 'window' does not apply to "
                              f"{refusal}: give 'dense' or 'auto'")
    from ..model.geostatic import GravityLoading
    from ..simulation.loading import gravity_loading

    if isinstance(world.initial_stress, GravityLoading):  # the stresses of a loading run
        try:
            world, _ = gravity_loading(world, progress=_loading_progress(progress),
                                       allow_many_steps=allow_many_steps)
        except ValueError as err:
            raise scene.error(("initial_stress",), str(err)) from None
        except RunInterrupted as stop:  # before the scene's run: no state of it to save
            raise _interrupted_loading(scene, stop) from None
    run = {**run, "mode": scene.mode,
           "record_every": max(1, int(round(t_end / world.dt / 200)))}
    solver = Solver(world, mode=scene.mode, energies=True, record_every=run["record_every"],
                    grid=scene.grid)
    try:
        if movie is not None:
            try:
                quantity(solver, color)  # a colour the scene lacks fails before the run
            except ValueError as err:
                raise scene.error(("output", "color"), str(err)) from None
            value_range, label, unit = _color_range(world, color, scene.output)
            movie.start(world, color, value_range=value_range, label=label, unit=unit,
                        title=scene.name)
        return _frames_saved(scene, solver, run, checkpoint, movie, t_end, frames, color=color,
                             fields=fields_writer, progress=progress)
    finally:
        solver.release()


def _loading_progress(progress):
    """The gravity loading's progress lines on stderr: with --progress, or (by default) on
    a terminal."""
    import sys

    if progress is False or (progress is None and not sys.stderr.isatty()):
        return None
    return lambda line: print(line, file=sys.stderr, flush=True)


def _interrupted_loading(scene, stop):
    """Ctrl-C (SIGTERM, SIGHUP) during the scene's gravity loading: the scene's own run had
    not begun, so no state is saved (a checkpoint of the loading run would resume as the
    scene's run, from stresses that are not its initial ones); the exception says so, and
    its result is the record of a run interrupted at t = 0, with where the loading
    stopped."""
    loading = getattr(stop, "loading", {"step": stop.step, "t": stop.t})
    by = "" if stop.signal == signal.SIGINT else f" by {signal.Signals(stop.signal).name}"
    stop.args = (f"interrupted{by} during the gravity loading (its step {loading['step']}, "
                 f"t = {loading['t']:g} s of its t_max = {loading.get('t_max', math.nan):g} s), "
                 "before the scene's run began: no state saved (there is none to resume; "
                 "rerun from the start)",)
    stop.checkpoint = None
    world = scene.world
    stop.result = SceneResult(name=scene.name, path=scene.path, particles=world.n_particles,
                              steps=0, dt=world.dt, t_end=0.0, compile_seconds=0.0,
                              simulation_seconds=0.0, interrupted=True,
                              summary={"interrupted_during": "gravity loading",
                                       "gravity_loading": dict(loading)})
    return stop


def _frames_saved(scene, solver, run, checkpoint, movie, t_end, frames, **options):
    """``run_frames`` of a world's solver (``options``: its colour, fields, progress ...),
    the movie closed and the state saved to ``checkpoint`` with the description ``run``
    at the end; at Ctrl-C the frames so far kept, the state saved (to
    ``timpm-interrupted.npz`` without a checkpoint) and the partial result on the
    exception.  Returns the :class:`SceneResult`."""
    from ..scenarios.demos import run_frames

    slide, measured = scene.output.get("landslide"), {}
    if slide is not None:  # the frames' front and scarp (timpm.studies.landslide)
        x0 = scene.world.model.positions

        def observe(s, t):
            return slide.observe(x0, s.positions(), s.h)

        options["observe"] = observe
    try:
        measured = run_frames(solver, t_end, frames, movie=movie, **options)
    except RunInterrupted as stop:  # Ctrl-C: keep the state, the frames so far
        if movie is not None:
            movie.close()
        stop.checkpoint = save_checkpoint(checkpoint or INTERRUPTED_CHECKPOINT, solver, run)
        stop.result = _world_result(scene, solver, movie)
        stop.result.interrupted = True
        raise
    if movie is not None:
        movie.close()
    result = _world_result(scene, solver, movie)
    if slide is not None:
        result.summary["landslide"] = slide.summary(measured, solver.h)
        result.series.update(landslide_t=measured["t"], front=measured["front"],
                             scarp=measured["scarp"])
    if checkpoint:
        try:
            save_checkpoint(checkpoint, solver, run)
        except OSError as err:  # the run's record is not lost with its checkpoint
            err.result = result
            raise
    return result


def resume_scene(saved, t_end, mode=None, fields=None, frames=20, checkpoint=None,
                 progress=None, allow_many_steps=False) -> SceneResult:
    """Continue the scene file's world run of the checkpoint ``saved``
    (:func:`timpm.simulation.checkpoint.load_checkpoint`) to ``t_end``: the scene rebuilt from its
    file with the overrides it ran with, the state restored (a file whose physics changed
    since is refused by the fingerprint), ``frames`` field frames over the resumed part
    into ``fields``, the state saved to ``checkpoint`` at the end and at Ctrl-C.  The
    file's own outputs (GIF, fields, JSON) are not written: the caller's are."""
    from ..platform import runtime
    from ..simulation.solver import Solver

    run = saved["run"]
    if "record_every" not in run or "mode" not in run:
        raise ValueError(f"the checkpoint of {run['scene_file']} was written by an older timpm "
                         "that kept neither the command's overrides nor the record interval: "
                         "rerun from the start")
    scene = load_scene(run["scene_file"], run.get("overrides") or None)
    if scene.world is None:  # a problem's checkpoint holds the problem's own description
        raise ValueError(f"{scene.path}: a problem scene now; the checkpoint holds a world "
                         "run of it: rerun from the start")
    if scene.precision != runtime.precision():
        raise ValueError(f"the checkpoint's scene runs in {scene.precision} but Taichi was "
                         f"started in {runtime.precision()}")
    if not t_end > saved["t"]:
        raise ValueError(f"--t-end {t_end:g} s is not after the checkpoint's time "
                         f"{saved['t']:g} s")
    solver = Solver(scene.world, mode=mode or run["mode"], energies=True,
                    record_every=run["record_every"], grid=scene.grid)
    try:
        try:
            solver.restore(saved)
        except ValueError as err:
            raise ValueError(f"{scene.path} no longer builds the checkpoint's scene: {err}")
        result = _frames_saved(scene, solver, run, checkpoint, None, t_end, frames,
                               fields=fields, progress=progress,
                               allow_many_steps=allow_many_steps)
        result.files = _files(fields, None) + ([str(checkpoint)] if checkpoint else [])
        return result
    finally:
        solver.release()


def _world_result(scene, solver, movie) -> SceneResult:
    world = scene.world
    return SceneResult(name=scene.name, path=scene.path, particles=world.n_particles,
                       steps=solver.step, dt=world.dt, t_end=solver.t,
                       compile_seconds=solver.compile_seconds,
                       simulation_seconds=solver.run_seconds,
                       render_seconds=movie.seconds if movie is not None else 0.0,
                       series=solver.energies(),
                       memory=dict(solver.memory(), process_peak_mb=_peak_memory_mb()))


def _peak_memory_mb():
    """The process's peak resident memory so far, in MiB (None where the platform does
    not say: the resource module is POSIX's)."""
    try:
        import resource
    except ImportError:
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux, B on macOS
    return peak / 1024.0 / (1024.0 if sys.platform == "darwin" else 1.0)
