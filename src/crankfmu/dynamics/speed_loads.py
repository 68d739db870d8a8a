"""Loads of the speeds beyond affine: a fan, a propeller, aerodynamic drag, a pump
(``moment = "-c_fan*omega1*abs(omega1)"``, ``fx = "-c*B_vx**2"``).

Every speed is omega1 times a transfer function of phi1, so a user's load whose expressions are
polynomials of degree <= 2 in the speeds (with abs, sign, max, min of them allowed: they only make
the polynomial depend on the direction of the crank) has, on each side of omega1 = 0, the torque

    Q = a0(phi1) + a1(phi1) omega1 + a2(phi1) omega1^2,   a_k = sym_k + sign(omega1) anti_k.

sym0 and sym1 join the tables' rows as an affine load's parts (Q0 with the position's loads, Q1 as
the dampers' coefficient); sym2 is a switched column whose value (1) the kernel multiplies by
omega1^2, and where the expressions read a kink of the speeds, anti0, anti1 and anti2 are columns
whose value is the crank's direction (+1, -1), times omega1^0, omega1^1, omega1^2 (the tables'
column powers). Nothing is tabulated in omega1; the reference integrator evaluates the expressions
exactly at (phi1, omega1).

The parts come from the expressions at six speeds, +-w0, +-2 w0, +-3 w0 (w0 the scale of the
start speed): a quadratic through three points on each side, exact for such a load; Scenario.build
checks the fit at two more speeds on each side. A term that is no such polynomial
(``T0*(1 - exp(-omega1/w0))``) never reaches this module: it is a law of the speed, held as
written (speed_laws.py). The same rule is the C model's (program_loads._speed_polynomial).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass

import numpy as np

from ..errors import DefinitionError
from ..expressions import KINKS, parse
from .loads import AppliedLoad
from .user_loads import KinkedLoad, SpeedLoad, kinked

#: the columns of a load with kinks of the speeds: (name, power of omega1); without kinks, the first
SPEED_COLUMNS = (("omega1^2", 2), ("sign", 0), ("sign omega1", 1), ("sign omega1^2", 2))
#: the samples on each side: j w0, j = 1, 2, 3 (the fit); 0.5 and 5 (its check)
FIT, CHECK = (1.0, 2.0, 3.0), (0.5, 5.0)


def speed_degree(source: str, speeds: set[str], where: str = "expression") -> tuple[int | None, bool]:
    """(the degree of an expression in the speeds, None where it is no polynomial of them; whether
    a kink reads a speed: abs(omega1), sign(P_vx)), from its text alone, so the Python engine and the
    C model's compiler class a load alike. abs, max and min keep the degree, sign has none."""
    kinked = False

    def degree(node) -> int | None:
        nonlocal kinked
        if isinstance(node, ast.Constant):
            return 0
        if isinstance(node, ast.Name):
            return int(node.id in speeds)
        if isinstance(node, ast.UnaryOp):
            return degree(node.operand)
        if isinstance(node, ast.BinOp):
            left, right = degree(node.left), degree(node.right)
            if left is None or right is None:
                return None
            if isinstance(node.op, (ast.Add, ast.Sub)):
                return max(left, right)
            if isinstance(node.op, ast.Mult):
                return left + right
            if isinstance(node.op, ast.Div):
                return left if right == 0 else None
            if right == 0 and left == 0:
                return 0
            exponent = node.right.value if isinstance(node.right, ast.Constant) else None
            if right == 0 and exponent is not None and float(exponent).is_integer() and exponent >= 0:
                return int(exponent) * left
            return None
        if isinstance(node, ast.Call):
            args = [degree(a) for a in node.args]
            if any(a is None for a in args):
                return None
            if node.func.id in KINKS:
                if max(args) > 0:
                    kinked = True
                return 0 if node.func.id == "sign" else max(args)
            return 0 if max(args, default=0) == 0 else None
        return None
    return degree(parse(source, where).body), kinked


def quadratic_parts(at, scale: float):
    """(sym, anti), each [part 0, part 1, part 2] (arrays or registers' values), of a function
    ``at(omega1)`` that is a0 + a1 omega1 + a2 omega1^2 on each side of 0: the quadratic through
    j scale, j = 1, 2, 3, on each side."""
    a = {}
    for side in (1.0, -1.0):
        f1, f2, f3 = (at(side * scale * j) for j in FIT)
        b2 = 0.5 * (f3 - 2.0 * f2 + f1)          # in u = omega1 / (side scale): b0 + b1 u + b2 u^2
        b1 = f2 - f1 - 3.0 * b2
        b0 = f1 - b1 - b2
        a[side] = (b0, b1 / (side * scale), b2 / (scale * scale))
    sym = [0.5 * (p + m) for p, m in zip(a[1.0], a[-1.0])]
    anti = [0.5 * (p - m) for p, m in zip(a[1.0], a[-1.0])]
    return sym, anti


@dataclass
class PolynomialSpeedLoad(SpeedLoad):
    """A force or couple of degree <= 2 in the speeds on each side of omega1 = 0 (the module's
    rule): its affine parts as a SpeedLoad's, the rest as switched columns times omega1's powers."""

    signed: bool = False              # its expressions read a kink of the speeds: the anti columns
    scale: float = 10.0               # rad/s: w0, the speeds the parts are fitted at
    has_speed_columns = True          # dynamics.reduced: a switched load, though linear_in_omega1's parts

    def _parts_of(self, at):
        return quadratic_parts(at, self.scale)

    def parts(self, kin):
        sym, _ = self._parts_of(lambda w: self.torque(kin, w))
        return sym[0], sym[1]

    @property
    def column_names(self) -> tuple[str, ...]:
        n = 4 if self.signed else 1
        return tuple(f"{self.link} {name}" for name, _ in SPEED_COLUMNS[:n])

    @property
    def column_powers(self) -> tuple[int, ...]:
        return tuple(power for _, power in SPEED_COLUMNS[:4 if self.signed else 1])

    def columns(self, kin, needed=None) -> list:
        sym, anti = self._parts_of(lambda w: self.torque(kin, w))
        out = [sym[2]] + (anti if self.signed else [])
        return [np.broadcast_to(np.asarray(c, dtype=float), kin.phi1.shape) for c in out]

    def values(self, kin, omega1) -> list:
        """1 for the omega1^2 column; the crank's direction for the others."""
        one = np.ones_like(kin.phi1)
        side = np.sign(np.asarray(omega1, dtype=float)) * one
        return [one] + ([side] * 3 if self.signed else [])

    def _applied_parts(self, kin):
        """(sym, anti) of each of fx, fy, moment."""
        parts = [self._parts_of(lambda w, k=k: self._components(kin, self.increasing, w)[k]) for k in range(3)]
        return parts

    def applied_parts(self, kin):
        """([the load at rest: sym0], [per omega1: sym1]) as AppliedLoads (the reactions' rows)."""
        parts = self._applied_parts(kin)
        return ([AppliedLoad(self.link, self.point, *(p[0][0] for p in parts))],
                [AppliedLoad(self.link, self.point, *(p[0][1] for p in parts))])

    def column_applied(self, kin, column: int) -> list[AppliedLoad]:
        parts = self._applied_parts(kin)
        pick = (lambda p: p[0][2]) if column == 0 else (lambda p: p[1][column - 1])   # noqa: E731
        return [AppliedLoad(self.link, self.point, *(pick(p) for p in parts))]

    def switch_angles(self, mechanism) -> list[float]:
        return []                     # it switches with the crank's direction only

    def polynomial_gap(self, kin) -> float:
        """How far the torque is from its fitted parts at 0.5 w0 and 5 w0 on each side, relative to
        its size there: round-off for a fan, O(1) for 1 - exp(-omega1/w0)."""
        sym, anti = self._parts_of(lambda w: self.torque(kin, w))
        gap, size = 0.0, 1e-300
        for side in (1.0, -1.0):
            for j in CHECK:
                w = side * j * self.scale
                exact = self.torque(kin, w)
                fitted = sum((s + side * a) * w ** k for k, (s, a) in enumerate(zip(sym, anti)))
                gap = max(gap, float(np.max(np.abs(exact - fitted))))
                size = max(size, float(np.max(np.abs(exact))))
        return gap / size


@dataclass
class KinkedSpeedLoad(KinkedLoad):
    """A load of the speeds with kinks of the position: a contact with damping (Hunt and Crossley's
    ``-max(0, x - x_w)*(k + lam*B_vx)``), a stop that damps. Each pattern of the kinks' sides has
    its branch, a polynomial of degree ``degree`` <= 2 in the speeds (no kink of a speed): its parts
    per power of omega1 are columns (pattern-major, powers 0 .. degree), each with the pattern's
    indicator as value and its power of omega1, so the kernel steps onto the switch angles as for a
    KinkedLoad and multiplies each part by omega1's power. Exact where evaluated (``torque``)."""

    degree: int = 1
    scale: float = 10.0               # rad/s: the speeds the parts are fitted at (speed_scale)
    has_speed_columns = True          # the reference evaluates it exactly, on the kinks' intervals

    def torque(self, kin, omega1=None):
        return self._torque_of(kin, self.increasing, 0.0 if omega1 is None else omega1)

    def applied(self, kin, omega1=None):
        return [AppliedLoad(self.link, self.point,
                            *self._components(kin, self.increasing, 0.0 if omega1 is None else omega1))]

    @property
    def column_names(self) -> tuple[str, ...]:
        n = len(self.arguments)
        return tuple(f"{self.link} kink pattern {pattern:0{n}b} omega1^{k}"
                     for pattern in range(len(self.branches)) for k in range(self.degree + 1))

    @property
    def column_powers(self) -> tuple[int, ...]:
        return tuple(range(self.degree + 1)) * len(self.branches)

    def _parts(self, at):
        return quadratic_parts(at, self.scale)[0][:self.degree + 1]

    def columns(self, kin, needed=None) -> list:
        out = []
        for branch in self.branches:
            parts = self._parts(lambda w, b=branch: self._torque_of(kin, b, w))
            out += [np.broadcast_to(np.asarray(part, dtype=float), kin.phi1.shape) for part in parts]
        return out

    def values(self, kin, omega1) -> list:
        """The pattern's indicator (KinkedLoad.values) for each of its powers."""
        return [v for v in super().values(kin, omega1) for _ in range(self.degree + 1)]

    def column_applied(self, kin, column: int) -> list[AppliedLoad]:
        pattern, power = divmod(column, self.degree + 1)
        branch = self.branches[pattern]
        components = [self._parts(lambda w, k=k: self._components(kin, branch, w)[k])[power] for k in range(3)]
        return [AppliedLoad(self.link, self.point, *components)]


def kinked_speed_load(link, point, expressions, mechanism, speeds, values, where):
    """A KinkedSpeedLoad of a force or couple whose expressions read the speeds and have kinks of the
    position only; None without kinks. Kinks of both the position and a speed in one load are
    refused by name (write them as two loads)."""
    kinks = kinked(expressions, where)
    if kinks is None:
        return None
    arguments, branches, calls = kinks
    of_speed = [call for a, call in zip(arguments, calls) if a.names & speeds]
    if not of_speed:
        degrees = [speed_degree(e.source, speeds, e.where)[0] for b in branches for e in b.values()]
        return KinkedSpeedLoad(link, point, expressions, mechanism=mechanism, arguments=arguments, branches=branches,
                               calls=calls, degree=max(1, max(d for d in degrees if d is not None)),
                               scale=speed_scale(values))
    if len(of_speed) < len(calls):
        raise DefinitionError(
            f"{where}: kinks of the position ({', '.join(c for c in calls if c not in of_speed)}) and of the speeds "
            f"({', '.join(of_speed)}) in one load: crankfmu locates the first as angles and holds the second by the "
            "crank's direction; write them as two loads")
    return None


def speed_scale(values) -> float:
    """w0 (rad/s): the start speed's size, at least 10 rad/s (speed causality has no start speed)."""
    return max(abs(float(values.get("omega1_start", 10.0))), 10.0)


def speed_class(expressions: dict, speeds: set[str], where: str) -> bool | None:
    """How a load of the speeds is held: None affine (a SpeedLoad: Q0 + omega1 Q1), else whether its
    polynomial reads a kink of the speeds (a PolynomialSpeedLoad's anti columns). A load that is no
    polynomial of degree <= 2 in them is refused by name."""
    degrees = {k: speed_degree(e.source, speeds, e.where) for k, e in expressions.items()}
    for key, (degree, _) in degrees.items():
        if degree is None or degree > 2:
            raise DefinitionError(
                f"{where} {key} = {expressions[key].source!r} is "
                + ("no polynomial" if degree is None else f"of degree {degree}")
                + " in the speeds (omega1, P_vx, P_vy, U_dot): crankfmu holds a load of the speeds as a polynomial of "
                "degree <= 2 in them on each side of omega1 = 0 (a brake -c*omega1, a fan -c*omega1*abs(omega1), "
                "drag -c*P_vx*abs(P_vx)); its other terms are laws of the speed (dynamics/speed_laws.py)")
    degree = max(d for d, _ in degrees.values())
    signed = any(k for _, k in degrees.values())
    return None if degree <= 1 and not signed else signed


def speed_load(link, point, expressions, mechanism, speeds, values, where):
    """The load object of a force or couple whose expressions read the speeds."""
    signed = speed_class(expressions, speeds, where)
    with_kinks = kinked_speed_load(link, point, expressions, mechanism, speeds, values, where)
    if with_kinks is not None:
        return with_kinks
    if signed is None:
        return SpeedLoad(link, point, expressions, mechanism=mechanism)
    return PolynomialSpeedLoad(link, point, expressions, mechanism=mechanism, signed=signed,
                               scale=speed_scale(values))
