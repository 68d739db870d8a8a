"""The fast path's hot loop: Dormand-Prince 5(4) on the tabulated reduced model, events located.

Everything here works on flat float arrays so that it compiles with numba (``nopython``) and runs
unchanged as plain Python where numba is absent or ``CRANKFMU_JIT=0`` is set: the same arithmetic
in the same order, hence the same numbers (tests compare the two). numba was chosen over a C
extension because the FMU already needs a Python interpreter and the model's tables come from
numpy; it needs no compiler on the user's machine and caches its machine code on disk.

The whole integrator state is one float array (layout below), so an FMU saves and restores it by
copying, and a run can stop and continue (progress, growing output buffers) without a trace.

Discrete state ("mode"): the motor branch (low, high, or sliding on a jump of the motor line),
the direction of motion of the slider forces (+1, -1, or 0 = stuck: the crank at rest held by
the slider forces), and the switch interval k of the slider forces, with its unwrapped angle
bounds. Events end a step exactly on:

  slot 0, 1  the motor line's kink, omega1 = omega_switch (sliding: the two ends of sliding)
  slot 2     phi1 reaches the end of the switch interval (crank turning forward)
  slot 3     phi1 reaches its start (turning backward)
  slot 4     omega1 = 0 with slider forces (they change direction)
"""

from __future__ import annotations

import math
import os

import numpy as np

# ``tableau`` is integrators/tableau.py, put into this module's namespace by fast.load_kernel
# before it runs this file: the file runs as a copy outside the package (see there), so it cannot
# import its siblings
tableau = globals()["tableau"]

_A = np.ascontiguousarray(tableau.A)
_B = np.ascontiguousarray(tableau.B)
_C = np.ascontiguousarray(tableau.C)
_E = np.ascontiguousarray(tableau.E)
_P = np.ascontiguousarray(tableau.P)
DENSE_P = _P        # the dense output's polynomial coefficients, for evaluating stored steps
N_STAGES = tableau.N_STAGES
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
TWO_PI = 2.0 * math.pi

# ---- state array layout
T, Y, F_, H = 0, 1, 6, 11                    # t s, y[5], f[5], proposed step s
MOTOR, DIRECTION, INTERVAL, PHI_LO, PHI_HI = 12, 13, 14, 15, 16
T_PREV, Y_PREV, K = 17, 18, 23               # last step: start, start state, 7x5 stages
N_RHS, STEP_MOTOR, STEP_DIRECTION, STEP_INTERVAL, N_STEPS = 58, 59, 60, 61, 62
STATE_SIZE = 63
# ---- parameter array layout
A_, B_, A_LOW, B_LOW, OMEGA_SWITCH, TAU_EXT, J_FLYWHEEL, RTOL, ATOL, H_MAX = range(10)
PARAM_SIZE = 10
# ---- modes
LOW, HIGH, SLIDE = 0.0, 1.0, 2.0
MODE_NAMES = {0: "low", 1: "high", 2: "slide"}
EVENT_NAMES = ("motor line kink (omega1 = omega_switch)", "sliding on the motor switch ends",
               "slider force switch angle (crank forward)", "slider force switch angle (crank backward)",
               "omega1 = 0: the slider forces change direction")
N_SLOTS = 5
# ---- output row: the state, then epsilon1, M_motor, M_load, J_red (output_row)
ROW_FIELDS = ("phi1", "omega1", "W_motor", "W_load", "W_ext", "epsilon1", "M_motor", "M_load", "J_red")
OUT_SIZE = len(ROW_FIELDS)

_USE_JIT = os.environ.get("CRANKFMU_JIT", "1") != "0"
try:
    if not _USE_JIT:
        raise ImportError
    import numba

    def _jit(function):
        return numba.njit(cache=True, nogil=True, error_model="numpy")(function)

    def _jit_inline(function):
        # the hot helpers are inlined at numba's level: a call between compiled functions with
        # array arguments otherwise costs reference counting on each array (about 150 ns per RHS)
        return numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")(function)
    COMPILED = True
except ImportError:
    def _jit(function):
        return function
    _jit_inline = _jit
    COMPILED = False


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
    if high:
        return P[A_] - P[B_] * omega
    return P[A_LOW] - P[B_LOW] * omega


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
        M = half_dJ * omega * omega - Q - tau
        eps = 0.0
    else:
        M = motor_torque(omega, motor == HIGH, P)
        eps = (M + Q + tau - half_dJ * omega * omega) / J
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
    """Motor mode from a state on omega1 = omega_switch (Filippov's rule, see MovementEquation)."""
    ws = P[OMEGA_SWITCH]
    J, half_dJ, Q = coefficients(phi, ws, direction, interval, C, forces, P, work)
    rest = Q + P[TAU_EXT] - half_dJ * ws * ws
    up_low = motor_torque(ws, False, P) + rest > 0.0
    up_high = motor_torque(ws, True, P) + rest > 0.0
    if up_low and up_high:
        return HIGH
    if not up_low and not up_high:
        return LOW
    if up_low and not up_high:
        return SLIDE
    return HIGH


@_jit
def _direction_at_rest(phi, motor, interval, C, forces, P, work, f):
    """Direction of the slider forces from rest: the way the crank accelerates, or 0 (stuck)."""
    eps_up = rhs(phi, 0.0, motor, 1.0, interval, C, forces, P, work, f)[0]
    if eps_up > 0.0:
        return 1.0
    eps_down = rhs(phi, 0.0, motor, -1.0, interval, C, forces, P, work, f)[0]
    if eps_down < 0.0:
        return -1.0
    return 0.0


@_jit
def _set_interval(S, switch, phi, direction):
    """Switch interval holding phi (ties go to the interval the motion enters) and its bounds."""
    m = switch.shape[0]
    if m == 0:
        S[INTERVAL] = 0.0
        S[PHI_LO] = -np.inf
        S[PHI_HI] = np.inf
        return
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
    S[INTERVAL] = float(k)
    S[PHI_LO] = phi - offset
    S[PHI_HI] = phi - offset + _width(switch, k)


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
    motor = HIGH if omega > ws else LOW
    direction = 1.0 if omega > 0.0 else (-1.0 if omega < 0.0 else 1.0)
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
def _events(S, y, C, forces, P, work, g):
    """Event functions of S's mode at state y into g[0:5]; inactive slots get NaN."""
    for i in range(N_SLOTS):
        g[i] = np.nan
    motor, direction = S[MOTOR], S[DIRECTION]
    ws = P[OMEGA_SWITCH]
    if direction == 0.0:          # stuck: nothing changes until a restart
        return
    if motor == SLIDE:
        J, half_dJ, Q = coefficients(y[0], ws, direction, S[INTERVAL], C, forces, P, work)
        equivalent = half_dJ * ws * ws - Q - P[TAU_EXT]
        g[0] = motor_torque(ws, False, P) - equivalent          # falls through 0: low line gives up
        g[1] = equivalent - motor_torque(ws, True, P)           # falls through 0: high line suffices
    else:
        g[0] = y[1] - ws
    if math.isfinite(S[PHI_HI]):
        g[2] = y[0] - S[PHI_HI]
        g[3] = y[0] - S[PHI_LO]
    if forces.shape[2] > 0:
        g[4] = y[1]


@_jit_inline
def _crosses(slot, g0, g1, motor, direction):
    if not (math.isfinite(g0) and math.isfinite(g1)):
        return False
    if slot == 0:
        if motor == SLIDE:
            return g0 > 0.0 >= g1
        if motor == LOW:
            return g0 < 0.0 <= g1
        return g0 > 0.0 >= g1
    if slot == 1:
        return g0 > 0.0 >= g1
    if slot == 2:
        return g0 < 0.0 <= g1
    if slot == 3:
        return g0 > 0.0 >= g1
    if direction > 0.0:
        return g0 > 0.0 >= g1
    return g0 < 0.0 <= g1


@_jit_inline
def _width(switch, k):
    """Angle (rad) from switch angle k to the next one round the turn."""
    m = switch.shape[0]
    end = switch[k + 1] if k + 1 < m else switch[0] + TWO_PI
    return end - switch[k]


@_jit
def _transition(S, slot, y, C, switch, forces, P, work, f):
    """Discrete state after the event in ``slot`` at state y (adjusted onto the surface)."""
    ws = P[OMEGA_SWITCH]
    m = switch.shape[0]
    if slot == 0 or slot == 1:
        y[1] = ws
        if ws == 0.0 and forces.shape[2] > 0:
            # the kink is at rest: the slider forces change direction at the same instant
            S[DIRECTION] = _direction_at_rest(y[0], S[MOTOR], S[INTERVAL], C, forces, P, work, f)
        if S[MOTOR] == SLIDE:
            S[MOTOR] = LOW if slot == 0 else HIGH
        else:
            S[MOTOR] = _mode_on_switch(y[0], S[DIRECTION], S[INTERVAL], C, forces, P, work)
    elif slot == 2:
        y[0] = S[PHI_HI]
        k = (int(S[INTERVAL]) + 1) % m
        S[INTERVAL] = float(k)
        S[PHI_LO] = S[PHI_HI]
        S[PHI_HI] = S[PHI_LO] + _width(switch, k)
    elif slot == 3:
        y[0] = S[PHI_LO]
        k = (int(S[INTERVAL]) - 1) % m
        S[INTERVAL] = float(k)
        S[PHI_HI] = S[PHI_LO]
        S[PHI_LO] = S[PHI_HI] - _width(switch, k)
    else:
        y[1] = 0.0
        if S[MOTOR] != SLIDE and ws > 0.0:
            S[MOTOR] = LOW
        S[DIRECTION] = _direction_at_rest(y[0], S[MOTOR], S[INTERVAL], C, forces, P, work, f)


@_jit_inline
def _omega_slope(S, x):
    """Sign-true slope of omega1 (h domega1/dt) at x in [0, 1] of the last step's interpolant."""
    acc = 0.0
    for s in range(N_STAGES + 1):
        acc += S[K + 5 * s + 1] * (_P[s, 0] + x * (2.0 * _P[s, 1] + x * (3.0 * _P[s, 2] + x * 4.0 * _P[s, 3])))
    return acc


@_jit
def _locate(S, slot, level, lo, hi, glo, ghi, C, forces, P, work, tmp, g):
    """Time in [lo, hi] of the last step where g changes sign, by Illinois on the dense output:
    g is event slot ``slot`` of S's mode, phi1 - level for slot -1, or the slope of omega1 for
    slot -2 (an extreme). Returns the end of the final bracket (on or just past the surface)."""
    for _ in range(60):
        tm = hi - ghi * (hi - lo) / (ghi - glo)
        if not (lo < tm < hi):
            tm = 0.5 * (lo + hi)
        dense(S, tm, tmp)
        if slot == -2:
            gm = _omega_slope(S, (tm - S[T_PREV]) / (S[T] - S[T_PREV]))
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

    Returns the event slot that ended it (0..4), -1 for none, -2 for a step size underflow.
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
            return -2
        _rk_step(S, t, y, f0, h, C, forces, P, work, Kst, ynew, tmp)
        n_rhs += N_STAGES
        acc = 0.0
        for j in range(5):
            e = 0.0
            for s in range(N_STAGES + 1):
                e += Kst[s, j] * _E[s]
            scale = P[ATOL] + P[RTOL] * max(abs(y[j]), abs(ynew[j]))
            acc += (h * e / scale) ** 2
        err = math.sqrt(acc / 5.0)
        if err <= 1.0:
            break
        h *= max(MIN_FACTOR, SAFETY * err ** -0.2)
    factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err ** -0.2)
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
        if not _crosses(slot, a, b, S[MOTOR], S[DIRECTION]):
            continue
        hi = _locate(S, slot, 0.0, t, t_new, a, b, C, forces, P, work, tmp, g1)
        if first_slot < 0 or hi < first_t:
            first_slot, first_t = slot, hi
    if first_slot < 0:
        for j in range(5):
            S[F_ + j] = Kst[N_STAGES, j]
        S[H] = h_next
        S[N_RHS] = n_rhs
        S[N_STEPS] += 1.0
        return -1
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


class Workspace:
    """Scratch arrays of one integration (allocated once, reused by every call)."""

    def __init__(self, n_functions: int):
        self.work = np.zeros(max(n_functions, 4))
        self.Kst = np.zeros((N_STAGES + 1, 5))
        self.ynew = np.zeros(5)
        self.tmp = np.zeros(5)
        self.f = np.zeros(5)
        self.g0 = np.zeros(N_SLOTS)
        self.g1 = np.zeros(N_SLOTS)
        self.y = np.zeros(5)
        self.f0 = np.zeros(5)

    def arrays(self):
        """The scratch arrays in the order the kernel's stepping functions take them."""
        return self.work, self.Kst, self.ynew, self.tmp, self.f, self.g0, self.g1, self.y, self.f0


@_jit
def advance(S, t_target, t_limit, C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y, f0, row):
    """Step until S reaches t_target (steps may end up to t_limit), outputs at t_target into row.

    Returns 0, or -2 on a step size underflow. The FMU's whole fmi2DoStep.
    """
    while S[T] < t_target:
        if step(S, t_limit, C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y, f0) == -2:
            return -2
    output_row(S, t_target, C, forces, P, work, f, row)
    return 0


@_jit
def run_chunk(S, t_end, times, i_out, rows, step_store, n_store, events, n_events, modes, n_modes,
              C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y, f0):
    """Step towards t_end, filling output rows at ``times`` and storing each step for dense output.

    step_store (capacity x STATE_SIZE) receives S after each step, events (capacity x 2) the
    (time, slot) of each event, modes (capacity x 4) (time, motor, direction, interval) at each
    change. Returns (status, i_out, n_store, n_events, n_modes); status 0: t_end reached,
    1: a buffer is full (call again to continue), -2: step size underflow.
    """
    capacity = step_store.shape[0]
    while i_out < times.shape[0] and times[i_out] <= S[T]:      # outputs at the start time
        output_row(S, times[i_out], C, forces, P, work, f, rows[i_out])
        i_out += 1
    while S[T] < t_end:
        if n_store >= capacity or n_events >= events.shape[0] or n_modes >= modes.shape[0]:
            return 1, i_out, n_store, n_events, n_modes
        slot = step(S, t_end, C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y, f0)
        if slot == -2:
            return -2, i_out, n_store, n_events, n_modes
        while i_out < times.shape[0] and times[i_out] <= S[T]:
            output_row(S, times[i_out], C, forces, P, work, f, rows[i_out])
            i_out += 1
        step_store[n_store, :] = S
        n_store += 1
        if slot >= 0:
            events[n_events, 0] = S[T]
            events[n_events, 1] = slot
            n_events += 1
            if (S[MOTOR] != S[STEP_MOTOR] or S[DIRECTION] != S[STEP_DIRECTION]):
                modes[n_modes, 0] = S[T]
                modes[n_modes, 1] = S[MOTOR]
                modes[n_modes, 2] = S[DIRECTION]
                modes[n_modes, 3] = S[INTERVAL]
                n_modes += 1
    return 0, i_out, n_store, n_events, n_modes


# ------------------------------------------------------------------------------------------
# steady cycles of many designs (sweeps, flywheel sizing)
# ------------------------------------------------------------------------------------------
SLOPE_SAMPLES = 8    # the speed's slope is sampled at 9 points of each step to bracket its extremes
STEADY_SIZE = 7      # omega1_mean, omega1_min, omega1_max, delta, period, turns, status
STEADY_OK, STEADY_NOT_CONVERGED, STEADY_STALLS, STEADY_UNDERFLOW = 0.0, 1.0, 2.0, 3.0


@_jit
def _step_extremes(S, t_end, C, forces, P, work, tmp, g, extremes):
    """Lowest and highest omega1 (rad/s) of the last step up to t_end into extremes[0:2].

    They lie at the step's ends or where the interpolant's slope changes sign; a sign change
    between slope samples is located, so an extreme is found to the interpolant's own accuracy
    (the error tolerance) whatever the step size, not to a sampling error O(h^2).
    """
    dense(S, S[T_PREV], tmp)
    lowest = tmp[1]
    highest = tmp[1]
    dense(S, t_end, tmp)
    lowest = min(lowest, tmp[1])
    highest = max(highest, tmp[1])
    h = S[T] - S[T_PREV]
    if h > 0.0:
        ta = S[T_PREV]
        da = _omega_slope(S, 0.0)
        for i in range(1, SLOPE_SAMPLES + 1):
            tb = S[T_PREV] + (t_end - S[T_PREV]) * i / SLOPE_SAMPLES
            db = _omega_slope(S, (tb - S[T_PREV]) / h)
            if (da > 0.0 >= db) or (da < 0.0 <= db):
                dense(S, _locate(S, -2, 0.0, ta, tb, da, db, C, forces, P, work, tmp, g), tmp)
                lowest = min(lowest, tmp[1])
                highest = max(highest, tmp[1])
            ta, da = tb, db
    extremes[0] = lowest
    extremes[1] = highest


@_jit
def one_turn(S, phi_start, omega_start, t_max, C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y, f0,
             stats, extremes):
    """Integrate one crank turn from (phi_start, omega_start) at t = 0.

    stats <- (omega1 at the end of the turn, min, max, period s). Returns 0, 2 when the crank
    stops or turns back before completing the turn (or takes longer than t_max), 3 on underflow.
    """
    for j in range(5):
        y[j] = 0.0
    y[0] = phi_start
    y[1] = omega_start
    S[:] = 0.0
    start(S, 0.0, y, C, switch, forces, P, work, f)
    phi_end = phi_start + TWO_PI
    w_min = omega_start
    w_max = omega_start
    while True:
        slot = step(S, t_max, C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y, f0)
        if slot == -2:
            return 3
        done = S[Y] >= phi_end
        t_end = S[T]
        if done:              # the time the turn ends
            t_end = _locate(S, -1, phi_end, S[T_PREV], S[T], S[Y_PREV] - phi_end, S[Y] - phi_end,
                            C, forces, P, work, tmp, g0)
        _step_extremes(S, t_end, C, forces, P, work, tmp, g0, extremes)
        w_min = min(w_min, extremes[0])
        w_max = max(w_max, extremes[1])
        if done:
            dense(S, t_end, tmp)
            stats[0] = tmp[1]
            stats[1] = w_min
            stats[2] = w_max
            stats[3] = t_end
            return 0
        if S[Y + 1] <= 0.0 or S[T] >= t_max:
            return 2


@_jit
def steady_batch(params, phi_start, omega_guess, rtol_shoot, max_turns, C, switch, forces, out):
    """The steady cycle of each design (row of params): omega1 at the start of the turn found by
    secant shooting on omega1(after one turn) - omega1(start), then that turn's statistics.

    out[i] <- (omega1_mean = 2 pi / period, omega1_min, omega1_max, delta, period, turns, status).
    """
    S = np.zeros(STATE_SIZE)
    work = np.zeros(max(C.shape[0], 4))
    Kst = np.zeros((N_STAGES + 1, 5))
    ynew = np.zeros(5)
    tmp = np.zeros(5)
    f = np.zeros(5)
    g0 = np.zeros(N_SLOTS)
    g1 = np.zeros(N_SLOTS)
    y = np.zeros(5)
    f0 = np.zeros(5)
    stats = np.zeros(4)
    extremes = np.zeros(2)
    for d in range(params.shape[0]):
        P = params[d]
        w = omega_guess[d]
        w_prev = 0.0
        r_prev = 0.0
        status = STEADY_NOT_CONVERGED
        turns = 0
        for it in range(max_turns):
            t_max = 1000.0 * TWO_PI / max(abs(w), 1e-3)
            code = one_turn(S, phi_start, w, t_max, C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y,
                            f0, stats, extremes)
            turns += 1
            if code == 2:
                status = STEADY_STALLS
                break
            if code == 3:
                status = STEADY_UNDERFLOW
                break
            r = stats[0] - w
            if abs(r) <= rtol_shoot * abs(w):
                status = STEADY_OK
                break
            if it == 0 or r == r_prev:
                w_next = stats[0]                       # one fixed-point turn first
            else:
                w_next = w - r * (w - w_prev) / (r - r_prev)
            if not (w_next > 0.0):
                w_next = 0.5 * w
            w_prev, r_prev = w, r
            w = w_next
        period = stats[3]
        mean = TWO_PI / period if period > 0.0 else np.nan
        out[d, 0] = mean
        out[d, 1] = stats[1]
        out[d, 2] = stats[2]
        out[d, 3] = (stats[2] - stats[1]) / mean
        out[d, 4] = period
        out[d, 5] = turns
        out[d, 6] = status
