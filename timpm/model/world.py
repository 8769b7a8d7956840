"""Scenes of bodies in a box: a box-shaped domain in 1D, 2D or 3D, bodies of material,
walls and gravity.

A :class:`World` is, like :class:`timpm.model.scene.Scene`, a checked, immutable builder of the
one model of 1D to 3D (:class:`timpm.model.Model`), which the engine reads.  Bodies are
shapes (:class:`Box`, :class:`Ball`, :class:`Points`) filled with a regular lattice of
``ppc`` particles per cell and axis; walls bound the domain (``sticky``, ``slip``, Coulomb
``friction`` or none, per side), and plane walls at any angle stand inside it (``planes``,
:class:`~timpm.model.walls.Plane`); the grid covers the domain and a padding band as wide as
the basis support on each side, so a particle that touches a wall still has its whole
stencil on the grid (the clamped B-splines ``bsplineN`` need none: their grid ends at the
walls).

Axes: x to the right, y up, z towards the viewer; gravity points down y by default (down x
in 1D).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..bases import Basis, get_basis
from ..platform.checks import check_size, positive as _positive, positive_int, vector as _vector
from .geometry import Polygon, Prism
from ..platform.errors import InputError, about
from .geostatic import K0, GravityLoading, geostatic_stress, jaky_k0
from .loads import field_function
from ..materials import MATERIALS, Material, get_material
from ..materials.mohr_coulomb_field import MohrCoulombField
from ..materials.pore_water import PoreWater
from .random_field import RandomField
from .model import (ND_BASES, SIDES, TRANSFERS, WALL_KINDS, Model, Plane, Wall,
                    check_scheme, walls_from)

__all__ = ["Box", "Ball", "Points", "Polygon", "Prism", "K0", "Body", "Wall", "Plane", "World",
           "ND_BASES", "TRANSFERS", "WALL_KINDS",
           "SIDES", "PRESETS"]


#: named materials with typical parameters (SI units)
PRESETS = {
    "sand": ("drucker-prager", dict(E=3.5e5, nu=0.3, density=1500.0, friction_angle=30.0)),
    "rubber": ("neo-hookean", dict(E=1e3, nu=0.3, density=1e3)),
    "water": ("fluid", dict(bulk_modulus=2e5, density=1e3, gamma=7.0)),
}


_PRESET_MATERIALS = {}


def _preset(name):
    """One material object per preset name, so that bodies of a preset share it (one
    compiled update, no per-particle material index)."""
    if name not in _PRESET_MATERIALS:
        kind, params = PRESETS[name]
        _PRESET_MATERIALS[name] = get_material(kind, **params)
    return _PRESET_MATERIALS[name]


@dataclass(frozen=True)
class Box:
    """Axis-aligned box [lo, hi), half-open as a :class:`~timpm.model.geometry.Polygon`:
    a lattice point on a face shared with another box or a polygon's edge belongs to one
    body only (the one above or to the right), so bodies that only touch are filled once
    and do not overlap."""

    lo: tuple
    hi: tuple

    def __post_init__(self):
        lo, hi = _vector("Box lo", self.lo), _vector("Box hi", self.hi, len(self.lo))
        if np.any(hi <= lo):
            raise ValueError(f"Box hi {tuple(map(float, hi))} must exceed lo "
                             f"{tuple(map(float, lo))} on every axis")
        object.__setattr__(self, "lo", tuple(map(float, lo)))
        object.__setattr__(self, "hi", tuple(map(float, hi)))

    @property
    def dim(self):
        return len(self.lo)

    def bounds(self):
        return np.array(self.lo), np.array(self.hi)

    def contains(self, x):
        return np.all((x >= np.array(self.lo)) & (x < np.array(self.hi)), axis=-1)


@dataclass(frozen=True)
class Ball:
    """Disk (2D) or ball (3D) of ``radius`` around ``center``."""

    center: tuple
    radius: float

    def __post_init__(self):
        c = _vector("Ball center", self.center)
        r = float(self.radius) if np.isscalar(self.radius) else float("nan")
        if not (math.isfinite(r) and r > 0):
            raise ValueError(f"Ball radius must be positive, got {self.radius!r}")
        object.__setattr__(self, "center", tuple(map(float, c)))
        object.__setattr__(self, "radius", r)

    @property
    def dim(self):
        return len(self.center)

    def bounds(self):
        c = np.array(self.center)
        return c - self.radius, c + self.radius

    def contains(self, x):
        return np.sum((x - np.array(self.center)) ** 2, axis=-1) <= self.radius ** 2


@dataclass(frozen=True, eq=False)
class Points:
    """Particles at given ``positions`` (n x dim), each of ``volume`` (one value or n):
    for scenes built elsewhere (a point cloud, another code's initial state).  A body of
    points ignores ``ppc`` and holds no region, so other bodies may not be tested against it
    for overlap."""

    positions: object
    volume: object

    def __post_init__(self):
        try:
            x = np.array(self.positions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError("Points positions must be an (n, dim) array of numbers") from None
        if x.ndim != 2 or x.shape[0] == 0 or x.shape[1] not in (1, 2, 3):
            raise ValueError(f"Points positions must be an (n, dim) array, dim 1, 2 or 3, got "
                             f"shape {x.shape}")
        if not np.all(np.isfinite(x)):
            bad = int(np.flatnonzero(~np.all(np.isfinite(x), axis=1))[0])
            raise ValueError(f"Points position {bad} is not finite: {x[bad]}")
        vol = np.broadcast_to(np.array(self.volume, dtype=np.float64), (len(x),)).copy()
        if not np.all(np.isfinite(vol) & (vol > 0)):
            raise ValueError(f"Points volume must be positive and finite, got {self.volume!r}")
        x.setflags(write=False)
        vol.setflags(write=False)
        object.__setattr__(self, "positions", x)
        object.__setattr__(self, "volume", vol)

    def __repr__(self):
        return f"Points({len(self.positions)} particles)"

    @property
    def dim(self):
        return self.positions.shape[1]

    def bounds(self):
        return self.positions.min(axis=0), self.positions.max(axis=0)

    def contains(self, x):
        return np.zeros(np.shape(x)[:-1], dtype=bool)


@dataclass(frozen=True)
class Body:
    """A shape filled with one material, moving at ``velocity``, ``ppc`` particles per cell
    and axis.  ``material`` is a material object or a preset name (``PRESETS``).
    ``displacement`` a function u0(X) of the body's (n, dim) reference positions: the body
    starts deformed (see :class:`~timpm.model.Model`: particles at X + u0, F = I + grad
    u0, its stresses)."""

    shape: object
    material: object
    velocity: tuple | None = None
    ppc: int = 2
    name: str = ""
    displacement: object = None
    water: object = None
    random_field: object = None

    def __post_init__(self):
        mat = self.material
        if isinstance(mat, str):
            if mat in PRESETS:
                mat = _preset(mat)
            else:
                raise ValueError(f"unknown material {mat!r}: choose a preset "
                                 f"({', '.join(PRESETS)}), or build one of "
                                 f"{', '.join(MATERIALS)} with timpm.get_material")
        if not isinstance(mat, Material):
            raise ValueError(f"body material must be a timpm material or a preset name, got {mat!r}")
        object.__setattr__(self, "material", mat)
        if not hasattr(self.shape, "contains"):
            raise ValueError(f"body shape must be a Box, a Ball, a Polygon, a Prism or Points, "
                             f"got {self.shape!r}")
        positive_int("ppc (particles per cell and axis)", self.ppc)
        if self.water is not None and not isinstance(self.water, PoreWater):
            raise InputError(f"body water must be a timpm.PoreWater (the water in the "
                             f"body's pores) or None, got {self.water!r}", "water")
        if self.random_field is not None:
            if not isinstance(self.random_field, RandomField):
                raise InputError(f"body random_field must be a timpm.RandomField (the "
                                 f"strength's variation) or None, got {self.random_field!r}",
                                 "random_field")
            self.random_field.check_soil(mat, f"body {self.name!r}" if self.name else "body",
                                         self.water)
        if self.displacement is not None and not callable(self.displacement):
            raise ValueError("body displacement must be a function u0(X) of the body's (n, "
                             f"dim) reference positions, got {type(self.displacement).__name__}")


class _BodyDisplacements:
    """The model's u0(X) of a world whose bodies start displaced: each body's function on
    its own rows (the model evaluates u0 at the particles' n positions, shifted, in
    particle order), zero for the other bodies."""

    def __init__(self, bodies, body_index):
        self.parts = [(k, np.flatnonzero(body_index == k), b.displacement)
                      for k, b in enumerate(bodies) if b.displacement is not None]
        self.n = len(body_index)

    def __call__(self, X):
        X = np.asarray(X, dtype=np.float64)
        if X.shape[0] != self.n:
            raise ValueError(f"a world's displacement is evaluated at its {self.n} particles, "
                             f"got {X.shape[0]} points")
        out = np.zeros_like(X)
        for k, rows, u0 in self.parts:
            out[rows] = field_function(u0, X[rows], f"body {k}'s displacement u0(X)")
        return out


#: a Model's keyword -> the World's that gave it (an error the Model raises names the
#: World's argument; InputError.key)
_WORLD_KEY_OF_MODEL = {"positions": "bodies", "materials": "bodies", "elements": "domain",
                       "h": "cells", "origin": "domain", "mass_matrix": "transfer",
                       "projection": "transfer", "particle_force": "tractions",
                       "level": "water.level", "analysis": "water.analysis",
                       "seepage": "water.seepage", "phreatic": "water.phreatic",
                       "smoothing": "water.smoothing", "drained_sides": "water.drained_sides",
                       "side_pressure": "water.side_pressure",
                       "side_pressure_time": "water.side_pressure_time",
                       "pore_water": "bodies", "conductivity": "bodies",
                       "pore_conductivity": "bodies"}


@dataclass(frozen=True, eq=False)
class World:
    """A scene in 1D, 2D or 3D: ``domain`` lengths (from the origin), ``cells`` along x; a
    builder of the one :class:`~timpm.model.Model` of 1D to 3D (``world.model``).

    ``walls`` is one wall for every side, or a dict of side name (``SIDES``) to wall with
    an optional ``"default"`` (None: no wall on that side; material may leave the domain
    and the grid, which stops the run with an error); ``fixed_nodes`` grid nodes (index
    tuples of the padded grid, ``world.model.nodes``) held at zero velocity, or a dict of
    node to prescribed velocity (times the time function ``fixed_time``).  ``tractions``
    lists :class:`~timpm.model.loads.SurfaceTraction` loads on the faces of bodies (2D, 3D; one
    time function for all).  Gravity points down y in 2D and 3D, down x
    in 1D, unless given.  ``dt=None`` picks ``courant`` (default 0.4) times the CFL
    limit h / (c + |v|), where c is the stiffest material's wave speed and |v| bounds the speed
    (the initial speed plus the free-fall speed over the domain's extent along gravity); a given ``dt``
    above the limit is refused unless ``allow_unstable_dt``.  ``integrator``: the time
    integration (``timpm.model.INTEGRATORS``; rk4 takes roller and sticky walls only).
    ``transfer_params``: the transfer scheme's parameters (``pic_fraction`` the musl
    transfer's, also given on its own; :class:`~timpm.model.Model`).
    ``initial_stress``: :class:`~timpm.model.geostatic.K0` (the K0 procedure: the weight of the
    bodies above each particle, sigma_h = K0 sigma_v), :class:`~timpm.model.geostatic.
    GravityLoading` (a damped run under gravity to rest, which the Solver makes first), an
    (n, 3, 3) array of Cauchy stresses, or None (stress-free); under water the K0
    procedure's stress is effective, from the buoyant weight below the level.
    ``water``: the scene's :class:`~timpm.model.water.Water` (its analysis and still-water
    level) where some body carries pore water (``Body(water=PoreWater(...))``);
    ``initial_pore_pressure`` the particles' initial excess pore pressures (n,).
    ``planes``: plane walls at any angle (2D, 3D; :class:`~timpm.model.walls.Plane`: a point,
    the normal out of the material into the wall, a kind, mu, drained), besides the box's
    walls; every body must start on their material side.
    """

    domain: tuple
    cells: int
    bodies: tuple
    basis: "str | type[Basis]" = "uniform-bspline2"  # the class once checked
    transfer: str = "apic"
    gravity: tuple | None = None
    walls: object = "slip"
    dt: float | None = None
    courant: float | None = None
    allow_overlap: bool = False
    allow_unstable_dt: bool = False
    damping: float = 0.0
    pic_fraction: float = 0.0
    transfer_params: dict | None = None
    fixed_nodes: tuple = ()
    fixed_time: object = None
    tractions: tuple = ()
    name: str = "world"
    integrator: str = "euler-cromer"
    initial_stress: object = None
    water: object = None
    initial_pore_pressure: object = None
    planes: tuple = ()
    _particles: dict = field(default=None, repr=False)

    def __post_init__(self):
        # each check's error names the argument it is about (InputError.key)
        with about("domain"):
            domain = _vector("domain", self.domain)
            dim = len(domain)
            if dim not in (1, 2, 3):
                raise ValueError(f"a World is 1D, 2D or 3D, got a {dim}-dimensional domain")
            if np.any(domain <= 0):
                raise ValueError(f"domain lengths must be positive, got "
                                 f"{tuple(map(float, domain))}")
        with about("cells"):
            positive_int("cells (along x)", self.cells)
        h = domain[0] / int(self.cells)
        n = np.rint(domain / h).astype(int)
        with about("domain"):
            if np.any(np.abs(n * h - domain) > 1e-9 * domain):
                raise ValueError(f"domain {tuple(map(float, domain))} is not a whole number of "
                                 f"cells of size h = {h:g} (domain[0] / cells) on every axis")
        with about("basis"):
            basis = get_basis(self.basis)
            if not basis.nd:
                raise ValueError(f"the {basis.name} basis is 1D only: a World's grid takes "
                                 f"{', '.join(ND_BASES)} (a Scene takes every basis)")
        params = check_scheme(dim, basis, self.transfer, damping=self.damping,
                              pic_fraction=self.pic_fraction,
                              transfer_params=self.transfer_params)
        with about("gravity"):
            g = np.zeros(dim) if self.gravity is None else _vector("gravity", self.gravity, dim)
        if self.gravity is None:
            g[min(1, dim - 1)] = -9.81  # down y in 2D and 3D, down x in 1D
        bodies = tuple(self.bodies) if not isinstance(self.bodies, Body) else (self.bodies,)
        if not bodies:
            raise InputError("a World needs at least one body", "bodies")
        for k, b in enumerate(bodies):
            if not isinstance(b, Body):
                raise InputError(f"bodies[{k}] must be a Body, got {b!r}", f"bodies[{k}]")
        object.__setattr__(self, "bodies", bodies)
        object.__setattr__(self, "domain", tuple(map(float, domain)))
        object.__setattr__(self, "gravity", tuple(g))
        object.__setattr__(self, "basis", basis)
        with about("walls"):
            object.__setattr__(self, "walls", walls_from(self.walls, dim, open_ok=True))
        object.__setattr__(self, "_particles", self._fill(dim, h, domain))
        self._check_dt(h, g, domain)
        if self.water is not None and self.water.level is not None:
            up = min(1, dim - 1)
            if not self.water.level > 0.0:
                raise InputError(f"water: the level {self.water.level:g} m lies below the "
                                 f"domain (its bottom is at {'xyz'[up]} = 0)", "water.level")
        with about("tractions"):
            forces, force_time = self._surface_forces(dim, h)
        with about("initial_stress"):
            initial_stress = self._initial_stress(dim, g, domain)
        with about("model", rename=_WORLD_KEY_OF_MODEL):
            model = self._model(basis, h, g, n, params, forces, force_time, initial_stress)
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "fixed_nodes", model.fixed_nodes)
        object.__setattr__(self, "planes", model.planes)

    def _model(self, basis, h, g, n, params, forces, force_time, initial_stress):
        part = self._particles
        return Model(basis=basis, origin=self.origin, h=h, elements=self.grid_elements,
                      positions=part["positions"], volume=part["volume"],
                      velocity=part["velocity"], materials=part["materials"],
                      material_index=part["material_index"], body_index=part["body_index"],
                      dt=self.dt, transfer=self.transfer, gravity=tuple(g),
                      damping=self.damping, transfer_params=params, walls=self.walls,
                      wall_cells=tuple((pad, pad + c) for pad, c in zip(self.pads, n)),
                      fixed_nodes=(dict(self.fixed_nodes) if isinstance(self.fixed_nodes, dict)
                                   else tuple(self.fixed_nodes)),
                      fixed_time=self.fixed_time, particle_force=forces,
                      particle_force_time=force_time, name=self.name,
                      integrator=self.integrator,
                      displacement=(_BodyDisplacements(self.bodies, part["body_index"])
                                    if any(b.displacement is not None for b in self.bodies)
                                    else None),
                      initial_stress=initial_stress, water=self.water,
                      pore_water=part["pore_water"],
                      initial_pore_pressure=self.initial_pore_pressure,
                      particle_values=part["particle_values"],
                      pore_conductivity=part["conductivity"], planes=self.planes)

    def _initial_stress(self, dim, g, domain):
        """The particles' initial stresses: a :class:`~timpm.model.geostatic.K0` procedure's
        geostatic stress, or the (n, 3, 3) array given (None: stress-free)."""
        spec = self.initial_stress
        if isinstance(spec, GravityLoading):
            return None  # computed by a loading run (timpm.simulation.loading), stress-free before it
        if isinstance(spec, str):
            raise ValueError(f"initial_stress={spec!r}: give timpm.K0() (the K0 procedure), "
                             "timpm.GravityLoading() (a damped run under gravity to rest), an "
                             "(n, 3, 3) array of Cauchy stresses, or None")
        if not isinstance(spec, K0):
            return spec
        if dim == 1:
            raise ValueError("the K0 procedure sets the stresses of 2D and 3D ground")
        if not (g[1] < 0.0 and np.all(g[np.arange(dim) != 1] == 0.0)):
            raise ValueError(f"the K0 procedure weighs the ground along -y: gravity must point "
                             f"down y, got {tuple(float(v) for v in g)}")
        for k, b in enumerate(self.bodies):
            if isinstance(b.shape, Points):
                raise ValueError(f"the K0 procedure integrates the weight through the bodies' "
                                 f"shapes: body {k} is Points (give its stresses as an array)")
        part = self._particles
        mats = part["materials"]
        k0 = (np.full(len(part["positions"]), spec.k0) if spec.k0 is not None else
              np.array([jaky_k0(m) for m in mats])[part["material_index"]])
        # under a water level the weight is the buoyant one and the stress effective
        level = None if self.water is None else self.water.table  # y_w(x), or None
        return geostatic_stress(part["positions"],
                                [(b.shape, b.material.density,
                                  0.0 if b.water is None else b.water.density)
                                 for b in self.bodies],
                                -float(g[1]), float(domain[1]), k0, level=level)

    # ---- derived geometry ----------------------------------------------------------------
    @property
    def dim(self) -> int:
        return len(self.domain)

    @property
    def h(self) -> float:
        return self.domain[0] / self.cells

    @property
    def padding(self) -> int:
        """Cells of grid beyond each wall: the basis support; none for the clamped
        B-splines, whose grid ends at the walls (their partition of unity holds up to the
        boundary, and the wall acts on the one node layer there)."""
        basis = self.basis
        return basis.support if basis.uniform_nodes else 0

    @property
    def pads(self) -> tuple:
        """The padding per axis: none along a periodic x (the grid is the period)."""
        walls = self.walls
        if not isinstance(walls, tuple):
            try:
                walls = walls_from(walls, self.dim, open_ok=True)
            except ValueError:
                walls = ()
        periodic = bool(walls) and walls[0] is not None and walls[0].kind == "periodic"
        return tuple(0 if periodic and k == 0 else self.padding for k in range(self.dim))

    @property
    def grid_elements(self) -> tuple:
        return tuple(int(round(L / self.h)) + 2 * pad for L, pad in zip(self.domain, self.pads))

    @property
    def origin(self) -> tuple:
        return tuple(-pad * self.h for pad in self.pads)

    def _check_size(self, dim, h, domain):
        """The grid and the lattices the bodies are filled from, checked before either is
        allocated (:func:`timpm.platform.checks.check_size`)."""
        basis = self.basis
        nodes = np.prod([float(basis.n_nodes(e)) for e in self.grid_elements])
        particles = 0.0
        for body in self.bodies:
            if isinstance(body.shape, Points):
                particles += len(body.shape.positions)
            elif body.shape.dim == dim:  # else _fill names the mismatch
                lo, hi = body.shape.bounds()
                lo, hi = np.maximum(lo, 0.0), np.minimum(hi, domain)
                dx = h / body.ppc
                particles += float(np.prod(np.maximum(np.ceil(hi / dx) - np.floor(lo / dx), 0)))
        check_size(f"a World of {self.cells} cells along x", particles, nodes, dim)

    def _fill(self, dim, h, domain):
        self._check_size(dim, h, domain)
        xs, vs, vols, mats, ids = [], [], [], [], []
        materials = []
        # random fields: (first row, strength values), (first row, conductivities), body ->
        # its realisation
        strength, conductivity, realised = [], [], {}
        for k, body in enumerate(self.bodies):
            label = f"body {k}" + (f" ({body.name!r})" if body.name else "")
            if body.shape.dim != dim:
                raise InputError(f"{label}: a {body.shape.dim}D shape in a {dim}D domain",
                                 f"bodies[{k}]")
            lo, hi = body.shape.bounds()
            if np.any(lo < -1e-12 * domain) or np.any(hi > domain * (1 + 1e-12)):
                raise InputError(f"{label}: {body.shape} extends outside the domain "
                                 f"[0, {tuple(float(d) for d in domain)}]", f"bodies[{k}]")
            if isinstance(body.shape, Points):
                pts, vol = body.shape.positions, body.shape.volume
            else:
                # a regular lattice of ppc points per cell and axis, kept inside the shape
                dx = h / body.ppc
                axes = [np.arange(np.floor(lo[a] / dx), np.ceil(hi[a] / dx)) * dx + 0.5 * dx
                        for a in range(dim)]
                pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
                pts = pts[body.shape.contains(pts)]
                vol = np.full(len(pts), dx ** dim)
            if len(pts) == 0:
                raise InputError(f"{label}: {body.shape} holds no particle at {body.ppc} per "
                                 f"cell and axis (h = {h:g}): make it larger or raise ppc",
                                 f"bodies[{k}]")
            with about(f"bodies[{k}]"):
                v = np.zeros(dim) if body.velocity is None else _vector(
                    f"{label} velocity", body.velocity, dim)
            slot = (body.material, body.water)  # a material slot: a law and its pore water
            if body.random_field is not None:
                real = body.random_field.realise(body.material, pts, h, np.zeros(dim),
                                                 body.water)
                first = sum(len(a) for a in xs)
                if body.random_field.strength_of(body.material):
                    # its own law, its strength per particle
                    law = MohrCoulombField.of(body.material)
                    slot = (law, body.water)
                    strength.append((first, law.strength_values(
                        real["cohesion"], real["friction_angle"], body.material.factor)))
                if "conductivity" in real:
                    conductivity.append((first, real["conductivity"]))
                realised[k] = real
            if slot not in materials:
                materials.append(slot)
            xs.append(pts)
            vs.append(np.broadcast_to(v, pts.shape))
            vols.append(vol)
            mats.append(np.full(len(pts), materials.index(slot), np.int32))
            ids.append(np.full(len(pts), k, np.int32))
        if not self.allow_overlap:
            for i, bi in enumerate(self.bodies):
                for j, bj in enumerate(self.bodies):
                    if i != j and np.any(bi.shape.contains(xs[j])):
                        raise InputError(
                            f"bodies {i} and {j} overlap ({bi.shape} holds particles of "
                            f"{bj.shape}); move them apart or pass allow_overlap=True",
                            f"bodies[{max(i, j)}]")
        x = np.concatenate(xs)
        vol = np.concatenate(vols)
        mat = np.concatenate(mats)
        density = np.array([m.density for m, _ in materials])[mat]
        out = dict(positions=x, velocity=np.concatenate(vs).copy(), volume=vol,
                   mass=density * vol, material_index=mat, body_index=np.concatenate(ids),
                   materials=tuple(m for m, _ in materials),
                   pore_water=tuple(w for _, w in materials))
        values = None
        if strength:  # the particles' strength where a body's varies (MohrCoulombField)
            values = np.zeros((len(x), 5))
            for first, block in strength:
                values[first:first + len(block)] = block
            values = {"strength": values}
        k_field = None
        if conductivity:  # the pore water's conductivity per particle (nan: the body's own)
            k_field = np.full(len(x), np.nan)
            for first, block in conductivity:
                k_field[first:first + len(block)] = block
        out.update(particle_values=values, random_fields=realised, conductivity=k_field)
        for key in ("positions", "velocity", "volume", "mass", "material_index", "body_index"):
            out[key].setflags(write=False)
        return out

    def _surface_forces(self, dim, h):
        """The particle forces of the surface tractions ((n, dim) or None) and their one
        time function: each particle within half a particle spacing of the body's extreme
        on the loaded side carries traction * V_p / dx, dx = h / ppc."""
        tractions = tuple(self.tractions)
        if not tractions:
            return None, None
        if dim == 1:
            raise ValueError("surface tractions act on faces of 2D and 3D bodies; in 1D use "
                             "a Scene's traction (timpm.Traction)")
        x, bodies = self.positions, self.body_index
        forces = np.zeros_like(x)
        for k, load in enumerate(tractions):
            with about(f"tractions[{k}]"):
                self._check_traction(k, load, dim)
            body = self.bodies[load.body]
            axis, upper = divmod(SIDES.index(load.side), 2)
            mine = bodies == load.body
            coord = x[:, axis]
            extreme = coord[mine].max() if upper else coord[mine].min()
            dx = h / body.ppc
            face = mine & (np.abs(coord - extreme) < 0.5 * dx)
            forces[face] += np.outer(self.volume[face] / dx, load.traction)
        times = {type(t.time_function) for t in tractions}
        params = {t.time_function.param for t in tractions}
        if len(times) > 1 or len(params) > 1:
            raise ValueError("the surface tractions of a World share one time function; got "
                             f"{[t.time_function for t in tractions]}")
        return forces, tractions[0].time_function

    def _check_traction(self, k, load, dim):
        from .loads import SurfaceTraction

        if not isinstance(load, SurfaceTraction):
            raise ValueError(f"tractions[{k}] must be a timpm.model.loads.SurfaceTraction, "
                             f"got {load!r}")
        if not (isinstance(load.body, (int, np.integer)) and 0 <= load.body < len(self.bodies)):
            raise ValueError(f"tractions[{k}]: body {load.body!r} does not exist "
                             f"({len(self.bodies)} bodies)")
        if load.side not in SIDES[:2 * dim]:
            raise ValueError(f"tractions[{k}]: unknown side {load.side!r}: the sides of a "
                             f"{dim}D body are {', '.join(SIDES[:2 * dim])}")
        if len(load.traction) != dim:
            raise ValueError(f"tractions[{k}]: the traction must have {dim} components, "
                             f"got {load.traction}")
        if isinstance(self.bodies[load.body].shape, Points):
            raise ValueError(f"tractions[{k}]: body {load.body} is a point cloud, without "
                             "faces or a particle spacing")

    def _check_dt(self, h, g, domain):
        c = max(self._wave_speed(b) for b in self.bodies)
        with np.errstate(over="ignore", invalid="ignore"):
            v0 = float(np.max(np.linalg.norm(self.velocity, axis=1)))
            g_norm = float(np.linalg.norm(g))
            height = float(np.abs(g) @ domain) / g_norm if g_norm > 0 else 0.0  # along g
            v_fall = math.sqrt(2.0 * g_norm * height) if math.isfinite(g_norm) else math.inf
        self._check_speeds(g_norm, v0, v_fall)
        limit = h / (c + v0 + v_fall)
        object.__setattr__(self, "_cfl", dict(c=c, v=v0 + v_fall, limit=limit))
        if self.courant is None:
            object.__setattr__(self, "courant", 0.4)
        courant = float(self.courant)
        if not (0.0 < courant <= 1.0):
            raise InputError(f"courant number must lie in (0, 1], got {self.courant!r}",
                             "courant")
        if self.dt is None:
            object.__setattr__(self, "dt", courant * limit)
            return
        with about("dt"):
            dt = _positive("time step dt", self.dt)
        object.__setattr__(self, "dt", dt)
        if dt > limit and not self.allow_unstable_dt:
            raise InputError(
                f"time step dt = {dt:g} s exceeds the CFL limit h / (c + |v|) = {limit:g} s "
                f"(h = {h:g} m, wave speed c = {c:g} m/s of the stiffest material, |v| <= "
                f"{v0 + v_fall:g} m/s: initial speed plus free fall over the domain height); "
                "choose a smaller dt, leave dt=None, or pass allow_unstable_dt=True", "dt")

    def _check_speeds(self, g_norm, v0, v_fall):
        """The speeds the CFL limit adds up, each finite: a value so large that a speed
        overflows (a modulus near the float's limit, a velocity or a gravity of 1e300) is
        refused naming its own key, not the time step it would make 0 or NaN."""
        for k, body in enumerate(self.bodies):
            label = f"body {k}" + (f" ({body.name!r})" if body.name else "")
            c = self._wave_speed(body)
            if not (math.isfinite(c) and c > 0.0):
                raise InputError(
                    f"{label}: the {body.material.name} material's wave speed is {c:g} m/s "
                    f"(its moduli over its density overflow a float): give moduli and a "
                    f"density of physical size (SI units)", f"bodies[{k}]")
        for k, body in enumerate(self.bodies if not math.isfinite(v0) else ()):
            with np.errstate(over="ignore", invalid="ignore"):
                v = np.asarray(body.velocity if body.velocity is not None else 0.0, float)
                speed = float(np.linalg.norm(v))
            if not math.isfinite(speed):
                raise InputError(f"body {k}: its initial speed overflows a float (velocity "
                                 f"{tuple(float(c) for c in np.ravel(v))}): give a velocity "
                                 "of physical size (m/s)", f"bodies[{k}]")
        if not (math.isfinite(g_norm) and math.isfinite(v_fall)):
            raise InputError(f"gravity {tuple(float(v) for v in np.ravel(self.gravity))} "
                             "overflows a float in the free fall over the domain (the CFL "
                             "limit's sqrt(2 |g| H)): give a gravity of physical size (m/s^2)",
                             "gravity")

    def _wave_speed(self, body):
        """The fastest wave in a body: its law's, or with pore water that moves with the
        skeleton (undrained and coupled analyses) the undrained compression wave
        sqrt((lambda + 2 mu + K_w / n) / rho)."""
        mat, water = body.material, body.water
        c = mat.wave_speed
        if water is not None and self.water is not None and self.water.pore_pressure:
            c = math.sqrt(c * c + water.storage_modulus / mat.density)
        return c

    # ---- particles ---------------------------------------------------------------------
    @property
    def positions(self):
        return self._particles["positions"]

    @property
    def velocity(self):
        return self._particles["velocity"]

    @property
    def volume(self):
        return self._particles["volume"]

    @property
    def mass_per_particle(self):
        return self._particles["mass"]

    @property
    def material_index(self):
        return self._particles["material_index"]

    @property
    def body_index(self):
        return self._particles["body_index"]

    @property
    def random_fields(self) -> dict:
        """Each random body's realisation (body index -> {"cohesion", "friction_angle": its
        particles' values (in the body's particle order), "clipped", "cells"}): the
        unreduced soil's (a strength-reduced body's particles hold them divided by its
        factor, MohrCoulombField.strength_values)."""
        return self._particles["random_fields"]

    @property
    def materials(self) -> tuple:
        return self._particles["materials"]

    @property
    def n_particles(self) -> int:
        return len(self.positions)

    @property
    def cfl_limit(self) -> float:
        """h / (c + |v|): the largest time step the scene accepts."""
        return self._cfl["limit"]
