"""Small, safe arithmetic expressions for data files.

Mechanism and scenario files write lengths, masses and closed-form positions as
expressions of named parameters (``"q1*l1**3/12"``, ``"atan2(dy, dx)"``). They are
parsed with :mod:`ast` and only arithmetic, numbers, names and a fixed set of
numpy functions are accepted, so a data file can never run arbitrary code.
Evaluation is vectorised: names may be bound to numpy arrays.
"""

from __future__ import annotations

import ast
import math
import re
from typing import Mapping

import numpy as np

from .errors import DefinitionError

FUNCTIONS = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "asin": np.arcsin,
    "acos": np.arccos,
    "atan": np.arctan,
    "atan2": np.arctan2,
    "sqrt": np.sqrt,
    "hypot": np.hypot,
    "exp": np.exp,
    "tanh": np.tanh,
    "sinh": np.sinh,
    "cosh": np.cosh,
    "log": np.log,
    "abs": np.abs,
    "sign": np.sign,
    "radians": np.radians,
    "degrees": np.degrees,
    "min": np.minimum,
    "max": np.maximum,
}
CONSTANTS = {"pi": math.pi}

_ALLOWED = (
    ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Name, ast.Load, ast.Call,
    ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd,
)


#: an expression's size: a data file's expression is a line or two; far longer text is an error, and
#: these bounds keep parsing and evaluating it within milliseconds and kilobytes
MAX_LENGTH = 2000       # characters
MAX_NODES = 1000        # operations, names and numbers


class _FloatNumbers(ast.NodeTransformer):
    """Every number as a float: arithmetic in IEEE doubles, as the C model computes it, so a power
    such as 9**9**9**9 overflows at once instead of building an integer of 370 million digits."""

    def visit_Constant(self, node):
        if isinstance(node.value, int) and not isinstance(node.value, bool):
            return ast.copy_location(ast.Constant(float(node.value)), node)
        return node


def parse(source: str, where: str = "expression") -> ast.Expression:
    """Parse ``source`` and reject anything that is not plain arithmetic of bounded size; its
    numbers become floats (_FloatNumbers)."""
    if isinstance(source, (int, float)):
        source = repr(float(source))
    if not isinstance(source, str):
        raise DefinitionError(f"{where}: expected a number or an expression string, got {source!r}")
    if len(source) > MAX_LENGTH:
        raise DefinitionError(f"{where}: the expression is {len(source)} characters long; at most {MAX_LENGTH} "
                              "are accepted")
    try:
        tree = ast.parse(source.strip(), mode="eval")
    except SyntaxError as exc:
        raise DefinitionError(f"{where}: cannot parse {source!r}: {exc.msg}") from None
    except (RecursionError, MemoryError):
        raise DefinitionError(f"{where}: the expression is nested too deeply to read: {source[:60]!r}...") from None
    nodes = sum(1 for _ in ast.walk(tree))
    if nodes > MAX_NODES:
        raise DefinitionError(f"{where}: the expression has {nodes} terms; at most {MAX_NODES} are accepted")
    for node in ast.walk(tree):
        if not isinstance(node, _ALLOWED):
            raise DefinitionError(f"{where}: {type(node).__name__} is not allowed in {source!r}")
        if isinstance(node, ast.Constant) and not isinstance(node.value, (int, float)):
            raise DefinitionError(f"{where}: only numeric constants are allowed in {source!r}")
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.keywords:
                raise DefinitionError(f"{where}: only plain calls like sin(x) are allowed in {source!r}")
    return ast.fix_missing_locations(_FloatNumbers().visit(tree))


def free_names(tree: ast.AST) -> set[str]:
    """Names an expression reads, functions and constants excluded."""
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call)}
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    return names - called - set(CONSTANTS)


#: checked and compiled expressions by (source, where, function names): a mechanism is bound to
#: new parameter values many times (every FMU initialisation, every design of a sweep), and
#: parsing and checking the same text again cost most of a binding
_COMPILED: dict[tuple, tuple[frozenset, object]] = {}
_DEFAULT_KEY = tuple(sorted(FUNCTIONS))


def _compile(source: str, where: str, functions: Mapping):
    key = (source, where, _DEFAULT_KEY if functions is FUNCTIONS else tuple(sorted(functions)))
    hit = _COMPILED.get(key)
    if hit is None:
        tree = parse(source, where)
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and node.func.id not in functions:
                raise DefinitionError(
                    f"{where}: unknown function {node.func.id!r} in {source!r} "
                    f"(known: {', '.join(sorted(functions))})"
                )
        names = frozenset(free_names(tree))
        code = compile(ast.fix_missing_locations(tree), f"<{where}>", "eval")
        # the copy for one crank angle (numpy scalars) differs only where the expression has a power
        powers = any(isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow) for node in ast.walk(tree))
        one_angle_code = (compile(ast.fix_missing_locations(_PowerCalls().visit(tree)), f"<{where}>", "eval")
                          if powers else code)
        hit = (names, code, one_angle_code)
        if len(_COMPILED) < 100_000:
            _COMPILED[key] = hit
    return hit


_POWER = "__power"


def _power(base, exponent):
    """``base ** exponent`` as numpy computes it on an array, for a numpy scalar too: the reference
    integrator evaluates at one crank angle on numpy scalars (contour, user_loads), and its numbers
    are then those of the same expression on an array of angles, to the bit. A numpy scalar's ``**``
    calls the C library's pow(); an array's runs the power ufunc's loop, which takes 2, 0.5 and -1
    by square, sqrt and reciprocal and, where the CPU has AVX-512, every other exponent by a
    vectorised pow: the two differ in the last bit for 5 % of numbers there. np.power on the scalar
    runs the array's loop. Only Expression.evaluate(env, one_angle=True) calls it: an array or a
    Python float takes ``**``."""
    if type(base) is np.float64:
        return np.power(base, exponent)
    return base ** exponent


class _PowerCalls(ast.NodeTransformer):
    """a ** b -> __power(a, b) (_power), on a compiled copy: the checked tree stays as written."""

    def visit_BinOp(self, node):
        node = self.generic_visit(node)
        if isinstance(node.op, ast.Pow):
            return ast.copy_location(ast.Call(ast.Name(_POWER, ast.Load()), [node.left, node.right], []), node)
        return node


_DEFAULT_GLOBALS = {"__builtins__": {}, **FUNCTIONS, **CONSTANTS, _POWER: _power}


class Expression:
    """A compiled expression; ``evaluate(env)`` binds its names from ``env``."""

    def __init__(self, source, where: str = "expression", functions: Mapping | None = None):
        self.source = source if isinstance(source, str) else repr(float(source))
        self.where = where
        self.functions = FUNCTIONS if functions is None else dict(functions)
        names, self._code, self._one_angle_code = _compile(self.source, where, self.functions)
        self.names = set(names)
        # functions and constants are the globals of the evaluation and the bound names its locals,
        # so an evaluation (a closed-form position is evaluated ~100 times a model build) copies
        # nothing but the names it reads
        self._globals = (_DEFAULT_GLOBALS if self.functions is FUNCTIONS
                         else {"__builtins__": {}, **self.functions, **CONSTANTS, _POWER: _power})

    def evaluate(self, env: Mapping[str, object], one_angle: bool = False):
        """The value with the names bound from ``env``. ``one_angle``: ``env`` binds the motion at
        one crank angle as numpy scalars, and the value is to the bit that of the same expression
        on an array of angles (a power by numpy's array rules, _power)."""
        try:
            scope = {name: env[name] for name in self.names}
        except KeyError:
            missing = {name for name in self.names if name not in env}     # (a lazy env computes on `in`)
            raise DefinitionError(
                f"{self.where}: {self.source!r} uses undefined name(s) {', '.join(sorted(missing))}"
            ) from None
        try:
            return eval(self._one_angle_code if one_angle else self._code,  # noqa: S307 - tree checked in parse()
                        self._globals, scope)
        except OverflowError:
            raise DefinitionError(f"{self.where}: {self.source!r} overflows: its value is beyond the largest "
                                  "floating-point number (1.8e308)") from None

    def __repr__(self) -> str:
        return f"Expression({self.source!r})"


#: the functions whose value has a kink or a jump where their argument crosses zero: max(a, b) and
#: min(a, b) where a - b does, abs(a) and sign(a) where a does
KINKS = ("max", "min", "abs", "sign")


class _KinkCalls(ast.NodeTransformer):
    """Numbers the kink calls of a tree in pre-order by their argument's text (the same argument
    twice is one kink; a kink raised to a power is none), and with ``bits`` replaces each by its branch on the side of zero that bit
    says (1: the argument positive): max(a, b) -> a or b, min(a, b) -> b or a, abs(a) -> a or -a,
    sign(a) -> 1 or -1."""

    def __init__(self, bits=None):
        self.arguments: list[str] = []
        self.calls: list[str] = []      # each argument's first call, as written (for messages)
        self.bits = bits

    def visit_BinOp(self, node):
        # a kink raised to a power (max(0, x)**3: an engine's valve law, a Hertz contact's 1.5) is
        # smooth to that order at its corner and held as it is; the kinks inside it still count
        if isinstance(node.op, ast.Pow) and self._is_kink(node.left):
            node.left.args = [self.visit(a) for a in node.left.args]
            node.right = self.visit(node.right)
            return node
        return self.generic_visit(node)

    @staticmethod
    def _is_kink(node) -> bool:
        return (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in KINKS
                and len(node.args) == (2 if node.func.id in ("max", "min") else 1))

    def visit_Call(self, node):
        name = node.func.id if isinstance(node.func, ast.Name) else None
        if not self._is_kink(node):
            return self.generic_visit(node)
        a = node.args[0]
        argument = ast.BinOp(a, ast.Sub(), node.args[1]) if len(node.args) == 2 else a
        text = ast.unparse(argument)
        if text not in self.arguments:
            self.arguments.append(text)
            # as written: the whole numbers the parse made floats back without ".0"
            self.calls.append(re.sub(r"(\d)\.0\b", r"\1", ast.unparse(node)) if self.bits is None else "")
        if self.bits is None:
            return self.generic_visit(node)
        positive = self.bits[self.arguments.index(text)]
        node = self.generic_visit(node)        # the branches' own kinks, on their bits
        if name == "max":
            return node.args[0] if positive else node.args[1]
        if name == "min":
            return node.args[1] if positive else node.args[0]
        if name == "abs":
            return node.args[0] if positive else ast.UnaryOp(ast.USub(), node.args[0])
        return ast.Constant(1.0 if positive else -1.0)


def kink_arguments(source: str, where: str = "expression") -> list[str]:
    """The arguments (as text) whose sign picks a branch of the expression's kink calls, in
    pre-order: an expression is smooth between the angles where one of them crosses zero."""
    return kink_calls(source, where)[0]


def kink_calls(source: str, where: str = "expression") -> tuple[list[str], list[str]]:
    """(the arguments of :func:`kink_arguments`, each one's call as written: "max(0, xB - x_w)")."""
    finder = _KinkCalls()
    finder.visit(parse(source, where))
    return finder.arguments, finder.calls


def kink_branch(source: str, bits, where: str = "expression") -> str:
    """The expression with each kink call replaced by its branch on the side ``bits`` says (one bit
    per argument of :func:`kink_arguments`, 1: positive): smooth wherever its arguments are."""
    tree = _KinkCalls(tuple(bits)).visit(parse(source, where))
    return ast.unparse(ast.fix_missing_locations(tree))


def evaluate(source, env: Mapping[str, object], where: str = "expression") -> float:
    """Evaluate a scalar expression (a number passes through)."""
    if isinstance(source, (int, float)) and not isinstance(source, bool):
        return float(source)
    return float(Expression(source, where).evaluate(env))
