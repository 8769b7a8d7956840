"""The schema of scene files: the value types, the keys of each table (type, default, unit,
allowed values, meaning) and the tables of each form (a world, a problem)."""
import inspect
import math
from dataclasses import dataclass

from ..bases import get_basis
from ..engine.features import GRIDS, MODES
from ..materials import MATERIALS
from ..materials.pore_water import PoreWater
from ..model.model import (INTEGRATORS, ND_BASES, PLANE_KINDS, SIDES, TRANSFERS, WALL_KINDS,
                           MASS_KINDS, PROJECTIONS)
from ..problems import PROBLEMS
from ..model.scene import PLACEMENTS, STRESS_UPDATES
from ..model.random_field import CORRELATIONS, MARGINALS
from ..model.water import ANALYSES, SEEPAGE, SMOOTHING
from ..model.world import PRESETS

REQUIRED = object()


def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


#: value types: name -> (what the error says is expected, test)
TYPES = {
    "number": ("a number", _is_number),
    "positive": ("a number > 0", lambda v: _is_number(v) and v > 0),
    "non-negative": ("a number >= 0", lambda v: _is_number(v) and v >= 0),
    "fraction": ("a number in (0, 1]", lambda v: _is_number(v) and 0 < v <= 1),
    "open-fraction": ("a number in (0, 1)", lambda v: _is_number(v) and 0 < v < 1),
    "share": ("a number in [0, 1]", lambda v: _is_number(v) and 0 <= v <= 1),
    "count": ("an integer >= 1", lambda v: isinstance(v, int) and not isinstance(v, bool)
              and v >= 1),
    "boolean": ("true or false", lambda v: isinstance(v, bool)),
    "string": ("a string", lambda v: isinstance(v, str) and v != ""),
    "vector": ("an array of numbers, one per axis",
               lambda v: isinstance(v, list) and all(_is_number(c) for c in v)),
    "table": ("a table", lambda v: isinstance(v, dict)),
    "points": ("an array of [x, y] pairs of numbers",
               lambda v: isinstance(v, list) and all(
                   isinstance(p, list) and len(p) == 2 and all(_is_number(c) for c in p)
                   for p in v)),
    "scale": ("a number > 0 or inf, or two [horizontal, vertical]",
              lambda v: (isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0)
              or (isinstance(v, list) and len(v) == 2 and all(
                  isinstance(c, (int, float)) and not isinstance(c, bool) and c > 0
                  for c in v))),
    "whole": ("an integer >= 0", lambda v: isinstance(v, int) and not isinstance(v, bool)
              and v >= 0),
    "sides": ("an array of sides (left, right, bottom, top, back, front)",
              lambda v: isinstance(v, list) and all(isinstance(c, str) for c in v)),
    "range": ("two increasing numbers [low, high]",
              lambda v: isinstance(v, list) and len(v) == 2 and all(_is_number(c) for c in v)
              and v[0] < v[1]),
}


@dataclass(frozen=True)
class Key:
    """One key of a table: its value type (``TYPES``), default (``REQUIRED``: none), unit,
    allowed values and meaning; ``check`` raises ValueError on a bad value of the type."""

    type: str
    default: object = REQUIRED
    unit: str = ""
    doc: str = ""
    choices: tuple = ()
    check: object = None


def _basis_check(value):
    get_basis(value)


def _nd_basis_check(value):
    basis = get_basis(value)
    if not basis.nd:
        raise ValueError(f"the {basis.name} basis is 1D only: a world's grid takes "
                         f"{', '.join(ND_BASES)}")


SIMULATION = {
    "name": Key("string", "the file's stem", doc="name of the run (reports, JSON)"),
    "t_end": Key("positive", unit="s", doc="end time"),
    "dt": Key("positive", None, "s", "time step (none: courant times the CFL limit)"),
    "courant": Key("fraction", 0.4, doc="fraction of the CFL limit h / (c + |v|) taken as dt "
                   "when dt is not given"),
    "basis": Key("string", "uniform-bspline2", doc="shape functions of the grid",
                 check=_nd_basis_check, choices=ND_BASES),
    "transfer": Key("string", "apic", doc="particle-grid transfer", choices=TRANSFERS),
    "damping": Key("non-negative", 0.0, doc="local damping factor alpha"),
    "pic_fraction": Key("share", 0.0, doc="PIC share b of the musl velocity update "
                        "(0: FLIP; the musl transfer's parameter, given on its own)"),
    "transfer_params": Key("table", {}, doc="the transfer scheme's parameters by name "
                           "(each scheme declares its own: the [simulation.transfer_params] "
                           "tables below)"),
    "integrator": Key("string", "euler-cromer", doc="time integration (rk4, midpoint: laws "
                      "with sigma(F), roller or sticky walls; midpoint conserves the energy, "
                      "on one thread)", choices=INTEGRATORS),
    "mode": Key("string", "auto", doc="how the steps run (serial: one thread, "
                "bit-reproducible)", choices=MODES),
    "precision": Key("string", "f64", doc="float type of the run", choices=("f64", "f32")),
    "grid": Key("string", "auto", doc="the grid's node loops: over every node (dense) or "
                "over the box of nodes the particles reach (window: the same results, a "
                "mostly empty domain skipped; 2D and 3D, euler-cromer, lumped mass, not "
                "periodic, no team); auto takes the window where it applies, no team runs and "
                "the bodies start in under half the domain", choices=GRIDS),
    "allow_unstable_dt": Key("boolean", False, doc="run a dt above the CFL limit"),
    "allow_overlap": Key("boolean", False, doc="let bodies overlap"),
}

DOMAIN = {
    "size": Key("vector", unit="m", doc="lengths of the box [0, size] along each axis "
                "(1 to 3 numbers: the dimension)"),
    "cells": Key("count", doc="grid cells along x (h = size[0] / cells; every length a whole "
                 "number of cells)"),
    "walls": Key("walls", "slip", doc="one wall for every side, or a table of side name "
                 f"({', '.join(SIDES)}, default) to wall"),
}

WALL = {
    "kind": Key("string", doc="kind of wall", choices=WALL_KINDS + ("none",)),
    "mu": Key("non-negative", 0.0, doc="Coulomb friction coefficient (kind friction)"),
}

#: the keys of a plane wall, [[plane]] (timpm.model.walls.Plane)
PLANE = {
    "point": Key("vector", REQUIRED, "m", "a point of the plane (2D and 3D domains)"),
    "normal": Key("vector", REQUIRED, doc="its normal, out of the material into the wall (any "
                  "length but zero); the wall holds the grid nodes on or beyond the plane, "
                  "every body starting on the other side"),
    "kind": Key("string", "slip", doc="sticky: held; slip: no penetration, no friction; "
                "friction: Coulomb (mu); roller: no normal motion either way",
                choices=PLANE_KINDS),
    "mu": Key("non-negative", 0.0, doc="Coulomb friction coefficient (kind friction)"),
    "drained": Key("boolean", False, doc="a coupled analysis's pore water flows through the "
                   "plane (p_e = 0 on it, as on a drained side); impermeable by default (the "
                   "water's normal velocity the skeleton's)"),
}

BODY = {
    "name": Key("string", "", doc="name of the body (reports)"),
    "material": Key("string", doc="a [material.NAME] of the file or a preset: "
                    + ", ".join(PRESETS)),
    "shape": Key("string", doc="box: lo and hi; ball: center and radius; polygon (2D): "
                 "vertices; prism (3D): vertices (x, y) and z", choices=("box", "ball",
                                                                         "polygon", "prism")),
    "lo": Key("vector", REQUIRED, "m", "lower corner of a box"),
    "hi": Key("vector", REQUIRED, "m", "upper corner of a box"),
    "center": Key("vector", REQUIRED, "m", "centre of a ball (a disk in 2D)"),
    "radius": Key("positive", REQUIRED, "m", "radius of a ball"),
    "vertices": Key("points", REQUIRED, "m", "outline of a polygon, or of a prism's cross-"
                    "section in x-y, as [x, y] pairs (the last joined to the first)"),
    "z": Key("range", REQUIRED, "m", "extent of a prism along z [z0, z1]"),
    "ppc": Key("count", 2, doc="particles per cell and axis"),
    "velocity": Key("vector", "zero", "m/s", "initial velocity"),
    "water": Key("table", None, doc="the water in the body's pores: {porosity = n, "
                 "conductivity = k (m/s) or permeability = kappa (m^2), viscosity, density, "
                 "bulk_modulus} (keys below: [body.water]); the scene's [water] says how it "
                 "is analysed"),
    "random_field": Key("table", None, doc="the variation of a Mohr-Coulomb body's "
                        "cohesion and friction angle about the material's values "
                        "(keys below: [body.random_field]); timpm study monte-carlo draws "
                        "one realisation after another"),
}


def _pore_water_schema():
    out = {}
    for name, param in PoreWater.PARAMS.items():
        default = (None if param.optional else REQUIRED if param.default is None
                   else param.default)
        out[name] = Key("number", default, param.unit, param.doc)
    return out


#: the keys of a body's water table
BODY_WATER = _pore_water_schema()

#: the keys of a body's random field (timpm.model.random_field)
RANDOM_FIELD = {
    "cohesion_cov": Key("non-negative", 0.0, doc="coefficient of variation of the cohesion "
                        "(its mean: the material's)"),
    "friction_angle_cov": Key("non-negative", 0.0, doc="coefficient of variation of the "
                              "friction angle (its mean: the material's)"),
    "conductivity_cov": Key("non-negative", 0.0, doc="coefficient of variation of the pore "
                            "water's hydraulic conductivity (its mean: the body's water's; "
                            "lognormal, independent of the strength; a coupled analysis's "
                            "drag)"),
    "correlation_length": Key("scale", REQUIRED, "m", "the scale of fluctuation theta "
                              "(Vanmarcke's; GSTools' len_scale is theta / 2): one (isotropic) "
                              "or [horizontal, vertical]; inf: one value per realisation"),
    "marginal": Key("string", "lognormal", doc="the distribution of each parameter",
                    choices=MARGINALS),
    "correlation": Key("string", "exponential", doc="the correlation function: exponential "
                       "exp(-2 tau / theta), gaussian exp(-pi tau^2 / theta^2)",
                       choices=CORRELATIONS),
    "angle": Key("number", 0.0, "degrees", "rotation of the anisotropy's axes from x toward y "
                 "(2D)"),
    "cross_correlation": Key("number", 0.0, doc="correlation of the cohesion's and the "
                             "friction angle's Gaussian fields, in [-1, 1]"),
    "seed": Key("whole", 0, doc="the seed of the realisation (a Monte Carlo study draws "
                "realisation k from seed + k)"),
    "points": Key("count", 2, doc="points per cell and axis of each cell's local average"),
}

WATER = {
    "analysis": Key("string", "coupled", doc="drained: the buoyant weight under the "
                    "level, no pore-pressure field; undrained: an excess pore pressure from "
                    "the volumetric strain, no flow; coupled: the water flows (the two-phase "
                    "step, Darcy's drag)", choices=ANALYSES),
    "level": Key("number", None, "m", "the still-water level along the up axis (y; x in "
                 "1D), above the ground for a sea over the seabed; none: no free water"),
    "seepage": Key("string", "none", doc="none: the water below the level is still; "
                   "parallel: steady seepage along x (an infinite slope in its frame, "
                   "gravity tilted: the pore pressure hydrostatic across the layer under "
                   "gravity's y component; drained)", choices=SEEPAGE),
    "phreatic": Key("points", None, "m", "a water table that is not level (drained; "
                    "instead of level): [x, y] vertices, x increasing, constant beyond the "
                    "ends; hydrostatic pore pressure below it (a slope after rapid "
                    "drawdown: the table at the ground surface)"),
    "smoothing": Key("string", "none", doc="none: each particle's excess pore pressure "
                     "follows its own volumetric strain; cell: the step's pore strain "
                     "averaged over each grid cell drives the pressure (no particle-scale "
                     "checkerboard in a large deformation; undrained or coupled, a linear or "
                     "quadratic basis)", choices=SMOOTHING),
    "final_level": Key("number", None, "m", "a drawdown: the level falls (or rises) from "
                       "level to final_level over drawdown_time, linearly (drained: the "
                       "table follows it; undrained and coupled: the pore water feels the "
                       "free water's unloading at once, B = 1)"),
    "drawdown_time": Key("positive", None, "s", "the drawdown's duration (with "
                         "final_level)"),
    "drained_sides": Key("sides", [], doc="coupled: the sides whose walls (or fixed nodes) "
                         "hold the skeleton only, the pore water flowing through them "
                         "(p_e = 0 on them, as at a free surface); the others are "
                         "impermeable"),
    "side_pressure": Key("table", None, "Pa", "coupled: a prescribed excess pore pressure "
                         "on drained sides instead of p_e = 0, {side = p_b} (over the "
                         "hydrostatic pressure of the level; an artesian pressure under a "
                         "clay layer): the traction -p_b n on the water there, from t = 0"),
    "side_pressure_ramp": Key("positive", None, "s", "the side pressures brought on "
                              "linearly over this time (none: at once)"),
}
SHAPE_KEYS = {"box": ("lo", "hi"), "ball": ("center", "radius"), "polygon": ("vertices",),
              "prism": ("vertices", "z")}

INITIAL_STRESS = {
    "kind": Key("string", doc="k0: the K0 procedure (sigma_v the weight above, sigma_h = "
                "K0 sigma_v); gravity: a damped run under gravity to rest (MUSL, local "
                "damping), its stresses kept", choices=("k0", "gravity")),
    "k0": Key("fraction", None, doc="(k0) sigma_h / sigma_v (default: each material's Jaky "
              "1 - sin phi, nu / (1 - nu) without friction)"),
    "damping": Key("open-fraction", 0.6, doc="(gravity) the loading run's local damping factor"),
    "t_max": Key("positive", None, "s", "(gravity) its longest time (default: 40 P-wave "
                 "crossings of the ground's height)"),
    "tolerance": Key("open-fraction", 1e-7, doc="(gravity) at rest: kinetic energy below this "
                     "share of the weight times the height"),
}

LOADS = {
    "gravity": Key("vector", "9.81 down y (down x in 1D)", "m/s^2", "acceleration of gravity"),
    "traction": Key("array", (), doc="surface tractions: [[loads.traction]] tables"),
}

TRACTION = {
    "body": Key("string", doc="name of the loaded body"),
    "side": Key("string", doc="loaded face", choices=SIDES),
    "traction": Key("vector", unit="Pa", doc="force per unit area (per unit depth in 2D)"),
    "ramp": Key("positive", None, "s", "brought on linearly over this time (none: at once)"),
}

OUTPUT = {
    "frames": Key("count", 20, doc="frames over the run (fields and GIF), besides the start"),
    "vtk": Key("string", None, doc="directory of ParaView files: particles.pvd and a .vtu "
               "per frame"),
    "npz": Key("string", None, doc="directory of NumPy archives, one .npz per frame"),
    "json": Key("string", None, doc="file of the run's summary and series as JSON"),
    "gif": Key("string", None, doc="animated GIF of the run (2D and 3D worlds)"),
    "color": Key("string", "speed", doc="colour of the GIF's particles",
                 choices=("speed", "pressure", "plastic", "von-mises", "body",
                          "pore-pressure")),
    "color_range": Key("range", None, doc="the colour bar's range, fixed for the run "
                       "(default: from the scene: speed to max(v0, sqrt(2 g H)), stresses to "
                       "rho g H or rho c v0, plastic strain to 1)"),
    "fps": Key("count", 20, doc="GIF frames per second"),
    "width": Key("count", 640, unit="px", doc="GIF width (320 to 8192)"),
    "landslide": Key("table", None, doc="a slope that fails (2D, facing +x, ground from y = "
                     "0): {toe = the x of its toe, height = its height H} (m); the JSON gets "
                     "the run-out beyond the toe, the scarp's retreat and the retrogressions "
                     "(timpm.studies.landslide)"),
}
#: the keys of [output.landslide]
LANDSLIDE = {
    "toe": Key("number", unit="m", doc="x of the slope's toe (the run-out is measured from "
               "it)"),
    "height": Key("positive", unit="m", doc="the slope's height H (the thresholds are "
                  "shares of it)"),
}
#: the output keys a problem run writes
PROBLEM_OUTPUT = ("frames", "vtk", "npz", "json")

PROBLEM = {
    "name": Key("string", doc="the problem", choices=tuple(PROBLEMS)),
    "elements": Key("count", "the problem's", doc="elements over the body"),
    "ppc": Key("count", "the problem's", doc="particles per element"),
    "basis": Key("string", "linear", doc="shape functions: linear, lagrange2, bsplineN "
                 "(clamped) or uniform-bsplineN (padded) of degree N", check=_basis_check),
    "mass": Key("string", "the problem's", doc="mass matrix (lumped but for mms-1d)",
                choices=MASS_KINDS),
    "dt": Key("positive", "the problem's", "s", "time step"),
    "t_end": Key("positive", "the problem's", "s", "end time"),
    "placement": Key("string", "the problem's", doc="particle positions in an element",
                     choices=tuple(PLACEMENTS)),
    "stress_update": Key("string", "study", doc="stress update", choices=STRESS_UPDATES),
    "damping": Key("non-negative", None, doc="local damping factor alpha"),
    "pic_fraction": Key("share", "the problem's", doc="PIC share b of the musl velocity "
                        "update (0: FLIP; the oedometer's 0.01)"),
    "projection": Key("string", "the problem's", doc="standard or mls (4.4; standard but for "
                      "mms-1d and mms-2d)", choices=PROJECTIONS),
    "integrator": Key("string", "the problem's", doc="euler-cromer, rk4 or midpoint "
                      "(euler-cromer but for mms-1d)", choices=INTEGRATORS),
    "transfer": Key("string", "musl", doc="particle-grid transfer", choices=TRANSFERS),
    "transfer_params": Key("table", {}, doc="the transfer scheme's parameters by name (as "
                           "[simulation.transfer_params])"),
    "allow_unstable_dt": Key("boolean", False, doc="run a dt above the critical time step"),
    "mode": Key("string", "auto", doc="how the steps run", choices=MODES),
    "params": Key("table", {}, doc="physical parameters of the problem by name (timpm run's "
                  "--param), e.g. E, density"),
}

#: the top-level tables of each form
WORLD_TABLES = ("simulation", "domain", "plane", "material", "body", "loads",
                "initial_stress", "water", "output")
PROBLEM_TABLES = ("problem", "output")

MATERIAL_TYPE = Key("string", doc="the material law", choices=tuple(MATERIALS))


def material_schema(kind) -> dict:
    """The keys of a ``[material.NAME]`` table of ``type = kind``: the arguments of the
    law's class with the unit and meaning its file declares (``Material.PARAMS``; the
    default its constructor's); the law checks the values as it does from Python."""
    cls = MATERIALS[kind]
    schema = {"type": MATERIAL_TYPE}
    for p in inspect.signature(cls.__init__).parameters.values():
        if p.name == "self":
            continue
        param = cls.PARAMS[p.name]
        default = REQUIRED if p.default is p.empty else p.default
        schema[p.name] = Key("boolean" if param.kind == "bool" else "number", default,
                             param.unit, param.doc)
    return schema
