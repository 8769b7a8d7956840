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
import re
from pathlib import Path

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
    assert {"_team_member", "_one_step", "_state"} <= defined  # it sees methods, globals
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
def unit_calls(units):
    """For each class of ``units`` (lowest first), the names it reads through ``self.`` that
    another class of ``units`` defines: {class: {(other class, name), ...}} (from the source,
    with ``ast``; every function of the class body, kernels and ``ti.func``s alike)."""
    import inspect
    import textwrap

    owner = {}
    for cls in units:
        for name in vars(cls):
            if not name.startswith("__"):
                owner.setdefault(name, cls)
    calls = {}
    for cls in units:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
        calls[cls] = {(owner[node.attr], node.attr) for node in ast.walk(tree)
                      if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                      and node.value.id == "self" and owner.get(node.attr, cls) is not cls}
    return calls


def test_the_units_of_a_program_call_only_the_units_below_them():
    """Program is its units mixed into one ``self`` (failures, stencil, scatter, phase
    runner, grid nodes, consistent mass, MLS, grid solve, transfer, integrators, uploads,
    recorder, drivers), listed lowest first: a unit reads what the units before it define,
    never one after it (no unit calls back into another), only their public names, and no
    two define one name."""
    from timpm.engine.program import Program

    units = list(Program.__bases__)  # lowest first
    assert all(cls.__module__.startswith("timpm.engine") for cls in units)
    names = [name for cls in units for name in vars(cls) if not name.startswith("__")]
    assert sorted({n for n in names if names.count(n) > 1}) == []
    rank = {cls: k for k, cls in enumerate(units)}
    calls = unit_calls(units)
    upward = sorted(f"{cls.__name__}.{name} is {other.__name__}'s, a unit above it"
                    for cls, found in calls.items() for other, name in found
                    if rank[other] > rank[cls])
    assert upward == []
    # and what a unit offers the others is public (a private name stays in its unit)
    private = sorted(f"{cls.__name__} calls {other.__name__}.{name}"
                     for cls, found in calls.items() for other, name in found
                     if name.startswith("_"))
    assert private == []


def test_a_call_up_the_units_is_found():
    class Low:
        def f(self):
            return self.g()

    class High:
        def g(self):
            return self.f()

    assert unit_calls([Low, High]) == {Low: {(High, "g")}, High: {(Low, "f")}}


def state_names():
    """What a phase reads as state: the names Program gives its particle, grid, scratch and
    run fields (``"x": ti.Vector.field``, ``particle["C"] = ti.Matrix.field``, ...), the
    grid's kernel names (grid.NODE_NAMES) and ``values``."""
    source = "".join((PACKAGE / "engine" / name).read_text()  # the integrators' scratch
                     for name in ("program.py", "rk4.py", "midpoint.py", "mls_stress_nd.py"))
    names = set(re.findall(r'"(\w+)": ti\.(?:Vector\.|Matrix\.)?field', source))
    names |= set(re.findall(r'(\w+)=ti\.(?:Vector\.|Matrix\.)?field', source))
    names |= set(re.findall(r'\w+\["(\w+)"\] = ti\.(?:Vector\.|Matrix\.)?field', source))
    tree = ast.parse((PACKAGE / "engine" / "grid.py").read_text())
    node_names = next(node.value for node in ast.walk(tree) if isinstance(node, ast.Assign)
                      and getattr(node.targets[0], "id", None) == "NODE_NAMES")
    return names | set(ast.literal_eval(node_names)) | {"values"}


def state_reads_through_the_program(source, program="prog"):
    """(line, name) of every ``prog.NAME`` (``program.NAME``) in ``source`` that names
    state."""
    names = state_names()
    return sorted((node.lineno, node.attr) for node in ast.walk(ast.parse(source))
                  if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                  and node.value.id == program and node.attr in names)


def test_a_scheme_reads_its_state_from_its_arguments():
    """A scheme's phases receive the particle fields, the grid fields and the run-time
    values (``particles.v[p]``, ``grid.node_mass[I]``, ``values.dt()``); through the
    program they reach its units' operations and compile-time choices only."""
    assert {"x", "v", "sigma", "C", "node_mass", "node_velocity", "band", "values"} <= \
        state_names()
    found = {path.name: state_reads_through_the_program(path.read_text())
             for path in sorted((PACKAGE / "schemes").glob("*.py"))}
    assert len(found) >= 4  # the schemes were read
    assert {name: reads for name, reads in found.items() if reads} == {}


@pytest.mark.parametrize("unit", ["rk4.py", "midpoint.py", "mls_projection.py",
                                  "mls_stress_nd.py", "consistent_mass.py"])
def test_an_integrator_projection_or_solve_reads_its_state_from_its_arguments(unit):
    """The integrators', the MLS projections' and the 1D consistent mass's functions
    receive the particle and grid fields (the MLS sums and the band with the grid:
    ``grid.g_mom[e, g]``, ``grid.q_mom[I, g]``, ``grid.band[i, k]``), the integrators'
    scratch (``stages.x_start[p]``, ``iterate.v_end[p]``) and the run-time values; through
    ``self`` they reach the program's operations and compile-time choices only."""
    assert {"x_start", "F_rate", "b_stages", "F_start", "v_end", "x_end", "g_mom", "n_vel",
            "body", "q_mom", "q_sig", "band", "inactive", "neg_pivots"} <= state_names()
    source = (PACKAGE / "engine" / unit).read_text()
    assert state_reads_through_the_program(source, program="self") == []


def test_a_state_read_through_the_program_is_found():
    source = "def f(self, prog, grid, p):\n    return prog.v[p] + grid.node_mass[p] + prog.dim\n"
    assert state_reads_through_the_program(source) == [(2, "v")]
    source = "def f(self, stages, p):\n    return self.x_start[p] + stages.v_start[p]\n"
    assert state_reads_through_the_program(source, program="self") == [(2, "x_start")]


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
