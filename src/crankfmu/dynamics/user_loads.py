"""Loads a user writes in the scenario file, without Python (``[[loads]]`` kinds ``force``,
``couple``, ``spring_damper``).

Each is an expression of the parameters and of the position: the crank angle ``phi1``, every
unknown of the contours (link angles, slider coordinates) and every point's coordinates
``P_x``, ``P_y``. A ``force`` or ``couple`` may also read the speeds (a brake, a generator, a
damper on a point): ``omega1`` (rad/s), each point's velocity ``P_vx``, ``P_vy`` (m/s) and each
unknown's rate ``U_dot`` (rad/s or m/s: ``phi2_dot``, ``xB_dot``), all omega1 times a transfer
function of phi1. A torque affine in the speeds, Q0(phi1) + omega1 Q1(phi1), the fast path,
the kernel and both FMUs hold exactly at every step (Q0 with the position's loads, Q1 as the
viscous coefficient; nothing is tabulated in omega1); one of degree 2 (a fan) by its parts per
power of omega1 (speed_loads.py); any other law of omega1 as a function of the position times the law
(speed_laws.py). Each states its power, so the energy balance and the
Newton-Euler reactions hold for it:

- ``force`` at a point of a link, components ``fx``, ``fy`` (N): power F . v_P, reduced to the
  crank Q = fx dx_P/dphi1 + fy dy_P/dphi1;
- ``couple`` on a link, ``moment`` (N.m, counter-clockwise): power M w_link, Q = M q_link (on the
  crank, q = 1: a constant or angle-dependent couple on the crank);
- ``spring_damper`` between two points of two links: tension T = k (d - d0) + c dd/dt along the
  line between them (d their distance), power -T dd/dt, Q = -k (d - d0) dd/dphi1 - c (dd/dphi1)^2 omega1.

A ``force`` or ``couple`` may depend on the direction of a chosen velocity (``direction_of``: a
point's coordinate ``"H.y"`` or an unknown such as ``"theta"``): ``increasing`` gives the values
while that coordinate grows, ``decreasing`` while it falls (a pumping unit's polished-rod load:
rods and fluid on the upstroke, buoyant rods on the downstroke, downward on both). Such a load
depends on omega1 only through the sign of the chosen velocity: the integrators hold the
direction as discrete state between the coordinate's extremes (switch angles located as events,
like the slider forces), and the fast path tabulates its two position-dependent torques. The
damper is linear in omega1 and goes with the viscous forces; nothing that depends on omega1 is
tabulated as if it did not.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import DefinitionError
from ..expressions import Expression, kink_arguments, kink_branch, kink_calls
from ..mechanisms import Kinematics, Mechanism
from .loads import TECHNOLOGICAL, AppliedLoad


class _LoadNames(dict):
    """The names a load expression may read (position_env), each point coordinate and speed
    computed when an expression first reads it: an engine's gas force reads a few of a mechanism's
    dozens of points, at every step of a crank-angle scheme.

    At one crank angle (the reference integrator's right-hand side) every motion name is bound as
    a numpy scalar, not a one-element array: the same IEEE operations and the same ufunc loops, so
    the same numbers to the bit (tests/test_user_loads.py holds it), at a third of the cost of an
    engine's gas law (each operation on an array allocates one)."""

    def __init__(self, mechanism: Mechanism, kin: Kinematics, omega1):
        super().__init__(mechanism.parameters)
        self.update(mechanism.constants)
        self._one = one = kin.phi1.shape == (1,)
        self["phi1"] = kin.phi1[0] if one else kin.phi1
        self.update({u: v[0] for u, v in kin.q.items()} if one else kin.q)
        self._mechanism = mechanism
        self._kin = kin
        if omega1 is not None:
            omega1 = np.broadcast_to(np.asarray(omega1, dtype=float), np.shape(kin.phi1))
            if one:
                omega1 = omega1[0]
            self["omega1"] = omega1
        self._omega1 = omega1

    def __missing__(self, name: str):
        owner, _, what = name.rpartition("_")
        kin, omega1, names = self._kin, self._omega1, self._mechanism.motion_names
        if what in ("x", "y") and owner in names.points:
            value = kin.point(owner)["xy".index(what)]
        elif omega1 is not None and what in ("vx", "vy") and owner in names.points:
            value = kin.point(owner)[2 + "xy".index(what[1])]
        elif omega1 is not None and what == "dot" and owner in names.unknowns:
            value = kin.dq[owner]
        else:
            raise KeyError(name)
        if self._one:
            value = value[0]
        if what != "x" and what != "y":
            value = value * omega1
        self[name] = value
        return value

    def __contains__(self, name) -> bool:
        try:
            self[name]
        except KeyError:
            return False
        return True


def position_env(mechanism: Mechanism, kin: Kinematics, omega1=None) -> dict:
    """Names a load expression may use: parameters, constants, phi1, unknowns, P_x and P_y; with
    ``omega1`` also the speeds (speed_names): P_vx, P_vy and U_dot. The points' coordinates and the
    speeds are computed on first read, as the expressions read them."""
    return _LoadNames(mechanism, kin, omega1)


def speed_names(mechanism: Mechanism) -> set[str]:
    """The speeds a force or couple may read: omega1, P_vx, P_vy of each point, U_dot of each unknown."""
    return ({"omega1"} | {f"{p}_v{a}" for p in mechanism.point_names for a in "xy"}
            | {f"{u}_dot" for u in mechanism.unknown_names})


def fixed_names(mechanism: Mechanism) -> set[str]:
    """The names a load reads that do not change with the motion: the parameters and constants."""
    return {*mechanism.parameters, *mechanism.definition.constants}


def known_names(mechanism: Mechanism) -> set[str]:
    return (fixed_names(mechanism) | {"phi1", *mechanism.unknown_names}
            | {f"{p}_{a}" for p in mechanism.point_names for a in "xy"})


@dataclass
class ExpressionLoad:
    """A force at a point (fx, fy) and/or a couple (moment) on ``link``, from expressions; with
    ``direction_of`` the expressions of ``increasing`` or ``decreasing`` apply by the sign of the
    chosen coordinate's velocity."""

    link: str
    point: str | None
    increasing: dict                  # {"fx", "fy", "moment"} -> Expression
    decreasing: dict | None = None    # None: no direction dependence
    direction_of: str | None = None   # "P.x", "P.y" or an unknown
    mechanism: Mechanism = field(default=None, repr=False)
    category = TECHNOLOGICAL

    @property
    def position_only(self) -> bool:
        return self.decreasing is None

    # ---------------------------------------------------------------- evaluation
    def _env(self, kin, omega1):
        # one environment per kinematics and speed, shared by the loads evaluated at them (an engine's
        # four gas forces read the same names at every step)
        key = (id(self.mechanism), None if omega1 is None else np.asarray(omega1, dtype=float).tobytes())
        cache = kin.__dict__.setdefault("_load_envs", {})
        env = cache.get(key)
        if env is None:
            env = cache[key] = position_env(self.mechanism, kin, omega1)
        return env

    def _components(self, kin, which: dict, omega1=None):
        env = self._env(kin, omega1)
        zero = np.zeros_like(kin.phi1)
        return tuple(np.broadcast_to(np.asarray(which[k].evaluate(env), dtype=float), kin.phi1.shape) if k in which
                     else zero for k in ("fx", "fy", "moment"))

    def _torque_of(self, kin, which: dict, omega1=None):
        # at one crank angle (the reference integrator's right-hand side) the same operations in the
        # same order on Python floats: the same numbers to the bit, without an array for each
        one = kin.phi1.shape == (1,)
        if one:
            env = self._env(kin, omega1)
            fx, fy, m = (float(which[k].evaluate(env, one_angle=True)) if k in which else 0.0
                         for k in ("fx", "fy", "moment"))
        else:
            fx, fy, m = self._components(kin, which, omega1)
        rate = kin.link_angle(self.link)[1]
        out = m * (float(rate[0]) if one else rate)
        if self.point is not None:
            _, _, dx, dy, _, _ = kin.point(self.point)
            if one:
                dx, dy = float(dx[0]), float(dy[0])
            out = out + fx * dx + fy * dy
        return np.array([out]) if one else out

    def _rate(self, kin):
        """d(chosen coordinate)/dphi1."""
        of = self.direction_of
        if "." in of:
            point, axis = of.split(".")
            return kin.point(point).ratio("xy".index(axis))
        return kin.dq[of]

    def _selectors(self, kin, omega1):
        rising = self._rate(kin) * np.asarray(omega1, dtype=float)
        return np.where(rising > 0.0, 1.0, 0.0), np.where(rising < 0.0, 1.0, 0.0)

    def torque(self, kin: Kinematics, omega1=None):
        if self.decreasing is None:
            return self._torque_of(kin, self.increasing)
        up, down = self._selectors(kin, omega1)
        return up * self._torque_of(kin, self.increasing) + down * self._torque_of(kin, self.decreasing)

    def applied(self, kin: Kinematics, omega1=None) -> list[AppliedLoad]:
        fx, fy, m = self._components(kin, self.increasing)
        if self.decreasing is not None:
            up, down = self._selectors(kin, omega1)
            gx, gy, gm = self._components(kin, self.decreasing)
            fx, fy, m = up * fx + down * gx, up * fy + down * gy, up * m + down * gm
        return [AppliedLoad(self.link, self.point, fx, fy, m)]

    # ---------------------------------------------------------------- the switched-load protocol
    @property
    def column_names(self) -> tuple[str, ...]:
        return (f"{self.link} {self.direction_of} rising", f"{self.link} {self.direction_of} falling")

    def columns(self, kin: Kinematics, needed=(True, True)) -> list:
        """The torque on the crank (N.m) of each direction's expressions: functions of phi1; a column
        not ``needed`` is left at zero, unevaluated."""
        return [self._torque_of(kin, which) if use else np.zeros_like(kin.phi1)
                for which, use in zip((self.increasing, self.decreasing), needed)]

    def values(self, kin: Kinematics, omega1) -> list:
        """Which column acts (1) and which does not (0), by the chosen velocity's sign."""
        return list(self._selectors(kin, omega1))

    def column_applied(self, kin: Kinematics, column: int) -> list[AppliedLoad]:
        """Column ``column``'s expressions (0: rising, 1: falling) at value 1, where they act."""
        return [AppliedLoad(self.link, self.point, *self._components(kin, (self.increasing, self.decreasing)[column]))]

    def switch_angles(self, mechanism: Mechanism) -> list[float]:
        """The chosen coordinate's extremes: where its velocity changes sign."""
        found = mechanism.stationary_angles(self._rate)
        if not found:
            raise DefinitionError(f"load on {self.link}: {self.direction_of} never changes direction over the "
                                  "turn: give one expression without direction_of")
        return [a for a, _ in found]


#: a load's kinks at most: its columns are one per pattern of their sides, 2**MAX_KINKS
MAX_KINKS = 3


@dataclass
class KinkedLoad(ExpressionLoad):
    """A force or couple of the position whose expressions have kinks (max, min, abs, sign: a
    contact max(0, y_ground - P_y), a stop, a clearance): smooth between the crank angles where a
    kink's argument crosses zero, the switch angles, which the integrators locate as they do a
    slider force's. The load is a switched load: one column per pattern of the arguments' signs,
    each the torque of the expressions with every kink on that pattern's branch (smooth over the
    whole turn, so a table of it has no kink to follow), and on each interval between switch
    angles the pattern that holds there is 1, the others 0. Exact where evaluated (``torque``)."""

    arguments: tuple = ()             # the kinks' arguments, Expressions of the position
    branches: tuple = ()              # per pattern (bit i: argument i > 0), the expressions of that branch
    calls: tuple = ()                 # each kink as written, for messages: "max(0, xB - x_w)"

    @property
    def position_only(self) -> bool:
        return False

    def torque(self, kin: Kinematics, omega1=None):
        return self._torque_of(kin, self.increasing)

    def applied(self, kin: Kinematics, omega1=None) -> list[AppliedLoad]:
        return [AppliedLoad(self.link, self.point, *self._components(kin, self.increasing))]

    @property
    def column_names(self) -> tuple[str, ...]:
        return tuple(f"{self.link} kink pattern {pattern:0{len(self.arguments)}b}"
                     for pattern in range(len(self.branches)))

    def columns(self, kin: Kinematics, needed=None) -> list:
        needed = (True,) * len(self.branches) if needed is None else needed
        return [self._torque_of(kin, branch) if use else np.zeros_like(kin.phi1)
                for branch, use in zip(self.branches, needed)]

    def signs(self, kin: Kinematics) -> list:
        """Each argument > 0 at the kinematics' angles (booleans)."""
        env = position_env(self.mechanism, kin)
        one = kin.phi1.shape == (1,)
        return [np.broadcast_to(np.asarray(a.evaluate(env, one_angle=one), dtype=float) > 0.0, kin.phi1.shape)
                for a in self.arguments]

    def values(self, kin: Kinematics, omega1) -> list:
        """1 for the pattern of the arguments' signs at each angle, 0 for the others."""
        signs = self.signs(kin)
        pattern = sum(sign.astype(int) << i for i, sign in enumerate(signs))
        return [np.where(pattern == j, 1.0, 0.0) for j in range(len(self.branches))]

    def column_applied(self, kin: Kinematics, column: int) -> list[AppliedLoad]:
        return [AppliedLoad(self.link, self.point, *self._components(kin, self.branches[column]))]

    def switch_angles(self, mechanism: Mechanism) -> list[float]:
        """Where an argument crosses zero over the turn (none: that kink keeps one side)."""
        angles = []
        for a in self.arguments:
            angles += [angle for angle, _, _ in mechanism.crossings(
                lambda kin, a=a: np.broadcast_to(np.asarray(a.evaluate(position_env(mechanism, kin)), dtype=float),
                                                 kin.phi1.shape), [0.0])]
        return angles


def kinked(expressions: dict, where: str):
    """(arguments, branches, calls) of a load's expressions ({key: Expression}) with kinks, None
    without; more than MAX_KINKS distinct arguments are refused by name."""
    found = {}
    for e in expressions.values():
        for argument, call in zip(*kink_calls(e.source, e.where)):
            found.setdefault(argument, call)
    arguments = list(found)
    if not arguments:
        return None
    if len(arguments) > MAX_KINKS:
        raise DefinitionError(f"{where}: {len(arguments)} kinks ({', '.join(found.values())}); at most {MAX_KINKS} "
                              "per load: split it into several loads")
    branches = []
    for pattern in range(2 ** len(arguments)):
        bits = [(pattern >> i) & 1 for i in range(len(arguments))]
        branch = {}
        for key, e in expressions.items():
            own = kink_arguments(e.source, e.where)
            branch[key] = Expression(kink_branch(e.source, [bits[arguments.index(a)] for a in own], e.where),
                                     f"{e.where} (its branch {pattern:0{len(arguments)}b})")
        branches.append(branch)
    return (tuple(Expression(a, f"{where}: the argument of {found[a]}") for a in arguments), tuple(branches),
            tuple(found.values()))


@dataclass
class SpeedLoad(ExpressionLoad):
    """A force or couple whose expressions read the speeds (omega1, P_vx, P_vy, U_dot): evaluated
    exactly at (phi1, omega1) by the engine; affine in omega1 (Scenario.build checks it), so the
    tables hold it exactly as Q0(phi1) + omega1 Q1(phi1) (``parts``)."""

    linear_in_omega1 = True

    @property
    def position_only(self) -> bool:
        return False

    def torque(self, kin: Kinematics, omega1=None):
        return self._torque_of(kin, self.increasing, 0.0 if omega1 is None else omega1)

    def parts(self, kin: Kinematics):
        """(Q0, Q1) N.m and N.m.s/rad: the torque at omega1 = 0 and its change per unit omega1."""
        at_rest = self.torque(kin, 0.0)
        return at_rest, self.torque(kin, 1.0) - at_rest

    def applied(self, kin: Kinematics, omega1=None) -> list[AppliedLoad]:
        return [AppliedLoad(self.link, self.point,
                            *self._components(kin, self.increasing, 0.0 if omega1 is None else omega1))]

    def affine_gap(self, kin: Kinematics, speed: float) -> float:
        """How far the torque is from affine in omega1 over (-speed, 3 speed), relative to its size:
        0 to round-off for a brake -c*omega1 or a generator a + b*omega1, O(1) for omega1**2."""
        q0, q1, q_back, q3 = (self.torque(kin, w) for w in (0.0, speed, -speed, 3.0 * speed))
        scale = max(float(np.max(np.abs(np.concatenate([q0, q1, q_back, q3])))), 1e-300)
        return float(max(np.max(np.abs(q_back - (2.0 * q0 - q1))), np.max(np.abs(q3 - (3.0 * q1 - 2.0 * q0))))
                     / scale)


def spring_damper_tension(k, c, d, d0, rate):
    """The tension (N) of a linear spring-damper of length d (m) changing at ``rate`` (m/s):
    k (d - d0) + c dd/dt; positive pulls its ends together."""
    return k * (d - d0) + c * rate


@dataclass
class Spring:
    """The spring part of a spring-damper: tension k (d - d0) between points a (on link_a) and b."""

    a: str
    b: str
    link_a: str
    link_b: str
    k: float
    d0: float
    position_only = True
    category = TECHNOLOGICAL

    def geometry(self, kin):
        xa, ya, dxa, dya, _, _ = kin.point(self.a)
        xb, yb, dxb, dyb, _, _ = kin.point(self.b)
        ex, ey = xb - xa, yb - ya
        d = np.hypot(ex, ey)
        if np.any(d == 0.0):
            raise DefinitionError(f"spring_damper {self.a}-{self.b}: the points meet (d = 0): no line of action")
        ux, uy = ex / d, ey / d
        dd = ux * (dxb - dxa) + uy * (dyb - dya)         # dd/dphi1
        return d, ux, uy, dd

    def tension(self, kin, omega1=None):
        d, _, _, _ = self.geometry(kin)
        return spring_damper_tension(self.k, 0.0, d, self.d0, 0.0)

    def torque(self, kin: Kinematics, omega1=None):
        _, _, _, dd = self.geometry(kin)
        return -self.tension(kin, omega1) * dd

    def applied(self, kin: Kinematics, omega1=None) -> list[AppliedLoad]:
        _, ux, uy, _ = self.geometry(kin)
        t = self.tension(kin, omega1)
        # a tension pulls a towards b and b towards a
        return [AppliedLoad(self.link_a, self.a, t * ux, t * uy), AppliedLoad(self.link_b, self.b, -t * ux, -t * uy)]


@dataclass
class Damper(Spring):
    """The damper part: tension c dd/dt, linear in omega1 (tabulated as a viscous coefficient)."""

    position_only = False
    linear_in_omega1 = True

    def tension(self, kin, omega1=None):
        d, _, _, dd = self.geometry(kin)
        return spring_damper_tension(0.0, self.k, d, d, dd * np.asarray(omega1, dtype=float))   # k holds c here
