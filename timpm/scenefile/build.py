"""The checked scene: a scene file's tables, read and checked, made into a
:class:`timpm.model.world.World` (the world form) or the arguments of
:func:`timpm.studies.study.run_problem` (the problem form)."""
from dataclasses import dataclass, field, fields
from pathlib import Path

from ..bases import get_basis
from ..model.loads import Ramp, SurfaceTraction
from ..materials import MATERIALS, get_material
from ..model.model import SIDES
from ..problems import PROBLEMS
from ..model.geostatic import K0, GravityLoading
from ..model.water import Water
from ..materials.pore_water import PoreWater
from ..model.random_field import RandomField
from ..model.world import PRESETS, Ball, Body, Box, Plane, Polygon, Prism, Wall, World
from .keypaths import key_lines, parse_path
from .reader import Reader, apply_overrides, describe, read_toml, suggest
from ..studies.landslide import Landslide
from .schema import (BODY, BODY_WATER, RANDOM_FIELD, DOMAIN, INITIAL_STRESS, LANDSLIDE, LOADS, MATERIAL_TYPE, OUTPUT, PROBLEM,
                     PLANE, PROBLEM_OUTPUT, PROBLEM_TABLES, SHAPE_KEYS, SIMULATION, TRACTION, WALL,
                     WATER, WORLD_TABLES, material_schema)


@dataclass(frozen=True, eq=False)
class SceneFile:
    """A checked scene file: a ``world`` (the world form) or the keyword arguments of
    :func:`timpm.studies.study.run_problem` (``problem``, the problem form), the run's
    ``t_end``, ``mode``, ``precision`` (None: a problem, which runs in the precision
    Taichi was started with), the ``output`` settings and the world's ``grid`` ("auto",
    "dense" or "window": :class:`timpm.Solver`)."""

    path: str
    name: str
    world: World | None
    problem: dict | None
    t_end: float | None
    mode: str
    precision: str
    output: dict
    reader: Reader = field(repr=False, default=None)
    grid: str = "auto"  # the world form's node loops (Solver's grid)

    def error(self, path, message) -> ValueError:
        """A ValueError naming the file, the line of key ``path`` and ``message``."""
        return self.reader.error(path, message)


def load_scene(path, overrides=None, document=None) -> SceneFile:
    """Read and check the scene file ``path``; ``overrides`` maps key paths
    (``"simulation.t_end"``, ``"body[0].ppc"``) to values that replace the file's (None
    removes a key); ``document``: the file's ``read_toml`` (text, tables) where the caller
    has read it already.  Errors are ValueErrors naming file, line and key (see the module)."""
    text, data = read_toml(path) if document is None else document
    overridden = apply_overrides(data, overrides, path)
    reader = Reader(path, data, key_lines(text), overridden)
    if "problem" in data:
        return _problem_scene(reader, data, Path(path))
    return _world_scene(reader, data, Path(path))


def _top_level(reader, data, tables, form):
    for name in data:
        if name not in tables:
            hint = ""
            if form == "problem" and name in WORLD_TABLES:
                hint = (" (a file with [problem] runs a benchmark problem; a world's tables "
                        "go in a file without it)")
            raise reader.error((name,), f"unknown table{suggest(name, tables)}: a {form} "
                               f"scene has {', '.join(f'[{t}]' for t in tables)}{hint}")


def _check_frames(reader, given, keys):
    """``output.frames`` spaces the outputs written frame by frame (the field files, the
    GIF, the landslide's measures): given without any of them it would do nothing, so it is
    refused, as the command line refuses ``--frames`` without ``--vtk`` or ``--npz``."""
    outputs = [k for k in ("vtk", "npz", "gif", "landslide") if k in keys]
    if "frames" in given and not any(given.get(k) is not None for k in outputs):
        names = [f"output.{k}" for k in outputs]
        listed = ", ".join(names[:-1]) + " or " + names[-1]
        raise reader.error(("output", "frames"), "frames spaces the outputs written frame by "
                           f"frame, and the scene asks for none: give {listed} too (or "
                           "leave frames out)")


def _output(reader, data, keys):
    schema = {k: OUTPUT[k] for k in keys}
    out = reader.table(("output",), data.get("output", {}), schema, skip=("landslide",))
    if out.get("vtk") is not None and out.get("npz") is not None:
        raise reader.error(("output", "npz"), "give vtk or npz, not both: one field format")
    _check_frames(reader, {**out, "landslide": data.get("output", {}).get("landslide")},
                  keys)
    out = {**{k: OUTPUT[k].default for k in keys}, **out}
    spec = data.get("output", {}).get("landslide")
    if spec is not None:  # (a world's: a problem's schema has no such key)
        where = ("output", "landslide")
        t = reader.table(where, spec, LANDSLIDE)
        try:
            out["landslide"] = Landslide(toe=t["toe"], height=t["height"])
        except ValueError as err:
            raise reader.error(where, str(err)) from None
    return out


def _problem_scene(reader, data, path) -> SceneFile:
    _top_level(reader, data, PROBLEM_TABLES, "problem")
    opts = reader.table(("problem",), data["problem"], PROBLEM)
    output = _output(reader, data, PROBLEM_OUTPUT)
    cls = PROBLEMS[opts.pop("name")]
    params = opts.pop("params", {})
    known = [f.name for f in fields(cls)]
    for name, value in params.items():
        if name not in known:
            raise reader.error(("problem", "params", name),
                               f"{cls.name} has no parameter {name!r}{suggest(name, known)}: "
                               f"its parameters are {', '.join(known)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise reader.error(("problem", "params", name),
                               f"expected a number, got {describe(value)}")
    try:
        cls().with_params(**params)
    except (ValueError, TypeError) as err:  # a parameter's error names it (InputError.key)
        key = getattr(err, "key", None)
        raise reader.error(("problem", "params") + ((key,) if key in params else ()),
                           str(err)) from None
    if "basis" in opts:  # checked by the schema: its class from here on
        opts["basis"] = get_basis(opts["basis"])
    kwargs = dict(opts, params=params)
    return SceneFile(path=str(path), name=cls.name, world=None,
                     problem=dict(problem=cls.name, **kwargs),
                     t_end=opts.get("t_end", cls.t_end), mode=opts.get("mode", "auto"),
                     precision=None, output=output, reader=reader)


def _walls(reader, value, dim):
    """The ``walls`` of World from ``domain.walls``: a wall, or a dict of side to wall."""
    path = ("domain", "walls")
    sides = SIDES[:2 * dim]

    def wall(where, spec):
        if isinstance(spec, str):
            spec = {"kind": spec}
        elif not isinstance(spec, dict):
            raise reader.error(where, f"expected a wall kind ({', '.join(WALL['kind'].choices)})"
                               f" or a table {{kind = ..., mu = ...}}, got {describe(spec)}")
        w = reader.table(where, spec, WALL)
        if w["kind"] == "none":
            if "mu" in w:
                raise reader.error(where + ("mu",), "an open side (kind none) takes no "
                                   "friction coefficient")
            return None
        try:
            return Wall(w["kind"], w.get("mu", 0.0))
        except ValueError as err:
            raise reader.error(where, str(err)) from None

    if isinstance(value, dict) and "kind" not in value:
        out = {}
        for side, spec in value.items():
            if side not in sides + ("default",):
                raise reader.error(path + (side,), f"unknown side{suggest(side, sides)}: "
                                   f"the sides of a {dim}D domain are {', '.join(sides)} "
                                   "(and default)")
            out[side] = wall(path + (side,), spec)
        return out
    return wall(path, value)


def _planes(reader, data, dim):
    """The plane walls of ``[[plane]]`` tables (timpm.model.walls.Plane), each error naming
    the table's key and line."""
    if "plane" not in data:
        return []
    tables = reader.array_of_tables(("plane",), data["plane"], "one per plane wall")
    if tables and dim == 1:
        raise reader.error(("plane", 0), "plane walls stand in 2D and 3D domains: a 1D bar's "
                           "ends are the domain's walls")
    out = []
    for k, table in enumerate(tables):
        where = ("plane", k)
        spec = reader.table(where, table, PLANE, dim)
        try:
            out.append(Plane(spec["point"], spec["normal"], spec.get("kind", "slip"),
                             spec.get("mu", 0.0), spec.get("drained", False)))
        except ValueError as err:  # names its key (InputError.key)
            key = getattr(err, "key", None)
            raise reader.error(where + ((key,) if key in table else ()), str(err)) from None
    return out


def _materials(reader, data):
    """The materials of ``[material.NAME]`` tables, by name."""
    tables = data.get("material", {})
    if not isinstance(tables, dict) or not all(isinstance(t, dict) for t in tables.values()):
        raise reader.error(("material",), "expected tables [material.NAME] (a name, then "
                           "type and parameters)")
    out = {}
    for name, table in tables.items():
        where = ("material", name)
        if "type" not in table:
            raise reader.error(where, f"missing required key 'type': one of "
                               f"{', '.join(MATERIALS)}")
        kind = reader.value(where + ("type",), MATERIAL_TYPE, table["type"])
        params = reader.table(where, table, material_schema(kind))
        params.pop("type")
        try:
            out[name] = get_material(kind, **params)
        except ValueError as err:  # a parameter's error names it (InputError.key)
            key = getattr(err, "key", None)
            raise reader.error(where + ((key,) if key in params else ()), str(err)) from None
    return out


def _bodies(reader, data, materials, dim):
    if "body" not in data:
        raise reader.error(("body",), "missing: a world needs at least one [[body]]")
    tables = reader.array_of_tables(("body",), data["body"], "one per body")
    if not tables:
        raise reader.error(("body",), "a world needs at least one [[body]]")
    bodies = []
    for k, table in enumerate(tables):
        where = ("body", k)
        shape = table.get("shape")
        keys = SHAPE_KEYS.get(shape, ())
        others = [n for n in dict.fromkeys(k for ks in SHAPE_KEYS.values() for k in ks)
                  if n not in keys]
        b = reader.table(where, table, BODY, dim, skip=others)
        for name in others:
            if name in table:
                raise reader.error(where + (name,), f"a {shape} takes "
                                   f"{' and '.join(SHAPE_KEYS[shape])}, not {name}")
        name = b["material"]
        if name in materials:
            material = materials[name]
        elif name in PRESETS:
            material = name
        else:
            known = list(materials) + list(PRESETS)
            raise reader.error(where + ("material",), f"unknown material {name!r}"
                               f"{suggest(name, known)}: define [material.{name}] or use "
                               f"one of {', '.join(known)}")
        water = None
        if b.get("water") is not None:
            spec = reader.table(where + ("water",), b["water"], BODY_WATER)
            try:
                water = PoreWater(**spec)
            except ValueError as err:  # names its key (InputError.key)
                key = getattr(err, "key", None)
                raise reader.error(where + ("water",) + ((key,) if key in spec else ()),
                                   str(err)) from None
        random_field = None
        if b.get("random_field") is not None:
            where_rf = where + ("random_field",)
            spec = reader.table(where_rf, b["random_field"], RANDOM_FIELD)
            try:
                random_field = RandomField(**spec)
            except ValueError as err:  # names its key (InputError.key)
                key = getattr(err, "key", None)
                raise reader.error(where_rf + ((key,) if key in spec else ()), str(err)) \
                    from None
        try:
            if shape in ("polygon", "prism") and dim != (2 if shape == "polygon" else 3):
                raise ValueError(f"a {shape} is a {'2D' if shape == 'polygon' else '3D'} "
                                 f"shape, the domain is {dim}D")
            geometry = (Box(b["lo"], b["hi"]) if shape == "box"
                        else Ball(b["center"], b["radius"]) if shape == "ball"
                        else Polygon(b["vertices"]) if shape == "polygon"
                        else Prism(b["vertices"], b["z"]))
            bodies.append(Body(geometry, material, velocity=b.get("velocity"),
                               ppc=b.get("ppc", 2), name=b.get("name", ""), water=water,
                               random_field=random_field))
        except ValueError as err:
            raise reader.error(where, str(err)) from None
    return bodies


def _tractions(reader, tables, bodies, dim):
    names = [b.name for b in bodies]
    out = []
    for k, table in enumerate(reader.array_of_tables(("loads", "traction"), tables,
                                                     "one per loaded face")):
        where = ("loads", "traction", k)
        t = reader.table(where, table, TRACTION, dim)
        if t["body"] not in names:
            raise reader.error(where + ("body",), f"no body is named {t['body']!r}"
                               f"{suggest(t['body'], names)}: the bodies are "
                               f"{', '.join(repr(n) for n in names)}")
        if t["side"] not in SIDES[:2 * dim]:
            raise reader.error(where + ("side",), f"a {dim}D body has the sides "
                               f"{', '.join(SIDES[:2 * dim])}")
        ramp = t.get("ramp")
        kwargs = {} if ramp is None else {"time_function": Ramp(ramp)}
        out.append(SurfaceTraction(names.index(t["body"]), t["side"], t["traction"], **kwargs))
    return out


#: the argument of World an error is about (InputError.key) -> the scene file's key
_WORLD_KEYS = {"domain": "domain", "cells": "domain.cells", "walls": "domain.walls",
               "basis": "simulation.basis", "transfer": "simulation.transfer",
               "transfer_params": "simulation.transfer_params",
               "damping": "simulation.damping", "pic_fraction": "simulation.pic_fraction",
               "integrator": "simulation.integrator", "dt": "simulation.dt",
               "courant": "simulation.courant", "gravity": "loads.gravity",
               "bodies": "body", "tractions": "loads.traction",
               "initial_stress": "initial_stress", "water": "water", "planes": "plane"}


def _world_error_key(key):
    """The key path of the scene file that World's argument ``key`` came from
    (``"bodies[2]"``: ``("body", 2)``; ``"transfer_params.alpha"``: ``("simulation",
    "transfer_params", "alpha")``), or None."""
    if key is None:
        return None
    head, dot, rest = key.partition(".")  # transfer_params.alpha: a key inside the table
    name, _, index = head.partition("[")
    if name not in _WORLD_KEYS:
        return None
    path = parse_path(_WORLD_KEYS[name])
    return path + ((int(index.rstrip("]")),) if index else ()) + ((rest,) if dot else ())


def _world_scene(reader, data, path) -> SceneFile:
    _top_level(reader, data, WORLD_TABLES, "world")
    for name in ("simulation", "domain"):
        if name not in data:
            raise reader.error((name,), f"missing table [{name}] (or [problem] for a "
                               "benchmark problem)")
    sim = reader.table(("simulation",), data["simulation"], SIMULATION)
    domain = reader.table(("domain",), data["domain"], DOMAIN, skip=("walls",))
    dim = len(domain["size"])
    if dim not in (1, 2, 3):
        raise reader.error(("domain", "size"), f"expected 1, 2 or 3 lengths, got {dim}")
    walls = _walls(reader, data["domain"].get("walls", "slip"), dim)
    planes = _planes(reader, data, dim)
    loads = reader.table(("loads",), data.get("loads", {}), LOADS, dim, skip=("traction",))
    materials = _materials(reader, data)
    bodies = _bodies(reader, data, materials, dim)
    tractions = _tractions(reader, data.get("loads", {}).get("traction", []), bodies, dim)
    output = _output(reader, data, tuple(OUTPUT))
    initial = None
    if "initial_stress" in data:
        spec = reader.table(("initial_stress",), data["initial_stress"], INITIAL_STRESS)
        if "kind" not in spec:
            raise reader.error(("initial_stress",), "missing required key 'kind' (k0)")
        given = [k for k in ("k0", "damping", "t_max", "tolerance") if k in spec]
        wrong = [k for k in given if (k == "k0") != (spec["kind"] == "k0")]
        if wrong:
            raise reader.error(("initial_stress", wrong[0]), f"kind = {spec['kind']!r} takes "
                               + ("k0" if spec["kind"] == "k0" else "damping, t_max and "
                                  "tolerance") + f", not {wrong[0]}")
        try:
            initial = (K0(spec.get("k0")) if spec["kind"] == "k0" else
                       GravityLoading(**{k: spec[k] for k in given}))
        except ValueError as err:
            raise reader.error(("initial_stress",), str(err)) from None
    water = None
    if "water" in data:
        spec = reader.table(("water",), data["water"], WATER)
        ramp = spec.get("side_pressure_ramp")
        if ramp is not None and "side_pressure" not in spec:
            raise reader.error(("water", "side_pressure_ramp"), "side_pressure_ramp brings "
                               "the side pressures on: give side_pressure too")
        try:
            water = Water(spec.get("analysis", "coupled"), spec.get("level"),
                          spec.get("seepage", "none"), spec.get("phreatic"),
                          spec.get("smoothing", "none"), spec.get("final_level"),
                          spec.get("drawdown_time"), tuple(spec.get("drained_sides", ())),
                          spec.get("side_pressure"), None if ramp is None else Ramp(ramp))
        except ValueError as err:
            key = getattr(err, "key", None)
            if key == "side_pressure_time":
                key = "side_pressure_ramp"
            raise reader.error(("water",) + ((key,) if key in WATER else ()), str(err)) from None
    if output["gif"] is not None and dim == 1:
        raise reader.error(("output", "gif"), "a 1D world draws no GIF")
    if output.get("landslide") is not None and dim != 2:
        raise reader.error(("output", "landslide"), f"a landslide is measured in 2D (a slope "
                           f"facing +x), the domain is {dim}D")
    name = sim.get("name", path.stem)
    try:
        world = World(domain=domain["size"], cells=domain["cells"], bodies=bodies,
                      basis=get_basis(sim.get("basis", "uniform-bspline2")),
                      transfer=sim.get("transfer", "apic"), gravity=loads.get("gravity"),
                      walls=walls, dt=sim.get("dt"), courant=sim.get("courant"),
                      allow_overlap=sim.get("allow_overlap", False),
                      allow_unstable_dt=sim.get("allow_unstable_dt", False),
                      damping=sim.get("damping", 0.0),
                      pic_fraction=sim.get("pic_fraction", 0.0),
                      transfer_params=sim.get("transfer_params"), tractions=tractions, name=name,
                      integrator=sim.get("integrator", "euler-cromer"),
                      initial_stress=initial, water=water, planes=planes)
    except ValueError as err:
        key = _world_error_key(getattr(err, "key", None))
        raise (reader.error(key, str(err)) if key else ValueError(f"{path}: {err}")) from None
    return SceneFile(path=str(path), name=name, world=world, problem=None, t_end=sim["t_end"],
                     mode=sim.get("mode", "auto"), precision=sim.get("precision", "f64"),
                     output=output, reader=reader, grid=sim.get("grid", "auto"))
