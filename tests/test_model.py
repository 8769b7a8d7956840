"""The one model of 1D to 3D: Scene and World build it, the engine runs it; walls and
Dirichlet nodes in every dimension."""
import itertools
import re

import numpy as np
import pytest

import timpm
from timpm import Body, Box, Grid1D, Material, Model, Scene, Solver, World, equidistant_particles
from timpm.materials import Hypoelastic1D, LinearElastic, NeoHookean

E, RHO, V0, LENGTH = 1e6, 1e3, 0.1, 0.5
C = (E / RHO) ** 0.5
#: a bar of LENGTH hitting a rigid wall at V0 touches it for 2 L / c, then leaves at +V0
T_REBOUND = 2.25 * LENGTH / C


def _rebound_error(solver, mass):
    """1 - (momentum after the rebound) / (m V0): 0 for the exact elastic rebound."""
    solver.run(n_steps=int(np.ceil(T_REBOUND / solver.dt)))
    v = solver.velocities()
    return 1.0 - np.sum(mass * v) / (np.sum(mass) * V0)


def _bar_world(cells, basis, transfer):
    return World(domain=(2.0,), cells=cells, basis=basis, transfer=transfer, gravity=(0.0,),
                 bodies=Body(Box((0.0,), (LENGTH,)), LinearElastic(E, 0.0, RHO),
                             velocity=(-V0,), ppc=2),
                 walls="slip", courant=0.5)


@pytest.mark.parametrize("basis, transfer", [("linear", "musl"), ("uniform-bspline2", "apic")])
def test_a_1d_world_bar_rebounds_from_a_slip_wall(basis, transfer):
    # 1D world: the elastic bar's rebound converges to the exact +V0 as the grid refines
    errors = []
    for cells in (16, 32, 64):
        world = _bar_world(cells, basis, transfer)
        errors.append(_rebound_error(Solver(world, mode="serial"), world.mass_per_particle))
    assert all(abs(b) < abs(a) for a, b in zip(errors, errors[1:])), errors
    assert abs(errors[-1]) < 0.1, errors


def test_a_scene_bar_rebounds_from_its_wall():
    # the study's 1D scene with a slip wall at its left end: the same exact rebound
    errors = []
    for elements in (32, 64):
        grid = Grid1D(elements, 2.0 / elements)
        x, vol = equidistant_particles(elements // 4, 2, grid.h)
        scene = Scene(grid, Material(E, RHO, "small"), x, vol, dt=0.5 * grid.h / C,
                      velocity=np.full(len(x), -V0), walls={"left": "slip"})
        assert scene.walls[1] is None and scene.walls[0].kind == "slip"
        errors.append(_rebound_error(Solver(scene, mode="serial"), scene.mass_per_particle))
    assert abs(errors[1]) < abs(errors[0]) < 0.2, errors


def test_the_model_is_what_the_engine_runs():
    # a Solver of the scene's model runs the same program and ends bit for bit the same
    from timpm.problems import get_problem

    scene = get_problem("vibrating-string").scene(elements=8)
    assert isinstance(scene.model, Model) and scene.model.dim == 1
    by_scene, by_model = Solver(scene, mode="serial"), Solver(scene.model, mode="serial")
    assert by_scene.features == by_model.features
    for s in (by_scene, by_model):
        s.run(n_steps=50)
    assert np.array_equal(by_scene.positions(), by_model.positions())
    assert np.array_equal(by_scene.stresses(), by_model.stresses())


def _drop(**world_kw):
    body = Body(Box((0.3, 0.02), (0.6, 0.3)), LinearElastic(1e4, 0.3, 1e3), velocity=(0.5, -1.0))
    return World(domain=(1.0, 0.5), cells=16, bodies=body, dt=2e-4, **world_kw)


def test_a_sticky_floor_is_its_nodes_held_fixed(strict_arithmetic):
    # APIC: a sticky wall sets v_i = 0 on the nodes at and below it, as Dirichlet nodes do.
    # Two programs compared bit for bit: without fast math, where every operation rounds as
    # written (with it, LLVM may vectorise and contract the two programs' loops apart)
    sticky = _drop(walls={"default": "slip", "bottom": "sticky"})
    (edge, _), = sticky.model.wall_nodes()[1:]  # the last node at or below the floor
    nx, ny = sticky.model.nodes
    floor = [(i, j) for i in range(nx) for j in range(edge + 1)]
    held = _drop(walls={"default": "slip", "bottom": None}, fixed_nodes=floor)
    assert held.walls[2] is None and held.fixed_nodes == tuple(floor)
    slip = _drop(walls="slip")
    runs = [Solver(w, mode="serial", energies=False) for w in (sticky, held, slip)]
    for s in runs:
        s.run(n_steps=400)
    # the floor acted: a slip floor lets the body slide on, the sticky one held it
    assert runs[2].positions()[:, 0].mean() - runs[0].positions()[:, 0].mean() > 0.01
    assert np.array_equal(runs[0].positions(), runs[1].positions())
    assert np.array_equal(runs[0].velocities(), runs[1].velocities())


@pytest.mark.parametrize("transfer", ["musl", "apic"])
def test_every_node_held_holds_every_particle(transfer):
    # with walls too: a Dirichlet node has zero velocity and zero acceleration
    world = _drop(transfer=transfer)
    nodes = world.model.nodes
    all_nodes = list(itertools.product(*(range(n) for n in nodes)))
    held = _drop(transfer=transfer, fixed_nodes=all_nodes)
    s = Solver(held, mode="serial", energies=False)
    s.run(n_steps=20)
    # no particle moves; MUSL's v_p += dt sum phi_i a_i keeps v_p (a_i = 0), APIC's
    # v_p = sum phi_i v_i is zero
    assert np.array_equal(s.positions(), held.positions)
    v_kept = np.broadcast_to(np.array([0.5, -1.0]), (held.n_particles, 2))
    assert np.array_equal(s.velocities(), v_kept if transfer == "musl" else 0 * v_kept)


@pytest.mark.parametrize("transfer", ["musl", "apic"])
def test_every_node_moving_carries_every_particle_along(transfer):
    # every node prescribed at v f(t), f = sin(omega t): each particle moves by the
    # exact integral of the node velocity up to Euler-Cromer's O(dt) in the phase
    world = _drop(transfer=transfer, gravity=(0.0, 0.0))
    nodes = list(itertools.product(*(range(n) for n in world.model.nodes)))
    v, omega = np.array([0.2, -0.1]), 5.0
    moving = _drop(transfer=transfer, gravity=(0.0, 0.0), fixed_time=timpm.Sine(omega),
                   fixed_nodes={i: v for i in nodes})
    s = Solver(moving, mode="serial", energies=False)
    s.run(n_steps=200)
    t, dt = s.t, moving.dt
    shift = v * (1 - np.cos(omega * t)) / omega
    assert np.allclose(s.positions() - moving.positions, shift, rtol=0,
                       atol=2 * omega * dt * np.abs(v).max())
    # APIC: v_p = sum phi_i v_i; MUSL: v_p += dt sum phi_i a_i keeps the initial velocity
    # and adds v (f(t) - f(0))
    v_initial = np.array([0.5, -1.0]) if transfer == "musl" else 0.0
    assert np.allclose(s.velocities(), v_initial + v * np.sin(omega * t), rtol=0, atol=1e-12)
    # an impulsive start (f = 1): the particles move at v from the first step on
    step = _drop(transfer=transfer, gravity=(0.0, 0.0), fixed_nodes={i: v for i in nodes})
    s = Solver(step, mode="serial", energies=False)
    s.run(n_steps=10)
    assert np.allclose(s.positions() - step.positions, 10 * step.dt * v, rtol=1e-12)


def test_a_bar_follows_its_moving_ends():
    # 1D: both end nodes prescribed at 0.1 sin(3 t); a stiff bar follows them rigidly
    x, vol = equidistant_particles(8, 2, 0.125)
    scene = Scene(Grid1D(8, 0.125), Material(1e6, 1.0), x, vol, dt=1e-5,
                  fixed_nodes={0: 0.1, 8: 0.1}, fixed_time=timpm.Sine(3.0))
    s = Solver(scene, mode="serial")
    s.run(0.2)
    assert np.allclose(s.displacements(), 0.1 * (1 - np.cos(3 * 0.2)) / 3, rtol=1e-4)


def test_an_initial_displacement_vibrates_as_the_exact_string():
    # u0 = A sin(pi X / L), v0 = 0 gives u = A sin(pi X / L) cos(w t); the body starts
    # stressed: its strain energy is the exact one, and the error is second order in h
    import dataclasses

    from timpm.problems import get_problem

    problem = get_problem("vibrating-string")
    L, A = problem.L, 0.01
    errors = []
    for elements in (16, 32):
        scene = problem.scene(elements=elements, ppc=4, dt=1e-3, stress_update="small")
        u0 = lambda X: A * np.sin(np.pi * X / L)  # noqa: E731
        # the same through the model and through the 1D scene
        if elements == 16:
            model = dataclasses.replace(scene.model, velocity=None, displacement=u0)
        else:
            model = dataclasses.replace(scene, velocity=None, displacement=u0).model
        solver = Solver(model, mode="serial", record_every=10)
        solver.run(3.0)
        exact = A * np.sin(np.pi * model.positions[:, 0] / L) * np.cos(problem.omega * solver.t)
        errors.append(np.sqrt(np.mean((solver.displacements() - exact) ** 2)))
        # W = E / 2 (du/dX)^2 integrated: E / 2 (A pi / L)^2 L / 2
        exact_energy = 0.25 * problem.E * (A * np.pi / L) ** 2 * L
        assert solver.energies()["strain"][0] == pytest.approx(exact_energy, rel=1e-8)
        solver.release()
    assert np.log2(errors[0] / errors[1]) > 1.8


def test_an_initial_displacement_deforms_a_2d_body():
    # a uniform stretch u0 = (0.1 X, -0.05 Y): F0 = diag(1.1, 0.95) in every particle, the
    # volumes det(F0) V0, the positions X + u0 and the Neo-Hookean energy W(F0) V0
    law = NeoHookean(1e4, 0.3, 1e3)
    world = World(domain=(1.0, 1.0), cells=8, gravity=(0.0, 0.0), transfer="apic",
                  bodies=Body(Box((0.3, 0.3), (0.6, 0.6)), law))
    model = world.model
    import dataclasses

    stretched = dataclasses.replace(model, displacement=lambda X: X * [0.1, -0.05])
    solver = Solver(stretched, mode="serial", record_every=1)
    assert np.allclose(solver.positions(), model.positions * [1.1, 0.95], rtol=1e-12)
    assert np.allclose(solver.volumes(), model.volume * 1.1 * 0.95, rtol=1e-12)
    solver.run(n_steps=1)
    F0 = np.diag([1.1, 0.95])
    assert np.allclose(stretched.initial_gradient, F0 - np.eye(2), atol=1e-8)
    mu, lam = law.mu, law.lam
    J = np.linalg.det(F0)
    W = 0.5 * mu * (np.sum(F0 * F0) - 2) - mu * np.log(J) + 0.5 * lam * np.log(J) ** 2
    assert solver.energies()["strain"][0] == pytest.approx(W * model.volume.sum(), rel=1e-6)
    solver.release()


def test_bodies_start_displaced_each_by_its_own_function():
    # two bodies: the first stretched by u0 = (0.1 (X - 0.3), 0), the second at rest; each
    # body's F0, volume and position, and the stretched one's energy W(F0) V0 alone
    law = NeoHookean(1e4, 0.3, 1e3)
    stretched = Body(Box((0.3, 0.3), (0.5, 0.5)), law,
                     displacement=lambda X: (X - 0.3) * [0.1, 0.0])
    resting = Body(Box((0.6, 0.3), (0.8, 0.5)), law)
    world = World(domain=(1.0, 1.0), cells=8, gravity=(0.0, 0.0), transfer="apic",
                  bodies=[stretched, resting])
    model = world.model
    first = model.body_index == 0
    X = model.positions
    solver = Solver(world, mode="serial", record_every=1)
    x = solver.positions()
    assert np.allclose(x[first], X[first] + (X[first] - 0.3) * [0.1, 0.0], rtol=1e-12)
    assert np.array_equal(x[~first], X[~first])
    assert np.allclose(solver.volumes()[first], model.volume[first] * 1.1, rtol=1e-12)
    assert np.array_equal(solver.volumes()[~first], model.volume[~first])
    solver.run(n_steps=1)
    F0 = np.diag([1.1, 1.0])
    J = 1.1
    W = 0.5 * law.mu * (np.sum(F0 * F0) - 2) - law.mu * np.log(J) + 0.5 * law.lam * np.log(J) ** 2
    assert solver.energies()["strain"][0] == pytest.approx(W * model.volume[first].sum(),
                                                           rel=1e-6)
    solver.release()


@pytest.mark.parametrize("displacement, message", [
    (0.1, "body displacement must be a function u0(X)"),
    (lambda X: X[:, :1], "body 0's displacement u0(X) must return an (n, 2) array"),
    (lambda X: X * np.nan, "body 0's displacement u0(X) is not finite at point 0"),
])
def test_a_bad_body_displacement_is_refused(displacement, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        World(domain=(1.0, 1.0), cells=8, gravity=(0.0, 0.0),
              bodies=Body(Box((0.3, 0.3), (0.5, 0.5)), "rubber", displacement=displacement))


def test_the_study_law_in_a_1d_world():
    # the study's material is a material like any other in 1D
    law = timpm.get_material("hypoelastic-1d", E=E, density=RHO, study=False)
    world = World(domain=(2.0,), cells=32, basis="linear", transfer="musl", gravity=(0.0,),
                  bodies=Body(Box((0.0,), (LENGTH,)), law, velocity=(-V0,), ppc=2),
                  walls="slip", courant=0.5)
    assert world.dim == 1 and world.materials == (law,)
    assert abs(_rebound_error(Solver(world, mode="serial"), world.mass_per_particle)) < 0.2


@pytest.mark.parametrize("build, message", [
    (lambda: World(domain=(1.0,), cells=8, bodies=Body(Box((0.0,), (0.5,)), "sand")),
     "drucker-prager material is defined in 2D and 3D, not in 1D"),
    (lambda: World(domain=(1.0, 1.0), cells=8,
                   bodies=Body(Box((0.0, 0.0), (0.5, 0.5)), Hypoelastic1D(1e4, 1e3))),
     "hypoelastic-1d material is defined in 1D, not in 2D"),
    (lambda: World(domain=(1.0, 1.0), cells=8, bodies=Body(Box((0.0, 0.0), (0.5, 0.5)), "rubber"),
                   fixed_nodes=[(0, 99)]),
     "fixed node (0, 99) does not exist"),
    (lambda: World(domain=(1.0, 1.0), cells=8, bodies=Body(Box((0.0, 0.0), (0.5, 0.5)), "rubber"),
                   fixed_nodes=[3]),
     "fixed node 3 must be 2 whole number(s)"),
    (lambda: World(domain=(1.0, 1.0), cells=8, bodies=Body(Box((0.0, 0.0), (0.5, 0.5)), "rubber"),
                   walls={"bottom": "glue"}),
     "unknown wall 'glue'"),
    (lambda: World(domain=(1.0,), cells=8, basis="lagrange2",
                   bodies=Body(Box((0.0,), (0.5,)), LinearElastic(1e4, 0.0, 1e3))),
     "the lagrange2 basis is 1D only: a World's grid"),
    (lambda: Scene(Grid1D(8, 0.125), Material(1e4, 1e3), *equidistant_particles(8, 2, 0.125),
                   dt=1e-4, basis="lagrange2", mass="consistent", walls="slip"),
     "walls act on the lumped nodal velocities"),
    (lambda: Scene(Grid1D(8, 0.125), Material(1e4, 1e3), *equidistant_particles(8, 2, 0.125),
                   dt=1e-4, walls={"top": "slip"}),
     "unknown wall side(s) ['top']: the sides of a 1D domain are left, right"),
    (lambda: Scene(Grid1D(8, 0.125), Material(1e4, 1e3), *equidistant_particles(8, 2, 0.125),
                   dt=1e-4, fixed_nodes=(0.7,)),
     "fixed node 0.7 must be a whole number"),
    (lambda: Scene(Grid1D(8, 0.125), Material(1e4, 1e3), *equidistant_particles(8, 2, 0.125),
                   dt=1e-4, fixed_nodes={0: [0.1, 0.2]}),
     "prescribed velocity of fixed node 0 must have 1 components"),
    (lambda: Scene(Grid1D(8, 0.125), Material(1e4, 1e3), *equidistant_particles(8, 2, 0.125),
                   dt=1e-4, fixed_nodes={0: float("nan")}),
     "prescribed velocity of fixed node 0 must be finite"),
    (lambda: Scene(Grid1D(8, 0.125), Material(1e4, 1e3), *equidistant_particles(8, 2, 0.125),
                   dt=1e-5, basis="bspline2", mass="consistent", fixed_nodes={0: 0.1}),
     "prescribed non-zero node velocities are implemented for the lumped mass"),
    (lambda: Scene(Grid1D(8, 0.125), Material(1e4, 1e3), *equidistant_particles(8, 2, 0.125),
                   dt=1e-4, fixed_nodes={0: 0.1}, fixed_time=3.0),
     "fixed_time must be a time function"),
    (lambda: Scene(Grid1D(8, 0.125), Material(1e4, 1e3), *equidistant_particles(8, 2, 0.125),
                   dt=1e-4, fixed_nodes=(0, 0)),
     "a fixed node is given twice"),
    (lambda: Model(basis="linear", origin=(0.0, 0.0), h=0.1, elements=(4, 4),
                   positions=np.full((3, 3), 0.2), volume=np.ones(3),
                   materials=(LinearElastic(1e4, 0.3, 1e3),), dt=1e-4),
     "particle positions must be an (n, 2) array"),
    (lambda: Model(basis="linear", origin=(0.0, 0.0), h=0.1, elements=(4, 4),
                   positions=np.full((3, 2), 0.2), volume=np.ones(3), dt=1e-4,
                   materials=(LinearElastic(1e4, 0.3, 1e3),), material_index=[0, 1, 0]),
     "material_index must lie in 0..0"),
    (lambda: Model(basis="linear", origin=(0.0, 0.0), h=0.1, elements=(4, 4),
                   positions=np.full((3, 2), 0.2), volume=np.ones(3), dt=1e-4,
                   materials=(LinearElastic(1e4, 0.3, 1e3),), mass_matrix="consistent",
                   transfer="apic"),
     "the consistent mass matrix is implemented with the musl transfer, not apic"),
    (lambda: Model(basis="linear", origin=(0.0, 0.0), h=0.1, elements=(4, 4),
                   positions=np.full((3, 2), 0.2), volume=np.ones(3), dt=1e-4,
                   materials=(LinearElastic(1e4, 0.3, 1e3),), traction=timpm.Traction(0, 1.0)),
     "the particle traction (3.5) acts along x in 1D models only"),
    (lambda: Model(basis="linear", origin=(0.0,), h=0.1, elements=(4,),
                   positions=np.full(3, 0.2), volume=np.ones(3), dt=1e-4,
                   materials=(LinearElastic(1e4, 0.0, 1e3),), displacement=np.zeros(3)),
     "displacement must be a function u0(X)"),
    (lambda: Model(basis="linear", origin=(0.0,), h=0.1, elements=(4,),
                   positions=np.array([0.1, 0.2, 0.3]), volume=np.ones(3), dt=1e-4,
                   materials=(LinearElastic(1e4, 0.0, 1e3),), displacement=lambda X: -2 * X),
     "the initial displacement u0(X) inverts particle 0 at X = 0.1: det(I + grad u0) = -1"),
    (lambda: Model(basis="linear", origin=(0.0,), h=0.1, elements=(4,),
                   positions=np.array([0.1, 0.2, 0.3]), volume=np.ones(3), dt=1e-4,
                   materials=(LinearElastic(1e4, 0.0, 1e3),), displacement=lambda X: X),
     "moves particle 2 from X = 0.3 to 0.6, outside the grid"),
    (lambda: Model(basis="linear", origin=(0.0,), h=0.1, elements=(4,),
                   positions=np.array([0.1, 0.2, 0.3]), volume=np.ones(3), dt=1e-4,
                   materials=(LinearElastic(1e4, 0.0, 1e3),),
                   displacement=lambda X: np.where(X < 0.15, np.nan, 0.0)),
     "the initial displacement u0(X) is not finite at point 0"),
])
def test_bad_models_are_refused(build, message):
    with pytest.raises(ValueError) as err:
        build()
    assert message in str(err.value)


@pytest.mark.parametrize("dim, track, every, steps", [
    (1, [1, 5, 7], 3, 40), (1, [1, 5, 7], 1, 1), (1, list(range(20)), 7, 20),
    (2, [0, 3], 2, 10), (2, [], 2, 10)])
def test_the_history_read_in_one_launch_is_every_fields_own(dim, track, every, steps):
    # read_history packs every history field into two arrays in one kernel: the same
    # values, dtypes and shapes as each field's to_numpy
    from timpm.problems import get_problem

    if dim == 1:
        scene = get_problem("vibrating-string").scene(elements=8)
    else:
        scene = _drop()
    solver = Solver(scene, track=track, mode="serial")
    solver.compile()
    prog = solver.program()
    prog.advance(steps, every, 0)
    n = int(prog.rec_count[None])
    assert n == steps // every  # a record every `every` steps
    packed = prog.read_history(n, len(track))
    assert set(packed) == set(prog.history_fields)
    for key, fld in prog.history_fields.items():
        own = fld.to_numpy()[:n]
        own = own[:, :len(track)] if fld.shape[1:] else own
        assert packed[key].dtype == own.dtype and packed[key].shape == own.shape, key
        assert np.array_equal(packed[key], own), key
