"""The midpoint integrator (schemes/midpoint.py): kinetic + stored (+ gravity's potential)
energy conserved to its iteration's tolerance whatever the particles' motion through the
grid (the affine transfers: never gained), second order in time, and what it refuses."""
import dataclasses

import numpy as np
import pytest

from timpm import SimulationError, Solver
from timpm.platform.errors import ErrorCode
from timpm.problems import get_problem


def _string(integrator, factor, basis="linear", mass="lumped", allow_unstable_dt=False):
    problem = get_problem("vibrating-string")
    kw = dict(elements=16, ppc=4, basis=basis, mass=mass, stress_update="study-exact",
              integrator=integrator)
    critical = problem.scene(dt=1e-9, **kw).critical_dt
    return problem.scene(dt=factor * critical, allow_unstable_dt=allow_unstable_dt, **kw)


def _energy_change(scene, steps):
    """Largest |E(t) - E(0)| over the records, relative to E(0), E the total energy."""
    solver = Solver(scene, mode="serial", energy_guard=None, record_every=10,
                    volume_range=None)
    solver.run(n_steps=steps)
    total = solver.energies()["total"]
    solver.release()
    return float(np.max(np.abs(total - total[0])) / total[0])


@pytest.mark.parametrize("basis, mass", [("linear", "lumped"), ("bspline2", "consistent")])
def test_the_string_keeps_its_energy_where_euler_cromer_does_not(basis, mass):
    # 3,000 steps at 0.9 of the critical step: the particles cross elements.  Largest
    # |E - E0| / E0 on 2026-11-25: Euler-Cromer 0.10 and 0.19 (its energy also swings
    # within each period), midpoint 1.1e-11 and 1.6e-12
    midpoint = _energy_change(_string("midpoint", 0.9, basis, mass), 3000)
    euler_cromer = _energy_change(_string("euler-cromer", 0.9, basis, mass), 3000)
    assert midpoint < 1e-9, midpoint
    assert euler_cromer > 1e3 * midpoint, (euler_cromer, midpoint)


def test_the_time_order_on_one_mesh():
    # one mesh, the step halved three times: the change of the final displacements falls
    # by 2^q per halving, q = 2 for the midpoint rule in v and F (a smooth basis: the
    # linear one's grid crossings make the displacements a rough function of dt).  The
    # weights stay at the step's start, as Euler-Cromer's do: an O(dt) term of both
    # shows as dt shrinks further (2026-11-25, 0.05 of the critical step: midpoint 1.84
    # and 1.73, Euler-Cromer 1.83 and 1.71; here both 1.91-1.95)
    runs = []
    scene = _string("midpoint", 0.2, basis="bspline3")
    for k in (1, 2, 4, 8):
        model = dataclasses.replace(scene.model, dt=scene.model.dt / k)
        solver = Solver(model, mode="serial", energies=False)
        solver.run(n_steps=100 * k)
        runs.append(solver.displacements())
        solver.release()
    changes = [np.abs(a - b).max() for a, b in zip(runs, runs[1:])]
    orders = np.log2(np.divide(changes[:-1], changes[1:]))
    assert np.all((1.85 < orders) & (orders < 2.1)), (changes, orders)


def test_a_2d_square_under_gravity_between_roller_walls_keeps_its_energy():
    # the mms-2d square without its body force, released under gravity onto the bottom
    # roller wall: kinetic + stored + gravity's potential energy stays put
    problem = get_problem("mms-2d", G=1e-3)
    scene = problem.scene(elements=8, basis="bspline2", mass="lumped",
                          projection="standard", integrator="euler-cromer")
    model = dataclasses.replace(scene.model, body_force=None, integrator="midpoint",
                                gravity=(0.0, -200.0),
                                dt=0.9 * scene.model.h / problem.material_law.wave_speed)
    solver = Solver(model, energy_guard=None, record_every=5)
    solver.run(n_steps=300)
    en = solver.energies()
    assert np.ptp(en["gravity"]) > 1e-2 * en["kinetic"].max()  # gravity does work
    total = en["total"]
    assert np.max(np.abs(total - total[0])) < 1e-9 * np.max(en["kinetic"] + en["strain"])


def test_a_step_above_the_critical_one_stops_the_run_naming_the_step():
    # relaxed by 1 / (1 + mu^2), the iteration contracts for any mu = |w dt| / 2 the
    # relaxation was set for: from the scene's critical step, or mu = 1 for a bare Model.
    # A bare Model at 4x that step diverges once the fastest modes are present (step 1 on
    # 2026-11-25; at 2.5x the string's smooth motion still converged)
    model = _string("midpoint", 4.0, allow_unstable_dt=True).model
    solver = Solver(model, energy_guard=None)
    with pytest.raises(SimulationError, match="midpoint integrator's iteration did not "
                                              "converge") as err:
        solver.run(n_steps=20)
    assert err.value.code == ErrorCode.MIDPOINT and 1 <= err.value.step <= 3


def test_an_iterate_that_inverts_stops_the_step_naming_the_particle():
    # the string thrown at 3,000 times its speed: the first pass's F_end = (I + dt grad
    # vbar) F_n inverts; the iteration stops there (not after 400 passes) and names a
    # particle, where sigma(F) would have been NaN and reported as mere non-convergence
    model = _string("midpoint", 0.5).model
    model = dataclasses.replace(model, velocity=model.velocity * 3e3)
    solver = Solver(model, energy_guard=None)
    with pytest.raises(SimulationError, match=r"the iterate of particle \d+'s F inverted") as err:
        solver.run(n_steps=10)
    assert err.value.code == ErrorCode.MIDPOINT and err.value.step == 1
    assert 0 <= err.value.particle < model.n_particles


@pytest.mark.parametrize("changes, message", [
    (dict(transfer_params={"pic_fraction": 0.5}), "does not take a PIC fraction"),
    (dict(damping=0.1), "does not take local damping"),
])
def test_what_the_midpoint_integrator_refuses_names_the_conflict(changes, message):
    model = _string("midpoint", 0.5).model
    with pytest.raises(ValueError, match=r"integrator 'midpoint' .* " + message):
        dataclasses.replace(model, **changes)


def test_the_midpoint_integrator_refuses_a_current_frame_force_and_the_parallel_mode():
    scene = get_problem("mms-1d", G=0.05).scene(elements=8, basis="bspline3")
    force = dataclasses.replace(scene.model.body_force, frame="current")
    with pytest.raises(ValueError, match="integrator 'midpoint' .* a body force in the "
                                         "current frame"):
        dataclasses.replace(scene.model, integrator="midpoint", body_force=force)
    with pytest.raises(ValueError, match="midpoint integrator iterates each step on one "
                                         "thread"):
        Solver(_string("midpoint", 0.5), mode="parallel")


def test_a_body_force_at_mid_step_balances_the_energy_with_its_work():
    # mms-1d under its body force b(X, t_n + dt / 2): the force does work m_p b_p . dx_p,
    # and kinetic + stored - that work stays put (the standard projection: the MLS one
    # integrates the stress at Gauss points, no discrete gradient of W; 4e-7 measured)
    problem = get_problem("mms-1d", G=0.05)
    scene = problem.scene(elements=16, basis="bspline3", projection="standard",
                          integrator="midpoint")
    solver = Solver(scene, energy_guard=None, record_every=4)
    solver.run(t_end=problem.t_end)
    en = solver.energies()
    # the force works (0.5 % of the energy on 2026-11-25: G = 0.05's nonlinear part),
    # 1e6 times the tolerance below
    assert np.ptp(en["external_work"]) > 1e-3 * en["kinetic"].max()
    total = en["total"]
    assert np.max(np.abs(total - total[0])) < 1e-9 * np.max(en["kinetic"] + en["strain"])


@pytest.mark.parametrize("basis, transfer", [("uniform-bspline2", "apic"),
                                             ("uniform-bspline2", "mls-mpm")])
def test_the_affine_midpoint_step_never_gains_the_apic_energy(basis, transfer):
    # the affine transfers iterate on the grid: v_i^n from P2G, the grid step conserves
    # its kinetic + stored + gravity's energy; P2G and G2P can only lose (Jensen's
    # inequality and the least-squares fit of C_p).  So E = sum m_p (|v_p|^2 + tr(C_p D
    # C_p^T)) / 2 + W + gravity's potential never grows, step by step (D = h^2 / 4 of the
    # quadratic B-spline, constant; the square under gravity between roller walls).  On
    # 2026-11-25 (APIC): every step lost at least 3e-4 of the energy in motion; Euler-Cromer
    # gained up to 2.2e-2 in a step
    problem = get_problem("mms-2d", G=1e-3)
    scene = problem.scene(elements=8, basis=basis, transfer=transfer, mass="lumped",
                          projection="standard", integrator="euler-cromer")
    model = dataclasses.replace(scene.model, body_force=None, integrator="midpoint",
                                gravity=(0.0, -200.0),
                                dt=0.9 * scene.model.h / problem.material_law.wave_speed)
    solver = Solver(model, energy_guard=None, record_every=1)
    D = model.h ** 2 / 4.0
    masses = solver.densities() * solver.volumes()  # m_p

    def affine_energy():
        C = solver.affine()
        return 0.5 * D * float(np.sum(masses * np.sum(C * C, axis=(1, 2))))

    affine = [affine_energy()]  # the start's
    energy = []
    for _ in range(60):
        solver.run(n_steps=1)
        affine.append(affine_energy())
        en = solver.energies()
        if not energy:
            energy.append(en["total"][0] + affine[0])
        energy.append(en["total"][-1] + affine[-1])
    scale = float(np.max(en["kinetic"] + en["strain"]))
    assert max(affine) > 1e-3 * scale  # the affine part is not nil
    assert np.all(np.diff(energy) < 1e-10 * scale), np.diff(energy).max() / scale
    assert np.ptp(en["gravity"]) > 1e-2 * scale  # gravity does work


@pytest.mark.slow
def test_the_2d_consistent_mass_holds_its_roller_walls_under_midpoint_and_rk4():
    # the consistent mass's solve takes the roller walls as constraints under both
    # integrators (their shared grid solve once used the lumped one at walls, and then
    # cleared the momentum: a square that never deformed); ~2 minutes of compilation
    problem = get_problem("mms-2d", G=1e-3)
    scene = problem.scene(elements=8, basis="bspline2", mass="lumped",
                          projection="standard", integrator="euler-cromer")
    dt = 0.04 * scene.model.h / problem.material_law.wave_speed  # below the consistent limit
    positions = {}
    for integrator in ("midpoint", "rk4"):
        for mass in ("lumped", "consistent"):
            model = dataclasses.replace(scene.model, body_force=None, dt=dt,
                                        integrator=integrator, mass_matrix=mass)
            solver = Solver(model, energy_guard=None, record_every=10)
            solver.run(n_steps=100)
            en = solver.energies()
            assert en["strain"].max() > 0.5 * en["kinetic"][0]  # it deforms
            if integrator == "midpoint":
                total = en["total"]
                assert np.max(np.abs(total - total[0])) < 1e-9 * total[0]
            positions[integrator, mass] = solver.positions()
            solver.release()
        shift = np.abs(positions[integrator, "lumped"] - positions[integrator, "consistent"])
        assert shift.max() > 1e-7, integrator  # the consistent mass is not the lumped
