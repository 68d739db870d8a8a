"""External loads reduced to the crank: their power divided by omega1 (seed 000 eq. 14, S1).

A load turns the kinematics at an array of crank angles into a torque on the crank (N.m).
Position-only loads (weights, the seed-000 technological moment) are marked so that models may
tabulate them; velocity-dependent ones receive omega1 too.

Each load also gives the forces and couples it applies link by link (``applied``): the
Newton-Euler solve of the joint reactions needs them where they act, not reduced to the crank.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DefinitionError
from ..mechanisms import Kinematics, Mechanism

WEIGHTS, TECHNOLOGICAL = "weights", "technological"
TWO_PI = 2.0 * np.pi


@dataclass
class AppliedLoad:
    """A force (fx, fy) in N at ``point`` and a couple ``moment`` in N.m, on ``link``."""

    link: str
    point: str | None
    fx: np.ndarray | float = 0.0
    fy: np.ndarray | float = 0.0
    moment: np.ndarray | float = 0.0


@dataclass
class Weights:
    """Gravity along -y on every link's mass centre: Q = -sum m_j g dy_Cj/dphi1."""

    masses: dict[str, float]       # link -> kg
    centres: dict[str, str]        # link -> point
    g: float                       # m/s^2
    position_only = True
    category = WEIGHTS

    def torque(self, kin: Kinematics, omega1=None):
        total = np.zeros_like(kin.phi1)
        if self.g == 0.0:
            return total
        for link, m in self.masses.items():
            total -= m * self.g * kin.point(self.centres[link]).dy
        return total

    def applied(self, kin: Kinematics, omega1=None) -> list[AppliedLoad]:
        return [AppliedLoad(link, self.centres[link], 0.0, -m * self.g) for link, m in self.masses.items()]


@dataclass
class ViscousForce:
    """A damper on a point along x or y, F = -c v (a piston's or slide's viscous friction).

    Reduced to the crank: Q = F dx/dphi1 = -c (dx/dphi1)^2 omega1. Smooth in omega1 and phi1, so
    it needs no switching; its power -c v^2 is never positive.
    """

    point: str
    axis: int                      # 0: x, 1: y
    coefficient: float             # c, N.s/m
    link: str = ""                 # the link the point belongs to (where the force acts)
    position_only = False
    linear_in_omega1 = True        # Q = c_lin(phi1) omega1: the fast path tabulates c_lin
    category = TECHNOLOGICAL

    def torque(self, kin: Kinematics, omega1=None):
        d = kin.point(self.point).ratio(self.axis)
        return -self.coefficient * d * d * np.asarray(omega1, dtype=float)

    def applied(self, kin: Kinematics, omega1=None) -> list[AppliedLoad]:
        force = -self.coefficient * kin.point(self.point).ratio(self.axis) * np.asarray(omega1, dtype=float)
        return [AppliedLoad(self.link, self.point, *((force, 0.0) if self.axis == 0 else (0.0, force)))]


@dataclass
class SliderForce:
    """A technological force on a slider along x or y that opposes its motion, with a magnitude
    that depends on the direction (seed 001: 1500 N while slider 3 moves in +x, 150 N while it
    moves in -x; seed 003: the cutting force on the working stroke only).

    ``band`` = (lo, hi) applies it only while the slider is inside that fraction of its stroke,
    measured from the end it starts the stroke at (seed 003: 0.05..0.95, idle over the first and
    last 5 %). The direction of motion is the sign of dx/dphi1 * omega1, so the force switches
    at the slider's extreme positions (where its power is zero) and at the band's ends.
    Reduced to the crank: Q = F dx/dphi1.
    """

    point: str
    link: str
    axis: int                      # 0: x, 1: y
    forward: float                 # N, magnitude while the slider moves in +axis
    backward: float                # N, magnitude while it moves in -axis
    band: tuple[float, float] = (0.0, 1.0)
    low: float = 0.0               # m, the slider's extreme positions (needed for the band)
    high: float = 0.0
    # rad, crank angles where the slider reverses; None: not searched yet (a model built on the C
    # model's searches has low and high from them, and switch_angles searches when a Python
    # integrator first needs the angles)
    extremes: tuple[float, ...] | None = None
    position_only = False
    category = TECHNOLOGICAL

    @classmethod
    def from_geometry(cls, mechanism: Mechanism, point: str, link: str, axis: int, forward: float,
                      backward: float, band=(0.0, 1.0)) -> "SliderForce":
        angles = cls.reversals(mechanism, point, axis)
        x = mechanism.kinematics(np.array(angles)).point(point).along(axis)
        return cls(point, link, axis, float(forward), float(backward), tuple(band),
                   float(np.min(x)), float(np.max(x)), angles)

    @staticmethod
    def reversals(mechanism: Mechanism, point: str, axis: int) -> tuple[float, ...]:
        """Crank angles (rad) where ``point`` reverses along ``axis``: the roots of dx/dphi1."""
        found = mechanism.stationary_angles(lambda kin: kin.point(point).ratio(axis))
        if not found:
            raise DefinitionError(f"point {point!r} does not move back and forth along "
                                  f"{'xy'[axis]}: a slider force needs a slider")
        return tuple(a for a, _ in found)

    @property
    def work_per_cycle(self) -> float:
        """Work of the force over one crank turn forward, J (negative: it resists)."""
        return -(self.forward + self.backward) * (self.high - self.low) * (self.band[1] - self.band[0])

    def switch_angles(self, mechanism: Mechanism) -> list[float]:
        """Crank angles (rad, in [0, 2 pi)) where the force jumps with the crank turning forward:
        the slider's extreme positions and, with a band, where it enters and leaves it."""
        if self.extremes is None:
            self.extremes = self.reversals(mechanism, self.point, self.axis)
        angles = list(self.extremes)
        if self.band != (0.0, 1.0):
            stroke = self.high - self.low
            levels = {self.low + f * stroke for f in self.band} | {self.high - f * stroke for f in self.band}
            angles += [a for a, _, _ in mechanism.crossings(lambda kin: kin.point(self.point).along(self.axis),
                                                             sorted(levels))]
        unique: list[float] = []
        for a in sorted(a % (2.0 * np.pi) for a in angles):
            if not unique or a - unique[-1] > 1e-9:   # a band level is met once per direction
                unique.append(a)
        return unique

    def force(self, kin: Kinematics, omega1):
        pos = kin.point(self.point)
        omega1 = np.asarray(omega1, dtype=float)
        rate, curvature = pos[2 + self.axis], pos[4 + self.axis]
        # on the slider's extreme itself (its rate zero to round-off: within 1e-12 rad of it) the
        # stroke the motion enters decides, as it does for the integrators' modes (modes.interval_of):
        # that stroke's velocity has the sign of x'' whichever way the crank turns
        at_extreme = np.isfinite(curvature) & (np.abs(rate) <= 1e-12 * np.abs(curvature))
        velocity = np.where(at_extreme, curvature * np.abs(omega1), rate * omega1)
        force = np.where(velocity > 0.0, -self.forward, np.where(velocity < 0.0, self.backward, 0.0))
        if self.band != (0.0, 1.0):
            stroke = self.high - self.low
            # fraction of the stroke done, counted from the end the current stroke starts at
            done = np.where(velocity > 0.0, pos[self.axis] - self.low, self.high - pos[self.axis]) / stroke
            force = np.where((done >= self.band[0]) & (done <= self.band[1]), force, 0.0)
        return force

    def torque(self, kin: Kinematics, omega1=None):
        return self.force(kin, omega1) * kin.point(self.point).ratio(self.axis)

    def applied(self, kin: Kinematics, omega1=None) -> list[AppliedLoad]:
        force = self.force(kin, omega1)
        return [AppliedLoad(self.link, self.point, *((force, 0.0) if self.axis == 0 else (0.0, force)))]

    # the switched-load protocol (slider_schedule, the table, the movement equation): Q is the sum
    # over columns of value * column, the columns functions of phi1 alone, the values constant
    # between two switch angles for each direction of the crank
    @property
    def column_names(self) -> tuple[str, ...]:
        return (f"{self.point}.{'xy'[self.axis]}",)

    def columns(self, kin: Kinematics, needed=None) -> list:
        """dx/dphi1 (m/rad): the force's lever to the crank (``needed``: which columns a caller uses)."""
        return [kin.point(self.point).ratio(self.axis)]

    def values(self, kin: Kinematics, omega1) -> list:
        return [self.force(kin, omega1)]

    def column_applied(self, kin: Kinematics, column: int) -> list[AppliedLoad]:
        """The force of column ``column`` at value 1 (1 N along the axis), where it acts."""
        one = np.ones_like(kin.phi1)
        return [AppliedLoad(self.link, self.point, *((one, 0.0) if self.axis == 0 else (0.0, one)))]


def interval_mids(switch: np.ndarray) -> np.ndarray:
    """The middle of each interval between consecutive switch angles round the turn (rad); the
    middle of the turn where there is no switch (one interval, the whole turn)."""
    if not len(switch):
        return np.array([0.5 * TWO_PI])
    return 0.5 * (switch + np.append(switch[1:], switch[0] + TWO_PI))


def slider_schedule(mechanism: Mechanism, sliders: list[SliderForce], extra_angles=()):
    """Where slider forces switch and their constant values in between, for integrators that hold
    the switch interval and the direction of motion as discrete state instead of reading them from
    (phi1, omega1) at every evaluation (which would put a jump inside an error-controlled step).

    Returns (switch_angles, forces): switch_angles (m,) rad, sorted in [0, 2 pi), every angle where
    any of ``sliders`` changes with the crank turning forward; forces (max(m, 1), 2, len(sliders))
    N, the signed force of slider s on interval k (from switch_angles[k] to the next one round the
    turn) while omega1 > 0 (index 0) and omega1 < 0 (index 1). Reduced to the crank, slider s
    gives forces[k, d, s] * dx_s/dphi1.
    Slider s here is column s of the switched loads (a SliderForce has one, a SwitchedLoad two).
    ``extra_angles``: more switch angles (rad), where something else switches (a joint's friction).
    """
    # a band level is met once per direction, so angles closer than 1e-13 rad are one switch
    angles = sorted({round(a % TWO_PI, 13) for load in sliders for a in load.switch_angles(mechanism)}
                    | {round(a % TWO_PI, 13) for a in extra_angles})
    switch = np.array(angles, dtype=float)
    n_columns = sum(len(load.column_names) for load in sliders)
    forces = np.zeros((max(len(switch), 1), 2, n_columns))
    if n_columns:
        # no switch: one interval, the whole turn, its values those anywhere on it (a kink whose
        # argument keeps its sign; crank_assembly.c's searches do the same)
        kin = mechanism.kinematics(interval_mids(switch) % TWO_PI)
        s = 0
        for load in sliders:
            forward, backward = load.values(kin, 1.0), load.values(kin, -1.0)
            for j in range(len(forward)):
                forces[:, 0, s] = forward[j]
                forces[:, 1, s] = backward[j]
                s += 1
    return switch, forces


@dataclass
class DeadPointMoment:
    """Technological moment of seed 000 eq. 18 acting on a rocker, counter-clockwise positive.

    M_ru = Mr sin((phi1 - phi1d)/2) sin((phi1 - phi1a)/2); phi1d and phi1a are the crank angles of
    the rocker's two extreme positions, found from the geometry as the roots of dphi_rocker/dphi1
    (for the four-bar: OA and AB collinear). phi1d is the extreme after which the rocker turns
    counter-clockwise, so the moment is negative while omega_rocker > 0 and positive while
    omega_rocker < 0: it always opposes the rocker (docs/papers.md). Reduced to the crank:
    Q = M_ru * dphi_rocker/dphi1.
    """

    link: str
    amplitude: float               # Mr, N.m
    phi1d: float                   # rad
    phi1a: float                   # rad
    position_only = True
    category = TECHNOLOGICAL

    @classmethod
    def from_geometry(cls, mechanism: Mechanism, link: str, amplitude: float) -> "DeadPointMoment":
        phi1d, phi1a = rocker_extremes(mechanism, link)
        return cls(link, amplitude, phi1d, phi1a)

    def moment(self, phi1):
        """M_ru on the rocker, N.m."""
        return self.amplitude * np.sin(0.5 * (phi1 - self.phi1d)) * np.sin(0.5 * (phi1 - self.phi1a))

    def torque(self, kin: Kinematics, omega1=None):
        return self.moment(kin.phi1) * kin.link_angle(self.link)[1]

    def applied(self, kin: Kinematics, omega1=None) -> list[AppliedLoad]:
        return [AppliedLoad(self.link, None, moment=self.moment(kin.phi1))]


def rocker_extremes(mechanism: Mechanism, link: str, n_grid: int = 720):
    """Crank angles (rad, in [0, 2 pi)) of a rocker's extreme positions: (start of its
    counter-clockwise swing, start of its clockwise swing), where dphi_link/dphi1 = 0."""
    found = mechanism.stationary_angles(lambda kin: kin.link_angle(link)[1], n_grid)
    rises = [a for a, rising in found if rising]
    falls = [a for a, rising in found if not rising]
    if len(rises) != 1 or len(falls) != 1:
        raise DefinitionError(
            f"link {link!r} is not a rocker with two extreme positions per crank turn "
            f"(found {len(found)} extremes); the dead-point moment of eq. 18 needs one"
        )
    return rises[0], falls[0]
