"""Plane walls at any angle (timpm/model/walls.py: Plane; timpm/engine/grid.py): a plane
along an axis is the box's wall to the bit, a block on an inclined plane slides as the
textbook block does, a saturated column between inclined planes consolidates as
Terzaghi's layer (sealed or drained at its base), and every bad input is refused, naming
its key (and, in a scene file, its line), before any work."""
import dataclasses
import math
import re

import numpy as np
import pytest

import timpm
from timpm.model.loads import SurfaceTraction
from timpm.platform.errors import InputError
from timpm.problems import get_problem
from timpm.problems.terzaghi import consolidation_series, degree_of_consolidation

G = 9.81
SLOPE = math.radians(30.0)


# ---- a plane along an axis is the box's wall ---------------------------------------------
def _box_or_plane(basis, transfer, kind, mu, plane):
    body = timpm.Body(timpm.Box((0.2, 0.0), (0.6, 0.3)),
                      timpm.LinearElastic(E=1e5, nu=0.3, density=1000.0), velocity=(1.0, -0.5))
    walls = {"default": "slip", "bottom": None if plane else timpm.Wall(kind, mu)}
    # the normal's length is free: kept as the unit vector (0, -1)
    planes = [timpm.Plane((0.3, 0.0), (0.0, -2.0), kind, mu)] if plane else []
    return timpm.World(domain=(1.0, 1.0), cells=10, bodies=[body], basis=basis,
                       transfer=transfer, walls=walls, planes=planes, dt=2e-4)


@pytest.mark.parametrize("basis, transfer, kind, mu", [
    ("linear", "musl", "friction", 0.3), ("uniform-bspline2", "apic", "friction", 0.3),
    ("uniform-bspline2", "apic", "slip", 0.0), ("bspline2", "musl", "sticky", 0.0),
    ("linear", "apic", "roller", 0.0)])
def test_a_plane_along_an_axis_is_the_box_s_wall(basis, transfer, kind, mu):
    """A plane through the bottom wall's line of nodes, normal -y, holds the nodes the
    bottom wall holds (the padded B-splines' rows beyond it, the clamped one's first) and
    projects their velocities to the same numbers: a block thrown at it moves to the bit as
    on the box's wall (100 steps)."""
    runs = [timpm.Solver(_box_or_plane(basis, transfer, kind, mu, plane),
                         energies=False).run(n_steps=100) for plane in (False, True)]
    assert runs[1].features.planes == ((kind, False),) and runs[1].features.walls[2] == "open"
    assert np.array_equal(runs[0].read("x"), runs[1].read("x"))
    assert np.array_equal(runs[0].read("v"), runs[1].read("v"))


def test_a_plane_along_an_axis_is_the_box_s_wall_under_the_consistent_mass():
    """The consistent mass (2D: conjugate gradients, the walls' held components its
    constraints) takes roller and sticky planes as it takes such walls: the same bits."""
    runs = []
    for plane in (False, True):
        body = timpm.Body(timpm.Box((0.2, 0.0), (0.6, 0.3)),
                          timpm.LinearElastic(E=1e5, nu=0.3, density=1000.0),
                          velocity=(1.0, -0.5))
        world = timpm.World(domain=(1.0, 1.0), cells=10, bodies=[body], transfer="musl",
                            walls={"default": "roller", "bottom": None if plane else "roller"},
                            planes=[timpm.Plane((0.0, 0.0), (0.0, -1.0), "roller")] if plane
                            else [], dt=2e-4)
        model = dataclasses.replace(world.model, mass_matrix="consistent")
        runs.append(timpm.Solver(model, energies=False).run(n_steps=50))
    assert np.array_equal(runs[0].read("x"), runs[1].read("x"))


@pytest.mark.parametrize("drained", [False, True])
def test_a_roller_plane_along_an_axis_is_the_box_s_wall_for_the_water(drained):
    """Terzaghi's layer as a 2D column (2 x 16 linear cells, roller sides, coupled) on a
    roller base, sealed or drained: the base a box wall (drained_sides=("bottom",)) or a
    plane through it (drained=True), the same bits after 2000 steps (the water's normal
    velocity the skeleton's, zero, either way; drained, its own balance): the lowest row's
    pressure below p0 / 2 drained, at p0 sealed (T = 0.01)."""
    prob = get_problem("terzaghi")
    soil = timpm.LinearElastic(E=prob.E, nu=0.0, density=prob.density)
    body = timpm.Body(timpm.Box((0.0, 0.0), (0.125, 1.0)), soil, water=prob.pore_water)
    runs = []
    for plane in (False, True):
        walls = {"left": "roller", "right": "roller", "bottom": None if plane else "roller",
                 "top": None}
        sides = ("bottom",) if drained and not plane else ()
        world = timpm.World(
            domain=(0.125, 1.0), cells=2, bodies=[body], transfer="musl", basis="linear",
            walls=walls, gravity=(0.0, 0.0), water=timpm.Water("coupled", drained_sides=sides),
            tractions=[SurfaceTraction(0, "top", (0.0, -prob.p0))],
            planes=[timpm.Plane((0.0, 0.0), (0.0, -1.0), "roller", drained=drained)] if plane
            else [], initial_pore_pressure=np.full(128, prob.p0))
        runs.append(timpm.Solver(world, energies=False).run(n_steps=2000))
    for name in ("pw", "w", "x"):
        assert np.array_equal(runs[0].read(name), runs[1].read(name)), name
    base = runs[1].read("pw")[runs[1].read("x")[:, 1] < 0.03]  # the lowest row
    assert (base.max() < 0.5 * prob.p0) if drained else (base.min() > 0.99 * prob.p0)


def test_the_nodes_a_plane_holds():
    """Model.plane_nodes: on or beyond the plane, at the nodes' positions (the clamped
    B-spline's control points at the Greville abscissae 0, h/2, 3h/2 ...)."""
    body = timpm.Body(timpm.Box((0.0, 0.3), (1.0, 0.6)), "rubber")
    # y = 0.25: the linear grid's rows at -0.2 ... 0.2 (two padding cells), the clamped
    # B-spline's at 0, 0.05, 0.15, 0.25 (no padding), the padded quadratic's at -0.4 ... 0.2
    for basis, rows in (("linear", 5), ("bspline2", 4), ("uniform-bspline2", 7)):
        world = timpm.World(domain=(1.0, 1.0), cells=10, bodies=[body], basis=basis,
                            transfer="musl", planes=[timpm.Plane((0.0, 0.25), (0.0, -1.0))])
        held = world.model.plane_nodes(0)
        assert np.all(held[:, :rows]) and not np.any(held[:, rows:]), basis
    world = timpm.World(domain=(1.0, 1.0), cells=10, bodies=[body], basis="linear",
                        planes=[timpm.Plane((0.15, 0.15), (-1.0, -1.0))])
    x = np.arange(15) * 0.1 - 0.2  # the nodes, padding and all
    assert np.array_equal(world.model.plane_nodes(), np.add.outer(x, x) <= 0.3 + 1e-9)


# ---- a block on an inclined plane ----------------------------------------------------------
def _block_on_slope(cells, kind, mu=0.0, point=(0.0, 1.0)):
    """An elastic block 0.4 x 0.2 m (particles on a lattice along the slope, 2 per cell and
    axis) resting on a plane at 30 degrees through ``point``, falling to the right; the
    default basis and transfer (padded quadratic B-splines, APIC)."""
    down = np.array([math.cos(SLOPE), -math.sin(SLOPE)])
    up = np.array([math.sin(SLOPE), math.cos(SLOPE)])  # out of the plane, into the block
    dx = 2.0 / cells / 2
    a, b = np.meshgrid(np.arange(0.3 + dx / 2, 0.7, dx), np.arange(dx / 2, 0.2, dx),
                       indexing="ij")
    x = np.array(point) + a.reshape(-1, 1) * down + b.reshape(-1, 1) * up
    body = timpm.Body(timpm.Points(x, dx * dx),
                      timpm.LinearElastic(E=1e6, nu=0.3, density=1000.0))
    world = timpm.World(domain=(2.0, 1.5), cells=cells, bodies=[body],
                        planes=[timpm.Plane(point, tuple(-up), kind, mu)])
    return world, down, up


@pytest.mark.parametrize("kind, mu", [("slip", 0.0), ("friction", 0.3), ("friction", 0.9),
                                      ("sticky", 0.0)])
def test_a_block_on_an_inclined_plane(kind, mu):
    """After 0.3 s on the 30 degree plane the block's mean velocity along the slope over
    the time is g sin(theta) on a slip plane (to round-off: the plane takes only the nodal
    momentum's normal component), g (sin - mu cos) on a friction plane with mu = 0.3 <
    tan(theta) (within 0.02 g sin(theta): the staircase of held nodes along the plane; 0.0054
    at 20 cells, 0.0036 at 40), and 0 where mu = 0.9 > tan(theta) and on a sticky plane
    (within the same: the elastic block's sway); the block stays on the plane (its centre
    of mass within 1 cm of its start normal to it, where free fall would take it 0.38 m),
    at 20 and 40 cells.  (mu = 0.7 held at 20 cells but slid at 40, 0.35 m/s^2: the
    stress-free block dropped under gravity bounces and its base's normal force dips; a
    box's bottom wall under the tilted gravity slides as well, 0.27 m/s^2.)"""
    exact = {"slip": G * math.sin(SLOPE), "friction": max(
        0.0, G * (math.sin(SLOPE) - mu * math.cos(SLOPE))), "sticky": 0.0}[kind]
    features = set()
    for cells in (20, 40):
        world, down, up = _block_on_slope(cells, kind, mu)
        solver = timpm.Solver(world, energies=False).run(t_end=0.3)
        features.add(solver.features)
        m = world.mass_per_particle[:, None]
        v = np.sum(m * solver.read("v"), axis=0) / m.sum()
        moved = np.sum(m * (solver.read("x") - world.positions), axis=0) / m.sum()
        a = v @ down / solver.t
        tolerance = 1e-9 if kind == "slip" else 0.02 * G * math.sin(SLOPE)
        assert abs(a - exact) < tolerance, (cells, a, exact)
        assert abs(moved @ up) < 0.01, (cells, moved @ up)
        if exact == 0.0:
            assert abs(moved @ down) < 0.01, (cells, moved @ down)
    assert len(features) == 1  # the plane's numbers are run-time values: one program


def test_moving_a_plane_compiles_nothing():
    """A plane elsewhere, turned, with another mu: the same feature set (one program)."""
    a, _, _ = _block_on_slope(20, "friction", 0.3)
    b = dataclasses.replace(a, planes=[timpm.Plane((0.0, 0.5), (-0.3, -0.8), "friction", 0.5)])
    assert timpm.Solver(a).features == timpm.Solver(b).features


def test_a_block_on_an_oblique_plane_in_3d():
    """3D: a plane tilted 25 degrees from level towards an azimuth of 30 degrees; a block
    on it slides down its fall line at g sin(theta) (slip, to round-off), without drifting
    across it, and at g (sin - mu cos) on a friction plane (mu = 0.3, within 0.02 g
    sin(theta); 0.0095 at 10 cells per metre)."""
    theta, azimuth = math.radians(25.0), math.radians(30.0)
    up = np.array([math.sin(theta) * math.cos(azimuth), math.cos(theta),
                   math.sin(theta) * math.sin(azimuth)])
    fall = np.array([0.0, -G, 0.0]) + G * up[1] * up
    fall /= np.linalg.norm(fall)
    across = np.cross(up, fall)
    point = np.array([0.75, 0.7, 0.75])
    dx = 0.05
    a, b, c = np.meshgrid(np.arange(dx / 2, 0.3, dx) - 0.15, np.arange(dx / 2, 0.3, dx) - 0.15,
                          np.arange(dx / 2, 0.15, dx), indexing="ij")
    x = point + a.reshape(-1, 1) * fall + b.reshape(-1, 1) * across + c.reshape(-1, 1) * up
    body = timpm.Body(timpm.Points(x, dx ** 3),
                      timpm.LinearElastic(E=1e6, nu=0.3, density=1000.0))
    for kind, mu in (("slip", 0.0), ("friction", 0.3)):
        world = timpm.World(domain=(1.5, 1.5, 1.5), cells=15, bodies=[body],
                            planes=[timpm.Plane(tuple(point), tuple(-up), kind, mu)])
        solver = timpm.Solver(world, energies=False).run(t_end=0.2)
        m = world.mass_per_particle[:, None]
        v = np.sum(m * solver.read("v"), axis=0) / m.sum()
        exact = G * (math.sin(theta) - mu * math.cos(theta))
        tolerance = 1e-9 if kind == "slip" else 0.02 * G * math.sin(theta)
        assert abs(v @ fall / solver.t - exact) < tolerance, (kind, v @ fall / solver.t)
        assert abs(v @ across) < 1e-3 and abs(v @ up) < 0.05


def test_a_movie_draws_the_ground_beyond_each_plane(tmp_path):
    """The GIF of a scene with planes shades the empty pixels beyond each plane in its
    kind's colour (rough: friction, sticky) and keeps the particles drawn over it: the
    block on the 30 degree plane, a friction plane, with a slip plane along the right."""
    from PIL import Image

    from timpm.output.render import PLANE_COLOR, ROUGH_PLANE_COLOR, Movie

    world, down, up = _block_on_slope(20, "friction", 0.3)
    world = dataclasses.replace(world, planes=[*world.planes,
                                               timpm.Plane((1.8, 0.0), (1.0, 0.0), "slip")])
    movie = Movie(tmp_path / "block.gif", width=320)
    movie.start(world)
    movie.add(world.model.positions, t=0.0)
    movie.close()
    frame = np.asarray(Image.open(tmp_path / "block.gif").convert("RGB"))
    x0, y0, pw, ph = movie.layout.plot_box
    plot = frame[y0:y0 + ph, x0:x0 + pw]

    def pixel(x, y):  # the plot's pixel at (x, y) m (domain 2 x 1.5 m, rows from the top)
        return tuple(plot[int((1.5 - y) / 1.5 * ph), int(x / 2.0 * pw)])

    assert pixel(1.0, 0.05) == ROUGH_PLANE_COLOR      # below the inclined plane
    assert pixel(1.95, 1.4) == PLANE_COLOR            # beyond the slip plane on the right
    assert pixel(0.3, 1.4) == (255, 255, 255)         # the open air above the slope
    centre = np.array((0.0, 1.0)) + 0.5 * down + 0.1 * up  # the block's centre: drawn
    assert pixel(*centre) not in (ROUGH_PLANE_COLOR, PLANE_COLOR, (255, 255, 255))


# ---- the pore water: a rotated Terzaghi column ---------------------------------------------
def _rotated_column(drained, angle=30.0, cells=16, width=0.5):
    """Terzaghi's layer (timpm/problems/terzaghi.py: H = 1 m, E_oed = 1 MPa, k = 1e-3 m/s,
    u0 = p0 = 1 kPa) as a 2D column 0.5 m wide (nu = 0), its axis turned 30 degrees from
    y, coupled, gravity off: its base a sticky plane (impermeable, or ``drained``), its
    sides roller planes (impermeable), its top free (drained) and loaded by -p0 along the
    axis, spread over the top particles.  The World fills the turned rectangle with its
    lattice along x and y (the linear basis, 16 cells along the axis)."""
    prob = get_problem("terzaghi")
    h = prob.H / cells
    a = math.radians(angle)
    up = np.array([-math.sin(a), math.cos(a)])
    across = np.array([math.cos(a), math.sin(a)])
    o = np.array([prob.H * math.sin(a) + 2 * h, 2 * h])  # the base's left corner
    corners = [o, o + width * across, o + width * across + prob.H * up, o + prob.H * up]
    span = (width * math.cos(a) + prob.H * math.sin(a), width * math.sin(a) + prob.H * math.cos(a))
    soil = timpm.LinearElastic(E=prob.E, nu=0.0, density=prob.density)
    body = timpm.Body(timpm.Polygon([tuple(c) for c in corners]), soil, water=prob.pore_water)
    planes = [timpm.Plane(tuple(o), tuple(-up), "sticky", drained=drained),
              timpm.Plane(tuple(o), tuple(-across), "roller"),
              timpm.Plane(tuple(o + width * across), tuple(across), "roller")]
    world = dict(domain=tuple(math.ceil(s / h + 5) * h for s in span),
                 cells=math.ceil(span[0] / h + 5), bodies=[body], transfer="musl",
                 basis="linear", walls=None, gravity=(0.0, 0.0), planes=planes,
                 water=timpm.Water("coupled"))
    n = timpm.World(**world).n_particles
    world = timpm.World(**world, initial_pore_pressure=np.full(n, prob.p0))
    z = (world.positions - o) @ up  # height above the base along the axis
    top = z > prob.H - h / 2  # the top row of particles: the load, -p0 along the axis
    force = np.zeros((n, 2))
    force[top] = -prob.p0 * width / top.sum() * up
    return prob, dataclasses.replace(world.model, particle_force=force), z


def test_a_turned_column_consolidates_through_its_planes():
    """The turned column sealed at its base (one drained face: u / u0 the series of Z = (H -
    z) / H at T = c_v t / H^2) and drained through it (two faces: Z the distance to the
    nearer over H / 2, at 4 T), at T = 0.05 and 0.2: the degree of consolidation 1 - int p_e
    dV / (p0 V) within 0.04 of the series' (measured 0.023 and 0.032 sealed, 0.004 and
    0.003 drained; at 32 cells 0.005, 0.003 and 0.008, 0.007), the mean pressure of each
    quarter of the column's length within 0.1 of p0 of the series' mean there (0.081; 0.048
    at 32 cells);
    at each time the drained base's consolidation at least 0.2 ahead of the sealed one's
    (the series: 0.504 against 0.252, 0.887 against 0.504).  The planes cut the grid's cells:
    those partly filled make the contact soft and carry the error (an axis-aligned column
    between planes through nodes is within 0.0002 of U)."""
    U = {}
    for drained in (False, True):
        prob, model, z = _rotated_column(drained)
        solver = timpm.Solver(model, energies=False)
        quarter = np.clip((4 * z / prob.H).astype(int), 0, 3)
        for T in (0.05, 0.2):
            solver.run(t_end=T * prob.H ** 2 / prob.c_v)
            pw, vol = solver.read("pw") / prob.p0, solver.read("vol")
            T_d = 4 * T if drained else T
            depth = np.minimum(z, prob.H - z) / (prob.H / 2) if drained else (prob.H - z) / prob.H
            exact = consolidation_series(depth, T_d)
            U[drained, T] = 1.0 - np.sum(pw * vol) / np.sum(vol)
            assert abs(U[drained, T] - degree_of_consolidation(T_d)) < 0.04, (drained, T, U)
            error = [pw[quarter == q].mean() - exact[quarter == q].mean() for q in range(4)]
            assert np.max(np.abs(error)) < 0.1, (drained, T, error)
    for T in (0.05, 0.2):
        assert U[True, T] > U[False, T] + 0.2


# ---- refusals ------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, key, words", [
    (dict(point=(0.0, float("nan")), normal=(0.0, -1.0)), "point", "finite"),
    (dict(point=(0.0,), normal=(0.0, -1.0)), "point", "2 or 3"),
    (dict(point="origin", normal=(0.0, -1.0)), "point", "finite"),
    (dict(point=(0.0, 0.0), normal=(0.0, 0.0)), "normal", "non-zero"),
    (dict(point=(0.0, 0.0), normal=(float("inf"), -1.0)), "normal", "finite"),
    (dict(point=(0.0, 0.0), normal=(0.0, 0.0, -1.0)), "normal", "as many components"),
    (dict(point=(0.0, 0.0), normal=(0.0, -1.0), kind="periodic"), "kind", "unknown kind"),
    (dict(point=(0.0, 0.0), normal=(0.0, -1.0), kind="glue"), "kind", "unknown kind"),
    (dict(point=(0.0, 0.0), normal=(0.0, -1.0), kind="slip", mu=0.3), "mu", "slip plane"),
    (dict(point=(0.0, 0.0), normal=(0.0, -1.0), kind="friction", mu=-0.1), "mu", ">= 0"),
    (dict(point=(0.0, 0.0), normal=(0.0, -1.0), kind="friction", mu=float("nan")), "mu",
     ">= 0"),
    (dict(point=(0.0, 0.0), normal=(0.0, -1.0), drained="yes"), "drained", "true or false")])
def test_a_plane_refuses_bad_values(kwargs, key, words):
    with pytest.raises(InputError, match=words) as err:
        timpm.Plane(**kwargs)
    assert err.value.key == key


def _world(planes, dim=2, water=None, pore=None, **kw):
    size = (1.0,) * dim
    body = timpm.Body(timpm.Box((0.25,) * dim, (0.75,) * dim),
                      timpm.LinearElastic(E=1e5, nu=0.3, density=1e3), water=pore)
    return timpm.World(domain=size, cells=4, bodies=[body], planes=planes, water=water,
                       transfer="musl", **kw)


FLOOR = timpm.Plane((0.0, 0.1), (0.0, -1.0))
PORE = timpm.PoreWater(porosity=0.4, conductivity=1e-5)


@pytest.mark.parametrize("make, key, words", [
    (lambda: _world([timpm.Plane((0.0, 0.5), (0.0, -1.0))]), "planes[0]",
     r"plane 0 .*: 8 of 16 particles start beyond it"),
    (lambda: _world([FLOOR, timpm.Plane((0.0, 0.1), (0.0, 1.0))]), "planes[1]",
     r"plane 1 .*: 16 of 16 particles start beyond it.*into the wall"),
    (lambda: _world([timpm.Plane((0.0, 0.0, 0.1), (0.0, -1.0, 0.0))]), "planes[0].point",
     "a 3D plane in a 2D scene"),
    (lambda: _world([timpm.Plane((0.0, 0.1), (0.0, -1.0), drained=True)]),
     "planes[0].drained", "the scene is dry"),
    (lambda: _world([timpm.Plane((0.0, 0.1), (0.0, -1.0), drained=True)], pore=PORE,
                    water=timpm.Water("undrained")), "planes[0].drained",
     "the scene's analysis is undrained"),
    (lambda: _world("floor"), "planes", "a list of timpm.Plane"),
    (lambda: _world([FLOOR, (0.0, 0.1)]), "planes[1]", "must be a timpm.Plane"),
    (lambda: _world([timpm.Plane((0.0, 0.1), (0.1, -1.0))], basis="linear",
                    walls={"left": "periodic", "right": "periodic"}), "planes[0].normal",
     "x is periodic"),
    (lambda: _world([timpm.Plane((0.0, 0.1), (0.0, -1.0), "slip")], integrator="rk4",
                    walls="roller"),
     "planes[0].kind", "rk4 integrator takes roller and sticky planes"),
    (lambda: timpm.World(domain=(1.0,), cells=4, bodies=[timpm.Body(
        timpm.Box((0.25,), (0.75,)), "rubber")], planes=[FLOOR]), "planes", "2D and 3D")])
def test_bad_planes_are_refused_before_any_work(make, key, words):
    with pytest.raises(InputError, match=words) as err:
        make()
    assert err.value.key == key


def test_planes_with_the_consistent_mass_take_roller_and_sticky_only():
    model = _world([FLOOR], walls="roller").model
    with pytest.raises(InputError, match="consistent mass the planes must be roller") as err:
        dataclasses.replace(model, mass_matrix="consistent", transfer="musl")
    assert err.value.key == "planes[0].kind"
    roller = dataclasses.replace(model, mass_matrix="consistent",
                                 planes=(timpm.Plane((0.0, 0.1), (0.0, -1.0), "roller"),))
    assert roller.planes[0].kind == "roller"


SCENE = """\
[simulation]
t_end = 0.01
transfer = "musl"

[domain]
size = [1.0, 1.0]
cells = 4

[[plane]]
point = [0.0, 0.1]
normal = [0.0, -1.0]
kind = "friction"
mu = 0.3

[material.soil]
type = "linear-elastic"
E = 1e5
nu = 0.3
density = 1000.0

[[body]]
material = "soil"
shape = "box"
lo = [0.25, 0.25]
hi = [0.75, 0.75]
"""


def test_a_scene_file_poses_planes(tmp_path):
    from timpm.scenefile import load_scene
    path = tmp_path / "plane.toml"
    path.write_text(SCENE)
    world = load_scene(path).world
    assert world.model.planes == (timpm.Plane((0.0, 0.1), (0.0, -1.0), "friction", 0.3),)
    wet = load_scene(path, overrides={"plane[0].drained": True, "plane[0].kind": "sticky",
                                      "plane[0].mu": None, "body[0].water":
                                      {"porosity": 0.4, "conductivity": 1e-5},
                                      "water.analysis": "coupled"}).world
    assert wet.model.planes[0].drained and wet.model.planes[0].kind == "sticky"


@pytest.mark.parametrize("old, new, line, key", [
    ("normal = [0.0, -1.0]", "normal = [0.0, 0.0]", 11, "plane[0].normal"),
    ("normal = [0.0, -1.0]", "normal = [0.0, -1.0, 0.0]", 11, "plane[0].normal"),
    ("point = [0.0, 0.1]", "point = [0.0, 0.1, 0.0]", 10, "plane[0].point"),
    ('kind = "friction"', 'kind = "glue"', 12, "plane[0].kind"),
    ('kind = "friction"', 'kind = "slip"', 13, "plane[0].mu"),
    ("mu = 0.3", "mu = 0.3\ndrained = true", 14, "plane[0].drained"),
    ("mu = 0.3", "mu = 0.3\ndrained = 1", 14, "plane[0].drained"),
    ("mu = 0.3", "mu = 0.3\nmue = 0.3", 14, "plane[0].mue"),
    ("point = [0.0, 0.1]", "point = [0.0, 0.5]", 9, "plane[0]"),
    ("normal = [0.0, -1.0]\n", "", 9, "plane[0]")])
def test_scene_file_plane_errors_name_key_and_line(tmp_path, old, new, line, key):
    from conftest import scene_file_error

    assert old in SCENE
    message = scene_file_error(tmp_path / "plane.toml", SCENE.replace(old, new))
    assert f"plane.toml:{line}: {key}" in message


def test_a_1d_scene_file_refuses_planes(tmp_path):
    from conftest import scene_file_error

    text = SCENE.replace("size = [1.0, 1.0]", "size = [1.0]").replace(
        "lo = [0.25, 0.25]\nhi = [0.75, 0.75]", "lo = [0.25]\nhi = [0.75]")
    message = scene_file_error(tmp_path / "plane.toml", text)
    assert re.search(r"plane.toml:9: plane\[0\]: plane walls stand in 2D", message)
