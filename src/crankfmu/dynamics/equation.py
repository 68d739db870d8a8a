"""The movement equation in the time domain, state (phi1, omega1):

    J(phi1) domega1/dt + 0.5 J'(phi1) omega1^2 = M_motor(omega1) + Q(phi1, omega1) + tau_ext

Unlike the crank-angle form (seed 000 eq. 17, which divides by omega1) it holds at omega1 = 0
and below: start from rest, stall and reversal.

The right-hand side is smooth between switches. A switch is a surface g(phi1, omega1) = 0 where
a load changes its formula (the motor line's kink at omega_switch); the integrators hold the
discrete mode (which side of each surface) fixed during a step, locate the crossing as an event
and restart there, instead of stepping across the kink.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .motor import MotorLine
from .reduced import ReducedModel

# state layout: the work integrals ride along so the energy balance is exact to the tolerance
PHI, OMEGA, W_MOTOR, W_LOAD, W_EXT = range(5)
STATE_SIZE = 5


@dataclass
class Switch:
    """g(y) = y[OMEGA] - level; mode True above the surface."""

    name: str
    level: float

    def __call__(self, t, y):
        return y[OMEGA] - self.level


class MovementEquation:
    """Right-hand side of the movement equation and its switches.

    ``tau_ext`` is a constant external torque on the crank (N.m), the FMU's coupling input.
    """

    def __init__(self, reduced: ReducedModel, motor: MotorLine, tau_ext: float = 0.0):
        self.reduced = reduced
        self.motor = motor
        self.tau_ext = float(tau_ext)
        self.switches = [Switch("motor line kink (omega1 = omega_switch)", motor.omega_switch)]
        self.n_rhs = 0

    # -------------------------------------------------------------- scalar hot path
    def rhs(self, t, y, mode):
        """d/dt of (phi1, omega1, W_motor, W_load, W_ext) with the motor branch fixed by ``mode``."""
        self.n_rhs += 1
        phi1, omega1 = y[PHI], y[OMEGA]
        J, half_dJ, Q, kin = self.reduced.coefficients(phi1)
        if self.reduced.velocity_dependent:
            Q = Q + self.reduced.velocity_load(kin, omega1)
        M = self.motor.torque(omega1, mode[0])
        eps = (M + Q[0] + self.tau_ext - half_dJ[0] * omega1 * omega1) / J[0]
        return np.array([omega1, eps, M * omega1, Q[0] * omega1, self.tau_ext * omega1])

    def mode_at(self, t, y):
        """Discrete mode at a state. On a surface, the side the motion is heading to."""
        mode = []
        for i, sw in enumerate(self.switches):
            g = sw(t, y)
            if g != 0.0:
                mode.append(g > 0.0)
                continue
            # exactly on the surface: the motor line is continuous there (both branches give the
            # same torque when A - B w_s = A_low - B_low w_s), so the acceleration decides
            trial = list(mode) + [False] * (len(self.switches) - len(mode))
            d_omega = self.rhs(t, y, tuple(trial))[OMEGA]
            self.n_rhs -= 1
            mode.append(d_omega > 0.0)
        return tuple(mode)

    # -------------------------------------------------------------- vectorised outputs
    def outputs(self, phi1, omega1):
        """Every contract output at arrays of states (branch of the motor by omega1 itself)."""
        phi1 = np.asarray(phi1, dtype=float)
        omega1 = np.asarray(omega1, dtype=float)
        J, half_dJ, Q, kin = self.reduced.coefficients(phi1)
        if self.reduced.velocity_dependent:
            Q = Q + self.reduced.velocity_load(kin, omega1)
        M = self.motor.torque_at(omega1)
        eps = (M + Q + self.tau_ext - half_dJ * omega1 ** 2) / J
        return {
            "epsilon1": eps,          # rad/s^2
            "M_motor": M,             # N.m
            "M_load": Q,              # N.m
            "J_red": J,               # kg.m^2
            "E_kin": 0.5 * J * omega1 ** 2,   # J
        }


