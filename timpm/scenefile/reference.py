"""The schema as documentation: the key tables of docs/scene_files.md."""
from ..materials import MATERIALS
from ..materials.pore_water import PoreWater
from ..schemes import TRANSFERS, scheme_params
from .schema import (BODY, DOMAIN, INITIAL_STRESS, LANDSLIDE, LOADS, MATERIAL_TYPE, OUTPUT,
                     PLANE, PROBLEM, RANDOM_FIELD, REQUIRED, SIMULATION,
                     TRACTION, TYPES, WALL, WATER, material_schema)


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


def _parameters(params, title):
    """The table of declared parameters (``timpm.platform.declare.Param``)."""
    rows = [f"**{title}**", "", "| key | type | default | unit | meaning |",
            "|---|---|---|---|---|"]
    for name, param in params.items():
        default = ("none" if param.optional else "required" if param.default is None
                   else f"{param.default:g}")
        rows.append(f"| `{name}` | a number in {param.range_text()} | {default} | "
                    f"{param.unit} | {param.doc.replace('|', chr(92) + '|')} |")
    return "\n".join(rows)


def _law_parameters(kind, title):
    """The table of a law's parameters: the keys of ``material_schema(kind)`` with the
    ranges the law declares (``Material.PARAMS``)."""
    declared = MATERIALS[kind].PARAMS
    rows = [f"**{title}**", "", "| key | type | default | unit | meaning |",
            "|---|---|---|---|---|"]
    for name, key in material_schema(kind).items():
        if name == "type":
            continue
        param = declared[name]
        kind_text = ("true or false" if param.kind == "bool"
                     else f"a number in {param.range_text()}")
        rows.append(f"| `{name}` | {kind_text} | {_default_text(key)} | {param.unit} | "
                    f"{param.doc.replace('|', chr(92) + '|')} |")
    return "\n".join(rows)


def schema_reference() -> str:
    """The key tables of docs/scene_files.md, from the schema (a test keeps them equal)."""
    parts = [_markdown(SIMULATION, "[simulation]"), _markdown(DOMAIN, "[domain]"),
             _markdown(WALL, "a wall: a string (the kind) or a table"),
             _markdown(PLANE, "[[plane]] (a plane wall at any angle, 2D and 3D)"),
             _markdown(LOADS, "[loads]"), _markdown(TRACTION, "[[loads.traction]]"),
             _markdown(BODY, "[[body]]"),
             _parameters(PoreWater.PARAMS, "[body.water] (a body's pore water)"),
             _markdown(RANDOM_FIELD, "[body.random_field] (a body's random strength)"),
             _markdown(WATER, "[water]"), _markdown(INITIAL_STRESS, "[initial_stress]")]
    for transfer in TRANSFERS:  # each scheme's own parameters, as it declares them
        if scheme_params(transfer):
            parts.append(_parameters(scheme_params(transfer), "[simulation.transfer_params] "
                                     f'with transfer = "{transfer}"'))
    parts.append(_markdown({"type": MATERIAL_TYPE}, "[material.NAME]"))
    for kind in MATERIALS:  # each law's parameters, as its file declares them
        parts.append(_law_parameters(kind, f'[material.NAME] with type = "{kind}"'))
    parts += [_markdown(OUTPUT, "[output]"), _markdown(LANDSLIDE, "[output.landslide]"),
              _markdown(PROBLEM, "[problem]")]
    return "\n\n".join(parts) + "\n"
