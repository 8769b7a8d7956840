"""Walls: on the sides of a box domain, their kinds and the spec a user gives per side
(:class:`Wall`, :func:`walls_from`; :class:`~timpm.model.Model` takes one per side), and
plane walls at any angle (:class:`Plane`).

A plane wall is the half-space beyond a plane through ``point`` with the unit ``normal``
pointing out of the material, into the wall (2D and 3D): a sloping bedrock, a tilted
table, a rotated box.  It acts, as a box wall does at and beyond its edge node, on the grid
nodes on or beyond it: node i with (x_i - p) . n >= -PLANE_TOLERANCE h, x_i the node's
position (its control point for the clamped B-splines, at the Greville abscissae; the
padded B-splines' nodes beyond the domain alike); :meth:`Model.plane_nodes
<timpm.model.Model.plane_nodes>` lists them.  A plane through a line of nodes along an
axis holds exactly the nodes a box wall there holds and projects their velocities to the
same numbers.  The lumped mass is untouched: the plane acts on the nodal velocities (after
the mass solve) of every node that carries mass, as the box walls do, in every scheme where
they act; a B-spline's nodes beyond the plane carry the mass of the particles within its
support (1.5 cells for the quadratic) and are held with it.  Along an inclined plane the
held nodes make a staircase and the plane cuts cells: a particle in a cut cell takes its
velocity from held nodes beyond the plane and free ones inside, so the contact is soft
within about a cell of the plane and the stress in the cut cells carries the error (the
sliding block and the turned Terzaghi column of docs/results.md).  A body must start on the
material side of every plane (Model refuses particles beyond one).

Its kinds, at a held node with velocity v and v_n = v . n: ``sticky`` v = 0; ``roller``
v_n = 0 both ways (v -= v_n n); ``slip`` v -= v_n n only where v_n > 0 (moving into the
wall: the material may separate); ``friction`` besides slows the tangential part v_t = v -
v_n n by mu v_n, down to rest (Coulomb).  Where planes (or a plane and a box wall) meet,
their projections follow one another in order (box walls first, then the planes in the
order given): exact where the walls are orthogonal, a sequence of projections at an acute
corner.

In a coupled analysis (``Water(analysis="coupled")``) a plane is impermeable unless
``drained``: at its held nodes the water's normal velocity is made the skeleton's, w -=
(w . n - v . n) n with v the skeleton's velocity after the walls, its tangential part free
(the water flows along the wall).  (The box walls apply their own projection to the water
as to the skeleton, which for a sticky wall also holds the water's tangential flow.)  A
``drained`` plane holds the skeleton only: at its nodes the water solves its own balance
with the skeleton's velocity held, as on a drained side (``Water.drained_sides``), the
excess pore pressure vanishing there (the weak form's natural condition).  The coupled
step takes the water's velocity at a node from F_w / (M_w / dt + Q): at a node the body
barely touches (a drained plane's held node a particle just reaches, a free surface that
cuts a cell near a node) it is large and the step can blow up (docs/results.md).
"""
import math
from dataclasses import dataclass

import numpy as np

from ..platform.checks import shown_point, vector
from ..platform.errors import InputError

__all__ = ["Wall", "walls_from", "SIDES", "WALL_KINDS", "Plane", "PLANE_KINDS",
           "PLANE_TOLERANCE", "checked_planes", "plane_nodes"]

#: the sides of a box, two per axis: x, then y, then z
SIDES = ("left", "right", "bottom", "top", "back", "front")
WALL_KINDS = ("sticky", "slip", "friction", "roller", "periodic")
#: the kinds of a plane wall (a box wall's, but periodic)
PLANE_KINDS = ("sticky", "slip", "friction", "roller")
#: a node (a particle) within this many cells beyond a plane counts as on it
PLANE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Wall:
    """A wall: ``sticky`` (material touching it is held: no motion, no separation),
    ``slip`` (no penetration, no friction), ``friction`` (Coulomb, coefficient ``mu``) or
    ``roller`` (no normal motion either way, no friction: the symmetry plane and the
    bilateral u_n = 0 of a Dirichlet side); slip and friction walls let the material
    separate.  ``periodic`` on both the left and the right side makes x periodic (no wall:
    the material leaving on one side enters on the other, the grid's last column of nodes
    is its first: an infinite slope, a shear layer).  A sticky wall with a ``velocity``
    (a vector along the wall: the wall stays where it is) drives the material touching it
    at ``velocity`` f(t), f the model's time function ``fixed_time`` (a lid-driven
    cavity, a shear box)."""

    kind: str = "slip"
    mu: float = 0.0
    velocity: tuple | None = None

    def __post_init__(self):
        if self.kind not in WALL_KINDS:
            raise ValueError(f"unknown wall {self.kind!r}: choose one of {', '.join(WALL_KINDS)}")
        mu = float(self.mu)
        if not (math.isfinite(mu) and mu >= 0.0):
            raise ValueError(f"wall friction coefficient must be finite and >= 0, got {self.mu!r}")
        if self.kind != "friction" and mu != 0.0:
            raise ValueError(f"a {self.kind} wall takes no friction coefficient (got mu={mu})")
        object.__setattr__(self, "mu", mu)
        if self.velocity is not None:
            if self.kind != "sticky":
                raise ValueError(f"a {self.kind} wall takes no velocity: a moving wall is "
                                 "sticky (it drives the material touching it)")
            v = tuple(float(c) for c in vector("wall velocity", self.velocity))
            object.__setattr__(self, "velocity", v if any(v) else None)

    @property
    def moves(self) -> bool:
        return self.velocity is not None


def _wall(value, where, open_ok):
    if value is None and open_ok:
        return None
    if isinstance(value, Wall):
        return value
    if isinstance(value, str):
        return Wall(value)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return Wall("friction", value)
    raise ValueError(f"wall {where}: give a Wall, a kind ({', '.join(WALL_KINDS)}) or a "
                     f"friction coefficient{', or None for no wall' if open_ok else ''}, "
                     f"got {value!r}")


def walls_from(spec, dim: int, default="slip", open_ok=False):
    """One wall (or None: no wall, where ``open_ok``) per side of a ``dim``-dimensional
    box from ``spec``: one wall for every side, a dict of side name to wall with an
    optional ``"default"``, or a tuple of one wall per side (what this returns)."""
    sides = SIDES[:2 * dim]
    if isinstance(spec, tuple) and len(spec) == 2 * dim and all(
            w is None or isinstance(w, Wall) for w in spec):
        return tuple(_wall(w, s, open_ok) for w, s in zip(spec, sides))
    if isinstance(spec, dict):
        unknown = set(spec) - set(sides) - {"default"}
        if unknown:
            raise ValueError(f"unknown wall side(s) {sorted(unknown)}: the sides of a "
                             f"{dim}D domain are {', '.join(sides)}")
        default = spec.get("default", default)
        return tuple(_wall(spec.get(s, default), s, open_ok) for s in sides)
    wall = _wall(spec, "for every side", open_ok)
    return (wall,) * (2 * dim)


def _finite_vector(value):
    try:
        v = np.array(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        return None
    if v.ndim != 1 or len(v) == 0 or not np.all(np.isfinite(v)) or \
            isinstance(value, (str, bytes)):
        return None
    return v


@dataclass(frozen=True)
class Plane:
    """A plane wall (see the module): the half-space (x - ``point``) . ``normal`` >= 0
    beyond the plane through ``point`` (m), ``normal`` pointing out of the material into
    the wall (any length: kept as the unit vector); ``kind`` one of ``PLANE_KINDS``, ``mu``
    the Coulomb coefficient of a friction plane; ``drained``: in a coupled analysis the
    pore water flows through it (impermeable by default, as the box walls).  Checked here
    (each error's ``key`` the argument); its dimension against the scene's by the Model."""

    point: tuple
    normal: tuple
    kind: str = "slip"
    mu: float = 0.0
    drained: bool = False

    def __post_init__(self):
        p = _finite_vector(self.point)
        if p is None or len(p) not in (2, 3):
            raise InputError(f"plane: point must be 2 or 3 finite coordinates (m), got "
                             f"{self.point!r}", "point")
        n = _finite_vector(self.normal)
        if n is None or len(n) not in (2, 3):
            raise InputError(f"plane: normal must be 2 or 3 finite components, got "
                             f"{self.normal!r}", "normal")
        length = float(np.linalg.norm(n))
        if not (math.isfinite(length) and length > 0.0):
            raise InputError(f"plane: normal must be a non-zero vector (out of the material, "
                             f"into the wall), got {self.normal!r}", "normal")
        if len(n) != len(p):
            raise InputError(f"plane: point and normal must have as many components, got "
                             f"{len(p)} and {len(n)}", "normal")
        if self.kind not in PLANE_KINDS:
            raise InputError(f"plane: unknown kind {self.kind!r}: choose one of "
                             f"{', '.join(PLANE_KINDS)}", "kind")
        ok = isinstance(self.mu, (int, float, np.integer, np.floating)) and \
            not isinstance(self.mu, bool)
        mu = float(self.mu) if ok else float("nan")
        if not (math.isfinite(mu) and mu >= 0.0):
            raise InputError(f"plane: the friction coefficient mu must be finite and >= 0, "
                             f"got {self.mu!r}", "mu")
        if self.kind != "friction" and mu != 0.0:
            raise InputError(f"plane: a {self.kind} plane takes no friction coefficient "
                             f"(got mu={mu:g}; kind='friction' takes one)", "mu")
        if not isinstance(self.drained, (bool, np.bool_)):
            raise InputError(f"plane: drained must be true or false, got {self.drained!r}",
                             "drained")
        object.__setattr__(self, "point", tuple(float(c) for c in p))
        object.__setattr__(self, "normal", tuple(float(c) for c in n / length))
        object.__setattr__(self, "mu", mu)
        object.__setattr__(self, "drained", bool(self.drained))

    @property
    def dim(self) -> int:
        return len(self.point)

    def distance(self, x):
        """The signed distance (x - point) . normal of the points ``x`` (n, dim): > 0
        beyond the plane (in the wall)."""
        return (np.asarray(x, dtype=np.float64) - np.array(self.point)) @ np.array(self.normal)


def checked_planes(model, dim) -> tuple:
    """``model.planes`` checked (:class:`~timpm.model.Model` calls it on construction),
    as a tuple: Plane walls of the scene's dimension (2D, 3D), every particle on their
    material side, mu and drained where they apply; each error's key the plane's
    (``planes[k]``, ``planes[k].normal`` ...)."""
    given = model.planes
    if given is None:
        given = ()
    elif isinstance(given, Plane):
        given = (given,)
    if isinstance(given, (str, bytes, dict)):
        raise InputError(f"planes must be a list of timpm.Plane walls, got {given!r}",
                         "planes")
    try:
        planes = tuple(given)
    except TypeError:
        raise InputError(f"planes must be a list of timpm.Plane walls, got {given!r}",
                         "planes") from None
    if not planes:
        return planes
    for k, plane in enumerate(planes):
        if not isinstance(plane, Plane):
            raise InputError(f"planes[{k}] must be a timpm.Plane (point, normal, kind), "
                             f"got {plane!r}", f"planes[{k}]")
    if dim == 1:
        raise InputError("plane walls stand in 2D and 3D scenes: a 1D bar's ends are its "
                         "walls (walls=, fixed_nodes=)", "planes")
    x = model.positions  # where the particles start: displaced, if they are
    if model.initial_displacement is not None:
        x = x + model.initial_displacement
    coupled = model.water is not None and model.water.analysis == "coupled"
    for k, plane in enumerate(planes):
        label = f"plane {k} (point {plane.point}, normal " \
                f"{tuple(round(c, 6) for c in plane.normal)})"
        if plane.dim != dim:
            raise InputError(f"{label}: a {plane.dim}D plane in a {dim}D scene",
                             f"planes[{k}].point")
        if plane.drained and not coupled:
            scene = "the scene is dry" if model.water is None else \
                f"the scene's analysis is {model.water.analysis}"
            raise InputError(f"{label}: drained lets the pore water flow through the "
                             f"plane, in a coupled analysis (Water(analysis='coupled')): "
                             f"{scene}", f"planes[{k}].drained")
        if model.periodic and plane.normal[0] != 0.0:
            raise InputError(f"{label}: x is periodic, and a plane that is not parallel "
                             "to x would not be (give its normal no x component)",
                             f"planes[{k}].normal")
        if plane.kind in ("slip", "friction") and model.integrator != "euler-cromer":
            raise InputError(f"{label}: the {model.integrator} integrator takes roller "
                             f"and sticky planes only (linear constraints), not "
                             f"{plane.kind}", f"planes[{k}].kind")
        if plane.kind in ("slip", "friction") and model.mass_matrix != "lumped":
            raise InputError(f"{label}: with the consistent mass the planes must be "
                             f"roller or sticky (constraints of the solve), not "
                             f"{plane.kind}", f"planes[{k}].kind")
        beyond = np.flatnonzero(plane.distance(x) > PLANE_TOLERANCE * model.h)
        if len(beyond):
            p = int(beyond[0])
            raise InputError(f"{label}: {len(beyond)} of {len(x)} particles start beyond "
                             f"it, in the wall (particle {p} at {shown_point(x[p])}, "
                             f"{plane.distance(x[p:p + 1])[0]:.4g} m beyond): the normal "
                             "points out of the material, into the wall", f"planes[{k}]")
    return planes


def plane_nodes(model, k=None) -> np.ndarray:
    """The grid nodes plane ``k`` holds (all planes: None), a boolean array of the
    nodes' shape: those on or beyond it, (x_i - p) . n >= -PLANE_TOLERANCE h with x_i
    the node's position (basis.node_coordinates: the control points of the clamped
    B-splines), as the kernels find them (timpm/engine/grid.py)."""
    held = np.zeros(model.nodes, dtype=bool)
    chosen = model.planes if k is None else (model.planes[k],)
    if not chosen:
        return held
    axes = []
    for k_axis, e in enumerate(model.elements):
        xi = model.basis.node_coordinates(e)[:model.nodes[k_axis]]
        axes.append(model.origin[k_axis] + model.h * xi)
    X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    for plane in chosen:
        held |= plane.distance(X.reshape(-1, model.dim)).reshape(model.nodes) >= \
            -PLANE_TOLERANCE * model.h
    return held
