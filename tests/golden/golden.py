"""Golden outputs: runs of many scenes x modes x scatters on ONE thread, recorded before the
engine redesign and compared bit for bit after it.

    python tests/golden/golden.py record [--precision f64|f32] [--only CASE...]   # writes
        golden_<prec>.npz (with --only: those cases added or replaced, the others kept)
    python tests/golden/golden.py update --only CASE... --keys ARRAY... [--rtol R]   # an intended change
    python tests/golden/golden.py check  [--precision f64|f32]   # exit 1 on any difference

Each case builds its scene through the public API only (problems, World, Solver), runs a
fixed number of steps and keeps positions, velocities, stresses, volumes, the recorded
energies and tracked series, the grid crossings and (1D) the RMS error against the exact
solution.  One thread makes the parallel modes' atomic adds run in a fixed order, so every
array must match to the last bit.  ``tests/test_golden.py`` runs ``check`` in a fresh
process with TIMPM_THREADS=1.
"""
import argparse
import os
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _demos(module="demos"):
    """timpm.scenarios.<module>, or timpm.<module> of the engine before the redesign."""
    import importlib

    try:
        return importlib.import_module(f"timpm.{module}")
    except ImportError:
        return importlib.import_module(f"timpm.scenarios.{module}")


def _problem(name, steps, solver_kw=None, **scene_kw):
    def build():
        from timpm.problems import get_problem

        problem = get_problem(name)
        scene = problem.scene(**scene_kw)
        return scene, problem, steps, dict(solver_kw or {})
    return build


def _sand(transfer, steps, basis="uniform-bspline2", **solver_kw):
    def build():
        from timpm import Body, Box, World
        from timpm.materials import DruckerPrager

        sand = DruckerPrager(E=2e5, nu=0.3, density=1500.0, friction_angle=30.0)
        body = Body(Box((0.0, 0.0), (0.3, 0.6)), sand, ppc=4)
        world = World(domain=(1.2, 0.8), cells=24, bodies=[body], transfer=transfer,
                      basis=basis, walls={"bottom": "friction"}, courant=0.5)
        return world, None, steps, solver_kw
    return build


def _disks(transfer, basis, steps, dim=2, cells=32, **solver_kw):
    def build():
        get_demo = _demos().get_demo

        world = get_demo("disks", transfer=transfer, basis=basis, cells=cells, dim=dim).world()
        return world, None, steps, solver_kw
    return build


def _slope(steps, **solver_kw):
    def build():
        get_demo = _demos().get_demo

        # the slope demo's Mohr-Coulomb soil from its K0 stress, its strength divided by 1.6:
        # it fails, the return mapping at work (at courant 0.5, the demo's default when made)
        world = get_demo("slope", cells_per_H=6, strength_factor=1.6, courant=0.5).world()
        return world, None, steps, solver_kw
    return build


def _dam(transfer, steps, **solver_kw):
    def build():
        get_demo = _demos().get_demo

        world = get_demo("dam-break", transfer=transfer, cells_per_a=10).world()
        return world, None, steps, solver_kw
    return build


def _two_materials(steps, **solver_kw):
    def build():
        from timpm import Body, Box, World
        from timpm.materials import LinearElastic, WeaklyCompressibleFluid

        solid = LinearElastic(E=1e4, nu=0.3, density=1000.0)
        water = WeaklyCompressibleFluid(bulk_modulus=2e4, density=1000.0, viscosity=1e-3)
        world = World(domain=(1.0, 0.5), cells=20, basis="uniform-bspline3", transfer="apic",
                      bodies=[Body(Box((0.05, 0.0), (0.35, 0.2)), solid, ppc=2,
                                   velocity=(0.5, 0.0)),
                              Body(Box((0.5, 0.0), (0.9, 0.25)), water, ppc=2)],
                      walls={"default": "slip", "bottom": "sticky"}, courant=0.5)
        return world, None, steps, solver_kw
    return build


def _box3d(transfer, steps, **solver_kw):
    def build():
        from timpm import Body, Box, Wall, World
        from timpm.materials import NeoHookean

        rubber = NeoHookean(E=1e4, nu=0.3, density=1000.0)
        world = World(domain=(0.5, 0.5, 0.5), cells=10, transfer=transfer,
                      bodies=[Body(Box((0.1, 0.1, 0.1), (0.3, 0.25, 0.3)), rubber, ppc=2,
                                   velocity=(0.3, 0.0, -0.2))],
                      walls={"default": "slip", "bottom": Wall("friction", 0.3)}, courant=0.5)
        return world, None, steps, solver_kw
    return build


def _mpm88(steps, **solver_kw):
    def build():
        mpm88_world = _demos("mpm88").mpm88_world

        # mpm88's initial state: a square [0.2, 0.6]^2 of random particles
        x0 = np.random.default_rng(0).random((2048, 2)) * 0.4 + 0.2
        world, _ = mpm88_world(x0)
        return world, None, steps, solver_kw
    return build


def _square_2d(steps, solver_kw, integrator=None, courant=None, gravity=None, **scene_kw):
    """The manufactured 2D square (G = 1e-3, 8 x 8 cells) with scene options; with an
    ``integrator``, its model without the body force at dt = courant h / c (and, given,
    ``gravity``: tests/test_midpoint.py's scenes)."""
    def build():
        import dataclasses

        from timpm.problems import get_problem

        problem = get_problem("mms-2d", G=1e-3)
        scene = problem.scene(elements=8, **scene_kw)
        if integrator is None:
            return scene, None, steps, dict(solver_kw)
        model = scene.model
        changes = dict(body_force=None, integrator=integrator,
                       dt=courant * model.h / problem.material_law.wave_speed)
        if gravity is not None:
            changes["gravity"] = gravity
        return (dataclasses.replace(model, **changes), None, steps,
                dict(solver_kw, energy_guard=None))
    return build


def _affine_midpoint(transfer, steps, **solver_kw):
    """The affine transfers' midpoint iteration on the square, under gravity between
    roller walls."""
    return _square_2d(steps, solver_kw, "midpoint", 0.9, (0.0, -200.0),
                      basis="uniform-bspline2", transfer=transfer, mass="lumped",
                      projection="standard")


S = {"mode": "serial"}
P = {"mode": "parallel"}

CASES = {
    # 1D: the study's problems, every basis, mass, projection, mode and scatter
    "string-linear-serial": _problem("vibrating-string", 1000, dict(S, track=[0, 7])),
    "string-linear-atomic": _problem("vibrating-string", 300, dict(P, scatter="atomic")),
    "string-linear-serialscatter": _problem("vibrating-string", 300, dict(P, scatter="serial")),
    "string-linear-private": _problem("vibrating-string", 300, dict(P, scatter="private"),
                                      elements=512),
    "string-bspline2-serial": _problem("vibrating-string", 500, S, basis="bspline2",
                                       elements=16),
    "string-bspline3-consistent-gauss": _problem(
        "vibrating-string", 500, dict(S, track=[3]), basis="bspline3", mass="consistent",
        placement="gauss", elements=16),
    "string-bspline3-consistent-atomic": _problem(
        "vibrating-string", 300, dict(P, scatter="atomic"), basis="bspline3",
        mass="consistent", elements=16),
    "string-lagrange2-serial": _problem("vibrating-string", 500, S, basis="lagrange2",
                                        mass="consistent", elements=16, ppc=3),
    "string-uniform3-serial": _problem("vibrating-string", 500, S, basis="uniform-bspline3",
                                       elements=16),
    "string-bspline4-serial": _problem("vibrating-string", 300, S, basis="bspline4",
                                       elements=16, ppc=5),
    "string-mls-serial": _problem("vibrating-string", 500, S, projection="mls", elements=16),
    "string-mls-atomic": _problem("vibrating-string", 300, dict(P, scatter="atomic"),
                                  projection="mls", elements=16),
    "string-griddisp": _problem("vibrating-string", 300, dict(S, grid_displacement=True),
                                basis="bspline2", elements=8),
    "soil-linear-80-serial": _problem("soil-column", 1000, dict(S, track=[50]), elements=80,
                                      ppc=2, dt=1e-3),
    "soil-bspline2-private": _problem("soil-column", 300, dict(P, scatter="private"),
                                      basis="bspline2", elements=400, ppc=2, dt=1e-4),
    "bar-bspline2-serial": _problem("vibrating-bar", 1000, dict(S, track=[0]),
                                    basis="bspline2"),
    "bar-linear-atomic": _problem("vibrating-bar", 300, dict(P, scatter="atomic")),
    # FLIP as recorded (the oedometer's default blends in 1% PIC since 2026-11-24)
    "oedometer-serial": _problem("oedometer", 1000, S, pic_fraction=0.0),
    "oedometer-consistent-atomic": _problem("oedometer", 300, dict(P, scatter="atomic"),
                                            basis="bspline2", mass="consistent"),
    "large-column-serial": _problem("large-column", 300, S),
    # 2D / 3D worlds: materials, transfers, walls, scatters, modes
    "sand-mlsmpm-private": _sand("mls-mpm", 60, **P, scatter="private"),
    "sand-mlsmpm-serial": _sand("mls-mpm", 60, **S),
    "sand-musl-atomic": _sand("musl", 60, **P, scatter="atomic"),
    "sand-musl-private": _sand("musl", 60, **P, scatter="private"),
    "sand-apic-cubic-serialscatter": _sand("apic", 40, basis="uniform-bspline3", **P,
                                           scatter="serial"),
    "disks-apic-linear-serial": _disks("apic", "linear", 60, **S),
    "disks-apic-linear-atomic": _disks("apic", "linear", 60, **P, scatter="atomic"),
    "disks-apic-quadratic-private": _disks("apic", "uniform-bspline2", 60, **P,
                                           scatter="private"),
    "dam-mlsmpm-serial": _dam("mls-mpm", 80, **S),
    "dam-apic-private": _dam("apic", 80, **P, scatter="private"),
    "two-materials-serial": _two_materials(60, **S, track=[0, 5]),
    "two-materials-atomic": _two_materials(60, **P, scatter="atomic"),
    "box3d-apic-serial": _box3d("apic", 30, **S),
    "box3d-musl-atomic": _box3d("musl", 20, **P, scatter="atomic"),
    "box3d-mlsmpm-private": _box3d("mls-mpm", 20, **P, scatter="private"),
    "mpm88-serial": _mpm88(100, **S, energies=False),
    "mpm88-private": _mpm88(100, **P, scatter="private", energies=False),
    "slope-mc-serial": _slope(300, **S),
    "slope-mc-private": _slope(300, **P, scatter="private"),
    # added 2026-11-28 (recorded from the engine of that day, which gave these final states
    # bit for bit with the commit before it): the integrators, the PIC blend, 2D MLS
    # stress and the 2D consistent mass, which the cases above do not reach
    "string-rk4-serial": _problem("vibrating-string", 300, S, basis="bspline2", elements=16,
                                  integrator="rk4", stress_update="study-exact"),
    "string-midpoint-serial": _problem("vibrating-string", 300, S, basis="bspline2",
                                       elements=16, integrator="midpoint",
                                       stress_update="study-exact"),
    "oedometer-pic-serial": _problem("oedometer", 300, S, elements=8),
    "oedometer-pic-atomic": _problem("oedometer", 300, dict(P, scatter="atomic"), elements=8),
    "square-apic-midpoint": _affine_midpoint("apic", 30, **S),
    "square-mlsmpm-midpoint": _affine_midpoint("mls-mpm", 30, **S),
    "square-mls-serial": _square_2d(30, S, basis="bspline2", mass="lumped", projection="mls"),
    "square-consistent-serial": _square_2d(30, S, basis="bspline2", mass="consistent"),
    "square-consistent-rk4": _square_2d(20, S, "rk4", 0.04, basis="bspline2",
                                        mass="consistent"),
    "square-consistent-midpoint": _square_2d(20, S, "midpoint", 0.04, basis="bspline2",
                                             mass="consistent"),
    # added 2026-11-28 (recorded from 5d3bc46, before rk4.py took its state as arguments):
    # the Runge-Kutta step with a body force (its stage values, the external work), the
    # consistent mass and the MLS projection, fused and as the parallel mode's launches
    "mms1d-rk4-serial": _problem("mms-1d", 40, S, basis="bspline3", elements=16),
    "mms1d-rk4-parallel": _problem("mms-1d", 40, P, basis="bspline3", elements=16),
}


def run_case(name):
    """Arrays of one case, keyed ``name/quantity``."""
    from timpm import Solver

    scene, problem, steps, kw = CASES[name]()
    solver = Solver(scene, **kw)
    try:
        solver.run(n_steps=steps)
        out = {"positions": solver.positions(), "velocities": solver.velocities(),
               "stresses": solver.stresses(), "volumes": solver.volumes(),
               "step": np.array(solver.step), "t": np.array(solver.t)}
        if solver.record_energies:
            for key, value in solver.energies().items():
                out[f"energy_{key}"] = value
        if solver.n_tracked:
            for key, value in solver.tracked().items():
                out[f"tracked_{key}"] = value
        if solver.track_crossings:
            out["crossings"] = np.array(solver.grid_crossings())
        if problem is not None:
            x0 = np.asarray(scene.positions)
            exact = problem.displacement(x0, solver.t) if _has_exact(problem) else None
            if exact is not None:
                err = solver.displacements() - exact
                out["rms_error"] = np.array(np.sqrt(np.mean(err ** 2)))
        if getattr(solver, "grid_displacement", False):
            x = np.linspace(0.0, 1.0, 17)
            out["displacement_field"] = solver.displacement_field(x)
    finally:
        solver.release()
    return {f"{name}/{k}": np.asarray(v) for k, v in out.items()}


def _has_exact(problem):
    try:
        problem.displacement(np.zeros(1), 0.0)
        return True
    except NotImplementedError:
        return False


def compute(names, precision, strict):
    import timpm

    # strict: Taichi without fast math, no reassociation, so a value that is a
    # compile-time constant in one engine and a run-time value in the other rounds the same
    timpm.init(threads=1, precision=precision, fast_math=not strict)
    out = {}
    for name in names:
        if precision == "f32" and not name.startswith(("mpm88", "sand", "disks", "dam")):
            continue
        out.update(run_case(name))
    return out


def _relative_difference(a, b):
    """max |a - b| as a fraction of b's largest magnitude."""
    diff = float(np.nanmax(np.abs(a.astype(np.float64) - b.astype(np.float64))))
    scale = float(np.nanmax(np.abs(b))) if b.size else 0.0
    return diff / scale if scale > 0 else float("inf")


def _update(path, ref, got, keys, rtol=None):
    """Replace the arrays named ``keys`` of the computed cases, and only where every other
    array of the golden file is still bit for bit (an intended change of one output), or,
    with ``rtol``, within that fraction of its largest value (an intended change of the
    method that moves the other outputs by rounding-sized amounts; each one is listed)."""
    if not keys:
        print("update needs --keys: the arrays the change replaces")
        return 2
    changed, moved, other = [], [], []
    for key, value in got.items():
        if key not in ref.files or not np.array_equal(value, ref[key], equal_nan=True):
            if key.split("/", 1)[1] in keys:
                changed.append(key)
            elif (rtol is not None and value.shape == ref[key].shape
                  and _relative_difference(value, ref[key]) <= rtol):
                moved.append(key)
            else:
                other.append(key)
    if other:
        for key in other:
            print("DIFF (not updated)", key)
        print(f"{len(other)} arrays outside --keys differ"
              f"{'' if rtol is None else f' by more than {rtol:g}'}: nothing written")
        return 1
    arrays = {k: ref[k] for k in ref.files}
    arrays.update({k: got[k] for k in changed + moved})
    np.savez_compressed(path, **arrays)
    for key in changed:
        print("updated", key)
    for key in moved:
        print(f"updated {key} (moved by {_relative_difference(got[key], ref[key]):.2e} "
              "of its largest value)")
    print(f"{len(changed) + len(moved)} arrays updated in {path}; every other array bit for bit")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("action", choices=("record", "check", "update"))
    ap.add_argument("--precision", default="f64", choices=("f64", "f32"))
    ap.add_argument("--only", nargs="*", default=None, help="case names (default: all)")
    ap.add_argument("--keys", nargs="*", default=(),
                    help="update: the arrays (e.g. energy_strain) an intended change of the "
                         "method replaces; every other array must still be bit for bit")
    ap.add_argument("--fast-math", action="store_true",
                    help="Taichi's default fast math (golden_<prec>_fast.npz): compile-time "
                         "constants folded by reassociation, so values moved to run time "
                         "round differently in the last bits")
    ap.add_argument("--rtol", type=float, default=None,
                    help="check: accept differences up to this fraction of each array's largest "
                         "magnitude (default: none, bit for bit); update: replace the arrays "
                         "outside --keys that moved by no more than this")
    args = ap.parse_args(argv)
    os.environ["TIMPM_THREADS"] = "1"
    path = HERE / f"golden_{args.precision}{'_fast' if args.fast_math else ''}.npz"
    names = args.only or list(CASES)
    got = compute(names, args.precision, strict=not args.fast_math)
    if args.action == "record":
        kept = {}
        if args.only and path.exists():  # new cases added to the file, the others kept
            with np.load(path) as old:
                kept = {k: old[k] for k in old.files if k.split("/")[0] not in names}
        np.savez_compressed(path, **kept, **got)
        print(f"recorded {len(got)} arrays of {len(names)} cases in {path}"
              + (f" (beside {len(kept)} arrays kept)" if kept else ""))
        return 0
    ref = np.load(path)
    if args.action == "update":
        return _update(path, ref, got, set(args.keys), args.rtol)
    bad, worst = [], {}
    cases = {k.split("/")[0] for k in got}
    expected = {k for k in ref.files if k.split("/")[0] in cases}
    for key in sorted(expected | set(got)):
        if key not in got or key not in ref.files:
            bad.append(f"{key}: {'missing now' if key not in got else 'not in the golden file'}")
            continue
        a, b = got[key], ref[key]
        if a.shape != b.shape or a.dtype != b.dtype:
            bad.append(f"{key}: shape/dtype {a.shape} {a.dtype} != golden {b.shape} {b.dtype}")
        elif not np.array_equal(a, b, equal_nan=True):
            diff = np.abs(a.astype(np.float64) - b.astype(np.float64))
            rel = _relative_difference(a, b)
            worst[key] = rel
            if args.rtol is None or not rel <= args.rtol:
                bad.append(f"{key}: differs, max |diff| {np.nanmax(diff):.3e} "
                           f"({rel:.2e} of the array's largest value)")
    for line in bad:
        print("DIFF", line)
    if worst:
        key = max(worst, key=worst.get)
        print(f"{len(worst)} arrays not bit for bit; the largest difference: {worst[key]:.2e} "
              f"of the largest value, in {key}")
    print(f"{len(cases)} cases, {len(expected)} arrays: {len(bad)} differ")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
