"""Scene files: a whole simulation described in TOML, read, checked and run
(``timpm run scene.toml``).

A scene file takes one of two forms (docs/scene_files.md lists every key):

* a **world**: ``[simulation]`` (end time, time step or Courant number, basis, transfer,
  mode, precision), ``[domain]`` (size, cells, walls), ``[[plane]]`` tables (plane walls
  at any angle: point, normal, kind, mu, drained), ``[material.NAME]`` tables,
  ``[[body]]`` tables (a box or a ball of a material), ``[loads]`` (gravity, surface
  tractions) and ``[output]`` (field frames, GIF, JSON); it builds a
  :class:`timpm.model.world.World` and runs it like a demo;
* a **problem**: ``[problem]`` names one of the 1D/2D/3D benchmark problems with the options
  of ``timpm run`` (``[problem.params]``: its physical parameters) and runs it through
  :func:`timpm.studies.study.run_problem`.

The file is read with :mod:`tomllib` and checked against the schema before any work:
an unknown key (with a close known one suggested), a value of the wrong type, a missing
required key or a bad value is a ``ValueError`` that names the file, the line and the key
path (``scene.toml:12: body[1].material: ...``).  :func:`key_lines` finds the lines (tomllib
reports none for keys).  ``overrides`` (a dict of key path to value, ``None`` removing the
key) change the file's values before the check: the command line's ``--t-end``, ``--json``,
``--set KEY=VALUE`` ... and the tests' tiny runs.

The top layer, beside the command line (``tests/test_layers.py``): it builds on the world,
the solver, the demos' colour quantities, the studies' ``run_problem`` and the output writers.
Its modules, each importing only those listed before it:

* ``toml``: the TOML parser (tomllib, or the tomli backport before Python 3.11);
* ``keypaths``: key paths (``body[1].material``) and their lines in a document;
* ``schema``: the value types and the keys of every table;
* ``reader``: the document read, overridden and checked table by table;
* ``build``: the checked tables made a :class:`SceneFile` (:func:`load_scene`);
* ``runner``: a scene run, its outputs written (:func:`run_scene`), a world run's
  checkpoint continued (:func:`resume_scene`);
* ``command``: ``timpm run FILE.toml`` (:func:`main`);
* ``reference``: the schema as the tables of docs/scene_files.md.
"""
from .build import SceneFile, load_scene
from .command import is_scene_argument, main
from .keypaths import key_lines
from .reference import schema_reference
from .runner import SceneResult, resume_scene, run_scene
from .schema import MODES, OUTPUT

__all__ = ["SceneFile", "SceneResult", "load_scene", "run_scene", "resume_scene", "key_lines",
           "main", "is_scene_argument", "schema_reference", "MODES", "OUTPUT"]
