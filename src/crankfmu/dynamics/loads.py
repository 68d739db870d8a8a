"""External loads reduced to the crank: their power divided by omega1 (seed 000 eq. 14, S1).

A load turns the kinematics at an array of crank angles into a torque on the crank (N.m).
Position-only loads (weights, the seed-000 technological moment) are marked so that models may
tabulate them; velocity-dependent ones receive omega1 too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DefinitionError
from ..mechanisms import Kinematics, Mechanism


@dataclass
class Weights:
    """Gravity along -y on every link's mass centre: Q = -sum m_j g dy_Cj/dphi1."""

    masses: dict[str, float]       # link -> kg
    centres: dict[str, str]        # link -> point
    g: float                       # m/s^2
    position_only = True

    def torque(self, kin: Kinematics, omega1=None):
        total = np.zeros_like(kin.phi1)
        if self.g == 0.0:
            return total
        for link, m in self.masses.items():
            total -= m * self.g * kin.point(self.centres[link])[3]
        return total


@dataclass
class ViscousForce:
    """A damper on a point along x or y, F = -c v (a piston's or slide's viscous friction).

    Reduced to the crank: Q = F dx/dphi1 = -c (dx/dphi1)^2 omega1. Smooth in omega1 and phi1, so
    it needs no switching; its power -c v^2 is never positive.
    """

    point: str
    axis: int                      # 0: x, 1: y
    coefficient: float             # c, N.s/m
    position_only = False

    def torque(self, kin: Kinematics, omega1=None):
        d = kin.point(self.point)[2 + self.axis]
        return -self.coefficient * d * d * np.asarray(omega1, dtype=float)


@dataclass
class DeadPointMoment:
    """Technological moment of seed 000 eq. 18 acting on a rocker, counter-clockwise positive.

    M_ru = Mr sin((phi1 - phi1d)/2) sin((phi1 - phi1a)/2); phi1d and phi1a are the crank angles of
    the rocker's two extreme positions, found from the geometry as the roots of dphi_rocker/dphi1
    (for the four-bar: OA and AB collinear). phi1d is the extreme after which the rocker turns
    counter-clockwise, so the moment is negative while omega_rocker > 0 and positive while
    omega_rocker < 0: it always opposes the rocker (CASES.md). Reduced to the crank:
    Q = M_ru * dphi_rocker/dphi1.
    """

    link: str
    amplitude: float               # Mr, N.m
    phi1d: float                   # rad
    phi1a: float                   # rad
    position_only = True

    @classmethod
    def from_geometry(cls, mechanism: Mechanism, link: str, amplitude: float) -> "DeadPointMoment":
        phi1d, phi1a = rocker_extremes(mechanism, link)
        return cls(link, amplitude, phi1d, phi1a)

    def moment(self, phi1):
        """M_ru on the rocker, N.m."""
        return self.amplitude * np.sin(0.5 * (phi1 - self.phi1d)) * np.sin(0.5 * (phi1 - self.phi1a))

    def torque(self, kin: Kinematics, omega1=None):
        return self.moment(kin.phi1) * kin.link_angle(self.link)[1]


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
