"""The kernel's drivers: what callers run, each a loop over ``method.step``.

``advance`` is the FMU's whole fmi2DoStep; ``run_chunk`` a run of the fast integrator (outputs on
a grid, each step stored for dense output anywhere); ``dense_many`` that dense output;
``steady_batch`` the steady cycle of many designs (sweeps, flywheel sizing) by shooting over one
crank turn. Like ``method.py`` this file runs as a copy outside the package: ``layout``,
``method`` and ``compiled`` are put into its namespace before it runs.
"""

from __future__ import annotations

import math

import numpy as np

layout, method, compiled = (globals()[name] for name in ("layout", "method", "compiled"))
_jit = compiled.jit

T, Y, T_PREV, Y_PREV, MOTOR, DIRECTION, INTERVAL = (
    layout.T, layout.Y, layout.T_PREV, layout.Y_PREV, layout.MOTOR, layout.DIRECTION, layout.INTERVAL)
STEP_MOTOR, STEP_DIRECTION, STATE_SIZE = layout.STEP_MOTOR, layout.STEP_DIRECTION, layout.STATE_SIZE
UNDERFLOW = layout.UNDERFLOW
SLOPE_SAMPLES = layout.SLOPE_SAMPLES
STEADY_OK, STEADY_NOT_CONVERGED, STEADY_STALLS, STEADY_UNDERFLOW = (
    layout.STEADY_OK, layout.STEADY_NOT_CONVERGED, layout.STEADY_STALLS, layout.STEADY_UNDERFLOW)
N_STAGES, N_SLOTS = method.N_STAGES, method.N_SLOTS
TWO_PI = 2.0 * math.pi
step, start, dense, output_row = method.step, method.start, method.dense, method.output_row
_locate, _omega_slope = method.locate, method.omega_slope


@_jit
def begin(S, t, y, tables, P, ws, row):
    """Initialise S at (t, y) and fill the output row there: the start of an FMU or of a run."""
    C, switch, forces = tables
    work, Kst, ynew, tmp, f, g0, g1, y_, f0 = ws
    start(S, t, y, C, switch, forces, P, work, f)
    output_row(S, t, C, forces, P, work, f, row)


@_jit
def advance(S, t_target, t_limit, tables, P, ws, row):
    """Step until S reaches t_target (steps may end up to t_limit), outputs at t_target into row.

    Returns 0, or UNDERFLOW on a step size underflow. The FMU's whole fmi2DoStep.
    """
    C, switch, forces = tables
    work, Kst, ynew, tmp, f, g0, g1, y, f0 = ws
    while S[T] < t_target:
        if step(S, t_limit, C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y, f0) == UNDERFLOW:
            return UNDERFLOW
    output_row(S, t_target, C, forces, P, work, f, row)
    return 0


@_jit
def run_chunk(S, t_end, times, i_out, rows, step_store, n_store, events, n_events, modes, n_modes, tables, P, ws):
    """Step towards t_end, filling output rows at ``times`` and storing each step for dense output.

    step_store (capacity x STATE_SIZE) receives S after each step, events (capacity x 3) the
    (time, slot, motor branch ended) of each event, modes (capacity x 4) (time, motor, direction, interval) at each
    change. Returns (status, i_out, n_store, n_events, n_modes); status 0: t_end reached,
    1: a buffer is full (call again to continue), UNDERFLOW: step size underflow.
    """
    C, switch, forces = tables
    work, Kst, ynew, tmp, f, g0, g1, y, f0 = ws
    capacity = step_store.shape[0]
    while i_out < times.shape[0] and times[i_out] <= S[T]:      # outputs at the start time
        output_row(S, times[i_out], C, forces, P, work, f, rows[i_out])
        i_out += 1
    while S[T] < t_end:
        if n_store >= capacity or n_events >= events.shape[0] or n_modes >= modes.shape[0]:
            return 1, i_out, n_store, n_events, n_modes
        slot = step(S, t_end, C, switch, forces, P, work, Kst, ynew, tmp, f, g0, g1, y, f0)
        if slot == UNDERFLOW:
            return UNDERFLOW, i_out, n_store, n_events, n_modes
        while i_out < times.shape[0] and times[i_out] <= S[T]:
            output_row(S, times[i_out], C, forces, P, work, f, rows[i_out])
            i_out += 1
        step_store[n_store, :] = S
        n_store += 1
        if slot >= 0:
            events[n_events, 0] = S[T]
            events[n_events, 1] = slot
            events[n_events, 2] = S[STEP_MOTOR]        # the mode the event ended
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
def one_turn(S, phi_start, omega_start, t_max, tables, P, ws, stats, extremes):
    """Integrate one crank turn from (phi_start, omega_start) at t = 0.

    stats <- (omega1 at the end of the turn, min, max, period s). Returns 0, 2 when the crank
    stops or turns back before completing the turn (or takes longer than t_max), 3 on underflow.
    """
    C, switch, forces = tables
    work, Kst, ynew, tmp, f, g0, g1, y, f0 = ws
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
        if slot == UNDERFLOW:
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
def steady_batch(params, phi_start, omega_guess, rtol_shoot, max_turns, tables, out, ws):
    """The steady cycle of each design (row of params): omega1 at the start of the turn found by
    secant shooting on omega1(after one turn) - omega1(start), then that turn's statistics.

    out[i] <- (omega1_mean = 2 pi / period, omega1_min, omega1_max, delta, period, turns, status).
    """
    S = np.zeros(STATE_SIZE)
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
            code = one_turn(S, phi_start, w, t_max, tables, P, ws, stats, extremes)
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


@_jit
def dense_many(store, times, out):
    """States at ``times`` (s, each within the run) into out (len(times) x 5), from the kernel states
    stored after each step (``run_chunk``'s step_store, the start state first)."""
    t_nodes = store[:, T]
    last = store.shape[0] - 1
    for i in range(times.shape[0]):
        k = min(max(np.searchsorted(t_nodes, times[i]), 1), last)      # the step ending at or after t
        dense(store[k], times[i], out[i])
