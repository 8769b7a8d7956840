"""Scene files: the examples build the demos' worlds and the problem runs, run at a tiny
size, and every bad file gets an error naming file, line and key."""
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from conftest import NO_FILES

from timpm.platform import runtime
from timpm.cli.main import main
from timpm.scenarios.demos import get_demo
from timpm.schemes import TRANSFERS
from timpm.scenefile import OUTPUT, key_lines, load_scene, run_scene, schema_reference
from timpm.studies.study import run_problem

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))

#: each example at a tiny size: a coarse grid, a few steps
TINY = {
    "column_collapse.toml": {"domain.size": [1.5, 1.125], "domain.cells": 12,
                             "simulation.t_end": 0.02},
    "disks.toml": {"domain.cells": 16, "simulation.t_end": 0.05},
    "dam_break.toml": {"domain.cells": 25, "simulation.t_end": 0.01},
    "cube_drop_3d.toml": {"domain.cells": 8, "simulation.t_end": 0.02},
    "vibrating_string.toml": {"problem.t_end": 0.002},
    "slope_griffiths_lane.toml": {"domain.cells": 30, "simulation.t_end": 0.02},
    "retrogressive_clay_slope.toml": {"domain.cells": 50, "simulation.t_end": 0.05},
    "submerged_layer.toml": {"domain.cells": 4, "simulation.t_end": 0.02},
    "slope_griffiths_lane_submerged.toml": {"domain.cells": 30, "simulation.t_end": 0.02},
    "slope_griffiths_lane_drawdown.toml": {"domain.cells": 30, "simulation.t_end": 0.02},
    "slope_morgenstern_drawdown.toml": {"domain.cells": 30, "simulation.t_end": 0.02},
    # with its seepage the slope cannot stand at full strength (F = 0.81): its gravity
    # loading is refused; under still water it stands (F = 1.59)
    "infinite_slope.toml": {"water.seepage": "none", "simulation.t_end": 0.02},
    "submarine_slope.toml": {"domain.cells": 40, "simulation.t_end": 0.02},
    "large_slope.toml": {"domain.cells": 40, "simulation.t_end": 0.2},
    "slope_undrained_random.toml": {"domain.cells": 30, "simulation.t_end": 0.02},
    "slope_griffiths_lane_random.toml": {"domain.cells": 30, "simulation.t_end": 0.02},
}


def line_of(text, start):
    """The 1-based line of ``text`` that starts with ``start`` (stripped)."""
    lines = [k for k, line in enumerate(text.splitlines(), 1) if line.strip().startswith(start)]
    assert len(lines) == 1, f"{start!r} starts {len(lines)} lines"
    return lines[0]


# ---- the key locator ----------------------------------------------------------------------

def test_key_lines_finds_tables_array_elements_and_dotted_keys():
    text = "\n".join([
        'title = "x = [fake]"   # a = comment',      # 1
        "[simulation]",                              # 2
        "t_end = 1.0",                               # 3
        "[[body]]",                                  # 4
        "name = 'a'",                                # 5
        "[[body]]",                                  # 6
        "velocity.x = 2  # dotted",                  # 7
        '"quoted key" = 3',                          # 8
        "lo = [",                                    # 9
        "  [0.0, 1.0],",                             # 10: no table header
        "  2.0 ]",                                   # 11
        'notes = """',                               # 12
        "[not.a.table]",                             # 13: inside a string
        'ppc = 4"""',                                # 14
        "walls = { kind = 'friction', mu = 0.5 }",   # 15
        "[ body.extra ]",                            # 16: a sub-table of body 1
        "k = 1",                                     # 17
    ])
    lines = key_lines(text)
    assert lines == {("title",): 1, ("simulation",): 2, ("simulation", "t_end"): 3,
                     ("body", 0): 4, ("body", 0, "name"): 5, ("body", 1): 6,
                     ("body", 1, "velocity"): 7, ("body", 1, "velocity", "x"): 7,
                     ("body", 1, "quoted key"): 8, ("body", 1, "lo"): 9,
                     ("body", 1, "notes"): 12, ("body", 1, "walls"): 15,
                     ("body", 1, "extra"): 16, ("body", 1, "extra", "k"): 17}


# ---- the examples -------------------------------------------------------------------------

def test_every_example_has_a_tiny_size_and_a_readme_entry():
    assert len(EXAMPLES) >= 5
    assert sorted(TINY) == [p.name for p in EXAMPLES]
    readme = (ROOT / "examples" / "README.md").read_text()
    for path in EXAMPLES:
        assert f"timpm run examples/{path.name}" in readme


#: cold compile on 2 CPU cores: the 3D quadratic B-spline program ~1 min (test_world.py
#: runs its 3D quadratic programs with -m slow too)
SLOW = {"cube_drop_3d.toml"}


@pytest.mark.parametrize("path", [pytest.param(p, id=p.stem, marks=[pytest.mark.slow] * (
    p.name in SLOW)) for p in EXAMPLES])
def test_every_example_runs_at_a_tiny_size(path, tmp_path):
    out = tmp_path / "run.json"
    # frames only where an output is written frame by frame (a landslide's measures):
    # without one the scene refuses them, as the command line refuses --frames
    slide = "landslide" in path.read_text()
    scene = load_scene(path, {**TINY[path.name], **NO_FILES, "output.json": str(out),
                              "output.frames": 2 if slide else None})
    result = run_scene(scene)
    doc = json.loads(out.read_text())
    assert result.steps == round(scene.t_end / result.dt) and result.steps >= 2
    assert abs(result.t_end - scene.t_end) <= 0.5 * result.dt * (1 + 1e-12)
    assert doc["steps"] == result.steps and doc["particles"] == result.particles
    assert doc["files"] == [str(out)]
    if scene.world is not None:
        assert result.particles == scene.world.n_particles <= 400
        # what the run cost: the fields' bytes, the process's peak, the simulated speed
        assert doc["memory"]["particles"] == result.particles
        assert doc["memory"]["particle_bytes"] > 0 and doc["memory"]["process_peak_mb"] > 0
        assert doc["simulated_per_wall_second"] == pytest.approx(
            result.t_end / result.simulation_seconds)
        energies = doc["series"]
        assert energies["t"][0] == 0.0 and energies["t"][-1] == pytest.approx(result.t_end)
    else:
        assert doc["record"]["problem"] == scene.name and doc["record"]["rms_error"] > 0


@pytest.mark.parametrize("name", ["column-collapse", "disks", "dam-break"])
def test_demo_scene_files_build_the_demos_worlds(name):
    scene = load_scene(ROOT / "examples" / f"{name.replace('-', '_')}.toml")
    demo = get_demo(name)
    mine, theirs = scene.world, demo.world()
    for key in ("positions", "mass_per_particle", "volume", "velocity", "material_index",
                "body_index"):
        np.testing.assert_array_equal(getattr(mine, key), getattr(theirs, key), err_msg=key)
    for key in ("domain", "cells", "basis", "transfer", "gravity", "walls", "dt", "name"):
        assert getattr(mine, key) == getattr(theirs, key), key
    assert [(type(m), m.parameters()) for m in mine.materials] == \
        [(type(m), m.parameters()) for m in theirs.materials]
    assert [b.name for b in mine.bodies] == [b.name for b in theirs.bodies]
    assert scene.t_end == demo.end_time()
    assert scene.output["color"] == demo.color


def test_the_3d_example_builds_a_3d_world():
    scene = load_scene(ROOT / "examples" / "cube_drop_3d.toml", TINY["cube_drop_3d.toml"])
    world = scene.world
    assert world.dim == 3 and world.h == 1.0 / 8 and world.gravity == (0.0, -9.81, 0.0)
    assert [w.kind for w in world.walls] == ["slip", "slip", "friction", "slip", "slip", "slip"]
    # a lattice of 2 particles per cell and axis, spacing h / 2, inside the cube
    x = world.positions
    dx = world.h / 2
    assert np.all((x >= (0.2, 0.45, 0.35)) & (x <= (0.5, 0.75, 0.65)))
    np.testing.assert_allclose(np.diff(np.unique(x[:, 0])), dx, rtol=1e-12)
    np.testing.assert_array_equal(world.velocity, np.tile((1.0, 0.0, 0.0), (len(x), 1)))
    np.testing.assert_allclose(world.mass_per_particle, 1000.0 * dx ** 3, rtol=1e-15)


@pytest.mark.cpu_only("compared bit for bit")
def test_problem_scene_gives_the_record_of_run_problem(tmp_path):
    scene = load_scene(ROOT / "examples" / "vibrating_string.toml",
                       {"problem.t_end": 0.002, "output.json": None})
    mine = run_scene(scene)
    theirs = run_problem("vibrating-string", elements=16, ppc=4, basis="linear",
                         mass="lumped", dt=1e-4, t_end=0.002, stress_update="study",
                         transfer="musl", params=dict(E=100.0, density=1.0, L=25.0, v0=0.1))
    timing = {"wall_seconds", "compile_seconds", "build_seconds"}
    assert {k: v for k, v in mine.record.items() if k not in timing} == \
        {k: v for k, v in theirs.record.items() if k not in timing}
    assert mine.record["steps"] == 20
    np.testing.assert_array_equal(mine.series["u"], theirs.series["u"])


def test_the_docs_list_every_key():
    assert schema_reference() in (ROOT / "docs" / "scene_files.md").read_text()


# ---- errors -------------------------------------------------------------------------------

SCENE = """\
[simulation]
t_end = 0.01
transfer = "apic"

[domain]
size = [1.0, 1.0]
cells = 8
walls = { default = "slip", bottom = { kind = "friction", mu = 0.5 } }

[material.jelly]
type = "neo-hookean"
E = 1000.0
nu = 0.3
density = 1000.0

[[body]]
name = "left"
material = "jelly"
shape = "box"
lo = [0.125, 0.125]
hi = [0.375, 0.375]

[[body]]
name = "right"
material = "jelly"
shape = "ball"
center = [0.7, 0.5]
radius = 0.125
velocity = [-0.5, 0.0]
ppc = 2

[output]
"""


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_base_scene_loads(tmp_path):
    scene = load_scene(write(tmp_path, SCENE))
    world = scene.world
    assert [b.name for b in world.bodies] == ["left", "right"]
    assert world.walls[2].kind == "friction" and world.walls[2].mu == 0.5
    assert world.walls[0].kind == "slip" and world.gravity == (0.0, -9.81)
    # no frames given (the scene writes nothing frame by frame): the default
    assert scene.name == "scene" and scene.t_end == 0.01 and scene.output["frames"] == 20


@pytest.mark.parametrize("old, new, key, message", [
    ('transfer = "apic"', "courrant = 0.5", "simulation.courrant",
     "unknown key (did you mean 'courant'?): simulation takes name, t_end, dt, courant"),
    ("ppc = 2", "ppc = 2.5", "body[1].ppc", "expected an integer >= 1, got 2.5 (a float)"),
    ("ppc = 2", "colour = 'red'", "body[1].colour", "unknown key: body[1] takes name, "
     "material, shape"),
    ("ppc = 2", "ppc = '2'", "body[1].ppc", 'expected an integer >= 1, got "2" (a string)'),
    ('material = "jelly"\nshape = "ball"', 'shape = "ball"\nmaterial = "jely"',
     "body[1].material", "unknown material 'jely' (did you mean 'jelly'?): define "
     "[material.jely] or use one of jelly, sand, rubber, water"),
    ("velocity = [-0.5, 0.0]", "velocity = [-0.5, 0.0, 1.0]", "body[1].velocity",
     "expected 2 numbers (one per axis of the 2D domain), got 3"),
    ("radius = 0.125", "radius = 0.125\nhi = [1.0, 1.0]", "body[1].hi",
     "a ball takes center and radius, not hi"),
    ('type = "neo-hookean"', 'type = "neo-hooke"', "material.jelly.type",
     "unknown value 'neo-hooke' (did you mean 'neo-hookean'?)"),
    ("nu = 0.3", "poisson = 0.3", "material.jelly.poisson", "unknown key: material.jelly "
     "takes type, E, nu, density"),
    ('transfer = "apic"', 'transfer = "gimp"', "simulation.transfer",
     f"unknown value 'gimp': choose one of {', '.join(TRANSFERS)}"),
])
def test_a_bad_key_is_named_with_its_line(tmp_path, old, new, key, message):
    text = SCENE.replace(old, new, 1)
    assert text != SCENE
    path = write(tmp_path, text)
    line = line_of(text, new.splitlines()[-1])
    with pytest.raises(ValueError) as err:
        load_scene(path)
    assert str(err.value).startswith(f"{path}:{line}: {key}: {message}")


def test_a_bad_material_value_names_the_material(tmp_path):
    path = write(tmp_path, SCENE.replace("nu = 0.3", "nu = 0.7"))
    with pytest.raises(ValueError) as err:
        load_scene(path)
    assert str(err.value) == (f"{path}:{line_of(SCENE, 'nu = 0.3')}: material.jelly.nu: "
                              "neo-hookean: nu must be a number in (-1, 0.5) (Poisson's ratio; "
                              "0.5 is incompressible: use a fluid or a smaller ratio), got 0.7")


def test_a_missing_required_key_names_its_table(tmp_path):
    path = write(tmp_path, SCENE.replace("t_end = 0.01\n", ""))
    with pytest.raises(ValueError, match=r"^" + f"{path}:1: simulation: missing required "
                       r"key 't_end' \(end time\)$"):
        load_scene(path)
    path = write(tmp_path, SCENE.replace('shape = "box"\n', ""))
    with pytest.raises(ValueError) as err:
        load_scene(path)
    line = SCENE.splitlines().index("[[body]]") + 1  # the first [[body]]
    assert str(err.value).startswith(f"{path}:{line}: body[0]: missing required key 'shape'")


def test_wall_and_table_errors(tmp_path):
    text = SCENE.replace('bottom = {', 'front = {')
    with pytest.raises(ValueError, match=f"scene.toml:{line_of(text, 'walls')}: "
                       "domain.walls.front: unknown side: the sides of a 2D domain are left, "
                       r"right, bottom, top \(and default\)$"):
        load_scene(write(tmp_path, text))
    with pytest.raises(ValueError, match=r"scene.toml:1: simulations: unknown table \(did you "
                       r"mean 'simulation'\?\)"):
        load_scene(write(tmp_path, SCENE.replace("[simulation]", "[simulations]")))
    one_body = SCENE.replace("[[body]]", "[body]", 1).split("[[body]]")[0]
    with pytest.raises(ValueError, match=f"scene.toml:{line_of(one_body, '[body]')}: body: "
                       r"expected an array of tables \(\[\[body\]\]"):
        load_scene(write(tmp_path, one_body))


def test_world_errors_and_overrides_name_the_file(tmp_path):
    path = write(tmp_path, SCENE)
    # the world's own checks (a body outside the domain, dt) name the file and the key,
    # and the override inside the body refused as a whole
    second = [k for k, line in enumerate(SCENE.splitlines(), 1) if line == "[[body]]"][1]
    with pytest.raises(ValueError, match=f"scene.toml:{second}: " + r"body\[1\] \(with "
                       r"body\[1\]\.center overridden\): body 1 \('right'\): Ball\(.*\) "
                       r"extends outside the domain"):
        load_scene(path, {"body[1].center": [0.95, 0.5]})
    with pytest.raises(ValueError, match=r"scene.toml: simulation.dt \(overridden\): time step "
                       r"dt = 1 s exceeds the CFL limit"):
        load_scene(path, {"simulation.dt": 1.0})
    # an overridden value has no line in the file
    with pytest.raises(ValueError, match=r"scene.toml: body\[0\].ppc \(overridden\): expected "
                       "an integer >= 1, got 0"):
        load_scene(path, {"body[0].ppc": 0})
    with pytest.raises(ValueError, match=r"scene.toml: override body\[5\].ppc: body has no "
                       "element 5$"):
        load_scene(path, {"body[5].ppc": 2})
    scene = load_scene(path, {"simulation.t_end": 0.5, "domain.walls": "sticky"})
    assert scene.t_end == 0.5 and {w.kind for w in scene.world.walls} == {"sticky"}


def test_a_scene_in_another_precision_is_refused_before_the_run(tmp_path):
    text = SCENE.replace("t_end = 0.01", 't_end = 0.01\nprecision = "f32"')
    scene = load_scene(write(tmp_path, text))
    assert runtime.precision() == "f64"
    with pytest.raises(ValueError, match=f"scene.toml:{line_of(text, 'precision')}: simulation."
                       r"precision: the scene runs in f32 but Taichi was started in f64: call "
                       r"timpm.init\(precision='f32'\) first"):
        run_scene(scene)


def test_surface_tractions_load_the_named_body(tmp_path):
    from timpm.model.loads import Ramp, SurfaceTraction
    from timpm.model.world import Wall, World

    text = SCENE.replace("[output]", "[[loads.traction]]\nbody = \"right\"\nside = \"top\"\n"
                         "traction = [0.0, -100.0]\nramp = 0.1\n\n[output]")
    mine = load_scene(write(tmp_path, text)).world
    theirs = World(domain=mine.domain, cells=mine.cells, bodies=mine.bodies, transfer="apic",
                   walls={"default": "slip", "bottom": Wall("friction", 0.5)},
                   tractions=[SurfaceTraction(1, "top", (0.0, -100.0), Ramp(0.1))])
    forces = mine.model.particle_force
    np.testing.assert_array_equal(forces, theirs.model.particle_force)
    assert mine.model.particle_force_time.duration == 0.1
    # on the top row of the ball's particles only, downwards
    loaded = np.any(forces != 0, axis=1)
    y = mine.positions[:, 1]
    top = y[mine.body_index == 1].max()
    assert loaded.any() and np.all(mine.body_index[loaded] == 1)
    assert np.all(top - y[loaded] < 0.5 * mine.h / 2) and np.all(forces[loaded, 1] < 0)
    with pytest.raises(ValueError, match=f"scene.toml:{line_of(text, 'body = ')}: "
                       r"loads.traction\[0\].body: no body is named 'rihgt' \(did you mean "
                       r"'right'\?\): the bodies are 'left', 'right'$"):
        load_scene(write(tmp_path, text.replace('body = "right"', 'body = "rihgt"')))


def test_problem_errors(tmp_path):
    text = '[problem]\nname = "vibrating-string"\n[problem.params]\nEE = 1.0\n'
    with pytest.raises(ValueError, match=r"scene.toml:4: problem.params.EE: vibrating-string "
                       r"has no parameter 'EE' \(did you mean 'E'\?\)"):
        load_scene(write(tmp_path, text))
    with pytest.raises(ValueError, match=r"scene.toml:2: problem.name: unknown value "
                       r"'vibrating-strin' \(did you mean 'vibrating-string'\?\)"):
        load_scene(write(tmp_path, '[problem]\nname = "vibrating-strin"\n'))
    with pytest.raises(ValueError, match=r"scene.toml:3: domain: unknown table: a problem "
                       r"scene has \[problem\], \[output\] \(a file with \[problem\] runs a "
                       r"benchmark problem; a world's tables go in a file without it\)$"):
        load_scene(write(tmp_path, '[problem]\nname = "oedometer"\n[domain]\ncells = 4\n'))


def test_cli_syntax_error_exits_2_without_traceback(tmp_path, capsys):
    path = write(tmp_path, SCENE.replace("cells = 8", "cells = = 8"))
    assert main(["run", str(path)]) == 2
    err = capsys.readouterr().err
    line = line_of(SCENE, "cells = 8")
    assert err.startswith(f"timpm: error: {path}:{line}:9: invalid TOML: Invalid value")
    assert "Traceback" not in err
    assert main(["run", str(path.with_name("missing.toml"))]) == 2
    assert "timpm: error: scene file" in capsys.readouterr().err
    assert main(["run", str(write(tmp_path, SCENE.replace("ppc = 2", "ppc = -2")))]) == 2
    assert capsys.readouterr().err.startswith(f"timpm: error: {path}:{line_of(SCENE, 'ppc = 2')}"
                                              ": body[1].ppc: expected an integer >= 1")


def test_cli_runs_a_scene_with_options_over_the_file(tmp_path, capsys, monkeypatch):
    path = write(tmp_path, SCENE + f'vtk = "{tmp_path / "never"}"\n')
    out, npz, gif = tmp_path / "run.json", tmp_path / "npz", tmp_path / "run.gif"
    reads, read_bytes = [], Path.read_bytes  # read once: what runs is what was read
    monkeypatch.setattr(Path, "read_bytes",
                        lambda self: reads.append(self) or read_bytes(self))
    # slip walls, no gravity: the disks example's program (compiled above): two bodies of
    # one neo-Hookean material, the affine transfer, quadratic B-splines
    assert main(["run", str(path), "--t-end", "0.02", "--npz", str(npz), "--json", str(out),
                 "--set", "body[1].ppc=3", "--frames", "3", "--set", "domain.walls=slip",
                 "--set", "loads.gravity=[0.0, 0.0]", "--gif", str(gif),
                 "--set", "output.width=320", "--set", "output.color=body",
                 "--threads", str(runtime.cpu_threads())]) == 0  # Taichi not restarted
    assert reads.count(path) == 1
    text = capsys.readouterr().out
    doc = json.loads(out.read_text())
    assert f"scene ({path}): {doc['particles']} particles, {doc['steps']} steps" in text
    assert "compile" in text and f"wrote {npz}, {gif}, {out}" in text
    with Image.open(gif) as im:  # Pillow merges identical frames: count their time
        shown = 0
        for k in range(im.n_frames):
            im.seek(k)
            shown += im.info["duration"]
        assert im.size[0] == 320 and shown == 4 * round(1000 / OUTPUT["fps"].default)
    assert doc["t_end"] == pytest.approx(0.02, abs=doc["dt"])
    assert len(list(npz.glob("particles_*.npz"))) == 4 and not (tmp_path / "never").exists()
    # the override of ppc: the ball's particles at 3 per cell and axis
    scene = load_scene(path, {"body[1].ppc": 3})
    assert doc["particles"] == scene.world.n_particles != load_scene(path).world.n_particles


def test_the_pic_share_reaches_the_world_and_the_problem(tmp_path):
    """simulation.pic_fraction (world) and problem.pic_fraction: read, checked in [0, 1]
    with the file's line, and handed to the World / run_problem."""
    text = SCENE.replace('transfer = "apic"', 'transfer = "musl"\npic_fraction = 0.25')
    scene = load_scene(write(tmp_path, text))
    assert scene.world.pic_fraction == 0.25
    assert scene.world.model.pic_fraction == 0.25
    problem = load_scene(write(tmp_path, '[problem]\nname = "oedometer"\npic_fraction = 0.0\n',
                               name="p.toml"))
    assert problem.problem["pic_fraction"] == 0.0
    with pytest.raises(ValueError, match=r"p2.toml:3: problem.pic_fraction: expected a number "
                                         r"in \[0, 1\], got 1.5"):
        load_scene(write(tmp_path, '[problem]\nname = "oedometer"\npic_fraction = 1.5\n',
                         name="p2.toml"))


def test_the_transfer_params_table_reaches_the_world_its_errors_naming_the_key(tmp_path):
    """[simulation.transfer_params]: the transfer scheme's parameters by name, the same
    channel as the pic_fraction key (the same Model); an unknown name or a value out of its
    declared range is refused naming the key inside the table and its line."""
    musl = SCENE.replace('transfer = "apic"', 'transfer = "musl"')
    table = musl.replace("[domain]", "[simulation.transfer_params]\npic_fraction = 0.25\n\n"
                                     "[domain]", 1)
    by_table = load_scene(write(tmp_path, table, "t.toml")).world.model
    by_key = load_scene(write(tmp_path, musl.replace('transfer = "musl"', 'transfer = "musl"\n'
                                                     'pic_fraction = 0.25'), "k.toml")).world.model
    assert by_table.transfer_params == by_key.transfer_params == {"pic_fraction": 0.25}
    for value, message in (("alpha = 0.5", r"simulation.transfer_params.alpha: the musl "
                                           r"transfer has no parameter 'alpha' \(its "
                                           r"parameters: pic_fraction\)"),
                           ("pic_fraction = 1.5", r"simulation.transfer_params.pic_fraction: "
                                                  r"the musl transfer: pic_fraction must be a "
                                                  r"number in \[0, 1\]"),
                           ("pic_fraction = true", r"simulation.transfer_params.pic_fraction: "
                                                   r".* got True")):
        text = table.replace("pic_fraction = 0.25", value)
        path = write(tmp_path, text, "bad.toml")
        with pytest.raises(ValueError, match=rf"bad.toml:{line_of(text, value)}: {message}"):
            load_scene(path)
    # a table for a transfer whose scheme has no parameters
    apic = SCENE.replace("[domain]", "[simulation.transfer_params]\npic_fraction = 0.1\n\n"
                                     "[domain]", 1)
    with pytest.raises(ValueError, match=r"simulation.transfer_params.pic_fraction: the apic "
                                         r"transfer has no parameter 'pic_fraction' \(its "
                                         r"parameters: none\)"):
        load_scene(write(tmp_path, apic, "apic.toml"))


def test_the_integrator_reaches_the_world_and_its_conflicts_name_the_key(tmp_path):
    """simulation.integrator of a world: handed to the World, and a conflict of the
    midpoint integrator (slip walls) named with the key; the colliding disks between
    roller walls under it never rise above their initial energy (kinetic + stored is at
    most the APIC energy, which never grows and starts there: C_p = 0)."""
    path = ROOT / "examples" / "disks.toml"
    tiny = {"domain.cells": 16, "simulation.t_end": 0.3, **NO_FILES}
    with pytest.raises(ValueError, match=r"disks.toml: simulation.integrator \(overridden\): "
                                         r"integrator 'midpoint' .* does not take slip"):
        load_scene(path, {**tiny, "simulation.integrator": "midpoint"})
    scene = load_scene(path, {**tiny, "simulation.integrator": "midpoint",
                              "domain.walls": "roller"})
    assert scene.world.model.integrator == "midpoint"
    total = np.asarray(run_scene(scene).series["total"])
    assert total.max() <= total[0] * (1.0 + 1e-9) and total[-1] < total[0]
