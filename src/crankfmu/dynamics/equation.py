"""The movement equation in the time domain, state (phi1, omega1):

    J(phi1) domega1/dt + 0.5 J'(phi1) omega1^2 = M_motor(omega1) + Q(phi1, omega1) + tau_ext

Unlike the crank-angle form (seed 000 eq. 17, which divides by omega1) it holds at omega1 = 0
and below: start from rest, stall and reversal.

The right-hand side is smooth within a *mode* (:class:`Mode`), the discrete state the
integrators hold fixed during a step. They locate the crossing of each switching surface as an
event and restart there in the mode ``transition`` gives, instead of stepping across a jump:

- the motor branch: the motor line has a kink (or, once A, B, A_low, B_low are tuned
  independently, a jump) at omega_switch. ``"low"`` (omega1 <= omega_switch line), ``"high"``,
  or ``"slide"``: a line that jumps down at omega_switch can trap the crank speed on the switch
  (below it the motor accelerates the crank, above it decelerates it). The solution in the sense
  of Filippov then slides along omega1 = omega_switch with the motor delivering the equivalent
  torque M_eq = 0.5 J' omega1^2 - Q - tau_ext, as long as M_eq lies between the two lines'
  torques. Without this mode an event-driven integrator chatters across the switch forever.
- the slider forces (seed 001's F3/F7, seed 003's cutting force) jump at fixed crank angles (a
  slider's reversals, a band's ends) and when omega1 changes sign. The mode holds the switch
  interval k with its unwrapped bounds and the direction of motion (+1, -1, or 0: stuck, the crank
  at rest held by the slider forces because the motor cannot move it against them); the forces
  are the constants of that interval and direction (``loads.slider_schedule``). Events: phi1
  reaches either bound, and omega1 = 0.

The compiled fast kernel (``integrators.kernel``) implements the same modes and rules on its
tables; the engine-based integrators (``reference``, ``radau``, ``dopri5``) use this class.
"""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np

from .loads import interval_bounds, interval_width
from .motor import MotorLine
from .reduced import ReducedModel

# state layout: the work integrals ride along so the energy balance is exact to the tolerance
PHI, OMEGA, W_MOTOR, W_LOAD, W_EXT = range(5)
STATE_SIZE = 5

LOW, HIGH, SLIDE = "low", "high", "slide"
STUCK = "stuck"
KINK = "motor line kink (omega1 = omega_switch)"

# kinds of switching surface (what ``transition`` does at each)
LOW_GIVES_UP, HIGH_SUFFICES = "low line gives up", "high line suffices"
INTERVAL_END, INTERVAL_START, REST = "interval end", "interval start", "rest"


class Mode(NamedTuple):
    """The discrete state of the movement equation (see the module's docstring)."""

    motor: str                     # LOW, HIGH or SLIDE
    direction: int = 1             # +1 / -1: the slider forces' side; 0: stuck at rest
    interval: int = 0              # switch interval k of the slider forces
    phi_lo: float = -math.inf      # rad, unwrapped bounds of interval k around the crank angle
    phi_hi: float = math.inf

    @property
    def name(self) -> str:
        """What ``Trajectory.modes`` records: the motor branch, or ``"stuck"``."""
        return STUCK if self.direction == 0 else self.motor


class Surface(NamedTuple):
    """A switching surface g(t, y) = 0 of a mode, crossed in ``direction`` (+1 rising, -1 falling)."""

    g: Callable[[float, np.ndarray], float]
    direction: float
    kind: str
    what: str


class MovementEquation:
    """Right-hand side of the movement equation, its modes and their switching events.

    ``tau_ext`` is a constant external torque on the crank (N.m), the FMU's coupling input.
    """

    def __init__(self, reduced: ReducedModel, motor: MotorLine, tau_ext: float = 0.0):
        self.reduced = reduced
        self.motor = motor
        self.tau_ext = float(tau_ext)
        self.n_rhs = 0
        self.sliders = reduced.sliders
        self._smooth_velocity_loads = [load for load in reduced.loads
                                       if not load.position_only and load not in self.sliders]

    # -------------------------------------------------------------- scalar hot path
    def coefficients(self, phi1, omega1, mode: Mode):
        """(J kg.m^2, 0.5 J' kg.m^2/rad, Q N.m) at one state, the slider forces those of ``mode``."""
        J, half_dJ, Q, kin = self.reduced.coefficients(phi1)
        q = Q[0]
        for load in self._smooth_velocity_loads:
            q += float(load.torque(kin, omega1)[0])
        if self.sliders and mode.direction != 0:
            _, forces = self.reduced.slider_schedule()
            side = 0 if mode.direction > 0 else 1
            s = 0
            for load in self.sliders:
                n = len(load.column_names)
                factors = forces[mode.interval, side, s:s + n]
                s += n
                # a direction-dependent load has one column switched on per interval: the other
                # direction's expressions are not evaluated on this hot path
                for factor, column in zip(factors, load.columns(kin, factors != 0.0)):
                    if factor != 0.0:
                        q += factor * column[0]
        return J[0], half_dJ[0], q

    def rhs(self, t, y, mode: Mode):
        """d/dt of (phi1 rad, omega1 rad/s, W_motor J, W_load J, W_ext J) in ``mode``."""
        self.n_rhs += 1
        omega1 = y[OMEGA]
        if mode.direction == 0:            # stuck: at rest (no power) until a restart changes the balance
            return np.zeros(STATE_SIZE)
        J, half_dJ, Q = self.coefficients(y[PHI], omega1, mode)
        if mode.motor == SLIDE:
            M = half_dJ * omega1 * omega1 - Q - self.tau_ext     # holds domega1/dt = 0
            eps = 0.0
        else:
            M = self.motor.torque(omega1, mode.motor == HIGH)
            eps = (M + Q + self.tau_ext - half_dJ * omega1 * omega1) / J
        return np.array([omega1, eps, M * omega1, Q * omega1, self.tau_ext * omega1])

    def _motor_on_switch(self, phi1, mode: Mode) -> str:
        """The motor branch to continue in from omega1 = omega_switch (Filippov's rule)."""
        ws = self.motor.omega_switch
        J, half_dJ, Q = self.coefficients(phi1, ws, mode)
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

    def _direction_at_rest(self, phi1, mode: Mode) -> int:
        """Side of the slider forces from rest: the way the crank accelerates, or 0 (stuck)."""
        y = np.array([phi1, 0.0, 0.0, 0.0, 0.0])
        if self.rhs(0.0, y, mode._replace(direction=1))[OMEGA] > 0.0:
            return 1
        if self.rhs(0.0, y, mode._replace(direction=-1))[OMEGA] < 0.0:
            return -1
        return 0

    def _in_interval(self, mode: Mode, phi1, direction: int) -> Mode:
        if not self.sliders:
            return mode._replace(direction=direction)
        switch, _ = self.reduced.slider_schedule()
        k, lo, hi = interval_bounds(switch, phi1, direction if direction != 0 else 1)
        return Mode(mode.motor, direction, k, lo, hi)

    # -------------------------------------------------------------- modes and events
    def mode_of_state(self, y) -> Mode:
        """The mode read off the state alone: what an integrator without events sees when it steps
        across the switches (the solve_ivp peers of the work-precision studies; never stuck)."""
        w = y[OMEGA]
        motor = HIGH if w > self.motor.omega_switch else LOW
        return self._in_interval(Mode(motor), y[PHI], 1 if w >= 0.0 else -1)

    def initial_mode(self, t, y) -> Mode:
        w, ws, phi1 = y[OMEGA], self.motor.omega_switch, y[PHI]
        direction = 1 if w >= 0.0 else -1
        mode = self._in_interval(Mode(HIGH if w > ws else LOW), phi1, direction)
        if w == ws:
            mode = mode._replace(motor=self._motor_on_switch(phi1, mode))
        if w == 0.0 and self.sliders:
            mode = self._in_interval(mode, phi1, self._direction_at_rest(phi1, mode))
        return mode

    def events(self, mode: Mode) -> list[Surface]:
        """The surfaces that end a segment in ``mode``."""
        if mode.direction == 0:
            return []                      # stuck: nothing changes until a restart
        ws = self.motor.omega_switch
        if mode.motor == SLIDE:
            # sliding ends when the equivalent torque leaves [M_high, M_low] at omega_switch
            m_low, m_high = self.motor.torque(ws, False), self.motor.torque(ws, True)

            def equivalent(y):
                J, half_dJ, Q = self.coefficients(y[PHI], ws, mode)
                return half_dJ * ws * ws - Q - self.tau_ext
            surfaces = [Surface(lambda t, y: m_low - equivalent(y), -1.0, LOW_GIVES_UP,
                                "sliding ends: the low line cannot hold omega_switch"),
                        Surface(lambda t, y: equivalent(y) - m_high, -1.0, HIGH_SUFFICES,
                                "sliding ends: the high line exceeds the need")]
        else:
            surfaces = [Surface(lambda t, y: y[OMEGA] - ws, 1.0 if mode.motor == LOW else -1.0, KINK, KINK)]
        if self.sliders:
            surfaces += [
                Surface(lambda t, y: y[PHI] - mode.phi_hi, 1.0, INTERVAL_END,
                        "slider force switch angle (crank forward)"),
                Surface(lambda t, y: y[PHI] - mode.phi_lo, -1.0, INTERVAL_START,
                        "slider force switch angle (crank backward)"),
            ]
            if ws != 0.0:          # a kink at rest is one event that turns the forces too
                surfaces.append(Surface(lambda t, y: y[OMEGA], -1.0 if mode.direction > 0 else 1.0, REST,
                                        "omega1 = 0: the slider forces change direction"))
        return surfaces

    def transition(self, mode: Mode, kind: str, t, y) -> Mode:
        """Mode after the surface of ``kind`` was reached at (t, y); y is put on the surface."""
        ws = self.motor.omega_switch
        if kind in (INTERVAL_END, INTERVAL_START):
            # the next interval by counting, not from the wrapped angle: rounding in the wrap could
            # put the angle back into the interval just left
            switch, _ = self.reduced.slider_schedule()
            m = switch.size
            if kind == INTERVAL_END:
                y[PHI] = mode.phi_hi
                k = (mode.interval + 1) % m
                return mode._replace(interval=k, phi_lo=mode.phi_hi, phi_hi=mode.phi_hi + interval_width(switch, k))
            y[PHI] = mode.phi_lo
            k = (mode.interval - 1) % m
            return mode._replace(interval=k, phi_lo=mode.phi_lo - interval_width(switch, k), phi_hi=mode.phi_lo)
        if kind == REST:
            y[OMEGA] = 0.0
            if mode.motor != SLIDE and ws > 0.0:
                mode = mode._replace(motor=LOW)
            return mode._replace(direction=self._direction_at_rest(y[PHI], mode))
        y[OMEGA] = ws
        if ws == 0.0 and self.sliders:
            mode = mode._replace(direction=self._direction_at_rest(y[PHI], mode))
        if kind == LOW_GIVES_UP:
            return mode._replace(motor=LOW)
        if kind == HIGH_SUFFICES:
            return mode._replace(motor=HIGH)
        return mode._replace(motor=self._motor_on_switch(y[PHI], mode))

    # -------------------------------------------------------------- vectorised outputs
    def outputs(self, phi1, omega1, modes=None):
        """Every contract output at arrays of states.

        The motor branch and the slider forces' side follow omega1. ``modes`` (mode names at the
        same states, ``Trajectory.mode_at``) marks where the motor holds omega1 on its switch
        (``"slide"``: the equivalent torque) and where the crank is stuck at rest (no acceleration).
        """
        phi1 = np.asarray(phi1, dtype=float)
        omega1 = np.asarray(omega1, dtype=float)
        J, half_dJ, Q, kin = self.reduced.coefficients(phi1)
        if self.reduced.velocity_dependent:
            Q = Q + self.reduced.velocity_load(kin, omega1)
        M = self.motor.torque_at(omega1)
        if modes is not None:
            M = np.where(modes == SLIDE, half_dJ * omega1 ** 2 - Q - self.tau_ext, M)
        eps = (M + Q + self.tau_ext - half_dJ * omega1 ** 2) / J
        if modes is not None:
            eps = np.where(modes == STUCK, 0.0, eps)
        return {
            "epsilon1": eps,          # rad/s^2
            "M_motor": M,             # N.m
            "M_load": Q,              # N.m
            "J_red": J,               # kg.m^2
            "E_kin": 0.5 * J * omega1 ** 2,   # J
        }
