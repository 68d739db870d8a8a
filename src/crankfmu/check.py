"""``crankfmu check SCENARIO``: a scenario and its mechanism file checked before anything is built.

Reported in order, each as OK, WARN or FAIL with the file, the section and the line where one
applies:

1. the files read (TOML syntax, required sections and keys: crankfmu's own parser);
2. every name used in an expression is a parameter, a constant, phi1 or an unknown (all at once,
   not the first only);
3. the degree of freedom from the contour count (2 equations per contour for the unknowns, phi1
   the one free coordinate) and, with joints, 2 per joint + 1 = 3 per moving link;
4. each four-bar loop's Grashof class (s + l against p + q);
5. assembly over the whole crank turn on the stated branch (AssemblyError names where and the
   changed parameters' bounds) and the smallest |det| of the column-normalised contour Jacobian
   with its crank angle (0 at a dead or change point);
6. masses and inertias not negative, the reduced inertia J_red > 0 at every angle, the loads and
   outputs built.

Exit status: 0 when everything holds (warnings allowed), 1 when a check fails, 2 when the files
cannot be read.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import AssemblyError, CrankfmuError, DefinitionError
from .expressions import CONSTANTS, FUNCTIONS, Expression

#: conditioning below which a geometry is reported as near a dead or change point (the
#: transmission angle of a four-bar below about 3 deg)
NEAR_DEAD_POINT = 0.05


@dataclass
class Finding:
    level: str            # "OK", "WARN", "FAIL"
    what: str
    where: str = ""


@dataclass
class Report:
    findings: list[Finding] = field(default_factory=list)
    unreadable: bool = False

    def add(self, level, what, where=""):
        self.findings.append(Finding(level, what, where))

    @property
    def status(self) -> int:
        if self.unreadable:
            return 2
        return 1 if any(f.level == "FAIL" for f in self.findings) else 0

    def text(self) -> str:
        return "\n".join(f"{f.level:4s} {f.what}" + (f"  [{f.where}]" if f.where else "") for f in self.findings)


# ------------------------------------------------------------------------------------------ lines

def locate(path: str | None, message: str) -> str:
    """'file, line N' of the entry an error message names (a contour, point, link, joint, section),
    found in the file's text; the file alone when the message names nothing findable."""
    if not path or not Path(path).is_file():
        return ""
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    patterns = []
    m = re.search(r"line (\d+)", message)
    if m:                                        # tomllib's own position
        return f"{path}, line {m.group(1)}"
    # a [[loads]] entry's key ("load 2: force fy = ..."), the n-th entry's header without one: before
    # the sections, as such a message also lists what is known ("parameters, phi1, ...")
    m = re.search(r"\bload (\d+)(?:: \w+ ([\w.]+)(?: =|:))?", message)
    if m:
        from .schema import line_of

        text, number, key = "\n".join(lines), int(m.group(1)), m.group(2)
        tables, _, key = (key or "").rpartition(".")
        line = line_of(text, ("loads", number - 1, *filter(None, [tables])), key) if key else None
        if line is None:
            headers = [i for i, line in enumerate(lines, start=1) if re.match(r"\s*\[\[loads\]\]", line)]
            line = headers[number - 1] if number <= len(headers) else None
        if line is not None:
            return f"{path}, line {line}"
    # an entry of a list ([[contours]], [[joints]]) by its name line, a table by its header, a key
    # (a point, an unknown, a parameter) by its own line
    for kind, how in (("contour", "entry"), ("joint", "entry"), ("output", "entry"), ("link", "table"), ("fixed point", "key"),
                      ("point", "key"), ("unknown", "key"), ("parameter", "key")):
        m = re.search(rf"{kind} '?([A-Za-z_][\w'-]*?)'?(:| |$|,)", message)
        if not m:
            continue
        name = re.escape(m.group(1).strip("'"))
        patterns.append({"entry": rf"^\s*name\s*=\s*[\"']{name}[\"']", "table": rf"^\s*\[links\.{name}\]",
                         "key": rf"^\s*{name}\s*="}[how])
    for section in ("assembly", "unknowns", "fixed_points", "points", "parameters", "experiment"):
        if f"[{section}]" in message or f"{section}" in message.split(":")[-1]:
            patterns.append(rf"^\s*\[{section}\]")
    for pattern in patterns:
        for i, line in enumerate(lines, start=1):
            if re.search(pattern, line):
                return f"{path}, line {i}"
    return str(path)


# ------------------------------------------------------------------------------------------ names

def unknown_names(definition, parameters: set[str]) -> list[tuple[str, set[str]]]:
    """(where, names) for every expression of the mechanism file that uses a name which is no
    parameter, constant, function, phi1 or unknown (closed-form steps may use earlier steps)."""
    known = set(parameters) | set(definition.constants) | set(CONSTANTS) | set(FUNCTIONS) | {"phi1", "pi"}
    known |= set(definition.unknowns)
    problems = []

    def check(source, where, extra=frozenset()):
        names = Expression(source, where).names - known - set(extra)
        if names:
            problems.append((where, names))

    for cname, terms in definition.contours:
        for t in terms:
            check(t.coefficient, f"contour {cname}")
            check(t.offset, f"contour {cname}")
    for p, (terms, xy) in definition.points.items():
        for t in terms:
            check(t.coefficient, f"point {p}")
            check(t.offset, f"point {p}")
        for c in xy:
            check(c, f"fixed point {p}")
    for lname, link in definition.links.items():
        for text in (link.mass, link.inertia, link.angle):
            check(text, f"link {lname}")
    for j in definition.joints:
        check(j.axis, f"joint {j.name}")
    assigned: set[str] = set()
    for name, expr in definition.closed_form or []:
        check(expr.source, f"[assembly] closed form {name}", assigned)
        assigned.add(name)
    for u, text in (definition.guess or {}).items():
        check(text, f"[assembly] guess {u}")
    above: set[str] = set()
    for name, value in definition.constants.items():
        if isinstance(value, Expression):     # the parameters and the constants above it
            names = value.names - set(parameters) - above - set(CONSTANTS)
            if names:
                problems.append((f"[assembly] constants {name}", names))
        above.add(name)
    merged: dict[str, set] = {}
    for where, names in problems:
        merged.setdefault(where, set()).update(names)
    return list(merged.items())


# ------------------------------------------------------------------------------------------ Grashof

def grashof(definition, values) -> list[str]:
    """The Grashof class of each contour that is a four-bar loop (four terms of constant length,
    one of them the crank phi1, one a constant direction: the frame), from the link lengths alone
    (no assembly needed: it explains an assembly that fails)."""
    env = {**values, **definition.constant_values(values)}
    out = []
    for cname, terms in definition.contours:
        if len(terms) != 4 or any(t.length for t in terms):
            continue
        crank = [t for t in terms if t.angle == "phi1"]
        frame = [t for t in terms if t.angle is None]
        if len(crank) != 1 or len(frame) != 1:
            continue
        lengths = {id(t): abs(float(Expression(t.coefficient).evaluate(env))) for t in terms}
        ordered = sorted(lengths.values())
        s, p, q, l = ordered
        role = {id(crank[0]): "crank", id(frame[0]): "frame"}
        shortest = role.get(min(lengths, key=lengths.get), "coupler or rocker")
        if math.isclose(s + l, p + q, rel_tol=1e-9):
            kind = "change point (s + l = p + q): the loop can fold; the branch is not unique at the fold"
        elif s + l < p + q:
            kind = {"crank": "Grashof crank-rocker (the crank is the shortest link: it turns fully)",
                    "frame": "Grashof double crank (drag link: the frame is the shortest link)"}.get(
                shortest, "Grashof double rocker (the coupler is the shortest link: the crank cannot turn fully)")
        else:
            kind = "non-Grashof triple rocker (s + l > p + q: no link turns fully)"
        out.append(f"contour {cname}: {kind}; s + l = {s + l:.6g} m, p + q = {p + q:.6g} m")
    return out


# ------------------------------------------------------------------------------------------ the check

def check_scenario(source) -> Report:
    """Every check of the module doc on a scenario (a packaged name or a path)."""
    from .scenario import load_scenario

    report = Report()
    path = str(source) if str(source).endswith(".toml") else None
    try:
        scenario = load_scenario(source)
    except CrankfmuError as exc:
        report.unreadable = True
        report.add("FAIL", f"the scenario file cannot be read: {exc}", locate(path, str(exc)))
        return report
    report.add("OK", f"scenario {scenario.name} read ({len(scenario.parameters)} parameters)", scenario.where)
    mech_path = scenario.mechanism_source()
    mech_file = str(mech_path) if str(mech_path).endswith(".toml") else None
    try:
        definition = scenario.mechanism_definition()
    except CrankfmuError as exc:
        report.unreadable = True
        report.add("FAIL", f"the mechanism file cannot be read: {exc}", locate(mech_file, str(exc)))
        return report
    report.add("OK", f"mechanism {definition.name} read: {len(definition.unknowns)} unknowns "
               f"({', '.join(definition.unknowns)}), {len(definition.contours)} contour(s), "
               f"{len(definition.links)} links, {len(definition.joints)} joints", mech_file or f"mechanism {definition.name}")

    try:
        bad = unknown_names(definition, set(scenario.parameters))
    except DefinitionError as exc:          # an expression that does not parse or is not allowed
        report.unreadable = True
        report.add("FAIL", f"the mechanism file cannot be read: {exc}", locate(mech_file, str(exc)))
        return report
    for where, names in bad:
        report.add("FAIL", f"{where}: unknown name(s) {', '.join(sorted(names))} (not a parameter of "
                   f"{scenario.name}, a constant, phi1 or an unknown)", locate(mech_file, where))
    if not bad:
        report.add("OK", "every name in the mechanism's expressions is a parameter, constant, phi1 or unknown")

    n_eq, n_unknown = 2 * len(definition.contours), len(definition.unknowns)
    report.add("OK", f"1 degree of freedom: {len(definition.contours)} contour(s) give {n_eq} equations for "
               f"{n_unknown} unknowns, phi1 free"
               + (f"; {len(definition.joints)} joints give {2 * len(definition.joints)} reactions + the driving "
                  f"moment = 3 x {len(definition.links)} links" if definition.joints else
                  "; no [[joints]]: no joint reactions, the drawing joins points to their base points"))
    if bad:
        return report
    try:                                    # an expression constant that is not finite at the file's values
        definition.constant_values(scenario.values)
    except DefinitionError as exc:
        report.add("FAIL", str(exc), locate(mech_file, str(exc).split(": ", 1)[-1].split(" = ")[0]))
        return report

    try:
        mechanism, worst, at = scenario.assembled_mechanism()
    except (AssemblyError, DefinitionError) as exc:
        for line in grashof(definition, scenario.values):
            report.add("OK", line)
        report.add("FAIL", str(exc), locate(mech_file, str(exc)))
        return report
    for line in grashof(definition, scenario.values):
        report.add("OK", line)
    level = "WARN" if worst < NEAR_DEAD_POINT else "OK"
    report.add(level, f"assembles over the whole turn on the branch '{definition.branch}'; smallest |det| of the "
               f"contour Jacobian {worst:.4g} at phi1 = {math.degrees(at) % 360:.2f} deg"
               + (" (near a dead or change point: large forces and a stiff model there)" if level == "WARN" else ""))
    try:
        model = scenario.build()
        quantities = scenario.quantities
    except CrankfmuError as exc:
        report.add("FAIL", str(exc), locate(path, str(exc)))
        return report
    masses = {l.name: (l.mass, l.inertia) for l in model.reduced.links}
    report.add("OK", "masses and inertias >= 0: " + ", ".join(f"{n} {m:g} kg {i:g} kg.m2" for n, (m, i) in masses.items()))
    with np.errstate(all="ignore"):         # a load that is not finite is named below, not warned of here
        J = model.reduced.coefficients(np.linspace(0.0, 2 * math.pi, 721))[0]
    report.add("OK", f"J_red from {np.min(J):.6g} to {np.max(J):.6g} kg.m2 over the turn (> 0)")
    report.add("OK", f"{len(model.reduced.loads)} loads, {len(quantities)} mechanism-specific outputs"
               + (f" ({', '.join(q.name for q in quantities)})" if quantities else "")
               + (f"; the machine's cycle is {scenario.cycle_turns} crank turns (cycle_turns): the loads repeat "
                  f"every {360 * scenario.cycle_turns} deg" if scenario.cycle_turns > 1 else ""))
    for port in model.reduced.ports:
        report.add("OK", f"{port.input_description}; input {port.input_name}, outputs "
                   + ", ".join(q.name for q in port.quantities))
    if not loads_finite(report, model, path):
        return report
    kinks_located(report, model)
    laws_held(report, model)
    fmu_declarations(report, source, scenario, path)
    native_tables_check(report, scenario, path)
    steady_cycle_check(report, scenario, path)
    return report


def steady_cycle_check(report: Report, scenario, path):
    """What ``crankfmu flywheel`` and the sweeps start from: the fast path's steady cycle at the
    file's values (studies.batch, the same function). A design with no steady cycle (the motor
    cannot drive it round) is a warning: the file is right, the study has nothing to size."""
    from .studies.batch import SteadyBatch

    try:
        found = SteadyBatch(scenario).run([{}])
    except CrankfmuError as exc:
        report.add("FAIL", f"crankfmu simulate --method fast, flywheel and sweep would refuse it: {exc}",
                   locate(path, str(exc)))
        return
    cycle = (f"a machine cycle of {scenario.cycle_turns} turns" if scenario.cycle_turns > 1 else "one crank turn")
    if found.failed:
        report.add("WARN", f"no steady cycle at the file's values over {cycle}: {found.failed[0]['reason']} "
                   "(crankfmu flywheel and sweep have none to start from)", path or "")
        return
    row = found.rows[0]
    report.add("OK", f"the fast path's steady cycle at the file's values over {cycle} (what crankfmu flywheel and "
               f"sweep start from): omega1 mean {row['omega1_mean']:.6g} rad/s, delta {row['delta']:.4g}")


#: the angles where each load expression is evaluated by check: every 0.1 deg, the crank's dead
#: centres (0, 90, 180, 270 deg) among them
FINITE_GRID = np.linspace(0.0, 2 * math.pi, 3601)


def kinks_located(report: Report, model):
    """Each load's kinks (user_loads.KinkedLoad) and where over the turn they switch: the angles
    every path steps onto, as it does a slider force's switch."""
    from .dynamics.user_loads import KinkedLoad

    for load in model.reduced.loads:
        if isinstance(load, KinkedLoad):
            # two kinks of one angle (sign(s) and max(0, sign(s))) are one switch, as in the schedule
            angles = sorted({round(a % (2 * math.pi), 13) for a in load.switch_angles(model.mechanism)})
            where = (f"switch at phi1 = {', '.join(f'{math.degrees(a):.2f}' for a in angles)} deg" if angles
                     else "keep one side over the whole turn")
            parts = (f" (each side a polynomial of degree {load.degree} in omega1, held by its parts)"
                     if hasattr(load, "degree") else "")
            report.add("OK", f"the load on {load.link} has {len(load.arguments)} kink(s), {', '.join(load.calls)}; "
                       f"they {where}: every path steps onto those angles and tabulates each side smooth{parts}")


def laws_held(report: Report, model):
    """Each general law of the speed (speed_laws.SpeedLawLoad) and how every path holds it."""
    from .dynamics.speed_laws import SpeedLawLoad, law_column_name

    for load in model.reduced.loads:
        if isinstance(load, SpeedLawLoad):
            name = law_column_name(load.link, load.law.source).split(" law ", 1)[1]
            report.add("OK", f"the load on {load.link} has a law of the speed, {name}: the tables hold its factor "
                       "of the position, and every path multiplies it by the law at each step's omega1")


def loads_finite(report: Report, model, path) -> bool:
    """Each expression of each user load ([[loads]] force or couple) finite over the turn: one that
    is not (1/sin(phi1) at 0 deg, 1e308*1e308*0) is named with its value and the first angle, not
    left for the tabulator to misread as a steep function."""
    from .dynamics.user_loads import ExpressionLoad, position_env

    turns = model.reduced.cycle_turns
    grid = np.linspace(0.0, model.reduced.period, (FINITE_GRID.size - 1) * turns + 1)    # over the machine's cycle
    kin = model.mechanism.kinematics(grid)
    # a load of the speeds at the start speed (at least 1 rad/s): finite there is finite at any
    # speed, its torque being affine in omega1 (Scenario.build checks that)
    speed = max(abs(model.y0[1]), 1.0)
    env = None
    bad = []
    for number, load in enumerate(model.reduced.loads, start=1):
        if not isinstance(load, ExpressionLoad):
            continue
        env = env or position_env(load.mechanism, kin, speed)
        sides = ([("increasing.", load.increasing), ("decreasing.", load.decreasing)] if load.decreasing
                 else [("", load.increasing)])
        for prefix, exprs in sides:
            for key, expr in exprs.items():
                with np.errstate(all="ignore"):
                    values = np.broadcast_to(np.asarray(expr.evaluate(env), dtype=float), grid.shape)
                wrong = np.flatnonzero(~np.isfinite(values))
                if wrong.size:
                    i = int(wrong[0])
                    bad.append(f"a load on {load.link}: {prefix}{key} = {expr.source!r} is not finite ({values[i]:g}) at "
                               f"phi1 = {math.degrees(grid[i]):.2f} deg"
                               + (f" and {wrong.size - 1} more of the {grid.size} angles checked" if wrong.size > 1
                                  else ""))
    for text in bad:
        report.add("FAIL", text + ": a load must be a finite number at every crank angle", locate(path, text))
    return not bad


def native_tables_check(report: Report, scenario, path):
    """What ``crankfmu fmu --native`` would refuse: its program and tables, built and checked by the
    same function (fmi.native.model.native_program), so check refuses exactly what the build would."""
    from .fmi.native.model import native_program
    from .native.mechanism import TABLE_NAMES

    try:
        _, tables = native_program(scenario)
    except CrankfmuError as exc:
        report.add("FAIL", f"crankfmu fmu --native would refuse it: {exc}", locate(path, str(exc)))
        return
    built = [f"{TABLE_NAMES[table].removeprefix('the ')}: {construction} (checked error {error:.2g})"
             for table, (error, construction) in tables.items()]
    report.add("OK", "the native FMU's tables, built by the C model when it initialises (at the file's values): "
               + "; ".join(built))


def fmu_declarations(report: Report, source, scenario, path):
    """What ``crankfmu fmu`` would refuse in the files (fmi.source.preflight, the same function):
    the model identifier, each variable's name and unit, the DefaultExperiment."""
    from .fmi.source import preflight

    name = scenario.data.get("fmu")
    if not name:
        report.add("WARN", "no fmu = \"NAME\" in the scenario file: crankfmu fmu needs --name NAME", path or "")
    try:
        source = preflight("scenario", str(source) if isinstance(source, (str, Path)) else scenario,
                           None if name else "Unnamed")
    except CrankfmuError as exc:
        report.add("FAIL", f"crankfmu fmu would refuse it: {exc}", locate(path, str(exc)))
        return
    report.add("OK", f"the FMU's declarations: model identifier {source.fmu}, {len(source.variables().units)} "
               "variables with distinct names and readable SI units, the DefaultExperiment")
    if source.initialise is not None:
        try:
            said = source.initialise()
        except CrankfmuError as exc:
            report.add("FAIL", f"crankfmu fmu would refuse it: the FMU cannot initialise at its start values: {exc}",
                       locate(path, str(exc)))
            return
        report.add("OK", said)
