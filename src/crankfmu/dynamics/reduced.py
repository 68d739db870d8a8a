"""The reduced (one-coordinate) model of a mechanism driven by its crank (seed 000 eqs. 13-16).

For links j with mass m_j, central inertia I_j, mass-centre transfer functions t, p, tt, pp and
angle transfer functions q, qq (eq. 11):

    J(phi1)       = I_flywheel + sum m_j (t^2 + p^2) + I_j q^2          (= -S2, kg.m^2)
    0.5 J'(phi1)  = sum m_j (t tt + p pp) + I_j q qq                     (= -S3, kg.m^2/rad)
    Q(phi1, w1)   = sum F_jx t + F_jy p + M_j q                          (=  S1, N.m)

The crank's own inertia I_1 enters through its link; the flywheel adds a constant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..mechanisms import Kinematics, Mechanism
from .loads import interval_mids, slider_schedule


@dataclass
class LinkInertia:
    name: str
    centre: str       # point name
    mass: float       # kg
    inertia: float    # kg.m^2 about the mass centre


class ReducedModel:
    """J, 0.5*J' and the reduced load Q of a mechanism at any crank angle."""

    def __init__(self, mechanism: Mechanism, links: list[LinkInertia], J_flywheel: float, loads: list, ports=(),
                 cycle_turns: int = 1):
        self.mechanism = mechanism
        #: crank turns of the machine's cycle: the loads repeat over it (a four-stroke engine's 2);
        #: the kinematics, J and J' over one turn
        self.cycle_turns = int(cycle_turns)
        self.period = 2.0 * math.pi * self.cycle_turns          # rad
        self.links = links
        self.J_flywheel = float(J_flywheel)        # kg.m^2
        self.loads = loads
        #: each load's entry in the scenario's [[loads]] (one entry may make two: a spring-damper)
        self.load_entries = list(range(len(loads)))
        self.ports = tuple(ports)                  # dynamics.ports: their inputs come from outside
        self.velocity_dependent = any(not load.position_only for load in loads)
        # switched loads: constant or tabulated between switch angles, by direction (slider forces,
        # direction-dependent user loads)
        # (and a load of the speeds' parts in omega1^2 and by direction: speed_loads.PolynomialSpeedLoad)
        self.sliders = [load for load in loads if hasattr(load, "switch_angles") and not load.position_only
                        and (not getattr(load, "linear_in_omega1", False) or getattr(load, "has_speed_columns", False))]
        self._slider_schedule = None
        #: the joints' friction (dynamics.friction.JointFrictions), None without any
        self.friction = None
        self._friction_signs = None

    def slider_schedule(self):
        """(switch_angles rad, forces N) of the slider forces (see loads.slider_schedule), built once."""
        if self._slider_schedule is None:
            extra = self.friction.switch_angles() if self.friction is not None else ()
            self._slider_schedule = slider_schedule(self.mechanism, self.sliders, extra)
        return self._slider_schedule

    def friction_signs(self) -> np.ndarray:
        """s_i (intervals, n_f) of the joints' frictions on each interval of the slider schedule
        while the crank turns forward (dynamics.friction; backward: the opposite), built once."""
        if self._friction_signs is None:
            switch, _ = self.slider_schedule()
            kin = self.mechanism.kinematics(interval_mids(switch) % (2.0 * math.pi))
            self._friction_signs = self.friction.signs(kin, 1.0)
        return self._friction_signs

    def coefficients(self, phi1, kin: Kinematics | None = None):
        """(J, half_dJ, Q_position) at each crank angle, and the kinematics used.

        J in kg.m^2, half_dJ = 0.5 dJ/dphi1 in kg.m^2/rad, Q_position (the loads that depend on
        the position only) in N.m.
        """
        if kin is None:
            kin = self.mechanism.kinematics(phi1)
        # at one crank angle (the reference integrator's right-hand side) the sums run on Python
        # floats: the same IEEE operations in the same order as numpy's on one-element arrays, the
        # same numbers to the bit, at a tenth of the cost per operation
        one = kin.phi1.size == 1
        J = self.J_flywheel if one else np.full_like(kin.phi1, self.J_flywheel)
        half_dJ = 0.0 if one else np.zeros_like(kin.phi1)
        for link in self.links:
            _, _, t, p, tt, pp = kin.point(link.centre)
            _, q, qq = kin.link_angle(link.name)
            if one:
                t, p, tt, pp, q, qq = float(t[0]), float(p[0]), float(tt[0]), float(pp[0]), float(q[0]), float(qq[0])
            J = J + (link.mass * (t * t + p * p) + link.inertia * q * q)
            half_dJ = half_dJ + (link.mass * (t * tt + p * pp) + link.inertia * q * qq)
        if one:
            J, half_dJ = np.array([J]), np.array([half_dJ])
        Q = np.zeros_like(kin.phi1)
        for load in self.loads:
            if load.position_only:
                Q += load.torque(kin)
        return J, half_dJ, Q, kin

    def velocity_load(self, kin: Kinematics, omega1):
        """The velocity-dependent part of Q (N.m); zero when no load depends on omega1."""
        Q = np.zeros_like(kin.phi1)
        for load in self.loads:
            if not load.position_only:
                Q += load.torque(kin, omega1)
        return Q

    def kinetic_energy_of_links(self, phi1, omega1):
        """E_kin (J) summed link by link from mass-centre and angular velocities, flywheel included.

        An independent path to 0.5*J*omega1^2, used to check the reduced inertia.
        """
        kin = self.mechanism.kinematics(phi1)
        omega1 = np.asarray(omega1, dtype=float)
        E = 0.5 * self.J_flywheel * omega1 ** 2
        for link in self.links:
            _, _, t, p, _, _ = kin.point(link.centre)
            vx, vy = t * omega1, p * omega1
            w = kin.link_angle(link.name)[1] * omega1
            E = E + 0.5 * link.mass * (vx * vx + vy * vy) + 0.5 * link.inertia * w * w
        return E
