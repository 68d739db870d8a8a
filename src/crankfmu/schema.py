"""What each kind of data file may hold: one JSON Schema per kind (scenario, mechanism, drive,
cushion, shaft, well), the one home of every key's name.

The loaders refuse a key the schema does not know (``check_keys``: the key, the table, the file's
line, and the closest known key: "did you mean stop_time?"), so a misspelt key never leaves a
default silently in force. ``crankfmu schema KIND`` prints the schema, which TOML editors (Even
Better TOML, Taplo, JetBrains' TOML plugin) take to validate and complete a file as it is typed
(docs/your-mechanism.md says how). ``check_keys`` reads the same schema, with the few JSON Schema
keywords it uses: ``type``, ``properties``, ``additionalProperties``, ``patternProperties``,
``items`` and ``enum``.
"""

from __future__ import annotations

import json
import re

from .errors import DefinitionError, did_you_mean

NUMBER = {"type": "number"}
INTEGER = {"type": "integer"}
STRING = {"type": "string"}
BOOLEAN = {"type": "boolean"}
#: an expression of the parameters, or a plain number
EXPRESSION = {"type": ["string", "number"]}
NAME = r"^[A-Za-z_][A-Za-z0-9_]*$"


def table(properties: dict, description: str = "", **extra) -> dict:
    """A TOML table whose keys are exactly ``properties``."""
    out = {"type": "object", "properties": properties, "additionalProperties": False, **extra}
    if description:
        out["description"] = description
    return out


def mapping(values: dict, description: str = "", names: str = NAME) -> dict:
    """A TOML table of user-chosen names (a parameter, a point, a link), each value ``values``."""
    out = {"type": "object", "patternProperties": {names: values}, "additionalProperties": False}
    if description:
        out["description"] = description
    return out


def array(items: dict, description: str = "") -> dict:
    out = {"type": "array", "items": items}
    if description:
        out["description"] = description
    return out


PARAMETER = table({
    "value": {**NUMBER, "description": "the value, in unit"},
    "unit": {**STRING, "description": "SI unit: m, kg, kg.m2, N, N.m, rad, rad/s, s, 1, ..."},
    "description": STRING,
    "min": NUMBER, "max": NUMBER,
    "min_inclusive": {**BOOLEAN, "description": "min itself is valid (default true)"},
    "max_inclusive": {**BOOLEAN, "description": "max itself is valid (default true)"},
    "tunable": {**BOOLEAN, "description": "an FMU may change it during the run (default false)"},
}, "a parameter: its value, SI unit, valid range and meaning")
EXPERIMENT = table({
    "start_time": {**NUMBER, "description": "s"},
    "stop_time": {**NUMBER, "description": "s"},
    "output_interval": {**NUMBER, "description": "s between output points"},
    "tolerance": {**NUMBER, "description": "the integrator's relative tolerance"},
    "cycles": {**INTEGER, "description": "machine cycles (of cycle_turns crank turns each) from the start over "
                                         "which crankfmu simulate checks the energy balance"},
    "summary_cycle": {**INTEGER, "description": "the machine cycle (from 1) whose extremes and delta are reported"},
}, "the default experiment")
FORCE_SIDE = table({"fx": EXPRESSION, "fy": EXPRESSION, "moment": EXPRESSION})
LOAD = table({
    "kind": {"enum": ["weights", "dead_point_moment", "viscous_force", "slider_force", "force", "couple",
                      "spring_damper"]},
    "link": STRING, "links": array(STRING), "point": STRING, "a": STRING, "b": STRING,
    "axis": EXPRESSION, "band": array(NUMBER, "[lo, hi]: fractions of the stroke"),
    "forward": EXPRESSION, "backward": EXPRESSION, "coefficient": EXPRESSION, "amplitude": EXPRESSION,
    "fx": EXPRESSION, "fy": EXPRESSION, "moment": EXPRESSION,
    "description": STRING,
    "direction_of": STRING, "increasing": FORCE_SIDE, "decreasing": FORCE_SIDE,
    "stiffness": EXPRESSION, "damping": EXPRESSION, "free_length": EXPRESSION,
}, "a load (docs/mechanism-files.md lists each kind's keys)")
OUTPUT = table({"name": STRING, "of": STRING, "order": INTEGER, "description": STRING})
PORT = table({"name": STRING, "kind": {"enum": ["force", "couple", "rope"]}, "link": STRING, "point": STRING,
              "axis": EXPRESSION, "lever": EXPRESSION, "description": STRING})
PAPER = table({
    "name": STRING, "quantity": STRING, "expected": NUMBER, "tolerance": NUMBER, "unit": STRING, "source": STRING,
    "published": STRING, "ours": NUMBER, "disagrees": STRING, "fitted": STRING, "not_comparable": STRING,
    "cycle": INTEGER, "index": INTEGER, "key": STRING, "omega1": NUMBER, "delta": NUMBER,
}, "a number the paper publishes, checked by crankfmu validate (docs/validation.md)")
KINEMATICS = table({
    "omega1": NUMBER, "at_deg": NUMBER, "span": NUMBER, "link": STRING, "link_label": STRING,
    "points": array(STRING), "relative": array(array(STRING)), "approximation": STRING,
    "time_series": array(STRING), "path": STRING, "slider": STRING, "arm": STRING, "stroke_of": STRING,
    "paper_tolerance": NUMBER, "paper_figures": array(STRING), "sweep_quantities": array(STRING),
    "figures": mapping(STRING), "paper": mapping(NUMBER),
    "claims": array(table({"text": STRING, "param": STRING, "direction": {"enum": ["increase", "decrease"]},
                           "quantities": array(STRING)})),
}, "the kinematic study (crankfmu kinematics, sweep)")

#: a joint's Coulomb friction (dynamics.friction): a pin's mu and radius, a slide's mu
FRICTION = table({"mu": {**EXPRESSION, "description": "friction coefficient (1), an expression of the parameters"},
                  "radius": {**EXPRESSION, "description": "a pin's radius (m): the friction moment is mu radius |R|"}},
                 "Coulomb friction of a joint: a pin's moment mu radius |R|, a slide's force mu |N|")

SCENARIO = table({
    "name": STRING, "title": STRING, "source": STRING, "citation": STRING,
    "mechanism": {**STRING, "description": "a packaged mechanism's name or a .toml path beside this file"},
    "fmu": {**STRING, "description": "the FMU's model identifier"},
    "cycle_turns": {**INTEGER, "minimum": 1, "maximum": 8,
                    "description": "crank turns in the machine's cycle, over which the loads repeat (a four-stroke "
                                   "engine: 2); default 1"},
    "parameters": mapping(PARAMETER),
    "loads": array(LOAD), "outputs": array(OUTPUT), "ports": array(PORT),
    "crank": table({"causality": {"enum": ["torque", "speed"]}}),
    "experiment": EXPERIMENT,
    "paper": array(PAPER),
    "paper_figures": mapping(STRING, names=r"^Fig\. [0-9]+[a-z]?$"),
    "run_figures": table({"cycles": STRING, "settled": STRING}),
    "kinematics": KINEMATICS,
    "equilibrium": table({"omega1": array(NUMBER), "figures": array(STRING), "angles": INTEGER, "moment": STRING,
                          "rating": {**NUMBER, "description": "N.m: the gearbox rating drawn at plus and minus"}}),
    "flywheel": table({"delta": NUMBER, "angle_offset": NUMBER, "eq3_steps_deg": array(NUMBER),
                       "paper_step_deg": NUMBER}),
    "drawing": table({"at_deg": NUMBER, "omega1": NUMBER, "caption": STRING, "show": array(STRING),
                      "trace": array(STRING)}),
    "friction": {**mapping(FRICTION), "description": "joint name -> its friction, beside or instead of the "
                                                     "mechanism file's"},
}, "a crankfmu scenario: a mechanism with its parameters, loads, motor and experiment")

MECHANISM = table({
    "name": STRING, "title": STRING, "source": STRING,
    "unknowns": mapping({"enum": ["angle", "length"]}),
    "fixed_points": mapping(array(EXPRESSION)),
    "contours": array(table({"name": STRING, "equation": STRING})),
    "points": mapping(STRING),
    "links": mapping(table({"number": INTEGER, "angle": STRING, "centre": STRING, "mass": EXPRESSION,
                            "inertia": EXPRESSION})),
    "joints": array(table({"name": STRING, "kind": {"enum": ["revolute", "prismatic"]}, "point": STRING,
                           "links": array(STRING), "axis": EXPRESSION, "friction": FRICTION})),
    "assembly": table({"branch": STRING, "closed_form": array(STRING), "constants": mapping(EXPRESSION),
                       "guess": mapping(EXPRESSION)}),
}, "a crankfmu mechanism: its unknowns, contours, points, links and joints")

_INPUT = table({"value": NUMBER, "unit": STRING, "description": STRING})
_COMPONENT_EXPERIMENT = table({"start_time": NUMBER, "stop_time": NUMBER, "output_interval": NUMBER,
                               "tolerance": NUMBER})
DRIVE = table({
    "name": STRING, "title": STRING, "source": STRING, "fmu": STRING,
    "parameters": mapping(PARAMETER), "inputs": mapping(_INPUT), "experiment": _COMPONENT_EXPERIMENT,
    "speed_causality": table({"fmu": STRING, "parameters": mapping(PARAMETER), "inputs": mapping(_INPUT)}),
}, "a crankfmu drive (Drive.fmu)")
CUSHION = table({
    "name": STRING, "title": STRING, "source": STRING, "fmu": STRING,
    "parameters": mapping(PARAMETER), "inputs": mapping(_INPUT), "experiment": _COMPONENT_EXPERIMENT,
}, "a crankfmu die cushion (DieCushion.fmu)")
SHAFT = table({
    "name": STRING, "title": STRING, "source": STRING, "fmu": STRING,
    "parameters": mapping(PARAMETER), "inputs": mapping(_INPUT), "experiment": _COMPONENT_EXPERIMENT,
}, "a crankfmu elastic shaft (ElasticShaft.fmu)")
WELL = table({
    "name": STRING, "title": STRING, "source": STRING, "citation": STRING, "fmu": STRING,
    "parameters": mapping(PARAMETER), "experiment": _COMPONENT_EXPERIMENT,
    "tapers": array(table({k: PARAMETER for k in ("length", "diameter", "mass_per_length", "E")})),
    "unit": table({"scenario": STRING, "title": STRING, "strokes_per_minute": NUMBER, "counterbalance": EXPRESSION,
                   "motor": table({"rated_power": NUMBER, "rated_slip": NUMBER}),
                   "parameters": mapping(EXPRESSION),
                   "reference": mapping(NUMBER),
                   "reference_accuracy": mapping({"type": ["number", "string"],
                                                  "description": "relative accuracy, or 'fitted: why' / "
                                                                 "'not comparable: why'"})}),
}, "a crankfmu pumping well: its rod string and its unit (RodString.fmu, crankfmu well)")

#: every kind of data file, by the name the loaders and `crankfmu schema` use
SCHEMAS = {"scenario": SCENARIO, "mechanism": MECHANISM, "drive": DRIVE, "cushion": CUSHION, "shaft": SHAFT,
           "well": WELL}


def schema_json(kind: str) -> str:
    """The JSON Schema (draft 2020-12) of a file kind, as `crankfmu schema KIND` prints it."""
    if kind not in SCHEMAS:
        raise DefinitionError(f"unknown file kind {kind!r}: give one of {', '.join(SCHEMAS)}")
    doc = {"$schema": "https://json-schema.org/draft/2020-12/schema", "title": f"crankfmu {kind} file",
           **SCHEMAS[kind]}
    return json.dumps(doc, indent=2)


def _types(schema) -> tuple:
    t = schema.get("type")
    return tuple(t) if isinstance(t, list) else (t,) if t else ()


def unknown_keys(data, schema, path=()) -> list[tuple[tuple, str, list[str]]]:
    """(the path of the table, the unknown key, the keys it may hold) for every key ``schema`` does
    not allow, depth first in the file's order."""
    found = []
    if isinstance(data, dict) and "object" in _types(schema):
        props = schema.get("properties", {})
        patterns = schema.get("patternProperties", {})
        extra = schema.get("additionalProperties", True)
        for key, value in data.items():
            if key in props:
                found += unknown_keys(value, props[key], (*path, key))
                continue
            match = next((s for p, s in patterns.items() if re.search(p, key)), None)
            if match is not None:
                found += unknown_keys(value, match, (*path, key))
            elif extra is False:
                found.append((path, key, sorted(props)))
            elif isinstance(extra, dict):
                found += unknown_keys(value, extra, (*path, key))
    elif isinstance(data, list) and "array" in _types(schema) and "items" in schema:
        for i, item in enumerate(data):
            found += unknown_keys(item, schema["items"], (*path, i))
    return found


def _table_name(path: tuple) -> str:
    """How a reader finds the table: [experiment], [parameters.l1], the 2nd [[loads]], the top level."""
    if not path:
        return "the top level"
    out, names = "", []
    for part in path:
        if isinstance(part, int):
            out = f"the {_ordinal(part + 1)} [[{'.'.join(names)}]]"
            names = []
        else:
            names.append(part)
    if names:
        return (f"{out}, table {'.'.join(names)}" if out else f"[{'.'.join(names)}]")
    return out


def _ordinal(n: int) -> str:
    return f"{n}{'th' if 10 <= n % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(n % 10, 'th')}"


def line_of(text: str, path: tuple, key: str) -> int | None:
    """The line (from 1) where ``key`` is written in the table at ``path``: after the table's
    header ([name], the n-th [[name]]) or in an inline table, before the next header."""
    lines = text.splitlines()
    start, end = 0, len(lines)
    headers = [(i, line.strip()) for i, line in enumerate(lines) if re.match(r"\s*\[", line)]
    tables = [p for p in path if isinstance(p, str)]
    if path:
        # the header that opens the table: the n-th [[a]] on an array's path, else the deepest [a.b]
        # whose name begins the path
        dotted = ".".join(tables)
        index = next((p for p in path if isinstance(p, int)), None)
        names = [(i, header, header.strip("[]").strip()) for i, header in headers]
        if index is not None:
            arrays = [i for i, header, name in names if header.startswith("[[") and name == tables[0]]
            best = arrays[index] if index < len(arrays) else None
        else:
            within = [(len(name), i) for i, _, name in names if dotted == name or dotted.startswith(name + ".")]
            best = max(within)[1] if within else None
        if best is not None:
            start = best + 1
            end = next((i for i, _ in headers if i > best), len(lines))
    elif headers:
        end = headers[0][0]
    # a key whose value is a table may be written as a header of its own: [key], [a.key], [[key]]
    own = ".".join([*tables, key])
    for i, header in headers:
        if header.strip("[]").strip() == own:
            return i + 1
    pattern = re.compile(rf'(^|[{{,\s])"?{re.escape(key)}"?\s*=')
    for i in range(start, end):
        if pattern.search(lines[i].split("#", 1)[0]):
            return i + 1
    for i, line in enumerate(lines):
        if pattern.search(line.split("#", 1)[0]):
            return i + 1
    return None


def check_keys(data: dict, kind: str, text: str, where: str) -> None:
    """DefinitionError naming the first key of ``data`` (a file of ``kind``) that its schema does
    not know: the key, its table, the file's line, the closest valid key and the valid keys."""
    found = unknown_keys(data, SCHEMAS[kind])
    if not found:
        return
    path, key, valid = found[0]
    line = line_of(text, path, key)
    hint = did_you_mean(key, valid)
    more = f"; {len(found) - 1} more unknown key(s) after it" if len(found) > 1 else ""
    raise DefinitionError(f"{where}{f', line {line}' if line else ''}: unknown key {key!r} in {_table_name(path)}"
                          f"{hint}; valid keys there: {', '.join(valid)}{more}")
