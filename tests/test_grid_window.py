"""The active window (timpm/engine/window.py): the node loops over the box of nodes the
particles reach change no bit of a run, follow the particles, and are refused where they
do not apply."""
import numpy as np
import pytest

import timpm
from timpm.bases.sample import stencils
from timpm.scenarios.demos import ColumnCollapse, SlopeFailure
from timpm.scenefile import load_scene

from conftest import NO_FILES

CUBE = "examples/cube_drop_3d.toml"


def _cube_in_a_big_box(scale=3):
    """The 3D cube scene file in a box ``scale`` times as long on every side."""
    return load_scene(CUBE, {"domain.size": [float(scale)] * 3,
                             "domain.cells": 16 * scale}).world


def _saturated_block():
    """A coupled saturated Mohr-Coulomb block on a sticky floor draining through it, in a
    box three times its width: it settles under gravity as its water flows out."""
    soil = timpm.MohrCoulomb(E=1e6, nu=0.3, density=2000.0, friction_angle=30.0,
                             cohesion=2e3)
    body = timpm.Body(timpm.Box((0.0, 0.0), (1.0, 1.0)), soil, ppc=2,
                      water=timpm.PoreWater(porosity=0.4, conductivity=1e-3))
    return timpm.World(domain=(3.0, 1.5), cells=24, bodies=[body], transfer="musl",
                       basis="uniform-bspline2", walls={"default": "roller", "top": None},
                       water=timpm.Water("coupled", drained_sides=("bottom",)))


SCENES = {
    # APIC, quadratic B-splines, neo-Hookean, a friction floor (fused serial steps)
    "cube 3D": (_cube_in_a_big_box, 60, "serial"),
    # MUSL, Mohr-Coulomb from a K0 start, a friction floor
    "slope MUSL": (lambda: SlopeFailure(cells_per_H=8, transfer="musl").world(), 40, "serial"),
    # MLS-MPM sand (Drucker-Prager), the private scatter on parallel threads
    "column MLS-MPM parallel": (lambda: ColumnCollapse(cells_per_width=8).world(), 40,
                                "parallel"),
    # the coupled two-phase step, a drained base
    "saturated block coupled": (_saturated_block, 40, "serial"),
}


@pytest.mark.parametrize("name", SCENES)
def test_the_window_changes_no_bit(name, exact_rounding):
    """Every particle's position, velocity and stress after the steps, and the energies,
    the same bits with the node loops over the active window as over the whole grid:
    the window leaves out only nodes no particle's stencil reaches.  (Without fast math:
    with it LLVM may vectorise a loop over the whole grid and one over the window each
    its own way, to round-off.)"""
    make, steps, mode = SCENES[name]
    out = {}
    for grid in ("dense", "window"):
        solver = timpm.Solver(make(), mode=mode, grid=grid)
        assert solver.features.grid_window == (grid == "window")
        solver.run(n_steps=steps)
        out[grid] = [solver.read(k) for k in ("x", "v", "sigma")]
        if mode == "serial":  # (parallel threads add the energies in their own order)
            out[grid].append(solver.energies()["kinetic"])
        if grid == "window":
            (lo, hi) = solver.active_window()
            assert np.prod(np.subtract(hi, lo)) < np.prod(solver.model.nodes)
    for a, b in zip(out["dense"], out["window"]):
        assert a.shape == b.shape and np.array_equal(a, b)


def test_the_window_follows_the_particles():
    """The cube in a box 27 times its own: after a few steps the window holds every
    particle's cell and its neighbours (the quadratic stencil) and under 2% of the grid's
    nodes; auto picks the window there and the dense loops in a box the bodies fill."""
    world = _cube_in_a_big_box()
    solver = timpm.Solver(world)  # grid="auto"
    assert solver.features.grid_window
    for _ in range(3):
        solver.run(n_steps=20)
        x = solver.positions()  # (the window the next step finds from here)
        solver.run(n_steps=1)
        lo, hi = (np.array(b) for b in solver.active_window())
        xi = (x - np.array(world.model.origin)) / world.h
        for k in range(3):  # every particle's stencil nodes, by the engine's stencil
            base, _, _ = stencils(solver.basis, xi[:, k], world.model.elements[k])
            assert base.min() >= lo[k] and base.max() + solver.basis.support <= hi[k]
        assert np.prod(hi - lo) < 0.02 * np.prod(world.model.nodes)
    full = timpm.World(domain=(1.0, 1.0), cells=8, transfer="musl",
                       bodies=[timpm.Body(timpm.Box((0.0, 0.0), (1.0, 1.0)),
                                          timpm.LinearElastic(E=1e6, nu=0.3, density=1e3))])
    assert not timpm.Solver(full).features.grid_window


def test_a_grid_written_from_python_is_cleared_whole(exact_rounding):
    """A grid field written between steps (inspection, tests) is cleared whole before the
    next P2G, where the window alone would clear only its box: after the next step the
    grid's masses are the dense grid's at every node."""
    masses = []
    for grid in ("dense", "window"):
        solver = timpm.Solver(SlopeFailure(cells_per_H=8, transfer="musl").world(),
                              mode="serial", grid=grid)
        solver.run(n_steps=10)
        solver.write("gm", np.ones(solver.model.nodes))
        solver.run(n_steps=1)
        masses.append(solver.read("gm"))
    assert np.count_nonzero(masses[0]) < masses[0].size // 2  # (the box mostly empty)
    assert np.array_equal(masses[0], masses[1])


def test_a_restored_state_runs_on_in_the_window():
    """A snapshot taken mid-run and restored into a new solver runs on to the bits of the
    run that was not stopped (the load clears the grid; the window starts from there)."""
    whole = timpm.Solver(_cube_in_a_big_box(), grid="window").run(n_steps=40)
    first = timpm.Solver(_cube_in_a_big_box(), grid="window").run(n_steps=20)
    again = timpm.Solver(_cube_in_a_big_box(), grid="window")
    again.restore(first.snapshot())
    again.run(n_steps=20)
    assert np.array_equal(whole.read("x"), again.read("x"))


def _world_1d():
    return timpm.World(domain=(1.0,), cells=8, bodies=[timpm.Body(
        timpm.Box((0.0,), (0.5,)), timpm.LinearElastic(E=1e6, nu=0.0, density=1e3))])


def _small(**kw):
    return timpm.World(domain=(2.0, 2.0), cells=8, bodies=[timpm.Body(
        timpm.Box((0.0, 0.0), (0.5, 0.5)), timpm.NeoHookean(E=1e5, nu=0.3, density=1e3))],
        **kw)


@pytest.mark.parametrize("make, options, words", [
    (_world_1d, {}, "1D grid"),
    (lambda: _small(transfer="musl", basis="linear", integrator="rk4",
                    walls={"default": "roller"}), {}, "rk4 integrator"),
    (lambda: _small(transfer="musl", basis="uniform-bspline2"), {"mode": "team"}, "team"),
    (lambda: _small(transfer="musl", basis="linear",
                    walls={"left": "periodic", "right": "periodic"}), {}, "periodic"),
])
def test_the_window_is_refused_where_it_does_not_apply(make, options, words):
    with pytest.raises(ValueError, match=f"grid='window' does not apply to .*{words}"):
        timpm.Solver(make(), grid="window", **options)


def test_an_unknown_grid_is_refused():
    with pytest.raises(ValueError, match="unknown grid 'sparse': choose one of auto, dense, "
                                         "window"):
        timpm.Solver(_small(transfer="musl"), grid="sparse")


@pytest.mark.cpu_only("compared bit for bit; the window is a CPU strategy")
def test_a_scene_file_picks_its_grid(exact_rounding):
    """``[simulation] grid``: the cube scene file in a box three times its size runs in the
    window as on the dense grid, its records bit for bit; a name the schema does not know,
    and the window where the scene cannot take it (a team), are refused naming the key,
    before any work."""
    from timpm.scenefile import run_scene

    big = {"domain.size": [3.0] * 3, "domain.cells": 24, "simulation.t_end": 0.05,
           **NO_FILES}
    series = {}
    for grid in ("dense", "window"):
        scene = load_scene(CUBE, {**big, "simulation.grid": grid})
        assert scene.grid == grid
        series[grid] = run_scene(scene).series
    assert series["dense"].keys() == series["window"].keys() and series["dense"]
    for key in series["dense"]:
        np.testing.assert_array_equal(series["window"][key], series["dense"][key])
    assert load_scene(CUBE, big).grid == "auto"
    with pytest.raises(ValueError, match=r"simulation\.grid.*'sparse'.*auto, dense, window"):
        load_scene(CUBE, {**big, "simulation.grid": "sparse"})
    team = load_scene(CUBE, {**big, "simulation.grid": "window", "simulation.mode": "team"})
    with pytest.raises(ValueError, match=r"simulation\.grid \(overridden\): grid = "
                                         r"'window' does not apply to mode='team'.*give "
                                         r"'dense' or 'auto'"):
        run_scene(team)
