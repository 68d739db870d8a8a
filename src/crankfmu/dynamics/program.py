"""A scenario compiled for the C model (native/crank_mechanism.c): its mechanism file's contours,
points and links and its loads and ports, as an instruction list of one small register machine
and the tables of the contour terms.

Why an instruction list rather than generated C (pydy's way): one C library then evaluates every
mechanism with no compiler at run time. An FMU carries its program (a few kB of ints and
doubles) and tabulates at initialisation for whatever values the host set; the in-process fast
path binds a new design in microseconds, where generated C would need a compiler per mechanism.

The program states each rule of the reduced model once more, in the evaluator's terms: J and
0.5 J' from the links' masses and mass-centre transfer functions (dynamics/reduced.py), each
load's torque on the crank (dynamics/loads.py, user_loads.py), the ports' transfer functions
(dynamics/ports.py). The Python engine stays the independent reference: tests/test_c_model.py
compares the two, function by function, at the packaged and the users' mechanisms, at their
default and at changed geometry.

The program is built from the scenario's data once per mechanism and load set (not per design):
every parameter is a register that the binding fills (``Program.parameters``' order).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field

import numpy as np

from ..expressions import CONSTANTS, Expression

#: the evaluator's operations, in crank_mechanism.h's order (enum mm_op)
OPS = ("literal", "copy", "add", "sub", "mul", "div", "pow", "neg",
       "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sqrt", "hypot", "exp", "log",
       "abs", "sign", "min", "max", "radians", "degrees", "if_positive", "if_negative", "not_above")
OP = {name: i for i, name in enumerate(OPS)}
_BINARY = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div", ast.Pow: "pow"}
SETUP, CLOSED, ROWS, VALUES, FIRST_SEARCH = range(5)
ROCKER, REVERSALS, BAND = range(3)
#: the slowest conditioning the assembly check accepts (Mechanism.check_assembly's default)
MIN_CONDITIONING = 1e-6


class Unsupported(Exception):
    """A part of the scenario the C model does not evaluate (the Python engine does)."""


@dataclass
class Program:
    """The compiled scenario: what crank_mechanism.h's mm_program points at."""

    parameters: tuple[str, ...]
    n_registers: int
    code: np.ndarray                  # (n, 5) int32
    literals: np.ndarray
    sections: np.ndarray              # (n_sections, 2) int32
    n_q: int
    n_contours: int
    n_chains: int
    terms: np.ndarray                 # (n_terms, 6) int32
    angles: np.ndarray                # (n_angles, 2) int32: the terms' distinct (angle column, offset)
    chain_constants: np.ndarray       # (n_chains, 2) int32
    angle_column: np.ndarray          # (n_q,) int32
    closed_form: int
    guess: int
    phi1: int
    kinematics: int
    n_points: int
    omega1: int
    rows: np.ndarray
    columns: np.ndarray
    searches: np.ndarray              # (n, 7) int32
    checks: np.ndarray
    check_names: tuple[str, ...]
    row_names: tuple[str, ...]
    n_ports: int
    column_names: tuple[str, ...] = field(default=())


class _Code:
    """Registers and instructions, section by section."""

    def __init__(self, n_parameters: int):
        self.n = n_parameters
        self.code: list[tuple[int, int, int, int, int]] = []
        self.literals: list[float] = []
        self.sections: dict[int, tuple[int, int]] = {}
        self._open = None
        self._literal_regs: dict[float, int] = {}

    def register(self) -> int:
        self.n += 1
        return self.n - 1

    def block(self, size: int) -> int:
        self.n += size
        return self.n - size

    def begin(self, section: int):
        self._open = (section, len(self.code))
        if section == SETUP:
            self._literal_regs = {}

    def end(self):
        section, start = self._open
        self.sections[section] = (start, len(self.code))
        self._open = None

    def emit(self, op: str, a: int = 0, b: int = 0, c: int = 0, into: int | None = None) -> int:
        dst = self.register() if into is None else into
        self.code.append((OP[op], dst, a, b, c))
        return dst

    def literal(self, value: float) -> int:
        """A register holding ``value``, set in SETUP (shared by every later section)."""
        value = float(value)
        if self._open and self._open[0] == SETUP:
            if value not in self._literal_regs:
                self.literals.append(value)
                self._literal_regs[value] = self.emit("literal", len(self.literals) - 1)
            return self._literal_regs[value]
        if value in self._literal_regs:
            return self._literal_regs[value]
        self.literals.append(value)
        return self.emit("literal", len(self.literals) - 1)

    def expression(self, source, names: dict[str, int], where: str) -> int:
        """The register of an expression of ``names`` (a data file's text, or a number)."""
        if isinstance(source, (int, float)) and not isinstance(source, bool):
            return self.literal(source)
        expr = Expression(source, where)
        missing = expr.names - names.keys()
        if missing:
            raise Unsupported(f"{where}: {', '.join(sorted(missing))} not available to the C model")
        return self._node(ast.parse(expr.source.strip(), mode="eval").body, names)

    def _node(self, node, names) -> int:
        if isinstance(node, ast.Constant):
            return self.literal(node.value)
        if isinstance(node, ast.Name):
            return self.literal(CONSTANTS[node.id]) if node.id in CONSTANTS and node.id not in names else names[node.id]
        if isinstance(node, ast.UnaryOp):
            inner = self._node(node.operand, names)
            return self.emit("neg", inner) if isinstance(node.op, ast.USub) else inner
        if isinstance(node, ast.BinOp):
            return self.emit(_BINARY[type(node.op)], self._node(node.left, names), self._node(node.right, names))
        if isinstance(node, ast.Call):
            args = [self._node(a, names) for a in node.args]
            if node.func.id not in OP or len(args) not in (1, 2):
                raise Unsupported(f"function {node.func.id} with {len(args)} arguments")
            return self.emit(node.func.id, *args)
        raise Unsupported(f"{type(node).__name__} in an expression")

    # arithmetic on registers, for the rules the program states itself
    def add(self, *regs):
        regs = [r for r in regs if r is not None]
        if not regs:
            return self.literal(0.0)
        total = regs[0]
        for r in regs[1:]:
            total = self.emit("add", total, r)
        return total

    def mul(self, *regs):
        total = regs[0]
        for r in regs[1:]:
            total = self.emit("mul", total, r)
        return total


class _Compiler:
    def __init__(self, scenario):
        from ..scenario import USER_LOADS

        self.user_kinds = USER_LOADS
        self.scenario = scenario
        self.definition = d = scenario.mechanism_definition()
        self.parameters = tuple(sorted(scenario.parameters))
        self.c = _Code(len(self.parameters))
        self.env = {name: i for i, name in enumerate(self.parameters)}
        self.unknowns = list(d.unknowns)
        self.points = list(d.points)
        self.checks: list[tuple[int, str]] = []

    # ---------------------------------------------------------------- registers of the kinematics
    def q(self, name):
        """(q, q', q'') registers of phi1 or an unknown."""
        if name == "phi1":
            return self.phi1, self.one, self.zero
        j = self.unknowns.index(name)
        base = self.kin + 3 * j
        return base, base + 1, base + 2

    def point(self, name):
        """(x, y, dx, dy, ddx, ddy) registers of a point."""
        base = self.kin + 3 * len(self.unknowns) + 6 * self.points.index(name)
        return tuple(range(base, base + 6))

    def link_angle(self, link):
        angle = self.definition.links[link].angle
        if angle == "phi1" or angle in self.unknowns:
            return self.q(angle)
        return self.link_constants[link], self.zero, self.zero

    def position_names(self):
        """Names a user load's expression may read: parameters, phi1, unknowns, P_x, P_y."""
        names = {**self.env, "phi1": self.phi1}
        for u in self.unknowns:
            names[u] = self.q(u)[0]
        for p in self.points:
            x, y = self.point(p)[:2]
            names[f"{p}_x"], names[f"{p}_y"] = x, y
        return names

    # ---------------------------------------------------------------- the program
    def compile(self) -> Program:
        d, c = self.definition, self.c
        c.begin(SETUP)
        self.one, self.zero = c.literal(1.0), c.literal(0.0)
        for name, value in d.constants.items():
            self.env[name] = c.literal(value)
        chains = [terms for _, terms in d.contours] + [d.points[p][0] for p in self.points]
        variables = d.variables
        terms, offsets = [], {}
        for chain, chain_terms in enumerate(chains):
            for t in chain_terms:
                coef = c.expression(t.coefficient, self.env, f"{d.name}: coefficient")
                if t.sign != 1.0:
                    coef = c.emit("mul", c.literal(t.sign), coef)
                if t.offset not in offsets:       # one register per offset: the terms' distinct angles
                    offsets[t.offset] = c.expression(t.offset, self.env, f"{d.name}: angle offset")
                offset = offsets[t.offset]
                terms.append((chain, coef, variables.index(t.length) if t.length else -1,
                              variables.index(t.angle) if t.angle else -1, offset))
        constants = [(-1, -1)] * len(d.contours)
        for p in self.points:
            x, y = d.points[p][1]
            constants.append((c.expression(x, self.env, "fixed point"), c.expression(y, self.env, "fixed point")))
        guess = -1
        if d.closed_form is None:
            g = d.guess
            values = [c.expression(g.get("phi1", "0"), self.env, "assembly guess phi1")]
            values += [c.expression(g[u], self.env, f"assembly guess {u}") for u in self.unknowns]
            guess = c.block(len(values))
            for i, v in enumerate(values):
                c.emit("copy", v, into=guess + i)
        self.link_constants = {}
        self.links = {}
        for name, ld in d.links.items():
            if ld.angle != "phi1" and ld.angle not in self.unknowns:
                self.link_constants[name] = c.expression(ld.angle, self.env, f"link {name} angle")
            mass = c.expression(ld.mass, self.env, f"mass of {name}")
            inertia = c.expression(ld.inertia, self.env, f"inertia of {name}")
            self.checks += [(mass, f"the mass of link {name}"), (inertia, f"the inertia of link {name}")]
            self.links[name] = (ld.centre, mass, inertia)
        # the per-angle registers: phi1, then (q, q', q'') per unknown, then 6 per point
        self.phi1 = c.register()
        self.kin = c.block(3 * len(self.unknowns) + 6 * len(self.points))
        self.omega1 = c.register()
        loads = self._loads_setup()
        c.end()

        c.begin(CLOSED)
        if d.closed_form is not None:
            names = {**self.env, "phi1": self.phi1}
            for name, expr in d.closed_form:
                reg = c.expression(expr.source, names, f"closed form {name}")
                if name in self.unknowns:
                    reg = c.emit("copy", reg, into=self.q(name)[0])
                names[name] = reg
        c.end()

        c.begin(ROWS)
        rows, row_names = self._rows(loads)
        c.end()
        c.begin(VALUES)
        columns = [v for load in loads if load.get("values") for v in load["values"]()]
        c.end()
        searches = []
        for load in loads:
            for search in load.get("searches", ()):
                kind, quantity, aux, *regs = search
                section = FIRST_SEARCH + len(searches) * 2
                c.begin(section)
                c.emit("copy", quantity())
                c.end()
                c.begin(section + 1)
                if aux is not None:
                    c.emit("copy", aux())
                c.end()
                searches.append((kind, section, section + 1 if aux is not None else -1, *regs))
        distinct = sorted({t[3:5] for t in terms})
        n_sections = max(c.sections) + 1
        sections = np.array([c.sections.get(i, (0, 0)) for i in range(n_sections)], dtype=np.int32)
        program = Program(
            parameters=self.parameters, n_registers=c.n,
            code=np.array(c.code, dtype=np.int32).reshape(-1, 5), literals=np.array(c.literals or [0.0]),
            sections=sections, n_q=len(variables), n_contours=len(d.contours), n_chains=len(chains),
            terms=np.array([t + (distinct.index(t[3:5]),) for t in terms], dtype=np.int32).reshape(-1, 6),
            angles=np.array(distinct, dtype=np.int32).reshape(-1, 2),
            chain_constants=np.array(constants, dtype=np.int32).reshape(-1, 2),
            angle_column=np.array([0] + [int(d.unknowns[u] == "angle") for u in self.unknowns], dtype=np.int32),
            closed_form=int(d.closed_form is not None), guess=guess, phi1=self.phi1, kinematics=self.kin,
            n_points=len(self.points), omega1=self.omega1,
            rows=np.array(rows, dtype=np.int32), columns=np.array(columns or [0], dtype=np.int32)[:len(columns)],
            searches=np.array(searches, dtype=np.int32).reshape(-1, 7),
            checks=np.array([r for r, _ in self.checks] or [0], dtype=np.int32)[:len(self.checks)],
            check_names=tuple(n for _, n in self.checks), row_names=tuple(row_names),
            n_ports=len(self.scenario.data.get("ports", [])),
            column_names=tuple(n for load in loads for n in load.get("column_names", ())),
        )
        return program

    # ---------------------------------------------------------------- loads
    def _value(self, spec, key, at):
        """A load's magnitude register, checked >= 0 at binding (Scenario._load_value)."""
        reg = self.c.expression(spec[key], self.env, f"{at} {key}")
        self.checks.append((reg, f"{at}: the load's {key} {spec[key]}"))
        return reg

    def _loads_setup(self) -> list[dict]:
        """Each load's registers set once (SETUP), and how it makes its rows, columns, values and
        searches (closures run in their sections)."""
        c, out = self.c, []
        for i, spec in enumerate(self.scenario.data.get("loads", [])):
            kind, at = spec.get("kind"), f"load {i + 1}"
            if kind == "weights":
                g = self.env["g"]
                out.append({"position": lambda g=g: c.add(*(
                    c.emit("mul", c.emit("neg", c.mul(mass, g)), self.point(centre)[3])
                    for centre, mass, _ in self.links.values()))})
            elif kind == "dead_point_moment":
                out.append(self._dead_point_moment(spec, at))
            elif kind in ("viscous_force", "slider_force"):
                axis = {"x": 0, "y": 1}[spec["axis"]]
                if kind == "viscous_force":
                    coefficient = self._value(spec, "coefficient", at)
                    out.append({"viscous": lambda p=spec["point"], a=axis, k=coefficient: self._viscous(p, a, k)})
                else:
                    out.append(self._slider_force(spec, axis, at))
            elif kind in ("force", "couple"):
                out.append(self._user_force(spec, kind, at))
            elif kind == "spring_damper":
                out += self._spring_damper(spec, at)
            else:
                raise Unsupported(f"{at}: load kind {kind!r}")
        return out

    def _viscous(self, point, axis, coefficient):
        rate = self.point(point)[2 + axis]
        return self.c.emit("neg", self.c.mul(coefficient, rate, rate))

    def _dead_point_moment(self, spec, at):
        c = self.c
        amplitude = c.expression(spec["amplitude"], self.env, f"{at} amplitude")
        rise, fall = c.register(), c.register()
        q = lambda: self.link_angle(spec["link"])[1]     # noqa: E731

        def torque():
            half = c.literal(0.5)
            s1 = c.emit("sin", c.mul(half, c.emit("sub", self.phi1, rise)))
            s2 = c.emit("sin", c.mul(half, c.emit("sub", self.phi1, fall)))
            return c.mul(amplitude, s1, s2, q())
        return {"position": torque, "searches": [(ROCKER, q, None, rise, fall, -1, -1)]}

    def _slider_force(self, spec, axis, at):
        c = self.c
        forward, backward = self._value(spec, "forward", at), self._value(spec, "backward", at)
        band = [float(v) for v in spec.get("band", [0.0, 1.0])]
        low, high = c.register(), c.register()
        lo, hi = c.literal(band[0]), c.literal(band[1])
        point = spec["point"]
        position = lambda: self.point(point)[axis]        # noqa: E731
        rate = lambda: self.point(point)[2 + axis]        # noqa: E731
        searches = [(REVERSALS, rate, position, low, high, -1, -1)]
        if band != [0.0, 1.0]:
            searches.append((BAND, position, None, low, high, lo, hi))

        def values():
            # loads.SliderForce.force with omega1 = +-1: on the extreme itself the stroke entered decides
            r, curvature = self.point(point)[2 + axis], self.point(point)[4 + axis]
            at_extreme = c.emit("not_above", c.emit("abs", r), c.mul(c.literal(1e-12), c.emit("abs", curvature)))
            velocity = c.emit("if_positive", at_extreme, c.mul(curvature, c.emit("abs", self.omega1)),
                              c.mul(r, self.omega1))
            force = c.emit("if_positive", velocity, c.emit("neg", forward),
                           c.emit("if_negative", velocity, backward, self.zero))
            if band != [0.0, 1.0]:
                x = self.point(point)[axis]
                stroke = c.emit("sub", high, low)
                done = c.emit("div", c.emit("if_positive", velocity, c.emit("sub", x, low), c.emit("sub", high, x)),
                              stroke)
                inside = c.mul(c.emit("not_above", lo, done), c.emit("not_above", done, hi))
                force = c.emit("if_positive", inside, force, self.zero)
            return [force]
        return {"columns": lambda: [rate()], "values": values, "searches": searches,
                "column_names": (f"{point}.{'xy'[axis]}",)}

    def _user_torque(self, link, point, expressions, at):
        c, names = self.c, self.position_names()
        regs = {k: c.expression(expressions[k], names, f"{at} {k}") for k in ("fx", "fy", "moment") if k in expressions}
        parts = []
        if "moment" in regs:
            parts.append(c.mul(regs["moment"], self.link_angle(link)[1]))
        if point is not None:
            x = self.point(point)
            parts += [c.mul(regs[k], x[2 + i]) for i, k in enumerate(("fx", "fy")) if k in regs]
        return c.add(*parts)

    def _user_force(self, spec, kind, at):
        c = self.c
        link, point = spec["link"], spec.get("point") if kind == "force" else None
        direction = spec.get("direction_of")
        if direction is None:
            return {"position": lambda: self._user_torque(link, point, spec, at)}

        def rate():
            if "." in direction:
                p, _, axis = direction.partition(".")
                return self.point(p)[2 + "xy".index(axis)]
            return self.q(direction)[1]

        def values():
            rising = c.mul(rate(), self.omega1)
            return [c.emit("if_positive", rising, self.one, self.zero),
                    c.emit("if_negative", rising, self.one, self.zero)]
        return {"columns": lambda: [self._user_torque(link, point, spec["increasing"], at),
                                    self._user_torque(link, point, spec["decreasing"], at)],
                "values": values, "searches": [(REVERSALS, rate, None, -1, -1, -1, -1)],
                "column_names": (f"{link} {direction} rising", f"{link} {direction} falling")}

    def _spring_damper(self, spec, at):
        c = self.c
        k = self._value({**spec, "stiffness": spec.get("stiffness", "0")}, "stiffness", at)
        damping = self._value({**spec, "damping": spec.get("damping", "0")}, "damping", at)
        d0 = self._value({**spec, "free_length": spec.get("free_length", "0")}, "free_length", at)

        def geometry():
            xa, ya, dxa, dya = self.point(spec["a"])[:4]
            xb, yb, dxb, dyb = self.point(spec["b"])[:4]
            ex, ey = c.emit("sub", xb, xa), c.emit("sub", yb, ya)
            d = c.emit("hypot", ex, ey)
            dd = c.add(c.mul(c.emit("div", ex, d), c.emit("sub", dxb, dxa)),
                       c.mul(c.emit("div", ey, d), c.emit("sub", dyb, dya)))
            return d, dd

        def spring():
            d, dd = geometry()
            return c.emit("neg", c.mul(k, c.emit("sub", d, d0), dd))

        def damper():
            _, dd = geometry()
            return c.emit("neg", c.mul(damping, dd, dd))
        return [{"position": spring}, {"viscous": damper}]

    # ---------------------------------------------------------------- the table's functions
    def _rows(self, loads):
        """The reduced table's functions in tabulated.ReducedTable's order."""
        c = self.c
        J, half = [], []
        for name, (centre, mass, inertia) in self.links.items():
            _, _, t, p, tt, pp = self.point(centre)
            _, q, qq = self.link_angle(name)
            J.append(c.add(c.mul(mass, c.add(c.mul(t, t), c.mul(p, p))), c.mul(inertia, q, q)))
            half.append(c.add(c.mul(mass, c.add(c.mul(t, tt), c.mul(p, pp))), c.mul(inertia, q, qq)))
        rows = [c.add(*J), c.add(*half),
                c.add(*(load["position"]() for load in loads if "position" in load)),
                c.add(*(load["viscous"]() for load in loads if "viscous" in load))]
        names = ["J_links", "half_dJ", "Q_position", "Q_viscous"]
        for load in loads:
            if "columns" in load:
                rows += load["columns"]()
                names += list(load["column_names"])
        for i, port in enumerate(self.scenario.data.get("ports", [])):
            rows.append(self._port_rate(port, f"port {i + 1}"))
            names.append(f"port {port['name']}")
        return rows, names

    def _port_rate(self, port, at):
        """ds/dphi1 of a port (Port.transfer's second value)."""
        c = self.c
        if port["kind"] == "couple":
            return self.link_angle(port["link"])[1]
        _, _, dx, dy, _, _ = self.point(port["point"])
        axis = c.expression(port["axis"], self.env, f"{at} axis")
        along = c.add(c.mul(dx, c.emit("cos", axis)), c.mul(dy, c.emit("sin", axis)))
        if port["kind"] == "force":
            return along
        lever = c.expression(port["lever"], self.env, f"{at} lever")
        return c.add(along, c.mul(lever, self.link_angle(port["link"])[1]))


_PROGRAMS: dict = {}


def compile_scenario(scenario) -> Program | None:
    """The scenario's program (cached per mechanism and loads), or None where a part of it is not
    one the C model evaluates (the Python engine then tabulates it)."""
    d = scenario.mechanism_definition()
    key = (id(d), repr(scenario.data.get("loads")), repr(scenario.data.get("ports")),
           tuple(sorted(scenario.parameters)))
    if key not in _PROGRAMS:
        try:
            _PROGRAMS[key] = (d, _Compiler(scenario).compile())
        except (Unsupported, KeyError, ValueError):
            _PROGRAMS[key] = (d, None)
    return _PROGRAMS[key][1]


def parameter_values(program: Program, values: dict) -> np.ndarray:
    """The registers the binding fills, from a scenario's values."""
    return np.array([values[name] for name in program.parameters], dtype=float)
