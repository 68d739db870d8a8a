"""The fast path: the compiled kernel on the tabulated reduced model, behind ``Integrator.run``.

``FastIntegrator`` is ``simulate(scenario, method="fast", rtol=...)``. It tabulates the model's
reduced coefficients once (``ReducedModel.table``, cached on the model), then runs the kernel of
:mod:`crankfmu.integrators.kernel` in chunks: each chunk fills the output rows that fall in it and
stores its steps for dense output anywhere in the run. Link-level kinematics are never computed
during the run; the contract outputs come from the tables.

``FastStepper`` is the same kernel one communication step at a time, for the FMU.
"""

from __future__ import annotations

import hashlib
import importlib.util
import math
import os
import sys
from pathlib import Path

import numpy as np

from ..errors import ParameterError, SchemeError
from . import tableau
from .base import Integrator, Trajectory


def load_kernel():
    """The kernel module, imported from a copy named by its content hash in a per-user cache
    directory ($CRANKFMU_CACHE, default ~/.cache/crankfmu).

    numba caches machine code beside the source file, keyed on its path. An FMU runs its own copy
    of this package from wherever the host extracted it (fmpy: a new temporary directory per run),
    so the kernel compiled there would be compiled again on every run (about 15 s). The copy's
    path depends only on its content: every FMU and process with the same kernel shares one
    compilation, and a changed kernel gets a new one (the tableau's file counts: numba freezes
    its arrays into the machine code). Where that directory cannot be written the package's own
    file is used. The module's name is the same in every copy of the package (numba's cache
    refers to its functions by module name, and an FMU's package has a private name of its
    own), so it cannot import its siblings: the tableau is handed in before it runs.
    """
    source = Path(__file__).with_name("kernel.py")
    text = source.read_bytes()
    digest = hashlib.sha256(text + Path(tableau.__file__).read_bytes()).hexdigest()[:16]
    name = f"crankfmu_kernel_{digest}"
    if name in sys.modules:
        return sys.modules[name]
    path = source
    try:
        folder = Path(os.environ.get("CRANKFMU_CACHE") or Path.home() / ".cache" / "crankfmu") / f"kernel_{digest}"
        target = folder / "kernel.py"
        if not target.is_file() or target.read_bytes() != text:
            folder.mkdir(parents=True, exist_ok=True)
            partial = folder / f"kernel.py.{os.getpid()}"
            partial.write_bytes(text)
            os.replace(partial, target)          # atomic: a concurrent process sees all or nothing
        path = target
    except OSError:
        pass
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    module.tableau = tableau
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


kn = load_kernel()

#: default rtol of the fast path (atol equal): on seed 000 it gives 6.6e-9 rad/s (max omega1 error over 2 s)
DEFAULT_RTOL = 1e-11
#: relative tolerance the tables are checked to (well below the integrator's error)
TABLE_TOLERANCE = 1e-11


def parameters(motor, J_flywheel: float, tau_ext: float, rtol: float, atol: float,
               h_max: float = math.inf) -> np.ndarray:
    """The kernel's parameter array (layout in kernel.py)."""
    P = np.zeros(kn.PARAM_SIZE)
    set_motor(P, motor)
    P[kn.TAU_EXT], P[kn.J_FLYWHEEL] = tau_ext, J_flywheel
    P[kn.RTOL], P[kn.ATOL], P[kn.H_MAX] = rtol, atol, h_max
    return P


def set_motor(P: np.ndarray, motor):
    """Write a MotorLine into a kernel parameter array."""
    P[kn.A_], P[kn.B_], P[kn.A_LOW], P[kn.B_LOW], P[kn.OMEGA_SWITCH] = (
        motor.A, motor.B, motor.A_low, motor.B_low, motor.omega_switch)


def _check_rtol(rtol):
    if not (rtol > 0 and math.isfinite(rtol)):
        raise ParameterError(f"rtol must be > 0, got {rtol!r}", "rtol")


def dense_from_store(store: np.ndarray, times) -> np.ndarray:
    """States (5 x len(times)) from stored kernel states (one row per step, the start first)."""
    times = np.atleast_1d(np.asarray(times, dtype=float))
    t_nodes = store[:, kn.T]
    idx = np.clip(np.searchsorted(t_nodes, times, side="left"), 1, max(len(store) - 1, 1))
    S = store[np.minimum(idx, len(store) - 1)]
    h = S[:, kn.T] - S[:, kn.T_PREV]
    safe = np.where(h == 0.0, 1.0, h)
    x = (times - S[:, kn.T_PREV]) / safe
    powers = np.stack([x, x * x, x ** 3, x ** 4], axis=1)               # (n, 4)
    weights = powers @ kn.DENSE_P.T                                          # (n, 7)
    stages = S[:, kn.K:kn.K + 35].reshape(-1, kn.N_STAGES + 1, 5)       # (n, 7, 5)
    y = S[:, kn.Y_PREV:kn.Y_PREV + 5] + h[:, None] * np.einsum("ns,nsj->nj", weights, stages)
    exact = (times == S[:, kn.T]) | (h == 0.0)
    y[exact] = S[exact, kn.Y:kn.Y + 5]
    return y.T


class FastIntegrator(Integrator):
    """Dormand-Prince 5(4) compiled on the tabulated model, every discontinuity located."""

    name = "fast"

    def __init__(self, rtol: float | None = None, atol: float | None = None, chunk: int = 4096):
        rtol = DEFAULT_RTOL if rtol is None else rtol
        _check_rtol(rtol)
        self.rtol = float(rtol)
        self.atol = float(rtol if atol is None else atol)
        self.chunk = chunk
        self.method = "Dormand-Prince 5(4) on the tabulated model" + (" (numba)" if kn.COMPILED else " (pure Python)")

    def run(self, equation, t0, y0, t_end, progress=None, output_times=None):
        table = equation.reduced.table(TABLE_TOLERANCE)
        P = parameters(equation.motor, equation.reduced.J_flywheel, equation.tau_ext, self.rtol, self.atol)
        C, switch, forces = table.coefficients, table.switch_angles, table.forces
        ws = kn.Workspace(C.shape[0])
        S = np.zeros(kn.STATE_SIZE)
        kn.start(S, float(t0), np.asarray(y0, dtype=float), C, switch, forces, P, ws.work, ws.f)
        times = np.zeros(0) if output_times is None else np.asarray(output_times, dtype=float)
        rows = np.zeros((times.size, kn.OUT_SIZE))
        i_out = 0
        stores, events, modes = [S[None, :].copy()], [], [(float(t0), _mode_name(S))]
        while True:
            store = np.zeros((self.chunk, kn.STATE_SIZE))
            ev = np.zeros((self.chunk, 2))
            md = np.zeros((self.chunk, 4))
            status, i_out, n_store, n_ev, n_md = kn.run_chunk(
                S, float(t_end), times, i_out, rows, store, 0, ev, 0, md, 0,
                C, switch, forces, P, *ws.arrays())
            stores.append(store[:n_store])
            events += [(float(t), kn.EVENT_NAMES[int(slot)]) for t, slot in ev[:n_ev]]
            modes += [(float(r[0]), _mode_name(r[1:], row=True)) for r in md[:n_md]]
            if progress is not None:
                progress(float(S[kn.T]))
            if status == -2:
                raise SchemeError(f"fast: step size underflow at t = {S[kn.T]:.9g} s")
            if status == 0:
                break
        store = np.concatenate(stores)
        trajectory = Trajectory(t=store[:, kn.T].copy(), y=store[:, kn.Y:kn.Y + 5].T.copy(),
                                dense=lambda tt: dense_from_store(store, tt), events=events, modes=modes,
                                n_rhs=int(S[kn.N_RHS]), n_steps=int(S[kn.N_STEPS]))
        if output_times is not None:
            outputs = dict(zip(kn.ROW_FIELDS[5:], rows[:, 5:].T))
            trajectory.outputs = {"state": rows[:, :5].T, **outputs,
                                  "E_kin": 0.5 * outputs["J_red"] * rows[:, 1] ** 2}
        trajectory.table = table
        return trajectory


def _mode_name(values, row: bool = False) -> str:
    motor, direction = (values[0], values[1]) if row else (values[kn.MOTOR], values[kn.DIRECTION])
    if direction == 0.0:
        return "stuck"
    return kn.MODE_NAMES[int(motor)]


class FastStepper:
    """The fast kernel one communication step at a time; the whole state is one array.

    ``state`` (kernel.STATE_SIZE floats) is all that determines the continuation: an FMU saves and
    restores it by copying, and a rolled-back step is recomputed bit for bit.
    """

    def __init__(self, table, motor, J_flywheel: float, rtol: float, tau_ext: float = 0.0, row=None):
        _check_rtol(rtol)
        self.table = table
        self.C, self.switch, self.forces = table.coefficients, table.switch_angles, table.forces
        self.P = parameters(motor, J_flywheel, tau_ext, rtol, rtol)
        self.ws = kn.Workspace(self.C.shape[0])
        self.state = np.zeros(kn.STATE_SIZE)
        # the output row, filled in place by every step (an FMU's getters read it directly)
        self.row = np.zeros(kn.OUT_SIZE) if row is None else row

    def set_motor(self, motor):
        set_motor(self.P, motor)

    def set_tau_ext(self, tau: float):
        self.P[kn.TAU_EXT] = tau

    def start(self, t: float, y) -> np.ndarray:
        """Initialise at (t, y) and return the output row there."""
        ws = self.ws
        self.state[:] = 0.0
        kn.start(self.state, float(t), np.asarray(y, dtype=float), self.C, self.switch, self.forces, self.P,
                 ws.work, ws.f)
        kn.output_row(self.state, float(t), self.C, self.forces, self.P, ws.work, ws.f, self.row)
        return self.row

    def restart(self, t: float):
        """Restart at t within the last step (a parameter or the input changed), keeping the
        proposed step size."""
        y = np.zeros(5)
        kn.dense(self.state, float(t), y)
        h = self.state[kn.H]
        n_rhs, n_steps = self.state[kn.N_RHS], self.state[kn.N_STEPS]
        self.start(t, y)
        self.state[kn.H] = h
        self.state[kn.N_RHS] += n_rhs
        self.state[kn.N_STEPS] = n_steps

    def advance(self, t_target: float, t_limit: float) -> np.ndarray:
        """Step to t_target (steps may end up to t_limit); the output row at t_target
        (phi1, omega1, W_motor, W_load, W_ext, epsilon1, M_motor, M_load, J_red)."""
        ws = self.ws
        status = kn.advance(self.state, t_target, t_limit, self.C, self.switch, self.forces, self.P,
                            *ws.arrays(), self.row)
        if status == -2:
            raise SchemeError(f"fast: step size underflow at t = {self.state[kn.T]:.9g} s")
        return self.row
