"""General laws of the crank speed in a user's load: a clutch or a friction drive's
``T0*tanh(omega1/w0)``, a pump's ``-T0*(1 - exp(-omega1/w0))``, a turbine's ``-c*omega1**3``.

A load of the speeds of degree <= 2 is held by its parts (speed_loads.py). Beyond that no fit in
omega1 is exact, so such a term is held as it is written: a function of the position times a law
g(omega1) of the crank speed and the parameters alone,

    Q = Q_polynomial(phi1, omega1) + sum_k a_k(phi1) g_k(omega1).

The tables carry each a_k as a switched column (its value 1, whatever the crank's direction,
also at rest), and the kernel multiplies it by g_k at the step's omega1: the column's power is
LAW, and the tables' law gives g_k (the C model evaluates it with its program's LAWS section at
each step; the Python paths with the expression itself, ColumnLaws). The reference integrator
evaluates the whole expression at (phi1, omega1).

The split is read from the expression's text (split_laws), the same for the Python engine and the
C model's compiler: each term of the top-level sum that is no polynomial of degree <= 2 in the
speeds must be a product whose factors either read no speed, or read omega1 and the parameters
only; a term such as ``tanh(P_vx/v0)`` (a point's speed inside the law, where it is omega1 times a
function of the angle) is refused by name.
"""

from __future__ import annotations

import ast
import math
import re
from dataclasses import dataclass, field

import numpy as np

from ..errors import DefinitionError
from ..expressions import Expression, free_names, parse
from .loads import AppliedLoad
from .speed_loads import speed_degree
from .user_loads import SpeedLoad

#: a switched column's power code for a general law: the kernel multiplies its value by g(omega1)
#: (crank_kernel.h's CK_LAW; 0, 1, 2 are omega1's powers)
LAW = 3


def _terms(node, sign=1.0):
    """The top-level sum's terms of an expression tree, with their signs."""
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
        return _terms(node.left, sign) + _terms(node.right, sign if isinstance(node.op, ast.Add) else -sign)
    if isinstance(node, ast.UnaryOp):
        return _terms(node.operand, -sign if isinstance(node.op, ast.USub) else sign)
    return [(sign, node)]


def _factors(node, sign=1.0):
    """(sign, [(factor, divides)]) of a product: its factors, each a multiplier or a divisor."""
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        s1, left = _factors(node.left)
        s2, right = _factors(node.right)
        return sign * s1 * s2, left + right
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
        s1, left = _factors(node.left)
        return sign * s1, left + [(node.right, True)]
    if isinstance(node, ast.UnaryOp):
        return _factors(node.operand, -sign if isinstance(node.op, ast.USub) else sign)
    return sign, [(node, False)]


def _operand(node) -> str:
    """A factor's text, in parentheses where it is a sum or a product of its own."""
    text = ast.unparse(node)
    return f"({text})" if isinstance(node, (ast.BinOp, ast.UnaryOp)) else text


def _product(factors) -> str:
    """The text of a product of (factor, divides) pairs ("1" when empty)."""
    if len(factors) == 1 and not factors[0][1]:
        return ast.unparse(factors[0][0])
    up = [_operand(f) for f, divides in factors if not divides]
    down = [_operand(f) for f, divides in factors if divides]
    return (" * ".join(up) or "1") + "".join(f" / {t}" for t in down)


def _text(source: str) -> str:
    """An expression's text with whole numbers as written (the parse made them floats)."""
    return re.sub(r"(\d)\.0\b", r"\1", source)


def split_laws(expressions: dict, speeds: set[str], fixed: set[str], where: str):
    """(the polynomial part {key: Expression} (its keys those with such terms), the laws [(g, {key:
    coefficient Expression})]) of a load's expressions ({key: Expression}). ``speeds``: the names
    of the speeds; ``fixed``: the names that do not change with the motion (the parameters and
    constants), which a law may read beside omega1."""
    polynomial: dict[str, list[str]] = {}
    laws: dict[str, dict[str, list[str]]] = {}
    for key, expr in expressions.items():
        for sign, term in _terms(parse(expr.source, expr.where).body):
            text = ast.unparse(term)
            degree, _ = speed_degree(text, speeds, expr.where)
            if degree is not None and degree <= 2:
                polynomial.setdefault(key, []).append(("-" if sign < 0 else "") + f"({text})")
                continue
            sign2, factors = _factors(term, sign)
            law, coefficient = [], []
            for factor, divides in factors:
                names = free_names(factor)
                if not names & speeds:
                    coefficient.append((factor, divides))
                elif names <= fixed | {"omega1"}:
                    law.append((factor, divides))
                else:
                    moving = sorted(names - fixed - {"omega1"})
                    raise DefinitionError(
                        f"{where} {key} = {_text(expr.source)!r}: its term {_text(text)!r} is no polynomial of degree "
                        f"<= 2 in the speeds, and its factor {_text(ast.unparse(factor))!r} reads "
                        f"{', '.join(moving)}: crankfmu holds a general law of the speed as a function of the position "
                        "times a law of omega1 and the parameters alone (T0*tanh(omega1/w0), "
                        "-c*P_y*(1 - exp(-omega1/w0))); a law that reads a point's or an unknown's speed, or the position, is "
                        "not supported")
            g = _product(law)
            a = ("-" if sign2 < 0 else "") + (f"({t})" if " " in (t := _product(coefficient)) else t)
            laws.setdefault(g, {}).setdefault(key, []).append(a)
    where_of = {key: e.where for key, e in expressions.items()}
    # a key without a law keeps its expression as written (the messages quote the file's text)
    with_laws = {key for coefficients in laws.values() for key in coefficients}
    poly = {key: expressions[key] if key not in with_laws else Expression(" + ".join(parts), where_of[key])
            for key, parts in polynomial.items()}
    out = [(Expression(g, f"{where} speed law"),
            {key: Expression(" + ".join(parts), where_of[key]) for key, parts in coefficients.items()})
           for g, coefficients in laws.items()]
    return poly, out


def law_column_name(link: str, law: str) -> str:
    """The name of a law's column in the tables (the Python engine's and the C model's)."""
    return f"{link} law {_text(law)}"


@dataclass
class SpeedLawLoad(SpeedLoad):
    """a(phi1) g(omega1): a force or couple (``increasing``: its coefficients' expressions, of the
    position) times a law of the crank speed ``law``: one switched column, its power LAW."""

    law: Expression = None
    has_speed_columns = True          # dynamics.reduced: a switched load; the reference evaluates it exactly
    linear_in_omega1 = False

    def law_value(self, omega1):
        env = {**self.mechanism.parameters, **self.mechanism.constants, "omega1": np.asarray(omega1, dtype=float)}
        return self.law.evaluate(env)

    def torque(self, kin, omega1=None):
        return self.law_value(0.0 if omega1 is None else omega1) * self._torque_of(kin, self.increasing)

    def applied(self, kin, omega1=None) -> list[AppliedLoad]:
        g = self.law_value(0.0 if omega1 is None else omega1)
        return [AppliedLoad(self.link, self.point, *(g * c for c in self._components(kin, self.increasing)))]

    def parts(self, kin):
        raise TypeError("a law of the speed has no affine parts")

    @property
    def column_names(self) -> tuple[str, ...]:
        return (law_column_name(self.link, self.law.source),)

    @property
    def column_powers(self) -> tuple[int, ...]:
        return (LAW,)

    @property
    def column_laws(self) -> tuple[str, ...]:
        return (self.law.source,)

    def columns(self, kin, needed=None) -> list:
        return [np.broadcast_to(np.asarray(self._torque_of(kin, self.increasing), dtype=float), kin.phi1.shape)]

    def values(self, kin, omega1) -> list:
        """1 whatever the crank's direction: the kernel multiplies the column by the law."""
        return [np.ones_like(kin.phi1)]

    def column_applied(self, kin, column: int) -> list[AppliedLoad]:
        return [AppliedLoad(self.link, self.point, *self._components(kin, self.increasing))]

    def switch_angles(self, mechanism) -> list[float]:
        return []


@dataclass
class ColumnLaws:
    """The laws of a table's switched columns as the Python paths evaluate them (the C model's
    program evaluates the same texts): ``sources[s]`` g's text for a column of power LAW (None for
    the others), ``env`` the parameters' and constants' values. Plain data: it pickles with the
    table (a Dask worker's), and compiles where it is first evaluated."""

    sources: tuple
    env: dict
    _compiled: dict = field(default_factory=dict, repr=False, compare=False)

    def __bool__(self) -> bool:
        return any(s is not None for s in self.sources)

    def __call__(self, column: int, omega1):
        expr = self._compiled.get(column)
        if expr is None:
            expr = self._compiled[column] = Expression(self.sources[column], "a law of the speed")
        return expr.evaluate({**self.env, "omega1": omega1})

    def __getstate__(self):
        return {"sources": self.sources, "env": self.env, "_compiled": {}}


def column_laws(sliders, mechanism) -> ColumnLaws | None:
    """The laws of the switched loads' columns (None where none has one)."""
    sources = tuple(s for load in sliders for s in getattr(load, "column_laws", (None,) * len(load.column_names)))
    if not any(s is not None for s in sources):
        return None
    env = {k: float(v) for k, v in {**mechanism.parameters, **mechanism.constants}.items()
           if np.ndim(v) == 0 and math.isfinite(float(v))}
    return ColumnLaws(sources, env)
