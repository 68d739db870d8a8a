"""The movement equation in the time domain, state (phi1, omega1):

    J(phi1) domega1/dt + 0.5 J'(phi1) omega1^2 = M_motor(omega1) + Q(phi1, omega1) + tau_ext

Unlike the crank-angle form (seed 000 eq. 17, which divides by omega1) it holds at omega1 = 0
and below: start from rest, stall and reversal.

The right-hand side is smooth within a *mode*: which line of the motor is in use. The motor line
has a kink (or, once A, B, A_low, B_low are tuned independently, a jump) at omega_switch; the
integrators hold the mode fixed during a step, locate the crossing of omega1 = omega_switch as an
event, and restart there with the mode ``transition`` gives, instead of stepping across it.

Modes: ``"low"`` (omega1 <= omega_switch line), ``"high"``, and ``"slide"``. A motor line that
jumps down at omega_switch can trap the crank speed on the switch (below it the motor
accelerates the crank, above it decelerates it): the solution in the sense of Filippov then
slides along omega1 = omega_switch with the motor delivering the equivalent torque
M_eq = 0.5 J' omega1^2 - Q - tau_ext, as long as M_eq lies between the two lines' torques.
Without this mode an event-driven integrator chatters across the switch forever.
"""

from __future__ import annotations

import numpy as np

from .motor import MotorLine
from .reduced import ReducedModel

# state layout: the work integrals ride along so the energy balance is exact to the tolerance
PHI, OMEGA, W_MOTOR, W_LOAD, W_EXT = range(5)
STATE_SIZE = 5

LOW, HIGH, SLIDE = "low", "high", "slide"
KINK = "motor line kink (omega1 = omega_switch)"


class MovementEquation:
    """Right-hand side of the movement equation, its modes and their switching events.

    ``tau_ext`` is a constant external torque on the crank (N.m), the FMU's coupling input.
    """

    def __init__(self, reduced: ReducedModel, motor: MotorLine, tau_ext: float = 0.0):
        self.reduced = reduced
        self.motor = motor
        self.tau_ext = float(tau_ext)
        self.n_rhs = 0

    # -------------------------------------------------------------- scalar hot path
    def coefficients(self, phi1, omega1):
        """(J kg.m^2, 0.5 J' kg.m^2/rad, Q N.m) at one state, the velocity-dependent loads included."""
        J, half_dJ, Q, kin = self.reduced.coefficients(phi1)
        q = Q[0]
        if self.reduced.velocity_dependent:
            q += float(self.reduced.velocity_load(kin, omega1)[0])
        return J[0], half_dJ[0], q

    def rhs(self, t, y, mode):
        """d/dt of (phi1 rad, omega1 rad/s, W_motor J, W_load J, W_ext J) in ``mode``."""
        self.n_rhs += 1
        omega1 = y[OMEGA]
        J, half_dJ, Q = self.coefficients(y[PHI], omega1)
        if mode == SLIDE:
            M = half_dJ * omega1 * omega1 - Q - self.tau_ext     # holds domega1/dt = 0
            eps = 0.0
        else:
            M = self.motor.torque(omega1, mode == HIGH)
            eps = (M + Q + self.tau_ext - half_dJ * omega1 * omega1) / J
        return np.array([omega1, eps, M * omega1, Q * omega1, self.tau_ext * omega1])

    def _mode_on_switch(self, y):
        """The mode to continue in from a state on omega1 = omega_switch (Filippov's rule)."""
        ws = self.motor.omega_switch
        J, half_dJ, Q = self.coefficients(y[PHI], ws)
        rest = Q + self.tau_ext - half_dJ * ws * ws          # J * domega1/dt less the motor torque
        up_from_low = self.motor.torque(ws, False) + rest > 0.0
        up_from_high = self.motor.torque(ws, True) + rest > 0.0
        if up_from_low and up_from_high:
            return HIGH
        if not up_from_low and not up_from_high:
            return LOW
        if up_from_low and not up_from_high:
            return SLIDE          # both sides push into the switch
        return HIGH               # both push away (a jump up): leave upwards, the motor's side

    # -------------------------------------------------------------- modes and events
    def initial_mode(self, t, y):
        w, ws = y[OMEGA], self.motor.omega_switch
        if w > ws:
            return HIGH
        if w < ws:
            return LOW
        return self._mode_on_switch(y)

    def events(self, mode):
        """[(g(t, y), direction, description)]: surfaces that end a segment in ``mode``."""
        ws = self.motor.omega_switch
        if mode == LOW:
            return [(lambda t, y: y[OMEGA] - ws, 1.0, KINK)]
        if mode == HIGH:
            return [(lambda t, y: y[OMEGA] - ws, -1.0, KINK)]
        # sliding ends when the equivalent torque leaves [M_high, M_low] at omega_switch
        m_low, m_high = self.motor.torque(ws, False), self.motor.torque(ws, True)

        def equivalent(y):
            J, half_dJ, Q = self.coefficients(y[PHI], ws)
            return half_dJ * ws * ws - Q - self.tau_ext
        return [(lambda t, y: m_low - equivalent(y), -1.0, "sliding ends: the low line cannot hold omega_switch"),
                (lambda t, y: equivalent(y) - m_high, -1.0, "sliding ends: the high line exceeds the need")]

    def transition(self, mode, index, t, y):
        """Mode after event ``index`` of ``events(mode)`` fired at (t, y); y may be adjusted."""
        y[OMEGA] = self.motor.omega_switch          # the event is on the surface, exactly
        if mode == SLIDE:
            return LOW if index == 0 else HIGH
        return self._mode_on_switch(y)

    # -------------------------------------------------------------- vectorised outputs
    def outputs(self, phi1, omega1, sliding=None):
        """Every contract output at arrays of states.

        The motor branch follows omega1; where ``sliding`` (a boolean array) is set the motor
        gives the equivalent torque that holds omega1 on the switch.
        """
        phi1 = np.asarray(phi1, dtype=float)
        omega1 = np.asarray(omega1, dtype=float)
        J, half_dJ, Q, kin = self.reduced.coefficients(phi1)
        if self.reduced.velocity_dependent:
            Q = Q + self.reduced.velocity_load(kin, omega1)
        M = self.motor.torque_at(omega1)
        if sliding is not None and np.any(sliding):
            M = np.where(sliding, half_dJ * omega1 ** 2 - Q - self.tau_ext, M)
        eps = (M + Q + self.tau_ext - half_dJ * omega1 ** 2) / J
        return {
            "epsilon1": eps,          # rad/s^2
            "M_motor": M,             # N.m
            "M_load": Q,              # N.m
            "J_red": J,               # kg.m^2
            "E_kin": 0.5 * J * omega1 ** 2,   # J
        }
