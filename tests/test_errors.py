"""Bad input gets a clear error that names the parameter; bad states stop the run."""
import numpy as np
import pytest

import timpm
from timpm.problems import get_problem
from timpm.studies.study import run_problem


@pytest.mark.parametrize("E,rho,match", [(0.0, 1.0, "Young's modulus E"), (-5.0, 1.0, "Young's modulus E"),
                                         (1.0, 0.0, "density"), (1.0, -2.0, "density"),
                                         (float("nan"), 1.0, "Young's modulus E")])
def test_material_constants_must_be_positive(E, rho, match):
    with pytest.raises(ValueError, match=match):
        timpm.Material(E, rho)


def test_problem_parameters_are_checked():
    with pytest.raises(ValueError, match="parameter E must be positive"):
        run_problem("vibrating-string", params={"E": -100.0})
    with pytest.raises(ValueError, match="parameter density must be positive"):
        run_problem("soil-column", params={"density": 0.0})
    with pytest.raises(ValueError, match="parameter L must be positive"):
        run_problem("vibrating-bar", params={"L": 0.0, "E": 100.0})


@pytest.mark.parametrize("kw,match", [
    (dict(elements=0), "number of elements must be a positive integer"),
    (dict(elements=-4), "number of elements must be a positive integer"),
    (dict(elements=2.5), "number of elements must be a positive integer"),
    (dict(ppc=0), "particles per element must be a positive integer"),
    (dict(dt=0.0), "time step dt must be a positive"),
    (dict(dt=-1e-3), "time step dt must be a positive"),
    (dict(dt=1.0), r"exceeds the critical time step .*Eq\. 2\.4"),
    (dict(basis="quintic"), "unknown basis 'quintic'"),
    (dict(mass="diagonal"), "unknown mass 'diagonal'"),
    (dict(placement="random"), "unknown placement 'random'"),
    (dict(stress_update="hyper"), "unknown stress_update 'hyper'"),
])
def test_bad_numerical_settings(kw, match):
    with pytest.raises(ValueError, match=match):
        get_problem("vibrating-string").scene(**kw)


def test_unknown_problem():
    with pytest.raises(ValueError, match="unknown problem 'wobbly-string'.*vibrating-string"):
        run_problem("wobbly-string")


def test_critical_step_can_be_overridden_explicitly():
    scene = get_problem("vibrating-string").scene(elements=8, dt=0.5, allow_unstable_dt=True)
    assert scene.dt > scene.critical_dt


def test_consistent_mass_critical_step_shrinks_with_few_particles():
    # the particle quadrature leaves the consistent mass nearly singular for the
    # checkerboard mode: one particle per element needs a far smaller step
    steps = [get_problem("vibrating-string").scene(elements=8, ppc=ppc, mass="consistent",
                                                    dt=1e-6).critical_dt for ppc in (1, 2, 4)]
    assert steps[0] < steps[1] < steps[2] and steps[0] < 0.5 * steps[2]
    with pytest.raises(ValueError, match="exceeds the critical time step .*particle discretisation"):
        get_problem("vibrating-string").scene(elements=8, ppc=1, mass="consistent", dt=0.1)


def test_singular_mass_is_refused():
    # two particles on one spot: the mass matrix of their element has rank one
    x = np.array([0.5, 0.5, 1.5, 1.5])
    with pytest.raises(ValueError, match="consistent mass matrix .* singular or indefinite"):
        timpm.Scene(grid=timpm.Grid1D(2, 1.0), material=timpm.Material(1.0, 1.0), positions=x,
                    volume=np.full(4, 0.5), dt=1e-3, mass="consistent")


def test_too_few_particles_for_the_quadrature():
    with pytest.raises(ValueError, match="bspline3 basis needs at least 2 particles per element"):
        get_problem("vibrating-string").scene(elements=8, ppc=1, basis="bspline3")


def test_mesh_too_coarse_for_the_basis():
    with pytest.raises(ValueError, match="bspline3 basis needs at least 3 elements"):
        get_problem("vibrating-string").scene(elements=2, basis="bspline3")


def _scene(**kw):
    x, vol = timpm.equidistant_particles(4, 2, 1.0, start=1.0)
    args = dict(grid=timpm.Grid1D(6, 1.0), material=timpm.Material(1.0, 1.0), positions=x,
                volume=vol, dt=0.1)
    args.update(kw)
    return timpm.Scene(**args)


def test_scene_input_checks():
    with pytest.raises(ValueError, match=r"particle 7 at x = 6.5 lies outside the grid \[0.0, 6.0\]"):
        _scene(positions=np.r_[np.linspace(1.1, 4.9, 7), 6.5])
    with pytest.raises(ValueError, match="particle 2 has a non-finite position"):
        _scene(positions=[1.0, 2.0, np.nan, 3.0, 3.5, 4.0, 4.5, 5.0])
    with pytest.raises(ValueError, match="particle 1 has a non-finite initial velocity"):
        _scene(velocity=[0.0, np.inf, 0, 0, 0, 0, 0, 0])
    with pytest.raises(ValueError, match="particle volume must be positive, particle 0"):
        _scene(volume=[0.0] + [0.5] * 7)
    with pytest.raises(ValueError, match="fixed node 9 does not exist"):
        _scene(fixed_nodes=(0, 9))
    with pytest.raises(ValueError, match="damping factor alpha"):
        _scene(damping=1.5)
    with pytest.raises(ValueError, match="traction particle 20 does not exist"):
        _scene(traction=timpm.Traction(20, 1.0))
    with pytest.raises(ValueError, match="number of elements must be a positive integer"):
        timpm.Grid1D(0, 1.0)
    with pytest.raises(ValueError, match="element size h must be a positive"):
        timpm.Grid1D(4, -1.0)


def test_particle_leaving_the_grid_stops_the_run_and_names_it():
    # the bar flies to the right; its first particle to cross x = 6 is the last one
    scene = _scene(velocity=np.full(8, 2.0), dt=0.05)
    for mode in ("serial", "parallel"):
        solver = timpm.Solver(scene, mode=mode)
        with pytest.raises(timpm.SimulationError, match=r"step (\d+) .*particle 7 left the grid") as info:
            solver.run(n_steps=1000)
        # x = 4 + 2/3 + 0.1 n passes 6 in step n = 14 (t = 0.7 s)
        assert info.value.step == 14 and info.value.particle == 7
        assert solver.step == 14  # stopped there, nothing beyond
        assert np.all(np.isfinite(solver.positions()))
        m_nodes, _ = solver.project()  # the grid holds the mass of the particles inside
        inside = solver.positions() <= 6.0
        assert m_nodes.sum() == pytest.approx(scene.mass_per_particle[inside].sum())
        solver.release()


def test_nan_in_the_state_stops_the_run():
    scene = _scene(fixed_nodes=(0,))
    solver = timpm.Solver(scene, mode="serial")
    solver.run(n_steps=3)
    sigma = solver.read("sigma")
    sigma[2] = float("nan")
    with pytest.raises(ValueError, match=r"write\('sigma'\): \d+ of the \d+ values are not "
                       r"finite"):
        solver.write("sigma", sigma)  # refused: the public write takes finite numbers
    solver.state.write(solver.program(), "sigma", sigma)  # the NaN put in past the check
    with pytest.raises(timpm.SimulationError, match=r"step 4 .*particle \d+ has a non-finite"):
        solver.run(n_steps=10)
    solver.release()


def test_tracked_particle_must_exist():
    with pytest.raises(ValueError, match="tracked particle 99 does not exist"):
        timpm.Solver(_scene(), track=[99])


def test_lagrange_like_basis_cannot_be_lumped():
    class NegativeBasis(timpm.Linear):
        name = "negative-test"
        lumpable = False

    with pytest.raises(ValueError, match="cannot be lumped.*consistent"):
        _scene(basis=NegativeBasis)


RESTART_SCRIPT = """
import pytest, timpm
from timpm.simulation.batch import Batch
from timpm.problems import get_problem
from timpm.simulation.solver import Solver
from timpm.studies.study import convergence, run_problem
timpm.init(threads=2)
scene = get_problem("vibrating-string").scene(elements=4, ppc=4)
s = Solver(scene, mode="serial", energies=False)
s.run(n_steps=10)
kept = run_problem("vibrating-string", elements=4, t_end=0.01).record
timpm.init(threads=1)  # other settings: Taichi restarts, the fields above are gone
ACCESSORS = (lambda: s.run(n_steps=1), s.reset, s.positions, s.velocities, s.displacements,
             s.stresses, s.strains, s.volumes, s.densities, s.grid_crossings, s.tracked,
             s.negative_pivots, s.memory, s.project, lambda: s.step, lambda: s.t,
             lambda: s.read("x"), lambda: Batch([s]))
for use in ACCESSORS:
    with pytest.raises((RuntimeError, ValueError), match="Taichi was restarted"):
        use()
s.release()  # nothing left to free: no crash
again = run_problem("vibrating-string", elements=4, t_end=0.01).record  # a new solver
assert again["rms_error"] == kept["rms_error"] and again["compile_seconds"] > 0
print("OK")
"""


def test_every_accessor_of_a_released_solver_raises():
    """After release() every accessor raises the same clear error (they used to abort the
    process), for a 1D solver and an affine 2D one."""
    from timpm import Body, Box, NeoHookean, World
    from timpm.platform.errors import Released

    world = World(domain=(0.4, 0.4), cells=8, gravity=(0.0, 0.0),
                  bodies=[Body(Box((0.1, 0.1), (0.2, 0.2)), NeoHookean(1e3, 0.3, 1e3))])
    for scene in (_scene(fixed_nodes=(0,)), world):
        s = timpm.Solver(scene, mode="serial")
        s.run(n_steps=2)
        s.release()
        s.release()  # twice: nothing left to free
        uses = [lambda: s.run(n_steps=1), s.reset, s.positions, s.velocities, s.stresses,
                s.volumes, s.densities, s.energies, s.tracked, s.memory, s.project,
                lambda: s.step, lambda: s.t, lambda: s.read("x"), lambda: s.write("x", 0)]
        uses += ([s.displacements, s.strains, s.grid_crossings, s.negative_pivots]
                 if scene.__class__.__name__ == "Scene" else
                 [s.affine, lambda: s.set_affine(np.zeros((2, 2)))])
        for use in uses:
            with pytest.raises(Released, match="this solver was released"):
                use()


def test_a_taichi_restart_gives_clear_errors_not_a_crash():
    """timpm.init with other settings restarts Taichi and frees every field: a solver built
    before raises a clear error (it used to crash the process: a study's kept solver reset
    after the CLI re-initialised Taichi), and the study drivers build new solvers."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", RESTART_SCRIPT], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip().endswith("OK")


@pytest.mark.parametrize("option, value, message", [
    ("record_every", 2.5, "record_every must be a positive integer, got 2.5"),
    ("record_every", 0, "record_every must be a positive integer, got 0"),
    ("check_every", "16", "check_every must be a positive integer, got '16'"),
    ("history_chunk", True, "history_chunk must be a positive integer, got True"),
    ("track", [1.9], "tracked particle must be an integer index, got 1.9"),
])
def test_solver_options_are_whole_numbers(option, value, message):
    """Counts and indices are refused when they are not whole numbers (they used to be
    truncated silently), before anything is compiled."""
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        timpm.Solver(_scene(), **{option: value})
