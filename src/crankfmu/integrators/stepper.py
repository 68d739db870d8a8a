"""An error-controlled Runge-Kutta stepper whose whole state can be saved and restored.

Dormand-Prince 5(4) (the tableau and its quartic dense output from tableau.py), stepping the
movement equation mode by mode: after each accepted step the mode's event surfaces are checked;
a crossing is located on the dense output and the step is recomputed to end exactly on it, then
the mode changes (the motor line's kink, sliding on a jump, the slider forces' switches).

Unlike a scipy solver object, everything that determines the continuation is in
:class:`StepperState` (time, state, derivative, proposed step, mode, the last step's stages), so
a caller can keep a state and continue from it later: a rolled-back step is recomputed bit for bit. Output times inside
a step are served from the dense output: the step sequence does not depend on the communication
step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, SchemeError
from ..dynamics.equation import Mode
from . import tableau
from .base import Integrator, Trajectory

_A, _B, _C, _E, _P = tableau.A, tableau.B, tableau.C, tableau.E, tableau.P
_N_STAGES = tableau.N_STAGES
_ERROR_EXPONENT = -1.0 / (tableau.ERROR_ESTIMATOR_ORDER + 1)
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0


@dataclass
class StepperState:
    """All that determines the continuation of a run."""

    t: float
    y: np.ndarray
    f: np.ndarray
    h: float                 # proposed next step, s
    mode: Mode
    t_prev: float            # the last step, for dense output between t_prev and t
    y_prev: np.ndarray
    K: np.ndarray            # (n_stages + 1) x n stage derivatives of the last step
    n_rhs: int = 0


class DormandPrinceStepper:
    """Steps ``equation`` with rtol/atol error control, one accepted step per ``step`` call; the
    located events and mode changes are kept in ``events`` and ``modes``."""

    def __init__(self, equation, rtol: float, atol: float | None = None):
        if not (rtol > 0 and math.isfinite(rtol)):
            raise ParameterError(f"rtol must be > 0, got {rtol!r}", "rtol")
        self.equation = equation
        self.rtol = float(rtol)
        self.atol = float(rtol if atol is None else atol)
        self.events: list[tuple[float, str]] = []
        self.modes: list[tuple[float, str]] = []

    # ---------------------------------------------------------------- state
    def start(self, t: float, y) -> StepperState:
        y = np.array(y, dtype=float)
        mode = self.equation.initial_mode(t, y)
        f = self.equation.rhs(t, y, mode)
        scale = self.atol + self.rtol * np.abs(y)
        d0, d1 = _rms(y / scale), _rms(f / scale)
        h = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        K = np.zeros((_N_STAGES + 1, y.size))
        K[-1] = f
        self.modes.append((t, mode.name))
        return StepperState(t, y, f, float(h), mode, t, y, K, 1)

    def dense(self, state: StepperState, t: float) -> np.ndarray:
        """State at t in [t_prev, t] from the last step's quartic interpolant."""
        if t == state.t:
            return state.y.copy()
        h = state.t - state.t_prev
        if h == 0.0:
            return state.y.copy()
        x = (t - state.t_prev) / h
        p = np.array([x, x * x, x ** 3, x ** 4])
        return state.y_prev + h * (state.K.T @ (_P @ p))

    # ---------------------------------------------------------------- stepping
    def _rk_step(self, t, y, f, h, mode):
        K = np.empty((_N_STAGES + 1, y.size))
        K[0] = f
        rhs = self.equation.rhs
        for s in range(1, _N_STAGES):
            K[s] = rhs(t + _C[s] * h, y + h * (K[:s].T @ _A[s, :s]), mode)
        y_new = y + h * (K[:-1].T @ _B)
        K[-1] = rhs(t + h, y_new, mode)
        return y_new, K

    def _error(self, y, y_new, K, h):
        scale = self.atol + self.rtol * np.maximum(np.abs(y), np.abs(y_new))
        return _rms(h * (K.T @ _E) / scale)

    def step(self, state: StepperState, t_limit: float) -> StepperState:
        """One accepted step, not beyond t_limit, ending on an event surface if one is crossed."""
        t, y, f, mode = state.t, state.y, state.f, state.mode
        h = state.h
        n_rhs = state.n_rhs
        while True:
            if t + h >= t_limit:
                h = t_limit - t
            if h <= 1e-14 * max(1.0, abs(t)):
                raise SchemeError(f"dopri5: step size underflow at t = {t:.9g} s (mode {mode.name})")
            y_new, K = self._rk_step(t, y, f, h, mode)
            n_rhs += _N_STAGES
            err = self._error(y, y_new, K, h)
            if err <= 1.0:
                break
            h *= max(MIN_FACTOR, SAFETY * err ** _ERROR_EXPONENT)
        factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err ** _ERROR_EXPONENT)
        new = StepperState(t + h, y_new, K[-1].copy(), h * factor, mode, t, y, K, n_rhs)
        if t + h == t_limit:
            new.t = t_limit           # exact, not t + (t_limit - t)
        return self._handle_events(state, new)

    def _handle_events(self, old: StepperState, new: StepperState) -> StepperState:
        surfaces = self.equation.events(old.mode)
        if not surfaces:
            return new
        y0, y1 = old.y, new.y
        first = None
        for i, (g, direction, _, _) in enumerate(surfaces):
            g0, g1 = g(old.t, y0), g(new.t, y1)
            crosses = (g0 < 0.0 <= g1) if direction > 0 else (g0 > 0.0 >= g1)
            if not crosses:
                continue
            # locate on the dense output (Illinois / regula falsi in theta)
            lo, hi, glo, ghi = old.t, new.t, g0, g1
            for _ in range(60):
                tm = hi - ghi * (hi - lo) / (ghi - glo)
                if not (lo < tm < hi):
                    tm = 0.5 * (lo + hi)
                gm = g(tm, self.dense(new, tm))
                if (gm < 0.0) == (glo < 0.0):
                    lo, glo = tm, gm
                    ghi *= 0.5
                else:
                    hi, ghi = tm, gm
                    glo *= 0.5
                if hi - lo <= 1e-15 * max(1.0, abs(hi)):
                    break
            if first is None or hi < first[0]:
                first = (hi, surfaces[i])
        if first is None:
            return new
        t_event, surface = first
        # recompute the step so that it ends on the event, then switch mode there
        y, f = old.y, old.f
        h = t_event - old.t
        y_e, K = self._rk_step(old.t, y, f, h, old.mode)
        n_rhs = new.n_rhs + _N_STAGES
        mode = self.equation.transition(old.mode, surface.kind, t_event, y_e)
        f_e = self.equation.rhs(t_event, y_e, mode)   # K keeps the old mode's stages: dense output
        self.events.append((t_event, surface.what))
        if mode.name != self.modes[-1][1]:
            self.modes.append((t_event, mode.name))
        return StepperState(t_event, y_e, f_e, max(new.h, h), mode, old.t, y, K, n_rhs + 1)


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


class DormandPrinceIntegrator(Integrator):
    """The FMU's integrator, run in process: same steps, same numbers."""

    name = "dopri5"

    def __init__(self, rtol: float = 1e-10, atol: float | None = None):
        self.rtol = float(rtol)
        self.atol = float(rtol if atol is None else atol)
        self.method = "Dormand-Prince 5(4), located events"

    def run(self, equation, t0, y0, t_end, progress=None, output_times=None):
        stepper = DormandPrinceStepper(equation, self.rtol, self.atol)
        state = stepper.start(t0, y0)
        ts, ys, states = [state.t], [state.y], [state]
        while state.t < t_end:
            state = stepper.step(state, t_end)
            ts.append(state.t)
            ys.append(state.y)
            states.append(state)
            if progress is not None and len(ts) % 200 == 0:
                progress(state.t)
        t_nodes = np.array(ts)

        def dense(times):
            times = np.atleast_1d(times)
            idx = np.clip(np.searchsorted(t_nodes, times, side="left"), 1, len(states) - 1)
            return np.column_stack([stepper.dense(states[i], tt) for i, tt in zip(idx, times)])
        return Trajectory(t=t_nodes, y=np.array(ys).T, dense=dense, events=stepper.events,
                          modes=stepper.modes, n_rhs=state.n_rhs, n_steps=len(ts) - 1)
