"""Dormand-Prince 5(4) on the tabulated reduced model, every switch located: the kernel's method.

The right-hand side evaluates the tables (``dynamics.tabulated``) and the motor line; the hybrid
rules (which mode, which surfaces end it, what follows an event) are ``dynamics.modes``'s, called
compiled. One home for the method: the tableau is ``tableau.py``'s, and this file holds the one
Dormand-Prince step, error norm, dense-output evaluation and event location of crankfmu (the
engine-based reference steps with scipy instead: an independent check).

Everything works on flat float arrays (layout in ``layout.py``) so that it compiles with numba and
runs unchanged as plain Python (``compiled.py``). This file runs as a copy outside the package
(see ``kernel/__init__.py``), so it cannot import its siblings: the modules it reads (``layout``,
``modes``, ``tableau``, ``compiled``) are put into its namespace before it runs.
"""

from __future__ import annotations

import math

import numpy as np

layout, modes, tableau, compiled = (globals()[name] for name in ("layout", "modes", "tableau", "compiled"))
_jit, _jit_inline = compiled.jit, compiled.jit_inline

_A = np.ascontiguousarray(tableau.A)
_B = np.ascontiguousarray(tableau.B)
_E = np.ascontiguousarray(tableau.E)
_P = np.ascontiguousarray(tableau.P)
N_STAGES = tableau.N_STAGES
_ERROR_EXPONENT = -1.0 / (tableau.ERROR_ESTIMATOR_ORDER + 1)
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
TWO_PI = 2.0 * math.pi

T, Y, F_, H = layout.T, layout.Y, layout.F_, layout.H
MOTOR, DIRECTION, INTERVAL, PHI_LO, PHI_HI = layout.MOTOR, layout.DIRECTION, layout.INTERVAL, layout.PHI_LO, layout.PHI_HI
T_PREV, Y_PREV, K = layout.T_PREV, layout.Y_PREV, layout.K
N_RHS, STEP_MOTOR, STEP_DIRECTION, STEP_INTERVAL, N_STEPS = (
    layout.N_RHS, layout.STEP_MOTOR, layout.STEP_DIRECTION, layout.STEP_INTERVAL, layout.N_STEPS)
A_, B_, A_LOW, B_LOW, OMEGA_SWITCH = layout.A_, layout.B_, layout.A_LOW, layout.B_LOW, layout.OMEGA_SWITCH
TAU_EXT, J_FLYWHEEL, RTOL, ATOL, H_MAX = layout.TAU_EXT, layout.J_FLYWHEEL, layout.RTOL, layout.ATOL, layout.H_MAX
LOW, HIGH, SLIDE = modes.LOW, modes.HIGH, modes.SLIDE
N_SLOTS = modes.N_SLOTS
NO_EVENT, UNDERFLOW = layout.NO_EVENT, layout.UNDERFLOW


@_jit_inline
def table_values(C, phi, work):
    """Every tabulated function at phi (rad) into work[0:n_functions]."""
    n = C.shape[1]
    h = TWO_PI / n
    wrapped = phi - TWO_PI * math.floor(phi / TWO_PI)
    i = int(wrapped / h)
    if i >= n:
        i = n - 1
    u = wrapped - i * h
    for f in range(C.shape[0]):
        work[f] = C[f, i, 0] + u * (C[f, i, 1] + u * (C[f, i, 2] + u * C[f, i, 3]))


@_jit_inline
def coefficients(phi, omega, direction, interval, C, forces, P, work):
    """(J kg.m2, 0.5 J' kg.m2/rad, Q N.m) with the slider forces of the given interval and direction."""
    table_values(C, phi, work)
    J = work[0] + P[J_FLYWHEEL]
    Q = work[2] + work[3] * omega
    if direction != 0.0:
        d = 0 if direction > 0.0 else 1
        k = int(interval)
        for s in range(forces.shape[2]):
            Q += forces[k, d, s] * work[4 + s]
    return J, work[1], Q


@_jit_inline
def motor_torque(omega, high, P):
    """Torque (N.m) of the given branch of the motor line in P."""
    if high:
        return modes.line_torque(P[A_], P[B_], omega)
    return modes.line_torque(P[A_LOW], P[B_LOW], omega)


@_jit_inline
def rhs(phi, omega, motor, direction, interval, C, forces, P, work, out):
    """d/dt (phi1, omega1, W_motor, W_load, W_ext) into out; returns (epsilon1, M_motor, Q, J)."""
    J, half_dJ, Q = coefficients(phi, omega, direction, interval, C, forces, P, work)
    tau = P[TAU_EXT]
    if direction == 0.0:          # stuck at rest (only slider forces can hold the crank so)
        M = motor_torque(0.0, motor == HIGH, P)
        eps = 0.0
        omega = 0.0
    elif motor == SLIDE:
        M = modes.equivalent_torque(half_dJ, Q, tau, omega)
        eps = 0.0
    else:
        M = motor_torque(omega, motor == HIGH, P)
        eps = modes.acceleration(J, half_dJ, Q, M, tau, omega)
    out[0] = omega
    out[1] = eps
    out[2] = M * omega
    out[3] = Q * omega
    out[4] = tau * omega
    return eps, M, Q, J


@_jit_inline
def dense(S, t, out):
    """State at t within the last step (quartic interpolant of the stages) into out[0:5]."""
    h = S[T] - S[T_PREV]
    if t == S[T] or h == 0.0:
        for j in range(5):
            out[j] = S[Y + j]
        return
    x = (t - S[T_PREV]) / h
    p0, p1, p2, p3 = x, x * x, x * x * x, x * x * x * x
    for j in range(5):
        acc = 0.0
        for s in range(N_STAGES + 1):
            acc += S[K + 5 * s + j] * (_P[s, 0] * p0 + _P[s, 1] * p1 + _P[s, 2] * p2 + _P[s, 3] * p3)
        out[j] = S[Y_PREV + j] + h * acc


@_jit
def _mode_on_switch(phi, direction, interval, C, forces, P, work):
    """Motor branch from a state on omega1 = omega_switch (modes.motor_on_switch)."""
    ws = P[OMEGA_SWITCH]
    J, half_dJ, Q = coefficients(phi, ws, direction, interval, C, forces, P, work)
    rest = Q + P[TAU_EXT] - half_dJ * ws * ws
    return modes.motor_on_switch(motor_torque(ws, False, P), motor_torque(ws, True, P), rest)


@_jit
def _direction_at_rest(phi, motor, interval, C, forces, P, work, f):
    """Side of the slider forces from rest at phi (modes.direction_at_rest)."""
    eps_forward = rhs(phi, 0.0, motor, 1.0, interval, C, forces, P, work, f)[0]
    eps_backward = rhs(phi, 0.0, motor, -1.0, interval, C, forces, P, work, f)[0]
    return modes.direction_at_rest(eps_forward, eps_backward)


@_jit
def _set_interval(S, switch, phi, direction):
    """S's switch interval: the one holding phi, entered in ``direction`` (modes.interval_of)."""
    k, lo, hi = modes.interval_of(switch, phi, direction)
    S[INTERVAL] = float(k)
    S[PHI_LO] = lo
    S[PHI_HI] = hi


@_jit
def start(S, t, y, C, switch, forces, P, work, f):
    """Initialise S at (t, y): discrete state, derivative and a first step size."""
    S[T] = t
    for j in range(5):
        S[Y + j] = y[j]
        S[Y_PREV + j] = y[j]
    S[T_PREV] = t
    omega = y[1]
    ws = P[OMEGA_SWITCH]
    motor = modes.motor_of_speed(omega, ws)
    direction = modes.direction_of_speed(omega)
    _set_interval(S, switch, y[0], direction)
    if omega == ws:
        motor = _mode_on_switch(y[0], direction, S[INTERVAL], C, forces, P, work)
    if omega == 0.0 and forces.shape[2] > 0:
        direction = _direction_at_rest(y[0], motor, S[INTERVAL], C, forces, P, work, f)
        _set_interval(S, switch, y[0], direction if direction != 0.0 else 1.0)
    S[MOTOR] = motor
    S[DIRECTION] = direction
    rhs(y[0], omega, motor, direction, S[INTERVAL], C, forces, P, work, f)
    for j in range(5):
        S[F_ + j] = f[j]
        for s in range(N_STAGES + 1):
            S[K + 5 * s + j] = f[j] if s == N_STAGES else 0.0
    d0 = 0.0
    d1 = 0.0
    for j in range(5):
        scale = P[ATOL] + P[RTOL] * abs(y[j])
        d0 += (y[j] / scale) ** 2
        d1 += (f[j] / scale) ** 2
    d0 = math.sqrt(d0 / 5.0)
    d1 = math.sqrt(d1 / 5.0)
    h = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    S[H] = min(h, P[H_MAX])
    S[N_RHS] += 1.0
    S[STEP_MOTOR] = motor
    S[STEP_DIRECTION] = direction
    S[STEP_INTERVAL] = S[INTERVAL]


@_jit_inline
def _rk_step(S, t, y, f, h, C, forces, P, work, Kst, ynew, tmp):
    """One Dormand-Prince step from (t, y, f) in S's discrete mode; stages into Kst (7x5)."""
    motor, direction, interval = S[MOTOR], S[DIRECTION], S[INTERVAL]
    for j in range(5):
        Kst[0, j] = f[j]
    for s in range(1, N_STAGES):
        for j in range(5):
            acc = 0.0
            for r in range(s):
                acc += Kst[r, j] * _A[s, r]
            tmp[j] = y[j] + h * acc
        rhs(tmp[0], tmp[1], motor, direction, interval, C, forces, P, work, Kst[s])
    for j in range(5):
        acc = 0.0
        for r in range(N_STAGES):
            acc += Kst[r, j] * _B[r]
        ynew[j] = y[j] + h * acc
    rhs(ynew[0], ynew[1], motor, direction, interval, C, forces, P, work, Kst[N_STAGES])


@_jit_inline
def _error_norm(y, ynew, Kst, h, P):
    """RMS over the state of the embedded error estimate, scaled by atol + rtol |y|."""
    acc = 0.0
    for j in range(5):
        e = 0.0
        for s in range(N_STAGES + 1):
            e += Kst[s, j] * _E[s]
        scale = P[ATOL] + P[RTOL] * max(abs(y[j]), abs(ynew[j]))
        acc += (h * e / scale) ** 2
    return math.sqrt(acc / 5.0)


@_jit_inline
def _events(S, y, C, forces, P, work, g):
    """Event functions of S's mode at state y into g[0:N_SLOTS]; inactive slots get NaN."""
    motor, direction = S[MOTOR], S[DIRECTION]
    ws = P[OMEGA_SWITCH]
    m_low = m_high = equivalent = 0.0
    if motor == SLIDE:
        J, half_dJ, Q = coefficients(y[0], ws, direction, S[INTERVAL], C, forces, P, work)
        equivalent = modes.equivalent_torque(half_dJ, Q, P[TAU_EXT], ws)
        m_low, m_high = motor_torque(ws, False, P), motor_torque(ws, True, P)
    has_sliders = forces.shape[2] > 0
    for slot in range(N_SLOTS):
        if modes.event_active(slot, motor, direction, S[PHI_HI], has_sliders, ws):
            g[slot] = modes.event_value(slot, y[0], y[1], motor, S[PHI_LO], S[PHI_HI], ws, m_low, m_high,
                                        equivalent)
        else:
            g[slot] = np.nan


@_jit
def _transition(S, slot, y, C, switch, forces, P, work, f):
    """Discrete state after the event in ``slot`` at state y (adjusted onto the surface)."""
    ws = P[OMEGA_SWITCH]
    if slot == modes.INTERVAL_END or slot == modes.INTERVAL_START:
        forward = slot == modes.INTERVAL_END
        y[0] = S[PHI_HI] if forward else S[PHI_LO]
        k, lo, hi = modes.next_interval(switch, int(S[INTERVAL]), S[PHI_LO], S[PHI_HI], forward)
        S[INTERVAL] = float(k)
        S[PHI_LO] = lo
        S[PHI_HI] = hi
        return
    y[1] = 0.0 if slot == modes.REST else ws
    if slot == modes.REST:
        S[MOTOR] = modes.motor_at_rest(S[MOTOR], ws)
    if modes.turns_forces(slot, ws, forces.shape[2] > 0):
        S[DIRECTION] = _direction_at_rest(y[0], S[MOTOR], S[INTERVAL], C, forces, P, work, f)
    if slot == modes.REST:
        return
    if S[MOTOR] == SLIDE:
        S[MOTOR] = modes.motor_after_sliding(slot)
    else:
        S[MOTOR] = _mode_on_switch(y[0], S[DIRECTION], S[INTERVAL], C, forces, P, work)


@_jit_inline
def omega_slope(S, x):
    """Sign-true slope of omega1 (h domega1/dt) at x in [0, 1] of the last step's interpolant."""
    acc = 0.0
    for s in range(N_STAGES + 1):
        acc += S[K + 5 * s + 1] * (_P[s, 0] + x * (2.0 * _P[s, 1] + x * (3.0 * _P[s, 2] + x * 4.0 * _P[s, 3])))
    return acc


@_jit
def locate(S, slot, level, lo, hi, glo, ghi, C, forces, P, work, tmp, g):
    """Time in [lo, hi] of the last step where g changes sign, by Illinois on the dense output:
    g is event slot ``slot`` of S's mode, phi1 - level for slot -1, or the slope of omega1 for
    slot -2 (an extreme). Returns the end of the final bracket (on or just past the surface)."""
    for _ in range(60):
        tm = hi - ghi * (hi - lo) / (ghi - glo)
        if not (lo < tm < hi):
            tm = 0.5 * (lo + hi)
        dense(S, tm, tmp)
        if slot == -2:
            gm = omega_slope(S, (tm - S[T_PREV]) / (S[T] - S[T_PREV]))
        elif slot == -1:
            gm = tmp[0] - level
        else:
            _events(S, tmp, C, forces, P, work, g)
            gm = g[slot]
        if (gm < 0.0) == (glo < 0.0):
            lo, glo = tm, gm
            ghi *= 0.5
        else:
            hi, ghi = tm, gm
            glo *= 0.5
        if hi - lo <= 1e-15 * max(1.0, abs(hi)):
            break
    return hi


@_jit
def step(S, t_limit, C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y, f0):
    """One accepted step, not beyond t_limit, ending on the first event crossed.

    Returns the event slot that ended it (modes' slots), NO_EVENT, or UNDERFLOW (step size).
    """
    t = S[T]
    for j in range(5):
        y[j] = S[Y + j]
        f0[j] = S[F_ + j]
    h = min(S[H], P[H_MAX])
    n_rhs = S[N_RHS]
    err = 0.0
    while True:
        if t + h >= t_limit:
            h = t_limit - t
        if h <= 1e-14 * max(1.0, abs(t)):
            return UNDERFLOW
        _rk_step(S, t, y, f0, h, C, forces, P, work, Kst, ynew, tmp)
        n_rhs += N_STAGES
        err = _error_norm(y, ynew, Kst, h, P)
        if err <= 1.0:
            break
        h *= max(MIN_FACTOR, SAFETY * err ** _ERROR_EXPONENT)
    factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err ** _ERROR_EXPONENT)
    h_next = min(h * factor, P[H_MAX])
    t_new = t_limit if t + h == t_limit else t + h

    # events: compare the event functions at both ends of the step
    _events(S, y, C, forces, P, work, g0)
    _events(S, ynew, C, forces, P, work, g1)
    S[T_PREV] = t
    S[T] = t_new
    for j in range(5):
        S[Y_PREV + j] = y[j]
        S[Y + j] = ynew[j]
        for s in range(N_STAGES + 1):
            S[K + 5 * s + j] = Kst[s, j]
    S[STEP_MOTOR] = S[MOTOR]
    S[STEP_DIRECTION] = S[DIRECTION]
    S[STEP_INTERVAL] = S[INTERVAL]
    first_slot = -1
    first_t = t_new
    for slot in range(N_SLOTS):
        a, b = g0[slot], g1[slot]
        if not modes.crosses(a, b, modes.event_rising(slot, S[MOTOR], S[DIRECTION])):
            continue
        hi = locate(S, slot, 0.0, t, t_new, a, b, C, forces, P, work, tmp, g1)
        if first_slot < 0 or hi < first_t:
            first_slot, first_t = slot, hi
    if first_slot < 0:
        for j in range(5):
            S[F_ + j] = Kst[N_STAGES, j]
        S[H] = h_next
        S[N_RHS] = n_rhs
        S[N_STEPS] += 1.0
        return NO_EVENT
    # recompute the step so that it ends on the event, then change mode there
    h_event = first_t - t
    _rk_step(S, t, y, f0, h_event, C, forces, P, work, Kst, ynew, tmp)
    n_rhs += N_STAGES
    S[T] = first_t
    for j in range(5):
        for s in range(N_STAGES + 1):
            S[K + 5 * s + j] = Kst[s, j]     # the old mode's stages: dense output up to the event
    _transition(S, first_slot, ynew, C, switch, forces, P, work, f)
    rhs(ynew[0], ynew[1], S[MOTOR], S[DIRECTION], S[INTERVAL], C, forces, P, work, f)
    for j in range(5):
        S[Y + j] = ynew[j]
        S[F_ + j] = f[j]
    S[H] = max(h_next, h_event)
    S[N_RHS] = n_rhs + 1.0
    S[N_STEPS] += 1.0
    return first_slot


@_jit
def output_row(S, t, C, forces, P, work, f, row):
    """The contract outputs at t within the last step into row (OUT_SIZE values)."""
    dense(S, t, row)
    if t == S[T]:
        motor, direction, interval = S[MOTOR], S[DIRECTION], S[INTERVAL]
    else:
        motor, direction, interval = S[STEP_MOTOR], S[STEP_DIRECTION], S[STEP_INTERVAL]
    eps, M, Q, J = rhs(row[0], row[1], motor, direction, interval, C, forces, P, work, f)
    row[5] = eps
    row[6] = M
    row[7] = Q
    row[8] = J


