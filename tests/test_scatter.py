"""P2G scatter strategies: atomic, serial and private grid copies give the same run."""
import numpy as np
import pytest

from timpm import Body, Box, World
from timpm.materials import DruckerPrager
from timpm.problems import get_problem
from timpm.simulation.solver import SCATTERS, SimulationError, Solver, auto_mode

STRATEGIES = [s for s in SCATTERS if s != "auto"]


def sand_column(transfer):
    """A small sand column collapsing on a rough floor: plasticity, walls, 1152 particles."""
    sand = DruckerPrager(E=2e5, nu=0.3, density=1500.0, friction_angle=30.0)
    body = Body(Box((0.0, 0.0), (0.3, 0.6)), sand, ppc=4)
    return World(domain=(1.2, 0.8), cells=24, bodies=[body], transfer=transfer,
                 walls={"bottom": "friction"}, courant=0.5)


def run(scene, scatter, steps):
    """scatter: a strategy of the parallel mode, or "fused" (the serial mode)."""
    if scatter == "fused":
        s = Solver(scene, mode="serial", energies=False)
    else:
        s = Solver(scene, mode="parallel", scatter=scatter, energies=False)
    try:
        s.run(n_steps=steps)
        return s.n_copies, s.positions(), s.velocities()
    finally:
        s.release()


@pytest.mark.cpu_only("the private scatter and the team are CPU strategies")
@pytest.mark.parametrize("transfer", ["mls-mpm", "musl"])
def test_scatter_strategies_agree_in_2d(transfer):
    """Same positions and velocities after 60 steps of a collapsing column, whichever way
    P2G scatters (MUSL scatters twice a step: forces, then momentum), and in the fused
    serial mode (what ``mode="auto"`` runs on one thread)."""
    scene = sand_column(transfer)
    assert scene.n_particles > 2 * 512  # both private copies are filled
    ref = run(scene, "atomic", 60)
    vmax = np.abs(ref[2]).max()
    assert vmax > 0.1  # the column is moving
    for scatter in STRATEGIES[1:] + ["fused"]:
        copies, x, v = run(scene, scatter, 60)
        assert copies == (2 if scatter == "private" else 1) or copies > 2
        assert np.abs(x - ref[1]).max() < 1e-13
        assert np.abs(v - ref[2]).max() < 1e-10 * vmax


@pytest.mark.cpu_only("the private scatter and the team are CPU strategies")
def test_scatter_strategies_agree_in_1d():
    """Serial scatters sum a run of particles in one element in registers first (the
    fused serial mode too): the same run to round-off."""
    scene = get_problem("vibrating-string").scene(elements=512, ppc=4)
    ref = run(scene, "atomic", 200)
    fused = Solver(scene, mode="serial", energies=False)
    fused.run(n_steps=200)
    assert fused.run_sums
    runs = [run(scene, scatter, 200) for scatter in STRATEGIES[1:]]
    for _, x, v in runs + [(1, fused.positions(), fused.velocities())]:
        np.testing.assert_allclose(x, ref[1], rtol=0, atol=1e-14)
        np.testing.assert_allclose(v, ref[2], rtol=0, atol=1e-11 * np.abs(ref[2]).max())
    fused.release()


@pytest.mark.cpu_only("the private scatter and the team are CPU strategies")
def test_private_scatter_needs_a_lumped_mass():
    scene = get_problem("vibrating-string").scene(elements=16, mass="consistent")
    with pytest.raises(ValueError, match="private scatter needs a lumped mass"):
        Solver(scene, scatter="private")
    assert Solver(scene, mode="parallel").scatter in ("serial", "atomic")


def test_unknown_scatter():
    scene = get_problem("vibrating-string").scene(elements=16)
    with pytest.raises(ValueError, match="unknown scatter 'gather'"):
        Solver(scene, scatter="gather")



@pytest.mark.cpu_only("the private scatter and the team are CPU strategies")
@pytest.mark.parametrize("transfer, scattered", [("mls-mpm", 1 + 2), ("musl", 1 + 2 + 2)])
def test_memory_counts_the_private_copies(transfer, scattered):
    """The private scatter's grid copies (mass, momentum and, for MUSL, force: one per
    thread, at least two) are reported per node apart from the state; none otherwise."""
    scene = sand_column(transfer)
    for scatter in STRATEGIES:
        s = Solver(scene, mode="parallel", scatter=scatter, energies=False)
        try:
            mem = s.memory()
            expected = s.n_copies * 8 * scattered if scatter == "private" else 0
            assert mem["scatter_node_bytes"] == expected
            assert mem["node_bytes"] == 8 * (1 + 2 + 2)  # m, P and v (affine) or F (MUSL)
        finally:
            s.release()


def test_auto_mode_fuses_small_scenes_and_every_scene_on_one_thread():
    assert auto_mode(4096, 4096, 2) == "serial"
    assert auto_mode(4097, 4096, 2) == "parallel"
    assert auto_mode(10**6, 4096, 1) == "serial"  # one thread: no pool to hand loops to
    assert auto_mode(10**6, 4096, 0) == "parallel"  # off the CPU
    assert auto_mode(16, 4096, 0) == "parallel"  # at any size (serial: one GPU thread)


def _two_threads():
    from taichi.lang import impl

    if impl.current_cfg().cpu_max_num_threads < 2:
        pytest.skip("a team needs two CPU threads")


@pytest.mark.cpu_only("the private scatter and the team are CPU strategies")
@pytest.mark.parametrize("transfer", ["mls-mpm", "apic", "musl", "musl-damped", "1d"])
def test_team_mode_gives_the_parallel_run_bit_for_bit(transfer, exact_rounding):
    """The team's threads run the same per-particle and per-node code on the same blocks
    and grid copies as the parallel mode's private scatter: the same run, bit for bit,
    for the affine transfers and the study's MUSL step (2D with friction walls, with
    local damping, and the 1D string).  Without fast math: with it LLVM may reassociate
    the two kernels' sums differently (round-off apart)."""
    _two_threads()
    if transfer == "1d":
        scene = get_problem("vibrating-string").scene(elements=512, ppc=4)
    elif transfer == "musl-damped":
        sand = DruckerPrager(E=2e5, nu=0.3, density=1500.0, friction_angle=30.0)
        scene = World(domain=(1.2, 0.8), cells=24, transfer="musl", damping=0.1,
                      bodies=[Body(Box((0.0, 0.0), (0.3, 0.6)), sand, ppc=4)], courant=0.5)
    else:
        scene = sand_column(transfer)
    _, x, v = run(scene, "private", 60)
    team = Solver(scene, mode="team", energies=False)
    try:
        assert team.team and team.n_copies == 2
        team.run(n_steps=25)
        team.run(n_steps=35)  # the step count carries over between launches
        assert team.step == 60 and team.t == pytest.approx(60 * scene.dt)
        np.testing.assert_array_equal(team.positions(), x)
        np.testing.assert_array_equal(team.velocities(), v)
    finally:
        team.release()


@pytest.mark.cpu_only("the private scatter and the team are CPU strategies")
def test_auto_mode_picks_a_team_where_the_private_scatter_runs():
    _two_threads()
    for transfer in ("mls-mpm", "apic", "musl"):
        s = Solver(sand_column(transfer), serial_threshold=0, energies=False)
        assert (s.mode, s.team) == ("parallel", True)
        s.release()
    linear = World(domain=(1.2, 0.8), cells=24, basis="linear", transfer="apic",
                   bodies=[Body(Box((0.0, 0.0), (0.3, 0.6)),
                                DruckerPrager(E=2e5, nu=0.3, density=1500.0,
                                              friction_angle=30.0), ppc=4)], courant=0.5)
    s = Solver(linear, serial_threshold=0, energies=False)
    assert (s.mode, s.team) == ("parallel", False)  # APIC's strain remap: no team
    s.release()
    with pytest.raises(ValueError, match="APIC with the linear basis"):
        Solver(linear, mode="team")
    with pytest.raises(ValueError, match="mode='team' needs the private scatter"):
        Solver(sand_column("mls-mpm"), mode="team", scatter="serial")


@pytest.mark.cpu_only("the private scatter and the team are CPU strategies")
def test_team_stops_at_a_nan_naming_step_and_particle():
    """A NaN velocity: the team stops after the step it appeared in (the first barrier of
    the next step), naming that step and a particle next to the one it was put in."""
    _two_threads()
    scene = sand_column("mls-mpm")
    s = Solver(scene, mode="team", energies=False)
    try:
        s.run(n_steps=3)
        k = 700  # in the second thread's block
        x = s.positions()
        v = s.velocities()
        v[k, 0] = np.nan
        s.state.write(s.program(), "v", v)  # past write()'s check, which refuses a NaN
        with pytest.raises(SimulationError, match=r"step 4 \(t = .*\): particle \d+ has a "
                                                  r"non-finite") as err:
            s.run(n_steps=10)
        assert (err.value.code, err.value.step) == (2, 4)
        assert np.abs(x[err.value.particle] - x[k]).max() < 3 * scene.h
        assert s.step == 4  # stopped there, nothing beyond
    finally:
        s.release()



@pytest.mark.cpu_only("compares the CPU program with the GPU's compiled for the CPU")
@pytest.mark.parametrize("transfer", ["mls-mpm", "musl"])
def test_gpu_program_compiled_for_the_cpu_gives_the_same_bits(transfer, strict_arithmetic,
                                                              monkeypatch):
    """A GPU's program differs from the CPU's in its layout (each particle field its own
    array) and its loops (over the capacity, the count checked inside: no serial task for
    the bounds).  Compiled for the CPU it steps the CPU program's run bit for bit (one
    thread: atomic adds in particle order)."""
    import dataclasses

    import timpm.simulation.solver

    scene = sand_column(transfer)
    cpu = run(scene, "atomic", 40)
    plan = timpm.simulation.solver.plan

    def gpu_plan(*args, **kwargs):
        features, layout = plan(*args, **kwargs)
        return dataclasses.replace(features, arch="cuda"), layout

    monkeypatch.setattr(timpm.simulation.solver, "plan", gpu_plan)
    s = Solver(scene, mode="parallel", scatter="atomic", energies=False)
    try:
        assert s.program().f.on_device and s.features.on_device
        s.run(n_steps=40)
        assert np.array_equal(s.positions(), cpu[1])
        assert np.array_equal(s.velocities(), cpu[2])
    finally:
        s.release()
