"""Layers: the package's imports point one way, down the layer order, and form no cycle.

Every module under timpm/ is parsed with ``ast`` (nothing is imported); its imports of
timpm modules, absolute and relative, at module level and inside functions, are the edges
of the import graph.  ``from X import name`` points at the module ``X.name`` when there is
one, else at ``X``.  Importing a submodule also runs its packages' ``__init__``; those
implicit edges are left out (``timpm/__init__.py`` re-exports the model and is exempt from
the layer order, though not from the cycle check).

Units keep their private names: no module reaches into a private name (``_x``) that
timpm defines elsewhere, through ``obj._x`` on anything but ``self``/``cls`` or through
``from module import _x``.
"""
import ast
from pathlib import Path
from types import SimpleNamespace

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "timpm"

#: the layers, lowest first: a module may import modules of its own layer and of the layers
#: below it.  A name covers the module and its submodules; a trailing ``*`` covers every
#: module whose name starts so (``timpm.model*``: timpm.model, timpm.models.x, ...)
LAYERS = (
    ("timpm.platform*",),                                   # Taichi's start, errors, checks
    ("timpm.bases*", "timpm.materials*", "timpm.schemes*"),  # components: bases, laws, transfers
    ("timpm.model*",),                                      # the model and its builders
    ("timpm.engine*",),                                     # the compiled programs
    ("timpm.simulation*",),                                 # solver, batch, checkpoints, loading
    ("timpm.problems*", "timpm.scenarios*"),                # the cases
    ("timpm.studies*",),
    ("timpm.output*",),
    ("timpm.cli*", "timpm.__main__", "timpm.scenefile*"),   # the command line, scene files
)

#: modules outside the layer order
EXEMPT = {"timpm"}


def module_name(path, root=PACKAGE.parent):
    """``timpm/studies/study.py`` -> ``timpm.studies.study``; a package's ``__init__.py``
    is the package."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def package_modules(package=PACKAGE):
    """Module name -> path of every ``.py`` file under ``package``."""
    return {module_name(p, package.parent): p for p in sorted(package.rglob("*.py"))
            if "__pycache__" not in p.parts}


def imports(module, source, is_package=False):
    """(name, line, from_import) of every import in ``source``, wherever it stands (other
    packages' too); ``from X import a`` gives ``X.a``; relative imports are made absolute
    against ``module`` (``is_package``: the source is its ``__init__.py``)."""
    here = module if is_package else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno, False
        elif isinstance(node, ast.ImportFrom):
            base = node.module
            if node.level:
                parts = here.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            for alias in node.names:
                yield f"{base}.{alias.name}", node.lineno, True


def _is_ours(name, top="timpm"):
    return name == top or name.startswith(top + ".")


def import_graph(modules):
    """module -> {imported module: first line}, and the imports that name no module."""
    graph, unresolved = {}, []
    for module, path in modules.items():
        edges = graph.setdefault(module, {})
        for name, line, from_import in imports(module, path.read_text(),
                                               path.name == "__init__.py"):
            if not _is_ours(name):
                continue
            target = name
            if from_import and name not in modules:  # ``from X import a``: X.a or X
                target = name.rpartition(".")[0]
            if target not in modules:
                unresolved.append(f"{module}:{line} imports {name}, which is no module of "
                                  "the package")
            elif target != module:
                edges.setdefault(target, line)
    return graph, unresolved


def layer_of(module, layers=LAYERS):
    """Index of ``module``'s layer in ``layers``, or None."""
    for i, names in enumerate(layers):
        for name in names:
            if name.endswith("*"):
                if module.startswith(name[:-1]):
                    return i
            elif module == name or module.startswith(name + "."):
                return i
    return None


def upward_imports(graph, layers=LAYERS, exempt=EXEMPT):
    """'importer (layer) imports imported (layer)' for every import that points up."""
    bad = []
    for module, edges in sorted(graph.items()):
        if module in exempt:
            continue
        low = layer_of(module, layers)
        for target, line in sorted(edges.items()):
            high = layer_of(target, layers)
            if target not in exempt and low is not None and high is not None and high > low:
                bad.append(f"{module} (layer {low + 1}) imports {target} (layer {high + 1}) "
                           f"at line {line}")
    return bad


def find_cycles(graph):
    """Import cycles of ``graph`` (module -> imported modules), each as [a, b, ..., a]: one
    per back edge of a depth-first search, so every cyclic group of modules shows up."""
    state, stack, cycles = {}, [], []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                cycles.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt)
        stack.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node)
    return cycles


def _private(name):
    return name.startswith("_") and not name.startswith("__")


def private_names(sources):
    """The private names timpm defines: functions, methods and classes, module and class
    variables, and attributes assigned on ``self``."""
    names = set()
    for source in sources:
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names.add(node.name)
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                for target in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                    if isinstance(target, ast.Name):
                        names.add(target.id)
                    elif (isinstance(target, ast.Attribute) and isinstance(target.value, ast.Name)
                          and target.value.id == "self"):
                        names.add(target.attr)
    return {n for n in names if _private(n)}


def _foreign_names(tree):
    """Names bound by imports from other packages (``kernel_impl`` of ``from taichi.lang
    import kernel_impl``): timpm may patch their private names, which are not its units'."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {(a.asname or a.name).partition(".")[0] for a in node.names
                      if not _is_ours(a.name)}
        elif isinstance(node, ast.ImportFrom) and not _is_ours_relative(node):
            names |= {a.asname or a.name for a in node.names}
    return names


def private_reaches(module, source, defined):
    """'module:line name' for every use of a private name in ``defined`` from outside its
    unit: ``obj._x`` where obj is not ``self``/``cls`` (nor another package's module),
    and ``from X import _x``."""
    found, tree = [], ast.parse(source)
    allowed = {"self", "cls"} | _foreign_names(tree)
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr in defined:
            owner = node.value
            if not (isinstance(owner, ast.Name) and owner.id in allowed):
                found.append(f"{module}:{node.lineno} {ast.unparse(node)}")
        elif isinstance(node, ast.ImportFrom) and _is_ours_relative(node):
            found += [f"{module}:{node.lineno} from {node.module or '.'} import {a.name}"
                      for a in node.names if a.name in defined]
    return found


def _is_ours_relative(node):
    return node.level > 0 or (node.module is not None and _is_ours(node.module))


# ---- the package --------------------------------------------------------------------------

MODULES = package_modules()
GRAPH, UNRESOLVED = import_graph(MODULES)


def test_the_package_was_parsed():
    assert {"timpm", "timpm.cli.main", "timpm.simulation.solver"} <= set(MODULES)
    assert "timpm.simulation.solver" in GRAPH["timpm.cli.main"]


def test_every_timpm_import_names_a_module():
    # an import inside a function runs only when called: a moved module shows up here
    assert not UNRESOLVED, "\n".join(UNRESOLVED)


def test_every_module_has_a_layer():
    missing = [m for m in MODULES if m not in EXEMPT and layer_of(m) is None]
    assert not missing, f"modules in no layer (add them to LAYERS): {', '.join(missing)}"


def test_no_import_cycles():
    cycles = find_cycles({m: set(edges) for m, edges in GRAPH.items()})
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_imports_point_down_the_layers():
    bad = upward_imports(GRAPH)
    assert not bad, "imports pointing up the layer order:\n" + "\n".join(bad)


def test_no_module_reaches_into_another_units_private_names():
    sources = {m: p.read_text() for m, p in MODULES.items()}
    defined = private_names(sources.values())
    assert {"_team_member", "_row_node", "_state"} <= defined  # it sees methods, globals
    bad = [hit for m, src in sorted(sources.items()) for hit in private_reaches(m, src, defined)]
    assert not bad, "private names used from outside their unit:\n" + "\n".join(bad)


# ---- the checks can fail ------------------------------------------------------------------

class _source:
    """Stands in for a module's path in :func:`import_graph`."""

    name = "module.py"

    def __init__(self, text):
        self.text = text

    def read_text(self):
        return self.text


def test_cycle_finder_finds_a_synthetic_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"a"}}
    assert find_cycles(graph) == [["a", "b", "c", "a"]]
    assert find_cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []
    assert find_cycles({"a": {"a"}}) == [["a", "a"]]


def test_imports_are_found_relative_and_inside_functions():
    source = ("import os\nimport timpm.solver\nfrom ..scene import Scene\n"
              "from . import analysis\n"
              "def f():\n    from ..output.viz import save\n    from timpm import runtime\n")
    found = [name for name, _, _ in imports("timpm.studies.study", source) if _is_ours(name)]
    assert found == ["timpm.solver", "timpm.scene.Scene", "timpm.studies.analysis",
                     "timpm.output.viz.save", "timpm.runtime"]
    # in a package's __init__, "." is the package itself
    assert [n for n, _, _ in imports("timpm.studies", "from .study import x", True)] == [
        "timpm.studies.study.x"]
    graph, unresolved = import_graph({"timpm.a": _source("from .b import f\nimport timpm.c"),
                                      "timpm.b": _source("")})
    assert graph == {"timpm.a": {"timpm.b": 1}, "timpm.b": {}}
    assert unresolved == ["timpm.a:2 imports timpm.c, which is no module of the package"]


def test_upward_imports_are_named():
    graph = {"timpm.simulation.solver": {"timpm.cli.main": 3, "timpm.model.scene": 4},
             "timpm.output.viz": {"timpm.scenarios.demos": 5}, "timpm": {"timpm.cli.main": 1}}
    assert upward_imports(graph) == ["timpm.simulation.solver (layer 5) imports "
                                     "timpm.cli.main (layer 9) at line 3"]
    assert layer_of("timpm.model.world") == layer_of("timpm.models") == 2
    assert layer_of("timpm.elsewhere") is None


def test_private_reaches_are_found():
    defined = private_names(["class A:\n    def _step(self):\n        self._n = 1\n",
                             "_table = {}\ndef _helper():\n    pass\n"])
    assert defined == {"_step", "_n", "_table", "_helper"}
    source = ("from .a import _helper, run\nimport os\nfrom taichi.lang import impl\n"
              "def f(solver):\n    solver._step()\n    os._exit(0)\n    impl._helper = 1\n"
              "    return self._n\n")
    assert private_reaches("timpm.b", source, defined) == [
        "timpm.b:1 from a import _helper", "timpm.b:5 solver._step"]


# ---- the units of a compiled program ------------------------------------------------------
#: the engine's units, lowest first: a unit holds (and calls) only units before it.  The
#: transfer schemes sit above the operations they are given, the integrators above the
#: scheme they wrap, the drivers above the scheme whose phases they run
UNIT_ORDER = ("Failures", "Stencil", "_Adds", "Scatter", "Boundary", "BandedMass", "CGMass",
              "MLSProjection", "MLSStressND", "GridSolve", "Loads", "Laws", "G2P",
              "transfer scheme", "integrator", "Recorder", "Drivers", "Uploads", "HostState")


def _rank(obj):
    """The place of a unit (an engine unit or a scheme) in UNIT_ORDER, None for anything
    else (a phase, a view, a field)."""
    from timpm.schemes import INTEGRATORS, Scheme

    cls = type(obj)
    if isinstance(obj, Scheme):
        return UNIT_ORDER.index("integrator" if cls in INTEGRATORS.values()
                                else "transfer scheme")
    if cls.__module__.startswith("timpm.engine.") and cls.__name__ in UNIT_ORDER:
        return UNIT_ORDER.index(cls.__name__)
    return None


def unit_edges(program):
    """(holder, held, attribute) of every unit a program's unit holds (an attribute whose
    value is a unit, or a bound method of one), from the live objects."""
    roots = [*vars(program.ops).values(), program.scheme, program.recorder, program.drivers,
             program.uploads, program.host]
    seen, edges, todo = set(), [], [u for u in roots if u is not None]
    while todo:
        unit = todo.pop()
        if id(unit) in seen:
            continue
        seen.add(id(unit))
        for name, value in vars(unit).items():
            held = getattr(value, "__self__", value)  # a bound method: its unit
            if held is not unit and _rank(held) is not None:
                edges.append((unit, held, name))
                todo.append(held)
    return edges


def _programs():
    """Programs of feature sets that together build every unit (fields allocated, nothing
    compiled)."""
    from timpm import Body, Box, World
    from timpm.engine.features import plan
    from timpm.engine.program import Program
    from timpm.engine.program_cache import Capacity
    from timpm.materials import LinearElastic, NeoHookean
    from timpm.problems import get_problem
    from timpm.platform.runtime import ensure_init

    ensure_init()
    rubber = NeoHookean(E=1e4, nu=0.3, density=1000.0)
    steel = LinearElastic(E=1e5, nu=0.3, density=2000.0)

    def world(walls="slip", **kw):
        bodies = [Body(Box((0.25, 0.25), (0.5, 0.5)), rubber),
                  Body(Box((0.5, 0.25), (0.75, 0.5)), steel)]
        return World(domain=(1.0, 1.0), cells=8, bodies=bodies, walls=walls, **kw)

    mms_1d, mms_2d = get_problem("mms-1d"), get_problem("mms-2d")
    scenes = [
        (get_problem("vibrating-string").scene(elements=8, basis="bspline2",
                                               mass="consistent", projection="mls"), {}),
        (get_problem("vibrating-string").scene(elements=8, projection="mls"), {}),  # 4.4
        (mms_1d.scene(elements=8, integrator="rk4"), {}),  # a body force, its stages
        (mms_1d.scene(elements=8, integrator="midpoint"), {}),
        (mms_2d.scene(elements=4, basis="bspline2"), {}),  # the 2D MLS stress
        (mms_2d.scene(elements=4, basis="uniform-bspline2", mass="consistent",
                      projection="standard"), {}),  # the 2D conjugate gradients
        (world(transfer="musl", pic_fraction=0.2), {"mode": "parallel"}),
        (world(walls="roller", transfer="apic", integrator="midpoint"), {"mode": "serial"}),
        (world(transfer="mls-mpm"), {"mode": "parallel", "scatter": "private"}),
    ]
    programs = []
    for scene, options in scenes:
        features, layout = plan(scene, track=[0], **options)
        programs.append(Program(features, Capacity.first(features, layout)))
    return programs


@pytest.fixture(scope="module")
def programs():
    built = _programs()
    yield built
    for prog in built:
        prog.release()


def test_program_holds_its_units_as_objects(programs):
    """Program mixes nothing in: it builds its units, each from what it reads."""
    from timpm.engine.program import Program

    assert Program.__bases__ == (object,)
    held = {type(u).__name__ for prog in programs for _, u, _ in unit_edges(prog)}
    assert {"Stencil", "Scatter", "Boundary", "GridSolve", "G2P", "Laws", "Drivers",
            "BandedMass", "CGMass", "MLSProjection", "MLSStressND"} <= held


def test_the_units_of_a_program_hold_only_the_units_below_them(programs):
    """A unit is given the units it calls when it is built, and only units below it:
    no unit calls back into one above it (the picture is a stack, not a web)."""
    upward = sorted({f"{type(a).__name__}.{name} holds {type(b).__name__}, a unit above it"
                     for prog in programs for a, b, name in unit_edges(prog)
                     if _rank(b) >= _rank(a) and not (a is b)})
    assert upward == []
    assert any(type(a).__name__ == "RungeKutta" and type(b).__name__ == "MUSL"
               for prog in programs for a, b, _ in unit_edges(prog))


def test_a_call_up_the_units_is_found():
    class Low:
        pass

    from timpm.engine.stencil import Stencil
    from timpm.engine.failures import Failures

    low = Failures.__new__(Failures)
    high = Stencil.__new__(Stencil)
    low.stencil = high  # a failure record holding the stencil: upward
    fake = SimpleNamespace(ops=SimpleNamespace(failures=low), scheme=None, recorder=None,
                           drivers=None, uploads=None, host=None)
    edges = unit_edges(fake)
    assert [(type(a).__name__, type(b).__name__, n) for a, b, n in edges] == [
        ("Failures", "Stencil", "stencil")]
    assert _rank(high) > _rank(low)


def state_names(programs):
    """What a phase reads as state: the names of every field of the programs (particle,
    grid by the kernels' names, run, history, scratch) and ``values``."""
    names = {"values"}
    for prog in programs:
        for view in (prog.particles, prog.grid, prog.run, prog.history):
            names |= set(view.names)
        names |= set(prog.scratch_fields) | set(prog.grid_fields)
    return names


def reads(source, names, owner="self"):
    """(line, name) of every ``owner.NAME`` in ``source`` that names a field."""
    return sorted((node.lineno, node.attr) for node in ast.walk(ast.parse(source))
                  if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                  and node.value.id == owner and node.attr in names)


SCHEMES = sorted((PACKAGE / "schemes").glob("*.py"))


def test_no_phase_reads_the_program(programs):
    """A scheme's phases receive the particle fields, the grid fields and the run-time
    values (``particles.v[p]``, ``grid.node_mass[I]``, ``values.dt()``); through ``self``
    they reach the operations they were given and their compile-time choices only: no
    program, no field."""
    names = state_names(programs)
    assert {"x", "v", "sigma", "C", "node_mass", "node_velocity", "band", "x_start",
            "F_rate", "v_end", "values"} <= names
    assert len(SCHEMES) >= 7
    found = {path.name: reads(path.read_text(), names) for path in SCHEMES}
    assert {name: r for name, r in found.items() if r} == {}
    program_names = {path.name: sorted({node.id for node in ast.walk(ast.parse(path.read_text()))
                                        if isinstance(node, ast.Name)
                                        and node.id in ("prog", "program", "Program")})
                     for path in SCHEMES}
    assert {name: n for name, n in program_names.items() if n} == {}


def _operation_calls(source):
    """(line, operation, name) of every ``self.OP.NAME`` in ``source``, OP an operation a
    scheme is given."""
    from timpm.schemes import OPERATIONS

    return sorted((node.lineno, node.value.attr, node.attr)
                  for node in ast.walk(ast.parse(source))
                  if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute)
                  and isinstance(node.value.value, ast.Name) and node.value.value.id == "self"
                  and node.value.attr in OPERATIONS)


def test_a_scheme_calls_only_what_its_operations_offer(programs):
    """Every ``self.stencil.of``, ``self.scatter.deposit``, ... of a scheme names a public
    member of the unit the engine gives it under that name."""
    offered = {}
    for prog in programs:
        for op, unit in vars(prog.ops).items():
            if unit is not None:
                offered.setdefault(op, set()).update(n for n in dir(unit) if not n.startswith("_"))
    bad = [f"{path.name}:{line} self.{op}.{name}" for path in SCHEMES
           for line, op, name in _operation_calls(path.read_text())
           if name not in offered.get(op, ())]
    assert bad == []
    assert ("stencil", "of") in {(op, n) for p in SCHEMES
                                 for _, op, n in _operation_calls(p.read_text())}


@pytest.mark.parametrize("unit", ["mls_projection.py", "mls_stress_nd.py", "consistent_mass.py",
                                  "consistent_mass_cg.py", "grid.py", "g2p.py", "loads.py",
                                  "laws.py", "drivers.py", "recorder.py", "failures.py",
                                  "scatter.py", "stencil.py", "uploads.py"])
def test_a_unit_reads_fields_through_its_views(programs, unit):
    """An engine unit reads a field from the views it was given or the arguments it
    receives (``grid.g_mom[e, g]``, ``self.grid.node_mass[I]``, ``self.run.time[None]``),
    never as its own attribute (``self.time``): what it holds is what it was given."""
    names = state_names(programs) - {"values"}
    views = {"particles", "grid", "run", "history", "team", "work", "buffer", "state"}
    source = (PACKAGE / "engine" / unit).read_text()
    assert [r for r in reads(source, names) if r[1] not in views] == []


def test_a_state_read_through_the_program_is_found():
    source = "def f(self, prog, grid, p):\n    return prog.v[p] + grid.node_mass[p] + prog.dim\n"
    assert reads(source, {"v", "node_mass"}, owner="prog") == [(2, "v")]
    source = "def f(self, p):\n    return self.x_start[p] + self.stencil.of(p)\n"
    assert reads(source, {"x_start", "x"}) == [(2, "x_start")]
    assert _operation_calls(source) == [(2, "stencil", "of")]


def test_a_field_the_program_lacks_is_named():
    """A view answers a name its program lacks with the names it has (a phase or a law
    reading a field the feature set does not allocate fails at its compile so)."""
    from timpm.engine.views import FieldView, MaterialState

    view = FieldView("particle", {"x": 1, "v": 2})
    assert (view.x, view.v, view.names) == (1, 2, ("x", "v"))
    with pytest.raises(AttributeError, match=r"no particle field 'F' \(its particle fields: "
                                             r"x, v\)"):
        view.F
    state = MaterialState({"F": 3}, 2, True, print)
    assert (state.F, state.dim, state.update_volume, state.accumulate) == (3, 2, True, print)
    assert not hasattr(state, "J")


def test_no_module_imports_the_package_root():
    # timpm/__init__.py re-exports the layers' names: a module below that imports it runs
    # back up the house (the version lives in timpm.platform.version)
    bad = [m for m, edges in GRAPH.items() if m not in EXEMPT and "timpm" in edges]
    assert not bad, f"modules importing the package root: {', '.join(bad)}"


def test_the_version_is_the_projects():
    import tomllib

    from timpm.platform.version import __version__

    project = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["project"]
    assert project["version"] == __version__
