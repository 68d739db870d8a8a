"""The C model's program (native/mechanism/crank_mechanism.c): what a scenario compiles to
(program_scenario.py), an instruction list of one small register machine and the tables of the
contour terms, links, joints and loads.

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
from ..mechanisms.assembly import MIN_CONDITIONING

#: the evaluator's operations, in crank_mechanism.h's order (enum mm_op)
OPS = ("literal", "copy", "add", "sub", "mul", "div", "pow", "neg",
       "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sqrt", "hypot", "exp", "log",
       "abs", "sign", "min", "max", "radians", "degrees", "if_positive", "if_negative", "not_above",
       "tanh", "sinh", "cosh")
OP = {name: i for i, name in enumerate(OPS)}
_BINARY = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div", ast.Pow: "pow"}
SETUP, CLOSED, ROWS, VALUES, OUTPUTS, REACTIONS, LAWS, FIRST_SEARCH = range(8)
ROCKER, REVERSALS, BAND, ZEROS, FRICTION_RATE = range(5)


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
    #: the parameters the program reads (indices into ``parameters``): the tables depend on these only
    table_parameters: tuple[int, ...] = ()
    #: what the loads' searches find, (load index in the file, name, register) each (program_loads)
    found: tuple[tuple[int, str, int], ...] = ()
    # the [[outputs]] and ports' coordinates: (q, q', q'' registers, is an angle) each
    coordinates: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), np.int32))
    coordinate_names: tuple[str, ...] = ()
    # the joint reactions: the links (centre point, mass, inertia, q', q'' registers), the crank's
    # index, the joints (kind, point, first and second link or -1 for the ground, axis register),
    # each term's inertia (epsilon1, omega1^2 factors) and the loads applied in each term (term,
    # link, point or -1, fx, fy, moment registers or -1)
    links: np.ndarray = field(default_factory=lambda: np.zeros((0, 5), np.int32))
    crank: int = -1
    joints: np.ndarray = field(default_factory=lambda: np.zeros((0, 5), np.int32))
    term_inertia: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int32))
    applied: np.ndarray = field(default_factory=lambda: np.zeros((0, 6), np.int32))
    reaction_names: tuple[str, ...] = ()
    #: the slowest conditioning the assembly check accepts: the engine's (Mechanism.check_assembly)
    min_conditioning: float = MIN_CONDITIONING
    #: crank turns of the machine's cycle (the scenario's cycle_turns): the reduced model's and the
    #: reactions' tables repeat over it
    cycle_turns: int = 1
    #: (n_columns,) the power of omega1 each switched column's value is multiplied by (a load of the
    #: speeds' parts in omega1 and omega1^2; 0 for the slider forces, kinks, directions)
    column_powers: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    #: the general laws of the speed (dynamics/speed_laws.py): LAWS reads omega1 from register
    #: law_speed and leaves each column's law in laws[column] (-1: none); column_laws their texts
    law_speed: int = -1
    laws: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    column_laws: tuple = ()
    #: the joints' friction: (joint index, coefficient register c, relative rate register) each;
    #: the reaction terms' last len(frictions) are their unit loads (crank_mechanism.h)
    frictions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int32))


class _Code:
    """Registers and instructions, section by section."""

    def __init__(self, n_parameters: int):
        self.n = self.n_parameters = n_parameters
        self.used: set[int] = set()          # the parameters' registers an expression read
        self.code: list[tuple[int, int, int, int, int]] = []
        self.literals: list[float] = []
        self.sections: dict[int, tuple[int, int]] = {}
        self._open = None
        self._literal_index: dict[str, int] = {}     # a value's bits (float.hex) -> its index in literals

    def register(self) -> int:
        self.n += 1
        return self.n - 1

    def block(self, size: int) -> int:
        self.n += size
        return self.n - size

    def begin(self, section: int):
        self._open = (section, len(self.code))

    def end(self):
        section, start = self._open
        self.sections[section] = (start, len(self.code))
        self._open = None

    def emit(self, op: str, a: int = 0, b: int = 0, c: int = 0, into: int | None = None) -> int:
        dst = self.register() if into is None else into
        self.code.append((OP[op], dst, a, b, c))
        return dst

    def literal(self, value: float) -> int:
        """A register holding ``value``, where it is needed: optimise moves it to SETUP and shares
        one register between every use of the same value (0.0 and -0.0 are two)."""
        index = self._literal_index.setdefault(float(value).hex(), len(self.literals))
        if index == len(self.literals):
            self.literals.append(float(value))
        return self.emit("literal", index)

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
            if node.id in CONSTANTS and node.id not in names:
                return self.literal(CONSTANTS[node.id])
            if names[node.id] < self.n_parameters:
                self.used.add(names[node.id])
            return names[node.id]
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


#: how many register operands each operation reads (a literal reads its index into ``literals``)
_ARITY = {OP[name]: n for names, n in (
    (("literal",), 0),
    (("copy", "neg", "sin", "cos", "tan", "asin", "acos", "atan", "sqrt", "exp", "log", "abs", "sign",
      "radians", "degrees", "tanh", "sinh", "cosh"), 1),
    (("add", "sub", "mul", "div", "pow", "atan2", "hypot", "min", "max", "not_above"), 2),
    (("if_positive", "if_negative"), 3)) for name in names}


def optimise(code: list, sections: dict, runtime: set[int], literals: list) -> tuple[list, dict]:
    """The same program with less work per crank angle: each instruction of a per-angle section
    whose operands do not change with the angle moves to SETUP (which runs once, at binding), and
    an instruction that repeats an earlier one of its section (same operation on the same values)
    becomes a copy of that one's result. The expressions are compiled as written, so a closed form
    states sin(phi1) twice and a row multiplies the same two masses at every angle; this pass
    makes the per-angle sections a fifth to a third shorter (22 to 35 % of their instructions on
    the packaged and the tests' mechanisms; the copies stay). Every value is computed by the same
    operation on the same operands as before, so every result is bit for bit the same.

    ``runtime``: the registers the C model writes itself (phi1, the kinematics, the crank's
    direction, what the searches find after binding). A search section's last instruction stays
    where it is: the search reads its value from it."""
    order = sorted(sections, key=lambda s: sections[s][0])
    body = {s: [list(ins) for ins in code[slice(*sections[s])]] for s in order}
    writes: dict[int, int] = {}
    for ins in code:
        writes[ins[1]] = writes.get(ins[1], 0) + 1
    varying = set(runtime) | {ins[1] for s in order if s != SETUP for ins in body[s]}

    def reads(ins):
        return ins[2:2 + _ARITY[ins[0]]]

    hoisted = []
    for s in order:
        if s == SETUP:
            continue
        kept = []
        for i, ins in enumerate(body[s]):
            last = s >= FIRST_SEARCH and i == len(body[s]) - 1
            if (not last and writes[ins[1]] == 1 and ins[1] not in runtime
                    and not any(r in varying for r in reads(ins))):
                hoisted.append(ins)
                varying.discard(ins[1])
            else:
                kept.append(ins)
        body[s] = kept
    # SETUP's repeats first: a copy there holds its source's value at every angle after
    known: dict[int, int] = {}
    body[SETUP] = _common(body[SETUP] + hoisted, literals, {}, known)
    known = {r: v for r, v in known.items() if writes.get(r) == 1 and v not in varying}
    for s in order:
        if s != SETUP:
            body[s] = _common(body[s], literals, known, {})
    out, new_sections = [], {}
    for s in order:
        new_sections[s] = (len(out), len(out) + len(body[s]))
        out += [tuple(ins) for ins in body[s]]
    return out, new_sections


def _common(section: list, literals: list, known: dict[int, int], aliases: dict[int, int]) -> list:
    """``section`` with each repeated computation replaced by a copy of its first result, and
    copies' destinations read from their sources (which may reveal more repeats). ``known``:
    registers that hold another's value on entry; ``aliases`` receives those of the section's end."""
    alias = dict(known)                      # register -> the register holding the same value
    seen: dict[tuple, int] = {}              # (operation, operands) -> register holding its value
    out = []
    for op, dst, a, b, c in section:
        n = _ARITY[op]
        operands = [alias.get(r, r) for r in (a, b, c)[:n]] + [a, b, c][n:]
        key = (op, float(literals[a]).hex()) if op == OP["literal"] else (op, *operands[:n])
        source = alias.get(operands[0], operands[0]) if op == OP["copy"] else seen.get(key)
        # dst's old value is gone: forget what was known of it
        alias = {k: v for k, v in alias.items() if dst not in (k, v)}
        seen = {k: v for k, v in seen.items() if v != dst and dst not in k[1:]}
        if source is not None and source != dst:
            out.append((OP["copy"], dst, source, 0, 0))
            alias[dst] = source
        else:
            out.append((op, dst, *operands))
            if op != OP["copy"] and dst not in operands[:n]:
                seen[key] = dst
    aliases.update(alias)
    return out


def parameter_values(program: Program, values: dict) -> np.ndarray:
    """The registers the binding fills, from a scenario's values."""
    return np.array([values[name] for name in program.parameters], dtype=float)
