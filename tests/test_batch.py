"""Solver.reset, Batch (runs side by side, one thread each) and the solvers a study keeps."""
import os

import numpy as np
import pytest

from timpm import Body, Box, World
from timpm.platform import runtime
from timpm.simulation.batch import Batch
from timpm.materials import NeoHookean
from timpm.problems import get_problem
from timpm.simulation.solver import SimulationError, Solver
from timpm.studies.study import clear_solvers, convergence, run_problem


def _string(elements, **kw):
    return get_problem("vibrating-string").scene(elements=elements, ppc=4, **kw)


def _state(s):
    out = {"x": s.positions(), "v": s.velocities(), "sigma": s.stresses(), "step": s.step,
           "t": s.t}
    if s.dim == 1:
        out.update(u=s.displacements(), crossings=s.grid_crossings())
    if s.record_energies:
        out.update({f"energy_{k}": v for k, v in s.energies().items()})
    if s.n_tracked:
        out.update({f"tracked_{k}": v for k, v in s.tracked().items()})
    return out


def _assert_same(a, b):
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_reset_repeats_a_1d_run_bit_for_bit():
    """The large-deformation column (A.5) under gravity: particles cross elements."""
    s = Solver(get_problem("large-column").scene(elements=10, ppc=4), track=[3], mode="serial")
    try:
        s.run(n_steps=300)
        first = _state(s)
        assert first["crossings"] > 0
        s.reset()
        assert s.step == 0 and s.t == 0.0 and s.grid_crossings() == 0
        np.testing.assert_array_equal(s.displacements(), 0.0)
        s.run(n_steps=300)
        _assert_same(first, _state(s))
        assert s.compile_seconds == 0.0  # nothing compiled for the second run
    finally:
        s.release()


def test_reset_repeats_a_2d_affine_run_bit_for_bit():
    """F, C, J and the grid start over too (Neo-Hookean block, APIC, sticky floor)."""
    body = Body(Box((0.2, 0.1), (0.5, 0.4)), NeoHookean(E=1e4, nu=0.3, density=1e3),
                velocity=(0.5, -1.0))
    world = World(domain=(1.0, 1.0), cells=16, bodies=[body], transfer="apic",
                  walls="sticky", courant=0.4)
    s = Solver(world, mode="serial", energies=True)
    try:
        s.run(n_steps=80)
        first = _state(s)
        s.reset()
        np.testing.assert_array_equal(s.positions(), world.positions)
        s.run(n_steps=80)
        _assert_same(first, _state(s))
    finally:
        s.release()


@pytest.mark.cpu_only("compared bit for bit")
def test_batch_members_match_their_runs_alone(exact_rounding):
    """Side by side on the threads, each member's run is its run alone, bit for bit: the
    same positions, energies, tracked series and grid crossings."""
    scenes = [_string(e) for e in (4, 8, 16)]
    alone = []
    for sc in scenes:
        s = Solver(sc, track=[1], mode="serial")
        s.run(t_end=0.03)
        alone.append(_state(s))
        s.release()
    members = [Solver(sc, track=[1], mode="serial") for sc in scenes]
    batch = Batch(members)
    try:
        batch.run(t_end=0.03)
        for state, s in zip(alone, members):
            _assert_same(state, _state(s))
        # every member's displacements, step, time and crossings read in one launch
        for state, read in zip(alone, batch.states()):
            _assert_same({k: state[k] for k in ("u", "step", "t")},
                         {k: read[k] for k in ("u", "step", "t")})
            assert read["grid_crossings"] == state["crossings"]
        assert batch.run_seconds > 0 and batch.compile_seconds > 0
        # and again after a reset, now warm: no compile time
        batch.reset()
        assert all(s.step == 0 for s in members)
        compiled = batch.compile_seconds
        batch.run(t_end=0.03)
        assert batch.compile_seconds == compiled
        for state, s in zip(alone, members):
            _assert_same(state, _state(s))
    finally:
        batch.release()
        for s in members:
            s.release()


def test_a_new_batch_of_the_same_programs_takes_the_built_kernel():
    """A study's second batch (new solvers of the same feature sets) reuses the first
    batch's kernel and fields: a new kernel over new fields would compile again, and miss
    Taichi's offline cache.  Its run is the first's, bit for bit."""
    runs = []
    for _ in range(2):
        members = [Solver(_string(e), mode="serial", energies=False) for e in (4, 8)]
        batch = Batch(members)
        batch.run(n_steps=50, progress=False)
        runs.append((batch._members(), [s.displacements() for s in members]))
        batch.release()
        for s in members:
            s.release()
    (first, u_first), (second, u_second) = runs
    assert second is first
    for a, b in zip(u_first, u_second):
        np.testing.assert_array_equal(a, b)
    # other recording intervals are another kernel
    members = [Solver(_string(e), mode="serial", energies=False, record_every=5)
               for e in (4, 8)]
    batch = Batch(members)
    try:
        assert batch._members() is not first
    finally:
        batch.release()
        for s in members:
            s.release()


def test_batch_states_read_every_member_at_once():
    """Batch.states() against each member's own reads, with members whose particles cross
    element boundaries (the large-deformation column, 20 crossings in 300 steps at 8
    elements)."""
    prob = get_problem("large-column")
    members = [Solver(prob.scene(elements=e, ppc=2), mode="serial", energies=False)
               for e in (4, 8)]
    batch = Batch(members)
    try:
        batch.run(n_steps=300, progress=False)
        states = batch.states()
        for s, read in zip(members, states):
            np.testing.assert_array_equal(read["u"], s.displacements())
            assert (read["step"], read["t"]) == (s.step, s.t) == (300, s.t)
            assert read["grid_crossings"] == s.grid_crossings()
        assert states[1]["grid_crossings"] > 0
        # 2D members have no displacement field: no combined read
        body = Body(Box((0.2, 0.2), (0.4, 0.4)), NeoHookean(E=1e4, nu=0.3, density=1e3))
        members.append(Solver(World(domain=(1.0, 1.0), cells=8, bodies=[body]),
                              mode="serial", energies=False))
        other = Batch(members[-1:])
        assert other.states() is None
        other.release()
    finally:
        batch.release()
        for s in members:
            s.release()


def test_batch_names_the_failing_member():
    """A member above its critical time step blows up; the error names the member, and the
    other member ran to the end."""
    good = Solver(_string(4), mode="serial", energies=False)
    sc = _string(8)
    bad = Solver(_string(8, dt=3 * sc.critical_dt, allow_unstable_dt=True), mode="serial",
                 energies=False)
    batch = Batch([good, bad])
    try:
        with pytest.raises(SimulationError, match="batch member 1: step"):
            batch.run(n_steps=4000, progress=False)
        assert good.step == 4000
    finally:
        batch.release()
        good.release()
        bad.release()


def test_batch_refuses_what_it_cannot_run():
    sc = _string(4)
    with pytest.raises(ValueError, match="at least one solver"):
        Batch([])
    par = Solver(sc, mode="parallel", energies=False)
    with pytest.raises(ValueError, match="member 0 runs in parallel mode"):
        Batch([par])
    ser = Solver(sc, mode="serial", energies=False)
    with pytest.raises(ValueError, match="appears twice"):
        Batch([ser, ser])
    with pytest.raises(TypeError, match="member 1 is a str"):
        Batch([ser, "solver"])
    ser.release()
    with pytest.raises(ValueError, match="batch member 0: this solver was released"):
        Batch([ser])
    par.release()


def test_a_solver_books_all_the_compilation_it_causes():
    """compile_seconds counts the state upload, the step and the readers of a new program,
    all that the process compile clock saw while the solver worked."""
    clear_solvers()
    scene = get_problem("vibrating-string").scene(elements=8, basis="bspline2")
    clock = runtime.compile_clock()
    solver = Solver(scene, energies=False)
    try:
        built = solver.compile_seconds
        assert built > 0  # the first upload into the new program compiled it
        solver.run(0.01)
        solver.displacements()
        caused = runtime.compile_clock() - clock
        assert solver.compile_seconds > built
        assert solver.compile_seconds == pytest.approx(caused, rel=1e-9)
    finally:
        solver.release()


@pytest.mark.cpu_only("compared bit for bit")
def test_meshes_after_the_first_compile_nothing_and_a_batch_gives_the_same_table(
        exact_rounding):
    """Solvers of one feature set share one compiled program: a second run of the same
    scene, and a run on another mesh, compile nothing."""
    clear_solvers()
    try:
        first = run_problem("vibrating-string", elements=8, t_end=0.02)
        again = run_problem("vibrating-string", elements=8, t_end=0.02)
        finer = run_problem("vibrating-string", elements=32, t_end=0.02)
        finest = run_problem("vibrating-string", elements=256, t_end=0.02)  # 259 nodes
        assert again.record["compile_seconds"] == 0.0
        assert finer.record["compile_seconds"] == 0.0
        assert finest.record["compile_seconds"] == 0.0
        assert finer.record["rms_error"] < first.record["rms_error"]
        assert again.record["rms_error"] == first.record["rms_error"]
        np.testing.assert_array_equal(again.series["u"], first.series["u"])
        seq = convergence("vibrating-string", elements=(4, 8), t_end=0.02, energies=False,
                          series=False)
        bat = convergence("vibrating-string", elements=(4, 8), t_end=0.02, energies=False,
                          series=False, batch=True)
        assert [r["rms_error"] for r in bat["runs"]] == [r["rms_error"] for r in seq["runs"]]
        for key in ("grid_crossings", "steps", "t_end"):
            assert [r[key] for r in bat["runs"]] == [r[key] for r in seq["runs"]], key
        # the scenes are built once per set of arguments; a result's x0 is its own
        first.x0[:] = -1.0
        third = run_problem("vibrating-string", elements=8, t_end=0.02)
        np.testing.assert_array_equal(third.x0, again.x0)
        assert third.record["rms_error"] == first.record["rms_error"]
        with pytest.raises(ValueError, match="mode must be 'serial'"):
            convergence("vibrating-string", elements=(4, 8), batch=True, mode="parallel")
        with pytest.raises(ValueError, match="a batch writes no outputs of its own: "
                                             "checkpoint apply to single runs"):
            convergence("vibrating-string", elements=(4, 8), batch=True, checkpoint="c.npz")
        with pytest.raises(TypeError, match="unexpected keyword argument 'bases'"):
            convergence("vibrating-string", elements=(4, 8), batch=True, bases="linear")
    finally:
        clear_solvers()


@pytest.mark.cpu_only("CPU worker threads")
def test_workers_are_pinned_one_per_core():
    """With two threads or more on two cores or more, timpm binds Taichi's workers to
    distinct cores (runtime.init's default)."""
    runtime.ensure_init()
    pinned = runtime.pin_workers()
    cores = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else {0}
    from taichi.lang import impl

    threads = impl.current_cfg().cpu_max_num_threads
    if len(cores) < 2 or threads < 2:
        assert pinned == []
    else:
        assert len(pinned) >= 2
        assert len({core for _, core in pinned}) == min(len(pinned), len(cores))
        for tid, core in pinned:
            assert os.sched_getaffinity(tid) == {core}


def test_solvers_take_turns_in_one_program_and_survive_its_growth():
    """Solvers of one feature set share a program: a run split into parts, with other
    solvers of the same feature set run in between (their states swapped in and out) and a
    scene too large for the program's capacity in between (the program grows: a new one),
    ends bit for bit where the run in one go ends."""
    string = get_problem("vibrating-string")
    small, other = string.scene(elements=16), string.scene(elements=32)
    whole = Solver(small, track=[5], mode="serial")
    whole.run(n_steps=600)
    reference = _state(whole)
    whole.release()
    parts = Solver(small, track=[5], mode="serial")
    neighbour = Solver(other, mode="serial")
    parts.run(n_steps=200)
    neighbour.run(n_steps=100)          # parts' state saved to host, neighbour's loaded
    parts.run(n_steps=200)
    big = Solver(string.scene(elements=512, ppc=4), mode="serial")  # 2048 > 1024 particles
    assert big.n_particles > 1024
    big.run(n_steps=10)
    parts.run(n_steps=200)
    try:
        assert parts.step == 600
        _assert_same(reference, _state(parts))
        assert neighbour.step == 100 and big.step == 10
    finally:
        for s in (parts, neighbour, big):
            s.release()
