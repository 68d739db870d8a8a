"""The movement equation's hybrid rules: the one home of each, as small scalar functions.

The right-hand side is smooth within a *mode*, the discrete state an integrator holds fixed
during a step: the motor branch (``LOW``, ``HIGH``, or ``SLIDE`` on a jump of the motor line),
the direction of the slider forces (+1, -1, or 0: stuck at rest) and the switch interval k of
the slider forces with its unwrapped angle bounds. What ends a mode is the crossing of a
switching surface, an *event slot*:

  MOTOR_SWITCH    omega1 = omega_switch (the line's kink); while sliding, the low line gives up
  SLIDE_HIGH      while sliding: the high line exceeds the need
  INTERVAL_END    phi1 reaches the end of the switch interval (crank turning forward)
  INTERVAL_START  phi1 reaches its start (crank turning backward)
  REST            omega1 = 0 with slider forces (they change direction)

These are the rules the scipy engine (``MovementEquation``, the independent reference) runs. The
C kernel (``native/kernel/crank_modes.h``) states each again in C, for the fast path and the FMUs:
tests/test_modes.py compares the two rule by rule on every mode and edge. Motor branches and
directions are floats (what the kernel's state array holds).
"""

from __future__ import annotations

import math
import numpy as np


TWO_PI = 2.0 * math.pi

# motor branches
LOW, HIGH, SLIDE = 0.0, 1.0, 2.0
MOTOR_NAMES = ("low", "high", "slide")
#: the names a run's mode record gives sliding on the switch and being stuck at rest
SLIDING, STUCK = MOTOR_NAMES[int(SLIDE)], "stuck"

# event slots
MOTOR_SWITCH, SLIDE_HIGH, INTERVAL_END, INTERVAL_START, REST = range(5)
N_SLOTS = 5
EVENT_NAMES = ("motor line kink (omega1 = omega_switch)",
               "sliding ends: the high line exceeds the need",
               "slider force switch angle (crank forward)",
               "slider force switch angle (crank backward)",
               "omega1 = 0: the slider forces change direction")
#: what slot MOTOR_SWITCH means while sliding
LOW_GIVES_UP = "sliding ends: the low line cannot hold omega_switch"


def mode_name(motor: float, direction: float) -> str:
    """What a run's mode record says: the motor branch, or ``"stuck"``."""
    return STUCK if direction == 0.0 else MOTOR_NAMES[int(motor)]


def event_name(slot: int, motor: float) -> str:
    """What a run's event record says for ``slot`` ended in a mode of motor branch ``motor``."""
    return LOW_GIVES_UP if slot == MOTOR_SWITCH and motor == SLIDE else EVENT_NAMES[slot]


# ------------------------------------------------------------------ the movement equation
def line_torque(A, B, omega):
    """Torque (N.m) of one motor line at omega1 (rad/s): A - B omega1, extended past its range."""
    return A - B * omega


def acceleration(J, half_dJ, Q, M, tau, omega):
    """domega1/dt (rad/s2) from J domega1/dt + 0.5 J' omega1^2 = M_motor + Q + tau_ext."""
    return (M + Q + tau - half_dJ * omega * omega) / J


def equivalent_torque(half_dJ, Q, tau, omega):
    """The motor torque (N.m) that holds domega1/dt = 0: what the motor delivers while sliding."""
    return half_dJ * omega * omega - Q - tau


def drive_torque(J, half_dJ, Q, tau, omega, epsilon):
    """The torque (N.m) a drive must apply to the crank to impose omega1 and epsilon1 (speed
    causality, inverse dynamics): J epsilon1 + 0.5 J' omega1^2 - Q - tau_ext. At epsilon1 = 0 it
    is the equivalent torque, and at constant omega1 the equilibrium moment M_e (seed 001 eq. 1)."""
    return J * epsilon + half_dJ * omega * omega - Q - tau


def kinetic_energy(J, omega):
    """E_kin (J) of the whole mechanism from the reduced inertia: 0.5 J omega1^2."""
    return 0.5 * J * (omega * omega)


# ------------------------------------------------------------------ which mode
def motor_of_speed(omega, omega_switch):
    """The motor branch off the switch: high above omega_switch, low at or below it."""
    return HIGH if omega > omega_switch else LOW


def direction_of_speed(omega):
    """The slider forces' side for a moving crank (forward at rest until ``direction_at_rest``)."""
    return -1.0 if omega < 0.0 else 1.0


def direction_imposed(omega):
    """The slider forces' side where the drive imposes omega1 (speed causality): omega1's sign, and
    none at rest (the crank held still by the drive feels no Coulomb force). Arrays too."""
    return np.where(omega > 0.0, 1.0, np.where(omega < 0.0, -1.0, 0.0))


def column_factor(forward, backward, direction):
    """A switched column's factor on the side ``direction`` from its values forward and backward on
    the interval: at rest (0) the value where the two agree (a load that does not depend on the
    direction: a contact, a kink of the position, a law of the speed), else none (a Coulomb force or
    a working stroke's, whose value at rest the mode decides). Arrays too."""
    at_rest = np.where(np.equal(forward, backward), forward, 0.0)
    return np.where(direction > 0.0, forward, np.where(direction < 0.0, backward, at_rest))


def motor_on_switch(m_low, m_high, rest):
    """Branch to continue in from omega1 = omega_switch, by Filippov's rule.

    m_low, m_high: the two lines' torques at omega_switch (N.m); rest: J domega1/dt there less
    the motor torque (Q + tau_ext - 0.5 J' omega_switch^2). A line that jumps down at the switch
    (below it the motor accelerates the crank, above it decelerates it) traps the speed on the
    switch: the solution slides along it with the equivalent torque (``SLIDE``). Without this
    rule an event-driven integrator chatters across the switch forever.
    """
    up_low = m_low + rest > 0.0
    up_high = m_high + rest > 0.0
    if up_low and up_high:
        return HIGH
    if not up_low and not up_high:
        return LOW
    if up_low and not up_high:
        return SLIDE          # both sides push into the switch
    return HIGH               # both push away (a jump up): leave upwards, the motor's side


def direction_at_rest(eps_forward, eps_backward):
    """Side of the slider forces from rest: the way the crank accelerates with the forces of that
    side (eps_forward: with the forward side's forces, eps_backward: the backward side's), or 0:
    stuck, the motor cannot move the crank against them."""
    if eps_forward > 0.0:
        return 1.0
    if eps_backward < 0.0:
        return -1.0
    return 0.0


def motor_at_rest(motor, omega_switch):
    """Motor branch once the crank comes to rest (REST): the low line, unless sliding (a switch
    at or below zero speed keeps its branch)."""
    if motor != SLIDE and omega_switch > 0.0:
        return LOW
    return motor


def motor_after_sliding(slot):
    """Branch after sliding ends: the low line gave up (MOTOR_SWITCH) or the high one suffices."""
    return LOW if slot == MOTOR_SWITCH else HIGH


def turns_forces(slot, omega_switch, has_sliders):
    """Whether the event in ``slot`` puts the crank at rest where the slider forces change side:
    REST, or the motor's switch when it lies at zero speed (one event that does both)."""
    if slot == REST:
        return True
    return slot <= SLIDE_HIGH and omega_switch == 0.0 and has_sliders


# ------------------------------------------------------------------ switch intervals
def interval_width(switch, k):
    """Angle (rad) from switch angle k to the next one round the turn."""
    m = switch.shape[0]
    end = switch[k + 1] if k + 1 < m else switch[0] + TWO_PI
    return end - switch[k]


def interval_of(switch, phi, direction):
    """(k, phi_lo, phi_hi): the switch interval holding crank angle phi (rad, unwrapped) and its
    unwrapped bounds around it (rad). On a switch angle the interval the motion enters wins
    (direction +1: the one starting there, -1: the one ending there). No switch angles:
    (0, -inf, inf)."""
    m = switch.shape[0]
    if m == 0:
        return 0, -np.inf, np.inf
    wrapped = phi - TWO_PI * math.floor(phi / TWO_PI)
    k = m - 1
    for i in range(m):
        if switch[i] <= wrapped:
            k = i
    if direction < 0.0 and wrapped == switch[k]:
        k = (k - 1) % m
    offset = wrapped - switch[k]
    if offset < 0.0:
        offset += TWO_PI
    return k, phi - offset, phi - offset + interval_width(switch, k)


def next_interval(switch, k, phi_lo, phi_hi, forward):
    """(k, phi_lo, phi_hi) of the neighbouring interval, by counting: the wrapped angle's rounding
    could put the crank back into the interval just left."""
    m = switch.shape[0]
    if forward:
        k = (k + 1) % m
        return k, phi_hi, phi_hi + interval_width(switch, k)
    k = (k - 1) % m
    return k, phi_lo - interval_width(switch, k), phi_lo


# ------------------------------------------------------------------ event surfaces
def event_active(slot, motor, direction, phi_hi, has_sliders, omega_switch):
    """Whether surface ``slot`` can end a mode (stuck: nothing changes until a restart)."""
    if direction == 0.0:
        return False
    if slot == MOTOR_SWITCH:
        return True
    if slot == SLIDE_HIGH:
        return motor == SLIDE
    if slot == REST:
        # a kink at rest is one event (MOTOR_SWITCH) that turns the forces too
        return has_sliders and omega_switch != 0.0
    return math.isfinite(phi_hi)


def event_value(slot, phi, omega, motor, phi_lo, phi_hi, omega_switch, m_low, m_high, equivalent):
    """g of surface ``slot`` at (phi1, omega1); m_low, m_high and equivalent (the torques at
    omega_switch, N.m) are read only while sliding."""
    if slot == MOTOR_SWITCH:
        if motor == SLIDE:
            return m_low - equivalent          # falls through 0: the low line gives up
        return omega - omega_switch
    if slot == SLIDE_HIGH:
        return equivalent - m_high             # falls through 0: the high line suffices
    if slot == INTERVAL_END:
        return phi - phi_hi
    if slot == INTERVAL_START:
        return phi - phi_lo
    return omega


def event_rising(slot, motor, direction):
    """Whether surface ``slot`` ends the mode when g rises through 0 (else when it falls)."""
    if slot == MOTOR_SWITCH:
        return motor == LOW
    if slot == INTERVAL_END:
        return True
    if slot == REST:
        return direction < 0.0
    return False


def crosses(g0, g1, rising):
    """Whether g went from g0 to g1 through 0 the way that ends the mode."""
    if not (math.isfinite(g0) and math.isfinite(g1)):
        return False
    if rising:
        return g0 < 0.0 <= g1
    return g0 > 0.0 >= g1
