"""The C model's program (native/crank_mechanism.c): what a scenario compiles to
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
       "abs", "sign", "min", "max", "radians", "degrees", "if_positive", "if_negative", "not_above")
OP = {name: i for i, name in enumerate(OPS)}
_BINARY = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div", ast.Pow: "pow"}
SETUP, CLOSED, ROWS, VALUES, OUTPUTS, REACTIONS, FIRST_SEARCH = range(7)
ROCKER, REVERSALS, BAND = range(3)


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


class _Code:
    """Registers and instructions, section by section."""

    def __init__(self, n_parameters: int):
        self.n = self.n_parameters = n_parameters
        self.used: set[int] = set()          # the parameters' registers an expression read
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


def parameter_values(program: Program, values: dict) -> np.ndarray:
    """The registers the binding fills, from a scenario's values."""
    return np.array([values[name] for name in program.parameters], dtype=float)
