"""The movement equation in the time domain, state (phi1, omega1):

    J(phi1) domega1/dt + 0.5 J'(phi1) omega1^2 = M_motor(omega1) + Q(phi1, omega1) + tau_e(t, phi1)

tau_e is the external torque: the input tau_ext on the crank plus each port's input times its
transfer function (dynamics.ports); its work is W_ext.

Unlike the crank-angle form (seed 000 eq. 17, which divides by omega1) it holds at omega1 = 0
and below: start from rest, stall and reversal.

The right-hand side is smooth within a *mode* (:class:`Mode`), the discrete state the
integrators hold fixed during a step. They locate the crossing of each switching surface as an
event and restart there in the mode ``transition`` gives, instead of stepping across a jump. The
rules (the motor branch and Filippov sliding on a jump of the motor line, the slider forces'
direction at rest and switch intervals, the surfaces and what follows each) are
:mod:`crankfmu.dynamics.modes`'s, the rules the C kernel states again (a test compares them); this class
evaluates them on the contour engine's kinematics for the engine-based integrators (``reference``,
``radau``, ``dopri5``).
"""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np

from . import modes
from .modes import HIGH, SLIDE, SLIDING, STUCK
from .motor import MotorLine
from .friction import friction_outputs, joint_values
from .loads import AppliedLoad
from .reactions import NewtonEuler
from .reduced import ReducedModel

rules = modes

# state layout: the work integrals ride along so the energy balance is exact to the tolerance;
# a model with joint friction has a sixth, the friction's work (dynamics.friction)
PHI, OMEGA, W_MOTOR, W_LOAD, W_EXT, W_FRICTION = range(6)
STATE_SIZE = 5


class Mode(NamedTuple):
    """The discrete state of the movement equation (see dynamics.modes)."""

    motor: float                   # modes.LOW, HIGH or SLIDE
    direction: float = 1.0         # +1 / -1: the slider forces' side; 0: stuck at rest
    interval: int = 0              # switch interval k of the slider forces
    phi_lo: float = -math.inf      # rad, unwrapped bounds of interval k around the crank angle
    phi_hi: float = math.inf

    @property
    def name(self) -> str:
        """What ``Trajectory.modes`` records: the motor branch, or ``"stuck"``."""
        return modes.mode_name(self.motor, self.direction)


class Surface(NamedTuple):
    """A switching surface g(t, y) = 0 of a mode, crossed in ``direction`` (+1 rising, -1 falling)."""

    g: Callable[[float, np.ndarray], float]
    direction: float
    slot: int                      # modes' event slot
    what: str


class MovementEquation:
    """Right-hand side of the movement equation, its modes and their switching events.

    ``tau_ext`` is a constant external torque on the crank (N.m), the FMU's coupling input; the
    reduced model's ports (dynamics.ports) take ``port_inputs``, one per port: a constant (N or
    N.m) or a function of time t (s).
    """

    def __init__(self, reduced: ReducedModel, motor: MotorLine, tau_ext: float = 0.0, port_inputs=None):
        self.reduced = reduced
        self.motor = motor
        self.tau_ext = float(tau_ext)
        self.ports = list(reduced.ports)
        self.port_inputs = list(port_inputs) if port_inputs is not None else [0.0] * len(self.ports)
        self.n_rhs = 0
        # a load of the speeds with columns (speed_loads.PolynomialSpeedLoad) is evaluated exactly here,
        # smooth on each side of omega1 = 0: only the loads switched by the angle use the schedule,
        # each from its own columns' offset in it
        self.sliders = [load for load in reduced.sliders if not getattr(load, "has_speed_columns", False)]
        offsets, offset = {}, 0
        for load in reduced.sliders:
            offsets[id(load)] = offset
            offset += len(load.column_names)
        self._slider_offsets = [(load, offsets[id(load)]) for load in self.sliders]
        self._switched_offsets = {id(load): s for load, s in self._slider_offsets}
        self._smooth_velocity_loads = [load for load in reduced.loads
                                       if not load.position_only and load not in self.sliders]
        #: the joints' friction (dynamics.friction.JointFrictions) or None
        self.friction = reduced.friction
        #: something switches at angles or at rest: the slider forces, or the joints' friction
        self.switched = bool(self.sliders) or self.friction is not None

    @property
    def friction_names(self) -> list[str]:
        """The outputs joint friction adds (dynamics.friction.friction_outputs): none without it."""
        return [] if self.friction is None else [name for name, _, _ in friction_outputs(self.friction.frictions)]

    @property
    def state_size(self) -> int:
        """The state's length: 5, and the friction's work with joint friction."""
        return STATE_SIZE + (self.friction is not None)

    def port_values(self, t):
        """The ports' inputs at time t (s): each a float, or an array where t is one."""
        values = []
        for u in self.port_inputs:
            if not callable(u):
                values.append(u)
            elif np.ndim(t):
                values.append(np.array([float(u(float(x))) for x in np.ravel(t)]))
            else:
                values.append(float(u(float(t))))
        return values

    def external_torque(self, t, kin):
        """tau_e (N.m): tau_ext and the ports' inputs at time t times their transfer functions."""
        tau = self.tau_ext
        for port, value in zip(self.ports, self.port_values(t)):
            tau = tau + port.torque(kin, value)
        return tau

    # -------------------------------------------------------------- scalar hot path
    def coefficients(self, phi1, omega1, mode: Mode, t: float = 0.0):
        """(J kg.m^2, 0.5 J' kg.m^2/rad, Q N.m, tau_e N.m) at one state, the slider forces those of
        ``mode``, the external torque at time t; with joint friction, Q holds the friction's
        generalised force at the speed held (epsilon1 = 0: what the motor's switch weighs)."""
        J, half_dJ, Q, tau, kin = self._coefficients(phi1, omega1, mode, t)
        if self.friction is not None:
            Q = Q + self._friction(kin, t, omega1, mode, J, 0.0, held=True)[3]
        return J, half_dJ, Q, tau

    def _coefficients(self, phi1, omega1, mode: Mode, t: float = 0.0):
        """``coefficients`` without the friction, and the kinematics at phi1."""
        J, half_dJ, Q, kin = self.reduced.coefficients(phi1)
        tau = float(np.asarray(self.external_torque(t, kin)).ravel()[0]) if self.ports else self.tau_ext
        q = Q[0]
        for load in self._smooth_velocity_loads:
            q += float(load.torque(kin, omega1)[0])
        if self.sliders:
            _, forces = self.reduced.slider_schedule()
            for load, s in self._slider_offsets:
                block = forces[mode.interval, :, s:s + len(load.column_names)]
                factors = rules.column_factor(block[0], block[1], mode.direction)
                # a direction-dependent load has one column switched on per interval: the other
                # direction's expressions are not evaluated on this hot path
                for factor, column in zip(factors, load.columns(kin, factors != 0.0)):
                    if factor != 0.0:
                        q += factor * column[0]
        return J[0], half_dJ[0], q, tau, kin

    def _applied_in_mode(self, kin, t, omega1, mode: Mode):
        """Every load as the joints see it (loads.AppliedLoad) at one state, the switched loads'
        values those of ``mode`` (as ``coefficients`` takes them), the ports' inputs at time t."""
        out = []
        switched = self._switched_offsets
        _, forces = self.reduced.slider_schedule() if self.sliders else (None, None)
        for load in self.reduced.loads:
            if id(load) not in switched:
                out += load.applied(kin, np.array([omega1]))
                continue
            s = switched[id(load)]
            block = forces[mode.interval, :, s:s + len(load.column_names)]
            for j, factor in enumerate(rules.column_factor(block[0], block[1], mode.direction)):
                if factor != 0.0:
                    out += [AppliedLoad(f.link, f.point, factor * f.fx, factor * f.fy, factor * f.moment)
                            for f in load.column_applied(kin, j)]
        for port, value in zip(self.ports, self.port_values(t)):
            out += port.applied(kin, value)
        return out

    def _friction(self, kin, t, omega1, mode: Mode, J, epsilon1, held: bool = False):
        """(eps_friction rad/s2, f, x, generalised N.m) at one state (dynamics.friction.forward):
        the acceleration the joints' friction adds to the frictionless ``epsilon1``, the
        frictions, the Newton-Euler unknowns and the friction's generalised force on the crank."""
        ne = NewtonEuler(self.reduced, kin)
        b = ne.loaded(self._applied_in_mode(kin, t, omega1, mode), omega1, epsilon1)
        signs = self.reduced.friction_signs()[mode.interval] * mode.direction
        return self.friction.forward(ne, b, np.atleast_1d(J), signs[None, :], held)

    def rhs(self, t, y, mode: Mode):
        """d/dt of (phi1 rad, omega1 rad/s, W_motor J, W_load J, W_ext J) in ``mode``."""
        self.n_rhs += 1
        omega1 = y[OMEGA]
        if mode.direction == 0:            # stuck: at rest (no power) until a restart changes the balance
            return np.zeros(self.state_size)
        if self.friction is not None:
            return self._rhs_with_friction(t, y, mode)
        J, half_dJ, Q, tau = self.coefficients(y[PHI], omega1, mode, t)
        if mode.motor == SLIDE:
            M = rules.equivalent_torque(half_dJ, Q, tau, omega1)     # holds domega1/dt = 0
            eps = 0.0
        else:
            M = self.motor.torque(omega1, mode.motor == HIGH)
            eps = rules.acceleration(J, half_dJ, Q, M, tau, omega1)
        return np.array([omega1, eps, M * omega1, Q * omega1, tau * omega1])

    def _rhs_with_friction(self, t, y, mode: Mode):
        """``rhs`` with the joints' friction: the frictionless acceleration, then the friction's
        part of it, solved with the reactions (dynamics.friction); its power is the sixth rate."""
        omega1 = y[OMEGA]
        J, half_dJ, Q, tau, kin = self._coefficients(y[PHI], omega1, mode, t)
        held = mode.motor == SLIDE
        if held:
            eps = 0.0
        else:
            M = self.motor.torque(omega1, mode.motor == HIGH)
            eps = rules.acceleration(J, half_dJ, Q, M, tau, omega1)
        extra, _, _, generalised = self._friction(kin, t, omega1, mode, J, eps, held)
        eps, friction = eps + float(extra[0]), float(generalised[0])
        if held:
            M = rules.equivalent_torque(half_dJ, Q + friction, tau, omega1)
        return np.array([omega1, eps, M * omega1, Q * omega1, tau * omega1, friction * omega1])

    def _switch_torques(self):
        """The low and the high line's torques at omega_switch (N.m)."""
        ws = self.motor.omega_switch
        return self.motor.torque(ws, False), self.motor.torque(ws, True)

    def _motor_on_switch(self, phi1, mode: Mode, t: float = 0.0) -> float:
        """The motor branch to continue in from omega1 = omega_switch (modes.motor_on_switch)."""
        ws = self.motor.omega_switch
        J, half_dJ, Q, tau = self.coefficients(phi1, ws, mode, t)
        return rules.motor_on_switch(*self._switch_torques(), Q + tau - half_dJ * ws * ws)

    def _direction_at_rest(self, phi1, mode: Mode, t: float = 0.0) -> float:
        """Side of the slider forces from rest (modes.direction_at_rest)."""
        y = np.zeros(self.state_size)
        y[PHI] = phi1
        return rules.direction_at_rest(self.rhs(t, y, mode._replace(direction=1.0))[OMEGA],
                                       self.rhs(t, y, mode._replace(direction=-1.0))[OMEGA])

    def _in_interval(self, mode: Mode, phi1, direction: float) -> Mode:
        if not self.switched:
            return mode._replace(direction=direction)
        switch, _ = self.reduced.slider_schedule()
        k, lo, hi = rules.interval_of(switch, phi1, direction if direction != 0 else 1.0)
        return Mode(mode.motor, direction, k, lo, hi)

    # -------------------------------------------------------------- modes and events
    def mode_of_state(self, y) -> Mode:
        """The mode read off the state alone: what an integrator without events sees when it steps
        across the switches (the solve_ivp peers of the work-precision studies; never stuck)."""
        w = y[OMEGA]
        return self._in_interval(Mode(rules.motor_of_speed(w, self.motor.omega_switch)), y[PHI],
                                 rules.direction_of_speed(w))

    def initial_mode(self, t, y) -> Mode:
        w, ws, phi1 = y[OMEGA], self.motor.omega_switch, y[PHI]
        mode = self.mode_of_state(y)
        if w == ws:
            mode = mode._replace(motor=self._motor_on_switch(phi1, mode, t))
        if w == 0.0 and self.switched:
            mode = self._in_interval(mode, phi1, self._direction_at_rest(phi1, mode, t))
        return mode

    def events(self, mode: Mode) -> list[Surface]:
        """The surfaces that end a segment in ``mode`` (modes.event_active, event_value)."""
        ws = self.motor.omega_switch
        m_low, m_high = self._switch_torques()

        def surface(slot):
            def g(t, y):
                equivalent = 0.0
                if mode.motor == SLIDE:
                    J, half_dJ, Q, tau = self.coefficients(y[PHI], ws, mode, t)
                    equivalent = rules.equivalent_torque(half_dJ, Q, tau, ws)
                return rules.event_value(slot, y[PHI], y[OMEGA], mode.motor, mode.phi_lo, mode.phi_hi, ws,
                                         m_low, m_high, equivalent)
            return Surface(g, 1.0 if rules.event_rising(slot, mode.motor, mode.direction) else -1.0, slot,
                           modes.event_name(slot, mode.motor))
        return [surface(slot) for slot in range(modes.N_SLOTS)
                if rules.event_active(slot, mode.motor, mode.direction, mode.phi_hi, self.switched, ws)]

    def transition(self, mode: Mode, slot: int, t, y) -> Mode:
        """Mode after surface ``slot`` was reached at (t, y); y is put on the surface."""
        ws = self.motor.omega_switch
        if slot in (modes.INTERVAL_END, modes.INTERVAL_START):
            forward = slot == modes.INTERVAL_END
            y[PHI] = mode.phi_hi if forward else mode.phi_lo
            switch, _ = self.reduced.slider_schedule()
            k, lo, hi = rules.next_interval(switch, mode.interval, mode.phi_lo, mode.phi_hi, forward)
            return mode._replace(interval=k, phi_lo=lo, phi_hi=hi)
        y[OMEGA] = 0.0 if slot == modes.REST else ws
        if slot == modes.REST:
            mode = mode._replace(motor=rules.motor_at_rest(mode.motor, ws))
        if rules.turns_forces(slot, ws, self.switched):
            mode = mode._replace(direction=self._direction_at_rest(y[PHI], mode, t))
        if slot == modes.REST:
            return mode
        if mode.motor == SLIDE:
            return mode._replace(motor=rules.motor_after_sliding(slot))
        return mode._replace(motor=self._motor_on_switch(y[PHI], mode, t))

    # -------------------------------------------------------------- vectorised outputs
    def outputs(self, phi1, omega1, modes=None, t=None):
        """Every contract output at arrays of states.

        The motor branch and the slider forces' side follow omega1. ``modes`` (mode names at the
        same states, ``Trajectory.mode_at``) marks where the motor holds omega1 on its switch
        (``"slide"``: the equivalent torque) and where the crank is stuck at rest (no acceleration).
        ``t`` (s, the states' times) is needed where a port's input is a function of time.
        """
        phi1 = np.asarray(phi1, dtype=float)
        omega1 = np.asarray(omega1, dtype=float)
        J, half_dJ, Q, kin = self.reduced.coefficients(phi1)
        if self.reduced.velocity_dependent:
            Q = Q + self.reduced.velocity_load(kin, omega1)
        tau = self.external_torque(np.zeros_like(phi1) if t is None else np.asarray(t, dtype=float), kin)
        M = self.motor.torque_at(omega1)
        if modes is not None:
            M = np.where(modes == SLIDING, rules.equivalent_torque(half_dJ, Q, tau, omega1), M)
        eps = rules.acceleration(J, half_dJ, Q, M, tau, omega1)
        friction = {}
        if self.friction is not None:
            sliding = np.zeros(phi1.shape, bool) if modes is None else modes == SLIDING
            extra, friction = self.friction_outputs(kin, phi1, omega1, eps, J, sliding, t)
            eps = eps + extra
            M = np.where(sliding, M - friction["M_friction"], M)
        if modes is not None:
            eps = np.where(modes == STUCK, 0.0, eps)
            for name in friction:
                friction[name] = np.where(modes == STUCK, 0.0, friction[name])
        return {
            "epsilon1": eps,          # rad/s^2
            "M_motor": M,             # N.m
            "M_load": Q,              # N.m
            "J_red": J,               # kg.m^2
            "E_kin": rules.kinetic_energy(J, omega1),   # J
            **friction,
        }

    def friction_outputs(self, kin, phi1, omega1, epsilon1, J, sliding, t=None):
        """(the acceleration the joints' friction adds, rad/s2; its outputs) at arrays of states
        whose frictionless acceleration is ``epsilon1``: ``M_friction`` (N.m, the friction's
        generalised force on the crank), each joint's ``<joint>_Mf`` (N.m) or ``<joint>_Ff`` (N)
        and its power ``<joint>_Pf`` (W, <= 0). Where ``sliding`` the speed is held (eps = 0)."""
        ne = NewtonEuler(self.reduced, kin)
        loads = [f for load in self.reduced.loads for f in load.applied(kin, omega1)]
        times = np.zeros_like(phi1) if t is None else np.asarray(t, dtype=float)
        for port, value in zip(self.ports, self.port_values(times)):
            loads += port.applied(kin, value)
        b = ne.loaded(loads, omega1, np.where(sliding, 0.0, epsilon1))
        J = J + np.zeros_like(phi1)
        # at rest the frictions are those of the motion that follows, as the integrators take them
        # (modes.direction_at_rest): forward where the crank accelerates forward with them
        direction = np.sign(omega1)
        rest = direction == 0.0
        if np.any(rest):
            eps_forward = epsilon1 + self.friction.forward(ne, b, J, self.friction.signs(kin, 1.0))[0]
            eps_backward = epsilon1 + self.friction.forward(ne, b, J, self.friction.signs(kin, -1.0))[0]
            direction = np.where(rest, np.where(eps_forward > 0.0, 1.0, np.where(eps_backward < 0.0, -1.0, 0.0)),
                                 direction)
        signs = self.friction.signs(kin, direction)
        extra, f, _, generalised = self.friction.forward(ne, b, J, signs)
        # where the speed is held, the motion is prescribed: the frictions of eps = 0
        if np.any(sliding):
            _, f_held, _, g_held = self.friction.forward(ne, b, J, signs, held=True)
            f, generalised = np.where(sliding[:, None], f_held, f), np.where(sliding, g_held, generalised)
            extra = np.where(sliding, 0.0, extra)
        rates = self.friction.rates(kin)
        return extra, {"M_friction": generalised, **joint_values(self.friction.frictions, f, rates, omega1)}
