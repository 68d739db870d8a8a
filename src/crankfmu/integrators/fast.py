"""The fast path: the C kernel on the tabulated reduced model, behind ``Integrator.run``.

``FastIntegrator`` is ``simulate(scenario, method="fast", rtol=...)``. It tabulates the model's
reduced coefficients once (``tabulated.table_of``, once per model), then runs the C kernel of
:mod:`crankfmu.native` in chunks: each chunk fills the output rows that fall in it and
stores its steps for dense output anywhere in the run. Link-level kinematics are never computed
during the run; the contract outputs come from the tables.

``FastStepper`` is the same kernel one communication step at a time, for the FMU.
"""

from __future__ import annotations

import math

import numpy as np

from ..dynamics import modes as hybrid
from ..dynamics.tabulated import table_of
from ..errors import ParameterError, SchemeError
from .base import Integrator, Trajectory
from .. import native as kernel


#: default rtol of the fast path (atol equal): on seed 000 it gives 6.6e-9 rad/s (max omega1 error over 2 s)
DEFAULT_RTOL = 1e-11
#: relative tolerance the tables are checked to (well below the integrator's error)
TABLE_TOLERANCE = 1e-11


def _check_rtol(rtol):
    if not (rtol > 0 and math.isfinite(rtol)):
        raise ParameterError(f"rtol must be > 0, got {rtol!r}", "rtol")


def dense_from_store(store: np.ndarray, times) -> np.ndarray:
    """States (5 x len(times)) from stored kernel states (one row per step, the start first)."""
    times = np.atleast_1d(np.asarray(times, dtype=float))
    out = np.zeros((times.size, kernel.N_Y))
    kernel.dense_many(store, times, out)
    return out.T


class FastIntegrator(Integrator):
    """Dormand-Prince 5(4) in C on the tabulated model, every discontinuity located."""

    name = "fast"
    #: the model this integrator runs is tabulated to this (Scenario.build(table=...))
    table_tolerance = TABLE_TOLERANCE

    def __init__(self, rtol: float | None = None, atol: float | None = None, chunk: int = 4096):
        rtol = DEFAULT_RTOL if rtol is None else rtol
        _check_rtol(rtol)
        self.rtol = float(rtol)
        self.atol = float(rtol if atol is None else atol)
        self.chunk = chunk
        self.method = "Dormand-Prince 5(4) on the tabulated model (C kernel)"

    def run(self, equation, t0, y0, t_end, progress=None, output_times=None):
        table = table_of(equation.reduced, TABLE_TOLERANCE)
        stepper = FastStepper(table, equation.motor, equation.reduced.J_flywheel, self.rtol, equation.tau_ext,
                              atol=self.atol)
        timed = any(callable(u) for u in equation.port_inputs)
        stepper.set_port_inputs(equation.port_values(t0))
        stepper.start(t0, y0)
        S = stepper.state
        times = np.zeros(0) if output_times is None else np.asarray(output_times, dtype=float)
        if timed:
            # an input given as a function of time enters the kernel linear in time between output
            # times (or every 1 ms without them): its value at each, the slope to the next. The
            # torque stays continuous, so the stepper goes on without a restart at those times.
            grid = times if times.size else np.arange(t0, t_end, 1e-3)
            ramp = np.unique(np.concatenate([[t0], grid[(grid > t0) & (grid < t_end)], [t_end]]))
            values = np.array([equation.port_values(t) for t in ramp], dtype=float)
        else:
            ramp = np.array([t0, t_end])
        rows = np.zeros((times.size, kernel.OUT_SIZE))
        friction = equation.friction is not None
        # with joint friction: each output time's frictions and their generalised force (n_f + 1)
        frictions = np.zeros((times.size, len(equation.friction) + 1)) if friction else None
        i_out = 0
        stores, events, modes = [S[None, :].copy()], [], [(float(t0), _mode_name(S))]
        k = 0
        while True:
            if timed:
                stepper.set_port_inputs(values[k], (values[k + 1] - values[k]) / (ramp[k + 1] - ramp[k]), ramp[k])
            store = np.empty((self.chunk, kernel.STATE_SIZE))     # the kernel fills each row it counts
            ev = np.empty((self.chunk, 3))
            md = np.empty((self.chunk, 4))
            i_first = i_out
            status, i_out, n_store, n_ev, n_md = kernel.run_chunk(
                S, float(ramp[k + 1]), times, i_out, rows, store, 0, ev, 0, md, 0, stepper.tables, stepper.P)
            if friction and i_out > i_first:
                # (from the chunk's steps and the one before: an output at the chunk's start is there)
                steps = np.concatenate([stores[-1][-1:], store[:n_store]])
                frictions[i_first:i_out] = kernel.friction_values(steps, times[i_first:i_out], rows[i_first:i_out, 5],
                                                                  stepper.tables, stepper.P)
            stores.append(store[:n_store])
            events += [(float(t), hybrid.event_name(int(slot), motor)) for t, slot, motor in ev[:n_ev]]
            modes += [(float(r[0]), _mode_name(r[1:], row=True)) for r in md[:n_md]]
            if progress is not None:
                progress(float(S[kernel.T]))
            if status == 0:
                k += 1
                if k + 1 >= ramp.size:
                    break
                continue
            if status != 1:                     # 1: a buffer is full, the next chunk continues
                refused(status, S)
        store = np.concatenate(stores)
        n_y = equation.state_size           # (W_friction is a state with joint friction)
        trajectory = Trajectory(t=store[:, kernel.T].copy(), y=store[:, kernel.Y:kernel.Y + n_y].T.copy(),
                                dense=lambda tt: dense_from_store(store, tt)[:n_y], events=events, modes=modes,
                                n_rhs=int(S[kernel.N_RHS]), n_steps=int(S[kernel.N_STEPS]))
        if output_times is not None:
            plain = kernel.N_PLAIN
            outputs = dict(zip(kernel.PLAIN_ROW_FIELDS[plain:], rows[:, plain:len(kernel.PLAIN_ROW_FIELDS)].T))
            state = rows[:, :plain].T
            if friction:
                state = np.vstack([state, rows[:, kernel.ROW_FIELDS.index("W_friction")]])
                outputs.update(_friction_outputs(equation, table, rows, frictions))
            trajectory.outputs = {"state": state, **outputs,
                                  "E_kin": hybrid.kinetic_energy(outputs["J_red"], rows[:, 1])}
        trajectory.table = table
        return trajectory


def _friction_outputs(equation, table, rows, frictions) -> dict:
    """The joints' friction's outputs (dynamics.friction.friction_outputs: M_friction, each joint's
    friction and its power) at the output rows, from the kernel's frictions there and the rates'
    table (the friction table's first functions)."""
    return {"M_friction": rows[:, kernel.ROW_FIELDS.index("M_friction")],
            **table.friction.joint_outputs(equation.friction, frictions, rows[:, 0], rows[:, 1], table.period)}


def refused(status: int, state) -> None:
    """The kernel's refusal as an error, in the kernel's words (ck_status_text, as the native FMU says
    it): a step size underflow, too many steps, or a state it cannot have written. "fast: " names the
    method where a run fails; an FMU's message leaves it out (fmi.python.core), as the native FMU's does."""
    raise SchemeError(f"fast: {kernel.status_text(status)} at t = {state[kernel.T]:.9g} s")


def _mode_name(values, row: bool = False) -> str:
    motor, direction = (values[0], values[1]) if row else (values[kernel.MOTOR], values[kernel.DIRECTION])
    return hybrid.mode_name(motor, direction)


class FastStepper:
    """The fast kernel one communication step at a time; the whole state is one array.

    ``state`` (kernel.STATE_SIZE floats) is all that determines the continuation: an FMU saves and
    restores it by copying, and a rolled-back step is recomputed bit for bit.
    """

    def __init__(self, table, motor, J_flywheel: float, rtol: float, tau_ext: float = 0.0, row=None,
                 atol: float | None = None):
        _check_rtol(rtol)
        self.table = table
        self.P = kernel.parameters(motor, J_flywheel, tau_ext, rtol, rtol if atol is None else atol)
        # what every kernel call takes, built once
        self.tables = kernel.Tables(*table.arrays())
        self.state = np.zeros(kernel.STATE_SIZE)
        # the output row, filled in place by every step (an FMU's getters read it directly)
        self.row = np.zeros(kernel.OUT_SIZE) if row is None else row
        self.bound = kernel.Bound(self.state, self.tables, self.P, self.row)

    def set_motor(self, motor):
        kernel.set_motor(self.P, motor)

    def set_tau_ext(self, tau: float):
        self.P[kernel.TAU_EXT] = tau

    def set_port_inputs(self, values, rates=None, t_input: float = 0.0):
        """The ports' inputs (N or N.m, in the ports' order), held from now, or linear in time from
        t_input with ``rates`` (per s)."""
        kernel.set_port_inputs(self.P, values, rates, t_input)

    def start(self, t: float, y) -> np.ndarray:
        """Initialise at (t, y) and return the output row there."""
        self.state[:] = 0.0
        self.bound.begin(float(t), y)
        return self.row

    def restart(self, t: float):
        """Restart at t within the last step (a parameter or the input changed), keeping the
        proposed step size."""
        y = np.zeros(kernel.N_Y)
        kernel.dense(self.state, float(t), y)
        h = self.state[kernel.H]
        n_rhs, n_steps = self.state[kernel.N_RHS], self.state[kernel.N_STEPS]
        self.start(t, y)
        self.state[kernel.H] = h
        self.state[kernel.N_RHS] += n_rhs
        self.state[kernel.N_STEPS] = n_steps

    def refresh(self, t: float) -> np.ndarray:
        """The output row at t (the last communication point) with the inputs as set now in P: an
        output that depends on an input at once is read at the value just set (the next step
        restarts from it)."""
        kernel.row_at(self.state, t, self.tables, self.P, self.row)
        return self.row

    def advance(self, t_target: float, t_limit: float) -> np.ndarray:
        """Step to t_target (steps may end up to t_limit); the output row at t_target
        (phi1, omega1, W_motor, W_load, W_ext, epsilon1, M_motor, M_load, J_red, tau_e)."""
        status = self.bound.advance(t_target, t_limit)
        if status != 0:
            refused(status, self.state)
        return self.row


class SpeedStepper:
    """The kernel in speed causality (crank_kernel.h, ck_speed_*) one communication step at a time:
    the drive imposes omega1, the kernel answers with tau_drive and integrates phi1 and the works.
    The output row is FastStepper's layout with the drive in the motor's place (W_motor is W_drive,
    M_motor is tau_drive); ``state`` is all that determines the continuation."""

    def __init__(self, table, J_flywheel: float, row=None):
        self.table = table
        self.P = np.zeros(kernel.PARAM_SIZE)        # no motor line, no tau_ext: the drive is outside
        self.P[kernel.J_FLYWHEEL] = J_flywheel
        self.tables = kernel.Tables(*table.arrays())
        self.state = np.zeros(kernel.STATE_SIZE)
        self.row = np.zeros(kernel.OUT_SIZE) if row is None else row
        self.bound = kernel.Bound(self.state, self.tables, self.P, self.row)

    def set_port_inputs(self, values, rates=None, t_input: float = 0.0):
        """The ports' inputs, held from t_input or linear in time with ``rates`` (per s)."""
        kernel.set_port_inputs(self.P, values, rates, t_input)

    def start(self, t: float, phi1: float, omega1: float) -> np.ndarray:
        self.bound.speed_begin(float(t), float(phi1), float(omega1))
        return self.row

    def refresh(self, omega1: float) -> np.ndarray:
        """The output row now with the input omega1 just set (and the ports' inputs in P): what the
        next step starts from, tau_drive with its slope."""
        kernel.speed_row_at(self.state, omega1, self.tables, self.P, self.row)
        return self.row

    def advance(self, t_target: float, omega1: float, rate: float | None = None) -> np.ndarray:
        """One step to t_target with the input omega1 at its start (rad/s) and its derivative
        ``rate`` (rad/s2) where the host gave one; the output row at t_target."""
        if self.bound.speed_advance(float(t_target), float(omega1), rate) != 0:
            raise SchemeError(f"speed causality: the step from t = {self.state[kernel.T]:.9g} s to {t_target:.9g} s "
                              f"with omega1 = {omega1:g} rad/s is refused (not forward, not finite, or over 1e9 "
                              "degrees of crank angle)")
        return self.row
