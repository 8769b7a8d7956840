"""Scene files: a whole simulation described in TOML, read, checked and run
(``timpm run scene.toml``).

A scene file takes one of two forms (docs/scene_files.md lists every key):

* a **world**: ``[simulation]`` (end time, time step or Courant number, basis, transfer,
  mode, precision), ``[domain]`` (size, cells, walls), ``[material.NAME]`` tables,
  ``[[body]]`` tables (a box or a ball of a material), ``[loads]`` (gravity, surface
  tractions) and ``[output]`` (field frames, GIF, JSON); it builds a
  :class:`timpm.world.World` and runs it like a demo;
* a **problem**: ``[problem]`` names one of the 1D/2D/3D benchmark problems with the options
  of ``timpm run`` (``[problem.params]``: its physical parameters) and runs it through
  :func:`timpm.studies.study.run_problem`.

The file is read with :mod:`tomllib` and checked against the schema here before any work:
an unknown key (with a close known one suggested), a value of the wrong type, a missing
required key or a bad value is a ``ValueError`` that names the file, the line and the key
path (``scene.toml:12: body[1].material: ...``).  :func:`key_lines` finds the lines (tomllib
reports none for keys).  ``overrides`` (a dict of key path to value, ``None`` removing the
key) change the file's values before the check: the command line's ``--t-end``, ``--json``,
``--set KEY=VALUE`` ... and the tests' tiny runs.

The top layer, beside the command line (``tests/test_layers.py``): it builds on the world,
the solver, the demos' colour quantities, the studies' ``run_problem`` and the output writers.
"""
import argparse
import difflib
import inspect
import json
import math
import os
import re
import sys
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python < 3.11: the tomli backport
    import tomli as tomllib

from .basis import get_basis
from .checkpoint import save_checkpoint
from .files import write_json
from .interrupt import INTERRUPTED_CHECKPOINT, RunInterrupted, deferred_sigint
from .loads import Ramp, SurfaceTraction
from .materials import MATERIALS, get_material
from .model import ND_BASES, SIDES, TRANSFERS, WALL_KINDS, MASS_KINDS, PROJECTIONS
from .problems import PROBLEMS
from .scene import PLACEMENTS, STRESS_UPDATES
from .world import PRESETS, Ball, Body, Box, Wall, World

__all__ = ["SceneFile", "SceneResult", "load_scene", "run_scene", "key_lines", "main",
           "is_scene_argument", "schema_reference", "MODES"]

MODES = ("auto", "serial", "parallel", "team")
REQUIRED = object()


# ---- where keys stand in the file ---------------------------------------------------------

def _scan(text, start=0):
    """Walk ``text`` from ``start`` outside strings: (code before any comment, index of the
    first ``=`` or -1, bracket depth change of [] and {}, the multi-line string delimiter
    left open or None)."""
    i, eq, depth, n = start, -1, 0, len(text)
    while i < n:
        c = text[i]
        if c == "#":
            return text[:i], eq, depth, None
        if c in "\"'":
            triple = text[i:i + 3]
            if triple in ('"""', "'''"):
                end = text.find(triple, i + 3)
                if end < 0:
                    return text, eq, depth, triple
                i = end + 3
                continue
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if (c == '"' and text[j] == "\\") else 1
            i = j + 1
            continue
        if c == "=" and eq < 0 and depth == 0:
            eq = i
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
        i += 1
    return text, eq, depth, None


def _key_parts(key_text):
    """The parts of a (dotted, quoted) TOML key, read by tomllib; None if it is no key."""
    try:
        doc = tomllib.loads(f"{key_text} = 0")
    except tomllib.TOMLDecodeError:
        return None
    parts = []
    while isinstance(doc, dict) and len(doc) == 1:
        (name, doc), = doc.items()
        parts.append(name)
    return tuple(parts)


def key_lines(text) -> dict:
    """Line (1-based) of every table header and key of the TOML document ``text``, by key
    path: a tuple of names with the index of each array-of-tables element, e.g.
    ``("body", 1, "material")`` for ``material = ...`` under the second ``[[body]]``.

    A dotted key also gives its leading parts the line; keys inside an inline table and
    values of multi-line arrays and strings are not keys of their own (their key's line
    stands for them: see :func:`_line_of`)."""
    lines, counts = {}, {}
    table = ()
    open_string, depth = None, 0
    for number, line in enumerate(text.splitlines(), 1):
        if open_string:  # inside a multi-line string value
            if open_string in line:
                rest = line[line.index(open_string) + 3:]
                open_string = None
                _, _, d, open_string = _scan(rest)
                depth += d
            continue
        if depth > 0:  # inside a multi-line array value
            _, _, d, open_string = _scan(line)
            depth += d
            continue
        code, eq, d, open_string = _scan(line)
        stripped = code.strip()
        if not stripped:
            continue
        if eq < 0 and stripped.startswith("["):
            array = stripped.startswith("[[") and stripped.endswith("]]")
            name = stripped[2:-2] if array else stripped[1:-1]
            parts = _key_parts(name.strip())
            if parts is None:
                continue
            path = ()
            for k, part in enumerate(parts):
                path += (part,)
                if array and k == len(parts) - 1:
                    counts[path] = counts.get(path, -1) + 1
                    path += (counts[path],)
                elif path in counts:
                    path += (counts[path],)
            table = path
            lines.setdefault(table, number)
            continue
        if eq > 0:
            parts = _key_parts(code[:eq].strip())
            if parts:
                for k in range(1, len(parts) + 1):
                    lines.setdefault(table + parts[:k], number)
            depth = max(d, 0)
    return lines


def _line_of(lines, path):
    """The line of ``path`` or of its longest prefix found in ``lines`` (None: none)."""
    for k in range(len(path), 0, -1):
        if tuple(path[:k]) in lines:
            return lines[tuple(path[:k])]
    return None


def dotted(path) -> str:
    """``("body", 1, "material")`` -> ``body[1].material``."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def parse_path(text):
    """``body[1].material`` -> ``("body", 1, "material")`` (bare names only)."""
    path = []
    for segment in text.split("."):
        m = re.fullmatch(r"([A-Za-z0-9_-]+)((?:\[\d+\])*)", segment)
        if not m:
            raise ValueError(f"bad key path {text!r}: write names and indices such as "
                             "simulation.t_end or body[0].ppc")
        path.append(m.group(1))
        path.extend(int(i) for i in re.findall(r"\[(\d+)\]", m.group(2)))
    return tuple(path)


# ---- the schema ---------------------------------------------------------------------------

def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


#: value types: name -> (what the error says is expected, test)
TYPES = {
    "number": ("a number", _is_number),
    "positive": ("a number > 0", lambda v: _is_number(v) and v > 0),
    "non-negative": ("a number >= 0", lambda v: _is_number(v) and v >= 0),
    "fraction": ("a number in (0, 1]", lambda v: _is_number(v) and 0 < v <= 1),
    "count": ("an integer >= 1", lambda v: isinstance(v, int) and not isinstance(v, bool)
              and v >= 1),
    "boolean": ("true or false", lambda v: isinstance(v, bool)),
    "string": ("a string", lambda v: isinstance(v, str) and v != ""),
    "vector": ("an array of numbers, one per axis",
               lambda v: isinstance(v, list) and all(_is_number(c) for c in v)),
    "table": ("a table", lambda v: isinstance(v, dict)),
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
    "mode": Key("string", "auto", doc="how the steps run (serial: one thread, "
                "bit-reproducible)", choices=MODES),
    "precision": Key("string", "f64", doc="float type of the run", choices=("f64", "f32")),
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

BODY = {
    "name": Key("string", "", doc="name of the body (reports)"),
    "material": Key("string", doc="a [material.NAME] of the file or a preset: "
                    + ", ".join(PRESETS)),
    "shape": Key("string", doc="box: lo and hi; ball: center and radius",
                 choices=("box", "ball")),
    "lo": Key("vector", REQUIRED, "m", "lower corner of a box"),
    "hi": Key("vector", REQUIRED, "m", "upper corner of a box"),
    "center": Key("vector", REQUIRED, "m", "centre of a ball (a disk in 2D)"),
    "radius": Key("positive", REQUIRED, "m", "radius of a ball"),
    "ppc": Key("count", 2, doc="particles per cell and axis"),
    "velocity": Key("vector", "zero", "m/s", "initial velocity"),
}
SHAPE_KEYS = {"box": ("lo", "hi"), "ball": ("center", "radius")}

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
                 choices=("speed", "pressure", "plastic", "von-mises", "body")),
    "color_range": Key("range", None, doc="the colour bar's range, fixed for the run "
                       "(default: from the scene: speed to max(v0, sqrt(2 g H)), stresses to "
                       "rho g H or rho c v0, plastic strain to 1)"),
    "fps": Key("count", 20, doc="GIF frames per second"),
    "width": Key("count", 640, unit="px", doc="GIF width (320 to 8192)"),
}
#: the output keys a problem run writes
PROBLEM_OUTPUT = ("frames", "vtk", "npz", "json")

PROBLEM = {
    "name": Key("string", doc="the problem", choices=tuple(PROBLEMS)),
    "elements": Key("count", "the problem's", doc="elements over the body"),
    "ppc": Key("count", "the problem's", doc="particles per element"),
    "basis": Key("string", "linear", doc="shape functions: linear, lagrange2, bsplineN "
                 "(clamped) or uniform-bsplineN (padded) of degree N", check=_basis_check),
    "mass": Key("string", "lumped", doc="mass matrix", choices=MASS_KINDS),
    "dt": Key("positive", "the problem's", "s", "time step"),
    "t_end": Key("positive", "the problem's", "s", "end time"),
    "placement": Key("string", "the problem's", doc="particle positions in an element",
                     choices=tuple(PLACEMENTS)),
    "stress_update": Key("string", "study", doc="stress update", choices=STRESS_UPDATES),
    "damping": Key("non-negative", None, doc="local damping factor alpha"),
    "projection": Key("string", "standard", doc="standard or mls (4.4)", choices=PROJECTIONS),
    "transfer": Key("string", "musl", doc="particle-grid transfer", choices=TRANSFERS),
    "allow_unstable_dt": Key("boolean", False, doc="run a dt above the critical time step"),
    "mode": Key("string", "auto", doc="how the steps run", choices=MODES),
    "params": Key("table", {}, doc="physical parameters of the problem by name (timpm run's "
                  "--param), e.g. E, density"),
}

#: the top-level tables of each form
WORLD_TABLES = ("simulation", "domain", "material", "body", "loads", "output")
PROBLEM_TABLES = ("problem", "output")

#: units and meanings of the materials' parameters (their classes' arguments)
MATERIAL_PARAMETERS = {
    "E": ("Pa", "Young's modulus"), "nu": ("", "Poisson's ratio"),
    "density": ("kg/m^3", "mass density"), "friction_angle": ("degrees", "friction angle"),
    "bulk_modulus": ("Pa", "bulk modulus"), "gamma": ("", "Tait exponent"),
    "viscosity": ("Pa s", "dynamic viscosity"), "tension": ("", "the fluid carries tension"),
    "study": ("", "the study's stress update"), "exact": ("", "integrated exactly over a step"),
}


MATERIAL_TYPE = Key("string", doc="the material law", choices=tuple(MATERIALS))


def material_schema(kind) -> dict:
    """The keys of a ``[material.NAME]`` table of ``type = kind``: the arguments of the
    material's class (a boolean default makes a boolean key)."""
    schema = {"type": MATERIAL_TYPE}
    for p in inspect.signature(MATERIALS[kind].__init__).parameters.values():
        if p.name == "self":
            continue
        unit, doc = MATERIAL_PARAMETERS.get(p.name, ("", ""))
        default = REQUIRED if p.default is p.empty else p.default
        schema[p.name] = Key("boolean" if isinstance(default, bool) else "number", default,
                             unit, doc)
    return schema


# ---- reading -----------------------------------------------------------------------------

def _describe(value):
    kinds = {bool: "a boolean", int: "an integer", float: "a float", str: "a string",
             list: "an array", dict: "a table"}
    kind = next((name for t, name in kinds.items() if type(value) is t), type(value).__name__)
    if isinstance(value, dict):
        return kind
    text = json.dumps(value) if isinstance(value, (str, list, bool)) else repr(value)
    if len(text) > 40:
        text = text[:37] + "..."
    return f"{text} ({kind})"


def _suggest(name, known):
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


class _Reader:
    """The parsed document with its key lines: checks tables against schemas and raises
    errors naming file, line and key path."""

    def __init__(self, path, data, lines, overridden):
        self.path, self.data, self.lines, self.overridden = str(path), data, lines, overridden

    def where(self, path) -> str:
        for k in range(len(path), 0, -1):
            if tuple(path[:k]) in self.overridden:
                return f"{self.path}: {dotted(path)} (overridden)"
        line = _line_of(self.lines, path)
        return f"{self.path}:{line}: {dotted(path)}" if line else f"{self.path}: {dotted(path)}"

    def error(self, path, message) -> ValueError:
        return ValueError(f"{self.where(path)}: {message}")

    def value(self, path, key, value, dim=None):
        """``value`` of ``key`` checked (type, choices, vector length, ``check``)."""
        expected, test = TYPES.get(key.type, (None, None))
        if test is not None and not test(value):
            raise self.error(path, f"expected {expected}, got {_describe(value)}")
        if key.choices and value not in key.choices and key.check is None:
            raise self.error(path, f"unknown value {value!r}{_suggest(value, key.choices)}: "
                             f"choose one of {', '.join(key.choices)}")
        if key.check is not None:
            try:
                key.check(value)
            except ValueError as err:
                raise self.error(path, str(err)) from None
        if key.type == "vector":
            if dim is not None and len(value) != dim:
                raise self.error(path, f"expected {dim} numbers (one per axis of the {dim}D "
                                 f"domain), got {len(value)}")
            return tuple(float(c) for c in value)
        if key.type in ("number", "positive", "non-negative", "fraction"):
            return float(value)
        return value

    def table(self, path, data, schema, dim=None, skip=()):
        """The table at ``path`` checked against ``schema``: unknown keys, missing required
        ones and each value; returns the values given (defaults are the caller's)."""
        if not isinstance(data, dict):
            raise self.error(path, f"expected a table, got {_describe(data)}")
        for name in data:
            if name not in schema:
                raise self.error(path + (name,), f"unknown key{_suggest(name, schema)}: "
                                 f"{dotted(path) or 'the file'} takes "
                                 f"{', '.join(schema)}")
        out = {}
        for name, key in schema.items():
            if name in skip:
                continue
            if name not in data:
                if key.default is REQUIRED:
                    raise self.error(path, f"missing required key {name!r} ({key.doc})")
                continue
            if key.type in TYPES:
                out[name] = self.value(path + (name,), key, data[name], dim)
            else:
                out[name] = data[name]
        return out

    def array_of_tables(self, path, data, what):
        if not (isinstance(data, list) and all(isinstance(t, dict) for t in data)):
            raise self.error(path, f"expected an array of tables ([[{dotted(path)}]]: "
                             f"{what}), got {_describe(data)}")
        return data


def _apply_overrides(data, overrides, file):
    """``data`` with ``overrides`` (key path or its text -> value; None removes the key)
    set; returns the key paths set (an error names the scene ``file``)."""
    done = set()
    for text, value in (overrides or {}).items():
        path = parse_path(text) if isinstance(text, str) else tuple(text)
        node = data
        for k, part in enumerate(path[:-1]):
            if isinstance(part, int):
                if not isinstance(node, list) or part >= len(node):
                    raise ValueError(f"{file}: override {dotted(path)}: {dotted(path[:k])} has no "
                                     f"element {part}")
                node = node[part]
            else:
                if not isinstance(node, dict):
                    raise ValueError(f"{file}: override {dotted(path)}: {dotted(path[:k])} is no "
                                     "table")
                node = node.setdefault(part, {})
        last = path[-1]
        if isinstance(last, int) or not isinstance(node, dict):
            raise ValueError(f"{file}: override {dotted(path)}: the last part must name a key "
                             "of a table")
        if value is None:
            node.pop(last, None)
        else:
            node[last] = value
        done.add(path)
    return done


def read_toml(path):
    """(text, document) of the TOML file ``path``; a missing file or a syntax error is a
    ValueError naming the file (and the line, column of the error)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"scene file {str(path)!r} " + ("is a directory" if path.is_dir()
                                                         else "does not exist"))
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not UTF-8 text ({err.reason} at byte {err.start})") from None
    try:
        return text, tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        message = str(err)
        m = re.search(r"\s*\(at line (\d+), column (\d+)\)$", message)
        if m:
            raise ValueError(f"{path}:{m.group(1)}:{m.group(2)}: invalid TOML: "
                             f"{message[:m.start()]}") from None
        raise ValueError(f"{path}: invalid TOML: {message}") from None


# ---- the scene ---------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class SceneFile:
    """A checked scene file: a ``world`` (the world form) or the keyword arguments of
    :func:`timpm.studies.study.run_problem` (``problem``, the problem form), the run's
    ``t_end``, ``mode``, ``precision`` (None: a problem, which runs in the precision
    Taichi was started with) and the ``output`` settings."""

    path: str
    name: str
    world: World | None
    problem: dict | None
    t_end: float | None
    mode: str
    precision: str
    output: dict
    reader: _Reader = field(repr=False, default=None)

    def error(self, path, message) -> ValueError:
        """A ValueError naming the file, the line of key ``path`` and ``message``."""
        return self.reader.error(path, message)


def load_scene(path, overrides=None) -> SceneFile:
    """Read and check the scene file ``path``; ``overrides`` maps key paths
    (``"simulation.t_end"``, ``"body[0].ppc"``) to values that replace the file's (None
    removes a key).  Errors are ValueErrors naming file, line and key (see the module)."""
    text, data = read_toml(path)
    overridden = _apply_overrides(data, overrides, path)
    reader = _Reader(path, data, key_lines(text), overridden)
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
            raise reader.error((name,), f"unknown table{_suggest(name, tables)}: a {form} "
                               f"scene has {', '.join(f'[{t}]' for t in tables)}{hint}")


def _output(reader, data, keys):
    schema = {k: OUTPUT[k] for k in keys}
    out = reader.table(("output",), data.get("output", {}), schema)
    if out.get("vtk") is not None and out.get("npz") is not None:
        raise reader.error(("output", "npz"), "give vtk or npz, not both: one field format")
    return {**{k: OUTPUT[k].default for k in keys}, **out}


def _problem_scene(reader, data, path) -> SceneFile:
    _top_level(reader, data, PROBLEM_TABLES, "problem")
    opts = reader.table(("problem",), data["problem"], PROBLEM)
    output = _output(reader, data, PROBLEM_OUTPUT)
    cls = PROBLEMS[opts.pop("name")]
    params = opts.pop("params", {})
    known = [f.name for f in fields(cls)]
    for name in params:
        if name not in known:
            raise reader.error(("problem", "params", name),
                               f"{cls.name} has no parameter {name!r}{_suggest(name, known)}: "
                               f"its parameters are {', '.join(known)}")
    try:
        cls().with_params(**params)
    except (ValueError, TypeError) as err:
        raise reader.error(("problem", "params"), str(err)) from None
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
                               f" or a table {{kind = ..., mu = ...}}, got {_describe(spec)}")
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
                raise reader.error(path + (side,), f"unknown side{_suggest(side, sides)}: "
                                   f"the sides of a {dim}D domain are {', '.join(sides)} "
                                   "(and default)")
            out[side] = wall(path + (side,), spec)
        return out
    return wall(path, value)


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
        except ValueError as err:
            raise reader.error(where, str(err)) from None
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
        others = [n for n in (*SHAPE_KEYS["box"], *SHAPE_KEYS["ball"]) if n not in keys]
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
                               f"{_suggest(name, known)}: define [material.{name}] or use "
                               f"one of {', '.join(known)}")
        try:
            geometry = (Box(b["lo"], b["hi"]) if shape == "box"
                        else Ball(b["center"], b["radius"]))
            bodies.append(Body(geometry, material, velocity=b.get("velocity"),
                               ppc=b.get("ppc", 2), name=b.get("name", "")))
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
                               f"{_suggest(t['body'], names)}: the bodies are "
                               f"{', '.join(repr(n) for n in names)}")
        if t["side"] not in SIDES[:2 * dim]:
            raise reader.error(where + ("side",), f"a {dim}D body has the sides "
                               f"{', '.join(SIDES[:2 * dim])}")
        ramp = t.get("ramp")
        kwargs = {} if ramp is None else {"time_function": Ramp(ramp)}
        out.append(SurfaceTraction(names.index(t["body"]), t["side"], t["traction"], **kwargs))
    return out


#: the key a World's error message is about, by the message's start
_WORLD_ERRORS = ((r"bodies \d+ and (\d+) overlap", "body"), (r"body (\d+)\b", "body"),
                 (r"tractions\[(\d+)\]", "loads.traction"), (r"the surface tractions", "loads"),
                 (r"time step dt", "simulation.dt"), (r"courant", "simulation.courant"),
                 (r"domain", "domain"), (r"the \S+ transfer|the mls-mpm", "simulation.transfer"),
                 (r"damping|local damping", "simulation.damping"))


def _world_error_key(message):
    """The key path a World's error ``message`` names (None: none)."""
    for pattern, key in _WORLD_ERRORS:
        m = re.match(pattern, message)
        if m:
            return parse_path(key) + tuple(int(g) for g in m.groups())
    return None


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
    loads = reader.table(("loads",), data.get("loads", {}), LOADS, dim, skip=("traction",))
    materials = _materials(reader, data)
    bodies = _bodies(reader, data, materials, dim)
    tractions = _tractions(reader, data.get("loads", {}).get("traction", []), bodies, dim)
    output = _output(reader, data, tuple(OUTPUT))
    if output["gif"] is not None and dim == 1:
        raise reader.error(("output", "gif"), "a 1D world draws no GIF")
    name = sim.get("name", path.stem)
    try:
        world = World(domain=domain["size"], cells=domain["cells"], bodies=bodies,
                      basis=sim.get("basis", "uniform-bspline2"),
                      transfer=sim.get("transfer", "apic"), gravity=loads.get("gravity"),
                      walls=walls, dt=sim.get("dt"), courant=sim.get("courant"),
                      allow_overlap=sim.get("allow_overlap", False),
                      allow_unstable_dt=sim.get("allow_unstable_dt", False),
                      damping=sim.get("damping", 0.0), tractions=tractions, name=name)
    except ValueError as err:
        key = _world_error_key(str(err))
        raise (reader.error(key, str(err)) if key else ValueError(f"{path}: {err}")) from None
    return SceneFile(path=str(path), name=name, world=world, problem=None, t_end=sim["t_end"],
                     mode=sim.get("mode", "auto"), precision=sim.get("precision", "f64"),
                     output=output, reader=reader)


# ---- running -----------------------------------------------------------------------------

@dataclass
class SceneResult:
    """What a scene's run produced: sizes, times, the files written, and (a problem) the
    record of :func:`timpm.studies.study.run_problem`."""

    name: str
    path: str
    particles: int
    steps: int
    dt: float
    t_end: float
    compile_seconds: float
    simulation_seconds: float
    render_seconds: float = 0.0
    files: list = field(default_factory=list)
    record: dict | None = None
    series: dict = field(default_factory=dict)
    interrupted: bool = False

    def report(self) -> str:
        rate = self.particles * self.steps / max(self.simulation_seconds, 1e-12) / 1e6
        lines = [f"{self.name} ({self.path}): {self.particles} particles, {self.steps} steps "
                 f"of dt = {self.dt:.3g} s to t = {self.t_end:.4g} s",
                 f"  compile {self.compile_seconds:.2f} s, simulation "
                 f"{self.simulation_seconds:.2f} s ({rate:.2f} M particle-steps/s)"
                 + (f", rendering {self.render_seconds:.2f} s" if self.render_seconds else "")]
        if self.record is not None and self.record.get("rms_error") is not None:
            lines.append(f"  e_RMS = {self.record['rms_error']:.4e} ({self.record['elements']} "
                         f"elements, {self.record['ppc']} PPC, {self.record['basis']})")
        if self.files:
            lines.append(f"  wrote {', '.join(self.files)}")
        return "\n".join(lines)

    def document(self) -> dict:
        """The JSON document of the run."""
        doc = {k: getattr(self, k) for k in ("name", "path", "particles", "steps", "dt",
                                            "t_end", "compile_seconds", "simulation_seconds",
                                            "render_seconds", "files")}
        if self.record is not None:
            doc["record"] = self.record
        if self.interrupted:
            doc["interrupted"] = True
        doc["series"] = {k: np.asarray(v).tolist() for k, v in self.series.items()}
        return doc


def _writers(scene):
    """The field writer and the movie of the scene's output (checked before any work)."""
    from .output.fields import FieldWriter, check_output_file

    out = scene.output
    fields_writer = movie = None
    for fmt in ("vtk", "npz"):
        if out.get(fmt) is not None:
            try:
                fields_writer = FieldWriter(out[fmt], fmt)
            except ValueError as err:
                raise scene.error(("output", fmt), str(err)) from None
    for key in ("json", "gif"):
        if out.get(key) is not None:
            try:
                check_output_file(out[key], f"output file {key}")
            except ValueError as err:
                raise scene.error(("output", key), str(err)) from None
    if out.get("gif") is not None:
        from .output.render import Movie

        movie = Movie(out["gif"], fps=out["fps"], width=out["width"])
    return fields_writer, movie


def _files(fields_writer, movie):
    files = []
    if fields_writer is not None:
        files.append(str(fields_writer.series if fields_writer.format == "vtk"
                         else fields_writer.directory))
    if movie is not None:
        files.append(movie.out)
    return files


def run_scene(scene, progress=None) -> SceneResult:
    """Run ``scene`` (a :class:`SceneFile` or a path), writing its outputs; returns the
    :class:`SceneResult` (its JSON document is written when ``output.json`` is set)."""
    from . import runtime

    if not isinstance(scene, SceneFile):
        scene = load_scene(scene)
    if scene.precision is not None and scene.precision != runtime.precision():
        raise scene.error(("simulation", "precision"), f"the scene runs in {scene.precision} "
                          f"but Taichi was started in {runtime.precision()}: call "
                          f"timpm.init(precision={scene.precision!r}) first")
    fields_writer, movie = _writers(scene)
    try:
        result = (_run_problem(scene, fields_writer, progress) if scene.problem is not None
                  else _run_world(scene, fields_writer, movie, progress))
    except RunInterrupted as stop:  # Ctrl-C: the partial record, then on to the caller
        if stop.result is not None and scene.output.get("json") is not None:
            write_json(scene.output["json"], stop.result.document())
        raise
    result.files = _files(fields_writer, movie)
    if scene.output.get("json") is not None:
        result.files.append(scene.output["json"])
        write_json(scene.output["json"], result.document())
    return result


def _run_problem(scene, fields_writer, progress) -> SceneResult:
    from .studies.study import run_problem

    try:
        run = run_problem(**scene.problem, fields=fields_writer,
                          frames=scene.output["frames"], progress=progress,
                          interrupted_to=INTERRUPTED_CHECKPOINT)
    except RunInterrupted as stop:
        stop.result = _problem_result(scene, stop.result)
        stop.result.interrupted = True
        raise
    return _problem_result(scene, run)


def _problem_result(scene, run) -> SceneResult:
    rec = run.record
    series = {k: v for k, v in run.series.items() if np.ndim(v) == 1}
    if run.energies is not None:
        series.update({f"energy_{k}": v for k, v in run.energies.items()})
    return SceneResult(name=scene.name, path=scene.path, particles=rec["particles"],
                       steps=rec["steps"], dt=rec["dt"], t_end=rec["t_end"],
                       compile_seconds=rec["compile_seconds"],
                       simulation_seconds=rec["wall_seconds"], record=rec, series=series)


class _WorldScales:
    """The colour scales of a scene file's world, as a demo gives them
    (:func:`timpm.scenarios.demos.color_range`): H the domain's height along gravity, v0
    the largest initial speed, rho and c the densest material's density and the fastest
    wave speed."""

    def __init__(self, world):
        gravity = np.asarray(world.model.gravity, dtype=float)
        g = float(np.linalg.norm(gravity))
        height = float(world.domain[int(np.argmax(np.abs(gravity))) if g > 0 else 0])
        v0 = float(np.max(np.linalg.norm(world.velocity, axis=1), initial=0.0))
        density = max(m.density for m in world.materials)
        wave = max(m.wave_speed for m in world.materials)
        self.speed = max(v0, np.sqrt(2.0 * g * height)) or 1.0
        self.stress = (density * g * height if g > 0 else density * wave * v0) or 1.0

    def speed_scale(self) -> float:
        """max(v0, sqrt(2 g H))."""
        return self.speed

    def stress_scale(self) -> float:
        """rho g H, or without gravity rho c v0."""
        return self.stress

    def strain_scale(self) -> float:
        return 1.0


def _color_range(world, color, output):
    """The GIF's colour range for the whole run, its label and unit: ``output.color_range``
    or the world's scales (:class:`_WorldScales`)."""
    from .scenarios.demos import color_range

    value_range, label, unit = color_range(_WorldScales(world), color, len(world.bodies))
    if output.get("color_range") is not None:
        value_range = tuple(float(v) for v in output["color_range"])
    return value_range, label, unit


def _run_world(scene, fields_writer, movie, progress) -> SceneResult:
    from .scenarios.demos import quantity, run_frames
    from .solver import Solver

    world, frames, t_end = scene.world, scene.output["frames"], scene.t_end
    color = scene.output["color"]
    solver = Solver(world, mode=scene.mode, energies=True,
                    record_every=max(1, int(round(t_end / world.dt / 200))))
    try:
        if movie is not None:
            try:
                quantity(solver, color)  # a colour the scene lacks fails before the run
            except ValueError as err:
                raise scene.error(("output", "color"), str(err)) from None
            value_range, label, unit = _color_range(world, color, scene.output)
            movie.start(world, color, value_range=value_range, label=label, unit=unit,
                        title=scene.name)
        try:
            run_frames(solver, t_end, frames, movie=movie, color=color, fields=fields_writer,
                       progress=progress)
        except RunInterrupted as stop:  # Ctrl-C: keep the state, the frames so far
            if movie is not None:
                movie.close()
            stop.checkpoint = save_checkpoint(INTERRUPTED_CHECKPOINT, solver,
                                              {"scene_file": str(scene.path)})
            stop.result = _world_result(scene, solver, movie)
            stop.result.interrupted = True
            raise
        if movie is not None:
            movie.close()
        return _world_result(scene, solver, movie)
    finally:
        solver.release()


def _world_result(scene, solver, movie) -> SceneResult:
    world = scene.world
    return SceneResult(name=scene.name, path=scene.path, particles=world.n_particles,
                       steps=solver.step, dt=world.dt, t_end=solver.t,
                       compile_seconds=solver.compile_seconds,
                       simulation_seconds=solver.run_seconds,
                       render_seconds=movie.seconds if movie is not None else 0.0,
                       series=solver.energies())


# ---- the command line --------------------------------------------------------------------

def is_scene_argument(argv) -> bool:
    """Whether ``timpm run`` arguments ``argv`` (after ``run``) name a scene file: an
    argument ending in ``.toml``, or a first argument that names an existing file."""
    if any(a.endswith(".toml") and not a.startswith("-") for a in argv):
        return True
    return bool(argv) and argv[0] not in PROBLEMS and os.path.isfile(argv[0])


def _setting(text):
    """KEY=VALUE: the value read as TOML (a number, true, [1, 2], "text"), else as a bare
    string; empty removes the key."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    if not value:
        return key, None
    try:
        return key, tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        return key, value


def _parser():
    from .argtypes import add_runtime_arguments, positive_float, positive_int

    p = argparse.ArgumentParser(prog="timpm run", description="Run a scene file (TOML): a "
                                "world of bodies or a benchmark problem; see "
                                "docs/scene_files.md.")
    p.add_argument("file", help="the scene file")
    p.add_argument("--t-end", type=positive_float, help="end time [s] (the file's t_end)")
    p.add_argument("--dt", type=positive_float, help="time step [s] (the file's dt)")
    p.add_argument("--mode", choices=MODES, help="how the steps run (the file's mode)")
    p.add_argument("--frames", type=positive_int, help="output frames (output.frames)")
    p.add_argument("--vtk", metavar="DIR", help="ParaView field files (replaces the file's "
                   "vtk / npz)")
    p.add_argument("--npz", metavar="DIR", help="NumPy field files (replaces the file's "
                   "vtk / npz)")
    p.add_argument("--gif", metavar="FILE.gif", help="animated GIF (output.gif)")
    p.add_argument("--json", metavar="FILE", help="the run as JSON (output.json)")
    p.add_argument("--set", type=_setting, action="append", default=[], metavar="KEY=VALUE",
                   dest="settings", help="set any key, e.g. domain.cells=64, body[0].ppc=3, "
                   "simulation.transfer=musl; KEY= removes it")
    add_runtime_arguments(p)
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar (default: on a terminal, for runs over 2 s)")
    p.add_argument("--quiet", action="store_true", help="no summary on stdout")
    return p


def _command_line_overrides(args, form):
    """The key paths the options set (after ``--set``, so they win)."""
    out = dict(args.settings)
    for option in ("t_end", "dt", "mode"):
        if getattr(args, option) is not None:
            out[f"{form}.{option}"] = getattr(args, option)
    if args.vtk and args.npz:
        raise ValueError("--vtk and --npz: choose one field format")
    for fmt, other in (("vtk", "npz"), ("npz", "vtk")):
        if getattr(args, fmt):
            out[f"output.{fmt}"], out[f"output.{other}"] = getattr(args, fmt), None
    for option in ("frames", "gif", "json"):
        if getattr(args, option) is not None:
            out[f"output.{option}"] = getattr(args, option)
    return out


def main(argv) -> int:
    """``timpm run FILE.toml [options]``: load, check and run the scene, print a summary;
    an error prints ``timpm: error: ...`` and returns 2."""
    from . import runtime
    from .solver import SimulationError

    args = _parser().parse_args(argv)
    try:
        _, data = read_toml(args.file)
        form = "problem" if "problem" in data else "simulation"
        scene = load_scene(args.file, _command_line_overrides(args, form))
        runtime.init(threads=args.threads, arch=args.arch,
                     precision=scene.precision or "f64")
        with deferred_sigint():
            result = run_scene(scene, progress=args.progress)
    except RunInterrupted as stop:
        saved = f"; state saved to {stop.checkpoint}" if stop.checkpoint else ""
        record = scene.output.get("json")
        print(f"timpm: interrupted at step {stop.step} (t = {stop.t:g} s){saved}"
              + (f"; partial record {record}" if record else ""), file=sys.stderr)
        return 130
    except (ValueError, SimulationError, runtime.BackendUnavailable) as exc:
        print(f"timpm: error: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(result.report())
    return 0


# ---- the schema as documentation ---------------------------------------------------------

def _default_text(key):
    if key.default is REQUIRED:
        return "required"
    if key.default is None:
        return "none"
    if isinstance(key.default, bool):
        return str(key.default).lower()
    if isinstance(key.default, str) and key.type in ("string", "walls") and key.default and \
            " " not in key.default and key.default != "the problem's":
        return f'`"{key.default}"`'
    if isinstance(key.default, (dict, tuple)):
        return "none"
    return str(key.default) if key.default != "" else '`""`'


def _markdown(schema, title):
    rows = [f"**{title}**", "", "| key | type | default | unit | meaning |",
            "|---|---|---|---|---|"]
    for name, key in schema.items():
        kind = TYPES[key.type][0] if key.type in TYPES else {
            "walls": "a string or a table", "array": "an array of tables"}[key.type]
        doc = key.doc + (f"; one of {', '.join(key.choices)}" if key.choices else "")
        doc = doc.replace("|", "\\|")  # a bar would end the cell
        rows.append(f"| `{name}` | {kind} | {_default_text(key)} | {key.unit} | {doc} |")
    return "\n".join(rows)


def schema_reference() -> str:
    """The key tables of docs/scene_files.md, from the schema (a test keeps them equal)."""
    parts = [_markdown(SIMULATION, "[simulation]"), _markdown(DOMAIN, "[domain]"),
             _markdown(WALL, "a wall: a string (the kind) or a table"),
             _markdown(LOADS, "[loads]"), _markdown(TRACTION, "[[loads.traction]]"),
             _markdown(BODY, "[[body]]")]
    parts.append(_markdown({"type": MATERIAL_TYPE}, "[material.NAME]"))
    for kind in MATERIALS:
        params = {k: v for k, v in material_schema(kind).items() if k != "type"}
        parts.append(_markdown(params, f'[material.NAME] with type = "{kind}"'))
    parts += [_markdown(OUTPUT, "[output]"), _markdown(PROBLEM, "[problem]")]
    return "\n\n".join(parts) + "\n"
