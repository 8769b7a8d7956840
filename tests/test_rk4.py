"""The rk4 integrator (Runge-Kutta on the particles' equations): its order in time, its
energy balance under a body force, its parallel stages, and what it refuses."""
import dataclasses

import numpy as np
import pytest

from timpm import Solver
from timpm.cli.main import main
from timpm.model import Wall
from timpm.problems import get_problem
from timpm.studies.study import run_problem


def _final_displacements(integrator, dt, G=0.05, **kw):
    return run_problem("mms-1d", elements=16, basis="bspline3", integrator=integrator,
                       params={"G": G}, dt=dt, t_end=0.005, series=False, energies=False,
                       **kw).displacement


@pytest.mark.parametrize("integrator, lowest, highest", [("rk4", 3.5, 4.5),
                                                         ("euler-cromer", 1.9, 2.1)])
def test_the_time_order_on_one_mesh(integrator, lowest, highest):
    # one mesh, the step halved three times: the change of the final displacements falls
    # by 2^q per halving, q the order in time (measured on 2026-11-25: rk4 3.27 then 3.78,
    # approaching 4 as dt resolves the grid's fast modes; Euler-Cromer 2.00 and 2.00)
    dt = 0.2 * (1.0 / 16) / 100.0  # the problem's 0.2 h / c
    u = [_final_displacements(integrator, dt / k) for k in (1, 2, 4, 8)]
    changes = [np.abs(a - b).max() for a, b in zip(u, u[1:])]
    order = np.log2(changes[1] / changes[2])
    assert lowest < order < highest, (changes, order)


def test_the_energy_balance_holds_under_the_body_force():
    # kinetic + strain - work of the body force (the stages' power m b . x', by the
    # method's own weights) stays put, and closer as the mesh is refined (Euler-Cromer:
    # 2e-2 and 1e-2 of the energy on these meshes)
    drifts = []
    for n in (16, 32):
        r = run_problem("mms-1d", elements=n, basis="bspline3", params={"G": 0.05},
                        series=False, record_every=1)
        assert r.record["integrator"] == "rk4"
        en = r.energies
        assert abs(en["external_work"]).max() > 1e-3 * en["kinetic"].max()  # it works
        drifts.append(r.record["energy_drift"])
    assert drifts[0] < 1e-4 and drifts[1] < drifts[0] / 4, drifts


def test_parallel_stages_compute_what_the_serial_loop_does(strict_arithmetic):
    # the fused serial mode loops over the four stages at run time, the parallel mode
    # unrolls them into top-level passes: the same arithmetic, so the same bits where
    # every operation rounds as written (with fast math the two paths are contracted and
    # vectorised apart: on an AVX-512 CPU the velocities then differ by 3e-11 of their
    # largest value after 40 steps)
    scene = get_problem("mms-1d", G=0.05).scene(elements=16, basis="bspline3")
    runs = {}
    for mode in ("serial", "parallel"):
        solver = Solver(scene, mode=mode, energies=False)
        solver.run(n_steps=40)
        runs[mode] = (solver.positions(), solver.velocities(), solver.read("F"))
        solver.release()
    for a, b in zip(runs["serial"], runs["parallel"]):
        np.testing.assert_array_equal(a, b)


def _mms_model(**changes):
    model = get_problem("mms-1d").scene(elements=8, basis="bspline3").model
    return dataclasses.replace(model, **changes)


@pytest.mark.parametrize("changes, message", [
    (dict(integrator="rk2"), "unknown integrator 'rk2'"),
    (dict(damping=0.1), "local damping"),
    (dict(transfer="apic", transfer_params=None, basis="uniform-bspline3",
          mass_matrix="lumped", projection="standard"), r"the apic transfer \(it takes musl\)"),
    (dict(mass_matrix="lumped", projection="standard", fixed_nodes=(),
          walls=(Wall("slip"), Wall("roller"))), "slip, friction or driven walls"),
])
def test_what_rk4_refuses_names_the_conflict(changes, message):
    with pytest.raises(ValueError, match=message):
        _mms_model(**changes)


def test_rk4_refuses_a_law_whose_stress_is_not_a_function_of_F(capsys):
    # the study's 1D problems update the stress along the path (2.2.4)
    with pytest.raises(ValueError, match="not a function of F"):
        get_problem("vibrating-string").scene(integrator="rk4")
    assert main(["run", "vibrating-string", "--integrator", "rk4"]) == 2
    assert "not a function of F" in capsys.readouterr().err


def test_the_string_with_the_exact_law_keeps_its_energy_under_rk4():
    # the study's 1D law integrated exactly is sigma(F): rk4 takes it; over the string's
    # default run (1000 steps of 1e-4 s) its energy holds to rounding, where
    # Euler-Cromer's drifts by ~1e-5 of the energy in motion, at the same error
    records = {}
    for integrator in ("euler-cromer", "rk4"):
        records[integrator] = run_problem(
            "vibrating-string", elements=16, basis="bspline3", mass="consistent",
            placement="gauss", stress_update="study-exact", integrator=integrator,
            series=False).record
    ec, rk = records["euler-cromer"], records["rk4"]
    assert rk["energy_drift"] < 1e-10 < 1e-6 < ec["energy_drift"], (ec, rk)
    assert rk["rms_error"] == pytest.approx(ec["rms_error"], rel=1e-3)


def test_rk4_refuses_the_team_and_the_grid_displacement():
    scene = get_problem("mms-1d").scene(elements=8, basis="bspline3", mass="lumped",
                                        projection="standard")
    with pytest.raises(ValueError, match="rk4 and midpoint integrators have no team"):
        Solver(scene, mode="team")
    with pytest.raises(ValueError, match="grid_displacement"):
        Solver(scene, grid_displacement=True)


def test_a_free_body_translates_exactly_in_2d():
    # no walls, no gravity: a uniform velocity projects to the same nodal velocity
    # (partition of unity), so x' = v, v' = 0, F' = 0 at every stage: x = X + v t, F = I
    from timpm import Body, Box, World
    from timpm.materials import NeoHookean

    v = np.array([0.5, -0.25])
    world = World(domain=(1.0, 1.0), cells=8, basis="bspline2", transfer="musl",
                  walls=None, gravity=(0.0, 0.0), integrator="rk4",
                  bodies=[Body(Box((0.3, 0.3), (0.6, 0.6)), NeoHookean(1e4, 0.3, 1e3),
                               velocity=tuple(v))])
    solver = Solver(world, mode="serial")
    x0 = solver.positions()
    solver.run(n_steps=40)
    np.testing.assert_allclose(solver.positions(), x0 + v * solver.t, rtol=0, atol=1e-13)
    np.testing.assert_allclose(solver.velocities(), np.tile(v, (len(x0), 1)), atol=1e-13)
    np.testing.assert_allclose(solver.read("F"), np.tile(np.eye(2), (len(x0), 1, 1)),
                               atol=1e-13)
    en = solver.energies()
    assert abs(en["total"][-1] - en["total"][0]) < 1e-12 * en["total"][0]


def test_rk4s_critical_step_is_sqrt2_times_euler_cromers():
    # the stability limit of |w dt| on the imaginary axis: 2 for Euler-Cromer, 2 sqrt(2)
    # for RK4.  At 1.3x Euler-Cromer's critical step Euler-Cromer blows up within steps,
    # rk4 stays bounded and keeps its energy
    from timpm import SimulationError

    problem = get_problem("vibrating-string")
    kw = dict(elements=16, basis="bspline3", mass="consistent", placement="gauss",
              stress_update="study-exact")
    ec_critical = problem.scene(dt=1e-9, **kw).critical_dt
    rk_critical = problem.scene(dt=1e-9, integrator="rk4", **kw).critical_dt
    assert rk_critical == pytest.approx(np.sqrt(2.0) * ec_critical, rel=1e-12)
    dt = 1.3 * ec_critical
    with pytest.raises(ValueError, match="exceeds the critical time step"):
        problem.scene(dt=dt, **kw)
    steps = 400
    rk = Solver(problem.scene(dt=dt, integrator="rk4", **kw), mode="serial")
    rk.run(n_steps=steps)
    energy = rk.energies()["total"]
    assert np.all(np.isfinite(rk.positions()))
    assert energy[-1] <= energy[0] * (1 + 1e-9)  # bounded: no growth
    ec = Solver(problem.scene(dt=dt, allow_unstable_dt=True, **kw), mode="serial",
                energy_guard=None, volume_range=None)
    with pytest.raises(SimulationError):
        ec.run(n_steps=steps)


def test_an_rk4_run_resumed_from_its_checkpoint_ends_where_the_straight_run_ends(tmp_path):
    # the state between steps is (x, v, F, sigma, V, u): the stages' scratch is rebuilt
    # every step and the body force evaluated at the resumed step's stage times
    from timpm.simulation.checkpoint import load_checkpoint
    from timpm.studies.study import resume_problem

    straight, part, resumed = (tmp_path / f"{k}.npz" for k in ("straight", "part", "resumed"))
    common = dict(elements=16, basis="bspline3", params={"G": 0.05}, mode="serial",
                  series=False, energies=False)
    end = run_problem("mms-1d", t_end=0.01, checkpoint=straight, **common).record
    assert end["integrator"] == "rk4"
    run_problem("mms-1d", t_end=0.005, checkpoint=part, **common)
    again = resume_problem(part, 0.01, checkpoint=resumed).record
    a, b = load_checkpoint(straight), load_checkpoint(resumed)
    assert a["step"] == b["step"] == end["steps"]
    for block in a["arrays"]:
        assert np.array_equal(a["arrays"][block], b["arrays"][block]), block
    assert again["rms_error"] == end["rms_error"] and again["integrator"] == "rk4"


def test_rk4_holds_roller_walls_in_2d_where_the_lumped_mass_sets_the_error():
    # mms-2d between roller walls: the walls hold the normal nodal velocity at zero at
    # every stage (a linear constraint, applied to v_i and a_i alike), and with the lumped
    # mass the error is the spatial one: rk4 and Euler-Cromer agree to a few per cent
    # (measured 1.050e-2 / 2.859e-3 against 1.079e-2 / 2.787e-3, cubic, 8 and 16 cells)
    problem = get_problem("mms-2d", G=0.05)
    errors = {}
    for integrator in ("euler-cromer", "rk4"):
        errors[integrator] = [run_problem("mms-2d", elements=n, basis="bspline3",
                                          integrator=integrator, projection="standard",
                                          params={"G": 0.05},
                                          series=False, energies=False).record["rms_error"]
                              for n in (8, 16)]
    for ec, rk in zip(errors["euler-cromer"], errors["rk4"]):
        assert rk == pytest.approx(ec, rel=0.05)
    assert errors["rk4"][1] < errors["rk4"][0] / 3  # converging
    solver = Solver(problem.scene(elements=8, basis="bspline3", integrator="rk4",
                                  projection="standard"),
                    mode="serial", energies=False)
    solver.run(n_steps=20)
    v = solver.read("node_velocity")  # the last stage's nodal velocities, walls applied
    assert v.shape == (*solver.read("gm").shape, 2)  # the live nodes, as the storage's names
    assert np.array_equal(v, solver.read("gp"))  # (the same field by its storage's name)
    assert np.all(v[0, :, 0] == 0.0) and np.all(v[-1, :, 0] == 0.0)
    assert np.all(v[:, 0, 1] == 0.0) and np.all(v[:, -1, 1] == 0.0)
    assert np.abs(v[0, :, 1]).max() > 0.0  # the tangential velocity is free


def test_rk4_takes_each_particles_own_law_in_a_multi_material_scene():
    # two bodies with equal but distinct laws (the multi-material path: a law index per
    # particle) move as the same bodies under one law do
    from timpm import Body, Box, World
    from timpm.materials import NeoHookean

    def world(laws):
        return World(domain=(1.0, 1.0), cells=8, basis="bspline2", transfer="musl",
                     walls=None, gravity=(0.0, -9.81), integrator="rk4",
                     bodies=[Body(Box((0.2, 0.3), (0.45, 0.6)), laws[0], velocity=(0.3, 0.0)),
                             Body(Box((0.55, 0.3), (0.8, 0.6)), laws[1],
                                  velocity=(-0.3, 0.0))])

    one = NeoHookean(1e4, 0.3, 1e3)
    runs = []
    for laws in ((one, one), (one, NeoHookean(1e4, 0.3, 1e3))):
        w = world(laws)
        assert len(w.model.materials) == len(set(map(id, laws)))
        solver = Solver(w, mode="serial")
        solver.run(n_steps=30)
        runs.append((solver.positions(), solver.read("sigma"), solver.read("vol")))
        solver.release()
    for a, b in zip(*runs):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-14)
    assert np.abs(runs[0][1]).max() > 0  # the bodies are stressed: the laws act
