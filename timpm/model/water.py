"""The water of a scene: how its saturated bodies are analysed and where the free water
stands.  NumPy (a side pressure's nodal forces sample the basis: timpm.bases.sample).

A body carries :class:`~timpm.materials.pore_water.PoreWater` (its porosity, permeability
and the water's properties); the scene's :class:`Water` says what the engine computes:

- ``"drained"``: the pore pressure is the hydrostatic one of the still-water ``level``,
  p_h = rho_w |g| (level - y) below it, and the soil's law acts on the effective stress
  under the buoyant weight: the particles below the level carry the upward force rho_w V
  |g| (the hydrostatic pressure's gradient, which with the water's pressure on the
  submerged faces makes Archimedes' buoyancy).  No pore-pressure field is compiled.
- ``"undrained"``: besides, every saturated particle keeps an excess pore pressure p_e
  that its volumetric strain drives, dp_e = -(K_w / n) d eps_v (no flow); the stress the
  grid sees is sigma' - p_e I.
- ``"coupled"``: the single-point two-phase formulation (Anura3D's): the water has its
  own velocity, the excess pore pressure follows the volumetric strains of both phases,
  dp_e = -(K_w / n) [(1 - n) d eps_v,solid + n d eps_v,water], and Darcy's drag n rho_w g
  / k couples the two momentum balances at the nodes (implicitly: a low permeability does
  not shorten the time step).

Pore pressures are *excess* pressures over the hydrostatic one of ``level`` (zero
without a level): the total pore pressure is p = p_h + p_e, and a free surface, where the
excess vanishes, drains.  ``level`` is the still-water level along the up axis (y in 2D
and 3D, x in 1D), possibly above the ground (the sea over a seabed); None: no free water
(gravity off, as in Terzaghi's consolidation, or a dry scene).

``seepage``: ``"none"`` (the water below the level is still: p_h = rho_w g . (x -
x_level), the buoyant force -rho_w V g) or ``"parallel"`` (steady seepage along x, the
ground water of an infinite slope posed in the slope's frame: x down the slope, y normal
to it, gravity tilted; the phreatic surface at ``level`` parallel to x): the pore
pressure is hydrostatic across the layer under gravity's normal component, p_h = rho_w
|g_y| (level - y), and constant along x, so the force of the pore water on the skeleton
is -V grad p_h = -rho_w V g_y e_y: the water's weight along x is carried by its drag on
the skeleton (the seepage force rho_w |g_x| V, hydraulic gradient i = sin(beta)).

``phreatic``: a water table that is not level (drained): vertices (x, y) of a polyline,
x increasing, held constant beyond its ends; below it the pore pressure is hydrostatic,
p_h = rho_w |g| (y_w(x) - y), and the pore water pushes the skeleton with -V grad p_h =
rho_w V |g| (-y_w'(x), 1): its buoyancy and the seepage force of the table's slope.  Where
the table stands above the ground it is the surface of free water.  A slope after rapid
drawdown keeps its table at its surface (Morgenstern's assumption, B = 1, no flow yet);
``level`` is then not given (the table says where the water is).

``final_level`` and ``drawdown_time``: the still-water level falls (or rises) in time, from
``level`` at t = 0 to ``final_level`` at ``drawdown_time`` (linearly, then held): a
drawdown.  Drained, the water table in the soil follows the level (a slow drawdown: the
buoyancy of the share of each particle below the level at time t).  Undrained and
coupled, the free water leaving the ground takes its weight off the soil as it goes and
the pore water feels that unloading at once (Skempton's B = 1, Morgenstern's assumption of
rapid drawdown): where the level passes between a particle and its ground surface y_s
(the top of its column of particles at the start) the total pore pressure stops falling
with it, dp_e = -rho_w |g| dL for y < L < y_s, so that just after a rapid drawdown the
pore pressure is the hydrostatic one of a table at the ground surface; coupled, it then
drains through the free surfaces, the water above the level carrying its weight.  (Tested
on layers, where the vertical unloading is the whole of it; on a 2D slope the undrained
and coupled drawdowns did not yet give trustworthy factors, docs/results.md.)

``drained_sides`` (coupled analyses): sides of the domain (``SIDES``: "left", "right",
"bottom", ...; in 1D "left" is the base at x = 0) whose walls or Dirichlet nodes hold the
skeleton only: the pore water flows through them, the excess pore pressure vanishing on
them (the water's natural condition, as at a free surface).  The other sides' walls and
Dirichlet nodes are impermeable (the water's normal velocity the skeleton's).  Plane walls
at any angle (:class:`~timpm.model.walls.Plane`) are impermeable too unless ``drained``
(model/walls.py).  At a
drained side's node the water's velocity solves its own balance with the skeleton's held
one, (M_w / dt + Q) w+ = F_w + M_w w / dt + Q v+ (schemes/two_phase.py).

``side_pressure`` (coupled analyses): a prescribed excess pore pressure p_b (Pa, over the
hydrostatic one of ``level``; {side: p_b}, kept as (side, p_b) pairs) on drained sides
instead of p_e = 0 there: an artesian pressure under a clay layer, a raised pressure at a
base.  It acts from t = 0, times ``side_pressure_time`` f(t) (a time function,
:mod:`~timpm.model.loads`: Constant by default, Ramp(duration) to bring it on).  In the
weak form of the water's balance it is the traction -p_b n on the water at the side (n
its outward normal): the nodal force -p_b n int_side phi_i dA, added to F_w at each wet
node whose function is non-zero on the side (the face's integral of the tensor-product
function: its value on the side's plane, 1 at the edge node of the linear and the clamped
bases, 1/8, 3/4, 1/8 across the three rows about a padded quadratic B-spline's, 1/6, 2/3,
1/6 about a cubic's; times its integrals along the side between the walls across it,
:func:`side_pressure_forces`), and to the mixture's F_i (the total traction's share, sigma'
n its held skeleton's reaction).  The side is the box domain's between its walls: the
saturated bodies should cover it (a node without pore water takes no share).

``smoothing`` (undrained and coupled analyses): ``"none"`` (each particle's excess pore
pressure follows its own volumetric strain) or ``"cell"`` (the step's pore volumetric
strain averaged over each grid cell, weighted by the particles' volumes, drives the
pressure of every particle in the cell: the pressure increment constant per cell, as in
a mixed element with a pressure constant per element, Q1-P0).  Each particle's own strain
can carry a pattern within a cell that the grid's forces cannot see, and the pressure,
stiffened by K_w / n, grows a particle-scale checkerboard in a large deformation; the cell
mean is the part the nodes see.  With the linear basis in 1D the strain is constant over
a cell and the two agree; the cubic B-splines are refused (their Terzaghi consolidation
drifted from the series under the cell mean, docs/results.md).  Measured sound on the
submarine slope with K_w = 0.1 GPa, and with water's own 2.2 GPa on Griffiths & Lane's
undrained slope (linear basis: at rest to 3 um; docs/results.md).
"""
import math
from dataclasses import dataclass

import numpy as np

from ..materials.pore_water import STANDARD_GRAVITY, PoreWater
from ..platform.errors import InputError, about
from .loads import time_function
from .walls import SIDES

__all__ = ["Water", "ANALYSES", "SEEPAGE", "SMOOTHING", "checked_water",
           "side_pressure_forces"]

#: the analyses a scene's water may ask for, the cheapest first
ANALYSES = ("drained", "undrained", "coupled")
#: the steady flows of the water below the level (the module)
SEEPAGE = ("none", "parallel")
#: how the pores' volumetric strain drives the excess pore pressure (the module)
SMOOTHING = ("none", "cell")


@dataclass(frozen=True)
class Water:
    """See the module: ``analysis`` one of ``ANALYSES``; ``level`` the still-water level
    (m, along the up axis) or None."""

    analysis: str = "coupled"
    level: float | None = None
    seepage: str = "none"
    phreatic: tuple | None = None
    smoothing: str = "none"
    final_level: float | None = None
    drawdown_time: float | None = None
    drained_sides: tuple = ()
    side_pressure: dict | tuple | None = None
    side_pressure_time: object = None

    def __post_init__(self):
        if self.analysis not in ANALYSES:
            raise InputError(f"water: unknown analysis {self.analysis!r}: choose one of "
                             f"{', '.join(ANALYSES)}", "analysis")
        if self.level is not None:
            ok = (isinstance(self.level, (int, float)) and not isinstance(self.level, bool)
                  and math.isfinite(self.level))
            if not ok:
                raise InputError(f"water: level must be a finite height in m (or None: no "
                                 f"free water), got {self.level!r}", "level")
            object.__setattr__(self, "level", float(self.level))
        if self.seepage not in SEEPAGE:
            raise InputError(f"water: unknown seepage {self.seepage!r}: choose one of "
                             f"{', '.join(SEEPAGE)}", "seepage")
        if self.seepage != "none" and (self.analysis != "drained" or self.level is None):
            raise InputError("water: a steady seepage is a drained analysis's ground water "
                             "under a level (give analysis='drained' and level=)", "seepage")
        if self.phreatic is not None:
            self._check_phreatic()
        if (self.final_level is None) != (self.drawdown_time is None):
            raise InputError("water: a drawdown takes both final_level (m) and "
                             "drawdown_time (s)", "final_level" if self.final_level is None
                             else "drawdown_time")
        if self.final_level is not None:
            self._check_drawdown()
        if self.smoothing not in SMOOTHING:
            raise InputError(f"water: unknown smoothing {self.smoothing!r}: choose one of "
                             f"{', '.join(SMOOTHING)}", "smoothing")
        if self.smoothing != "none" and not self.pore_pressure:
            raise InputError("water: a drained analysis keeps no excess pore pressure to "
                             "smooth (smoothing is for analysis='undrained' or 'coupled')",
                             "smoothing")
        self._check_drained_sides()
        self._check_side_pressure()
        if self.analysis == "drained" and self.level is None and self.phreatic is None:
            raise InputError("water: a drained analysis without a water level is a dry one: "
                             "give level= (the still-water level, m)", "level")

    def _check_phreatic(self):
        try:
            P = np.array(self.phreatic, dtype=np.float64)
        except (TypeError, ValueError):
            P = np.zeros((0,))
        if P.ndim != 2 or P.shape[1] != 2 or len(P) < 2 or not np.all(np.isfinite(P)):
            raise InputError(f"water: phreatic must be two or more finite (x, y) vertices, "
                             f"got {self.phreatic!r}", "phreatic")
        if not np.all(np.diff(P[:, 0]) > 0.0):
            raise InputError("water: the phreatic surface's x must increase from vertex to "
                             "vertex (a water table is a function of x)", "phreatic")
        if self.analysis != "drained":
            raise InputError("water: a phreatic surface is a drained analysis's water table "
                             "(analysis='drained')", "phreatic")
        if self.level is not None or self.seepage != "none":
            raise InputError("water: give a still-water level or a phreatic surface, not "
                             "both (where the table stands above the ground it is the "
                             "free water's surface)", "phreatic")
        object.__setattr__(self, "phreatic", tuple((float(x), float(y)) for x, y in P))

    def _check_drained_sides(self):
        sides = self.drained_sides
        if isinstance(sides, str):
            sides = (sides,)
        try:
            sides = tuple(sides)
        except TypeError:
            sides = None
        if sides is None or not all(isinstance(s, str) for s in sides):
            raise InputError(f"water: drained_sides must be a list of sides of the domain "
                             f"({', '.join(SIDES)}), got {self.drained_sides!r}",
                             "drained_sides")
        for s in sides:
            if s not in SIDES:
                raise InputError(f"water: unknown side {s!r} in drained_sides: choose from "
                                 f"{', '.join(SIDES)}", "drained_sides")
        if len(set(sides)) != len(sides):
            raise InputError(f"water: drained_sides names a side twice: {list(sides)}",
                             "drained_sides")
        if sides and self.analysis != "coupled":
            raise InputError("water: drained sides let the pore water flow out of the "
                             "domain: a coupled analysis's (analysis='coupled'; drained has "
                             "no excess pore pressure, undrained no flow)", "drained_sides")
        object.__setattr__(self, "drained_sides", sides)

    def _check_side_pressure(self):
        given = self.side_pressure
        if given is None or (isinstance(given, (dict, tuple, list)) and len(given) == 0):
            object.__setattr__(self, "side_pressure", None)
            if self.side_pressure_time is not None:
                raise InputError("water: side_pressure_time is the time function of the "
                                 "side pressures: give side_pressure too",
                                 "side_pressure_time")
            return
        pairs = None
        if isinstance(given, dict):
            pairs = list(given.items())
        elif not isinstance(given, str):
            try:
                pairs = [tuple(pair) for pair in given]
            except TypeError:
                pairs = None
        if pairs is None or not all(len(pair) == 2 and isinstance(pair[0], str)
                                    for pair in pairs):
            raise InputError(f"water: side_pressure must be a table of side "
                             f"({', '.join(SIDES)}) to excess pore pressure (Pa), got "
                             f"{given!r}", "side_pressure")
        sides = [side for side, _ in pairs]
        for side, value in pairs:
            if side not in SIDES:
                raise InputError(f"water: unknown side {side!r} in side_pressure: choose "
                                 f"from {', '.join(SIDES)}", "side_pressure")
            ok = (isinstance(value, (int, float, np.floating, np.integer))
                  and not isinstance(value, bool) and math.isfinite(value))
            if not ok:
                raise InputError(f"water: side_pressure on the {side} side must be a finite "
                                 f"excess pore pressure in Pa, got {value!r}", "side_pressure")
        if len(set(sides)) != len(sides):
            raise InputError(f"water: side_pressure names a side twice: {sides}",
                             "side_pressure")
        if self.analysis != "coupled":
            raise InputError("water: a side pressure drives the pore water through a drained "
                             "side: a coupled analysis's (analysis='coupled')", "side_pressure")
        for side in sides:
            if side not in self.drained_sides:
                raise InputError(f"water: side_pressure on the {side} side, which is not "
                                 f"drained: the pressure is prescribed where the water flows "
                                 f"through (add {side!r} to drained_sides; drained: "
                                 f"{list(self.drained_sides) or 'none'})", "side_pressure")
        object.__setattr__(self, "side_pressure",
                           tuple((side, float(value)) for side, value in pairs))
        if self.side_pressure_time is not None:
            with about("side_pressure_time"):
                time_function("side_pressure_time", self.side_pressure_time)

    def _check_drawdown(self):
        for key, value, positive in (("final_level", self.final_level, False),
                                     ("drawdown_time", self.drawdown_time, True)):
            ok = (isinstance(value, (int, float)) and not isinstance(value, bool)
                  and math.isfinite(value) and (value > 0.0 or not positive))
            if not ok:
                raise InputError(f"water: {key} must be a finite "
                                 + ("duration in s, > 0" if positive else "height in m")
                                 + f", got {value!r}", key)
            object.__setattr__(self, key, float(value))
        if self.level is None or self.phreatic is not None or self.seepage != "none":
            raise InputError("water: a drawdown moves a still-water level: give level= "
                             "(no phreatic surface, no seepage)", "final_level")

    @property
    def drawdown(self) -> bool:
        """Whether the level moves in time (final_level, drawdown_time)."""
        return self.final_level is not None

    def table(self, x):
        """The water table's height at x (arrays): the level, or the phreatic polyline
        (constant beyond its ends); None without either."""
        if self.phreatic is not None:
            P = np.array(self.phreatic)
            return np.interp(x, P[:, 0], P[:, 1])
        if self.level is None:
            return None
        return np.full(np.shape(x), self.level)

    @property
    def highest(self) -> float | None:
        """The water table's highest point (the level, or the phreatic surface's top)."""
        if self.phreatic is not None:
            return max(y for _, y in self.phreatic)
        return self.level

    @property
    def pressured(self) -> bool:
        """Whether a drained side carries a non-zero prescribed pressure (side_pressure)."""
        return self.side_pressure is not None and any(p != 0.0 for _, p in self.side_pressure)

    @property
    def pressure_time(self):
        """The side pressures' time function f(t) (Constant unless side_pressure_time)."""
        return time_function("side_pressure_time", self.side_pressure_time)

    @property
    def pore_pressure(self) -> bool:
        """Whether the particles keep an excess pore pressure (undrained, coupled)."""
        return self.analysis != "drained"


def ground_surface_above(positions, volume, up):
    """Each particle's ground surface y_s: the top of its column of particles (those that
    share its other coordinates, the lattice a body is filled with), the top particle's
    upper edge (its position plus half its extent, V^(1/d) / 2)."""
    x = np.asarray(positions, dtype=np.float64).reshape(len(volume), -1)
    extent = np.asarray(volume, dtype=np.float64) ** (1.0 / x.shape[1])
    columns = (np.round(np.delete(x, up, axis=1), 9) if x.shape[1] > 1
               else np.zeros((len(x), 1)))
    _, where = np.unique(columns, axis=0, return_inverse=True)
    where = where.reshape(-1)
    top = np.full(where.max() + 1 if len(where) else 0, -np.inf)
    np.maximum.at(top, where, x[:, up] + 0.5 * extent)
    return top[where]


def side_pressure_forces(model):
    """The nodal force of the drained sides' prescribed pore pressures at f(t) = 1, an
    array of the Model's nodes by dim: F_i = -sum_s p_s n_s int_s phi_i dA over each side
    s of ``Water.side_pressure`` (n_s its outward normal), on the water and the mixture
    alike (schemes/two_phase.py).  phi_i is the tensor product of one-dimensional
    functions: int_s phi_i dA = phi_a(x_s) prod_(b != a) h int phi_b, phi_a(x_s) the
    value of node i's function along the side's axis a on the side's plane x_s (the wall's
    position, ``Model.wall_cells``), the integrals along the other axes between the walls
    (exact: :func:`~timpm.bases.sample.integrals`; x periodic: its last column of nodes is
    the first).  In 1D the force per unit area, in 2D per unit depth."""
    from ..bases.sample import evaluate, integrals

    dim, basis, water = model.dim, model.basis, model.water
    forces = np.zeros(model.nodes + (dim,))
    for side, pressure in water.side_pressure or ():
        axis, upper = divmod(SIDES.index(side), 2)
        shares = []
        for k, e in enumerate(model.elements):
            lo, hi = model.wall_cells[k]
            if k == axis:
                share, _ = evaluate(basis, [hi if upper else lo], e)
                share = share[0]
            else:
                share = model.h * integrals(basis, e, lo, hi)
            if k == 0 and model.periodic:  # node n_x is node 0
                share = np.concatenate(([share[0] + share[-1]], share[1:-1]))
            shares.append(share)
        area = shares[0]
        for share in shares[1:]:
            area = np.multiply.outer(area, share)
        outward = 1.0 if upper else -1.0
        forces[..., axis] -= pressure * outward * area
    return forces


def _conductivity(model, arrays):
    """The Model's ``pore_conductivity`` (n,) checked: positive where given (nan: the
    material's), given on saturated particles only; None if not given."""
    if model.pore_conductivity is None:
        return None
    n = len(model.positions)
    try:
        k = np.array(model.pore_conductivity, dtype=np.float64).reshape(n)
    except (TypeError, ValueError):
        raise InputError(f"pore_conductivity must be {n} numbers (one per particle; nan: "
                         f"the material's), got shape {np.shape(model.pore_conductivity)}",
                         "pore_conductivity") from None
    bad = np.flatnonzero(~(np.isnan(k) | ((k > 0.0) & np.isfinite(k))))
    if len(bad):
        raise InputError(f"pore_conductivity of particle {int(bad[0])} must be a positive "
                         f"conductivity (m/s), got {k[bad[0]]!r}", "pore_conductivity")
    dry = np.flatnonzero(np.isfinite(k) & (arrays["rho_w"] == 0.0))
    if len(dry):
        raise InputError(f"pore_conductivity: particle {int(dry[0])} is of a dry material "
                         f"(no pore water)", "pore_conductivity")
    return k


def checked_water(model):
    """A :class:`~timpm.model.Model`'s water checked: its ``pore_water`` as one PoreWater
    or None per material, and the per-particle arrays the engine uploads (the Model's
    ``water_arrays``; None for a dry scene)."""
    dim = model.dim
    given = model.pore_water
    pores = (None,) * len(model.materials) if given is None else tuple(given)
    if len(pores) != len(model.materials):
        raise InputError(f"pore_water must give one PoreWater or None per material "
                         f"({len(model.materials)}), got {len(pores)}", "pore_water")
    for k, (mat, pw) in enumerate(zip(model.materials, pores)):
        if pw is None:
            continue
        if not isinstance(pw, PoreWater):
            raise InputError(f"pore_water[{k}] must be a timpm.PoreWater or None, got "
                             f"{pw!r}", "pore_water")
        if not mat.carries_pore_water:
            raise InputError(f"the {mat.name} material cannot carry pore water (a "
                             f"saturated body is a soil skeleton: a solid law)",
                             "pore_water")
    water = model.water
    saturated = [k for k, pw in enumerate(pores) if pw is not None]
    if water is None:
        if saturated:
            raise InputError("a body carries pore water: give the scene's water "
                             "(water=timpm.Water(analysis='drained' | 'undrained' | "
                             "'coupled', level=...))", "water")
        if model.initial_pore_pressure is not None:
            raise InputError("initial_pore_pressure needs a scene with water",
                             "initial_pore_pressure")
        return pores, None
    if not isinstance(water, Water):
        raise InputError(f"water must be a timpm.Water, got {water!r}", "water")
    if not saturated:
        raise InputError("the scene has water but no body carries pore water: give a "
                         "body pore_water=timpm.PoreWater(...)", "water")
    up = min(1, dim - 1)
    if water.seepage == "parallel" and dim == 1:
        raise InputError("water: a seepage parallel to x needs a 2D or 3D scene", "seepage")
    if water.phreatic is not None:
        if dim == 1:
            raise InputError("water: a phreatic surface needs a 2D or 3D scene", "phreatic")
        g = np.asarray(model.gravity, dtype=np.float64)
        if not (g[1] < 0.0 and np.all(np.delete(g, 1) == 0.0)):
            raise InputError(f"water: a phreatic surface's hydrostatic pressure needs "
                             f"gravity straight down y, got {model.gravity}", "phreatic")
    if water.highest is not None:
        level, key = water.highest, "level" if water.phreatic is None else "phreatic"
        what = "level" if water.phreatic is None else "top of the phreatic surface"
        bottom = model.origin[up]
        if level <= bottom:
            raise InputError(f"water: the {what} {level:g} m lies below the grid (its "
                             f"bottom is at {'xyz'[up]} = {bottom:g} m)", key)
        if not model.gravity[up] < 0.0:
            raise InputError(f"water: a still-water level needs gravity pointing down "
                             f"{'xyz'[up]} (the hydrostatic pressure's direction), got "
                             f"{model.gravity}", "level")
    if water.pore_pressure and model.integrator != "euler-cromer":
        raise InputError(f"water: the {model.integrator} integrator does not take pore "
                         "water (its stages set the stress from F): use euler-cromer",
                         "integrator")
    if water.smoothing == "cell" and model.basis.support > 3:
        raise InputError(f"water: smoothing='cell' takes the linear or a quadratic basis, "
                         f"not {model.basis.name}: with the cubic B-spline the cell mean "
                         "drove Terzaghi's consolidation away from the series as the grid "
                         "was refined (U = 0.992 against 0.931 at T = 1, 32 elements; "
                         "docs/results.md)", "smoothing")
    for side, _ in water.side_pressure or ():
        if SIDES.index(side) >= 2 * dim:
            raise InputError(f"water: side_pressure on the {side} side, which a {dim}D "
                             f"domain does not have (its sides: "
                             f"{', '.join(SIDES[:2 * dim])})", "side_pressure")
    for side in water.drained_sides:
        if SIDES.index(side) >= 2 * dim:
            raise InputError(f"water: a {dim}D domain has no {side} side (its sides: "
                             f"{', '.join(SIDES[:2 * dim])})", "drained_sides")
        if model.periodic and side in ("left", "right"):
            raise InputError(f"water: the {side} side is periodic, not a face the water "
                             f"can drain through", "drained_sides")
    if water.analysis == "coupled":
        wrong = [what for what, bad in (
            (f"the {model.transfer} transfer (the two-phase step is MUSL's: "
             "transfer='musl')", model.transfer != "musl"),
            ("the consistent mass", model.mass_matrix != "lumped"),
            ("the MLS projection", model.projection != "standard"),
            ("a PIC fraction", model.pic_fraction > 0.0),
            ("prescribed non-zero node velocities", model.prescribes_motion)) if bad]
        if wrong:
            raise InputError(f"water: the coupled analysis does not take "
                             f"{'; '.join(wrong)}", "analysis")
    n = len(model.positions)
    index = model.material_index
    column = lambda values: np.asarray(values, dtype=np.float64)[index]  # noqa: E731
    arrays = {"rho_w": column([0.0 if pw is None else pw.density for pw in pores])}
    if water.pore_pressure:
        arrays["storage"] = column([0.0 if pw is None else pw.storage_modulus
                                    for pw in pores])
        pressure = np.zeros(n)
        if model.initial_pore_pressure is not None:
            try:
                pressure = np.array(model.initial_pore_pressure, dtype=np.float64)
                pressure = pressure.reshape(n)
            except (TypeError, ValueError):
                raise InputError(f"initial_pore_pressure must be {n} numbers (one per "
                                 f"particle), got shape "
                                 f"{np.shape(model.initial_pore_pressure)}",
                                 "initial_pore_pressure") from None
            bad = np.flatnonzero(~np.isfinite(pressure))
            if len(bad):
                raise InputError(f"initial_pore_pressure of particle {int(bad[0])} is "
                                 "not finite", "initial_pore_pressure")
            dry = np.flatnonzero((arrays["rho_w"] == 0.0) & (pressure != 0.0))
            if len(dry):
                raise InputError(f"initial_pore_pressure: particle {int(dry[0])} is of a "
                                 "dry material (no pore water) and cannot hold one",
                                 "initial_pore_pressure")
        arrays["pw"] = pressure
    elif model.initial_pore_pressure is not None:
        raise InputError("initial_pore_pressure: a drained analysis keeps no excess "
                         "pore pressure (undrained or coupled do)",
                         "initial_pore_pressure")
    if water.drawdown and water.pore_pressure:
        arrays["ground"] = ground_surface_above(model.positions, model.volume, up)
    if water.analysis == "coupled":
        with about("pore_water"):
            arrays["porosity"] = column([0.0 if pw is None else pw.porosity
                                         for pw in pores])
            arrays["drag"] = column([0.0 if pw is None else pw.drag() for pw in pores])
        k = _conductivity(model, arrays)
        if k is not None:  # a random field's: n rho_w g / k particle by particle
            given = np.isfinite(k)
            arrays["drag"][given] = (arrays["porosity"][given] * arrays["rho_w"][given]
                                     * STANDARD_GRAVITY / k[given])
    elif model.pore_conductivity is not None:
        raise InputError(f"pore_conductivity (a random field's conductivity_cov) is read by "
                         f"a coupled analysis's drag only, not by a {water.analysis} one",
                         "pore_conductivity")
    for arr in arrays.values():
        arr.setflags(write=False)
    return pores, arrays
