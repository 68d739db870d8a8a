"""The components' physics (crank_components.c: the DC drive's exact steps, the die cushion's and
the elastic shaft's laws, the rod string's steps) and the coupled well's steps (crank_well.c), through
the kernel library's binding (native/__init__.py): what the Python component FMUs and the in-process
well call, the same C the native component FMUs run.

numpy and ctypes only: the FMUs ship this package.
"""

from __future__ import annotations

import ctypes

import numpy as np

from ..errors import CrankfmuError
from . import LIBRARY, _d


class DriveSteps:
    """The DC drive's exact steps by the components' C (crank_components.h), for Drive.fmu and
    DriveSpeed.fmu: ``constants`` in dynamics.drive.DRIVE_CONSTANTS' order (R, L, k_t, n_gear, Kp,
    Ki). dynamics.drive.DcDrive states the same model in Python: the reference a test compares with."""

    def __init__(self, constants):
        self.constants = np.ascontiguousarray(constants, dtype=float)
        assert self.constants.shape == (6,)
        self.out = np.zeros(3)
        self._c, self._out = _d(self.constants), _d(self.out)

    def voltage(self, x, omega, omega_set) -> float:
        return LIBRARY.cc_drive_voltage(self._c, x, omega, omega_set)

    def torque(self, i) -> float:
        return LIBRARY.cc_drive_torque(self._c, i)

    def step(self, i, x, omega, omega_set, h) -> tuple[float, float]:
        LIBRARY.cc_drive_step(self._c, i, x, omega, omega_set, h, self._out)
        return float(self.out[0]), float(self.out[1])

    def step_with_rotor(self, i, x, omega, omega_set, tau_load, J_drive, h) -> tuple[float, float, float]:
        LIBRARY.cc_drive_step_with_rotor(self._c, i, x, omega, omega_set, tau_load, J_drive, h, self._out)
        return float(self.out[0]), float(self.out[1]), float(self.out[2])


def expm4(M) -> np.ndarray:
    """exp(M) of a 4 x 4 matrix by the components' C (the drive's speed-causal step uses it)."""
    M = np.ascontiguousarray(M, dtype=float)
    assert M.shape == (4, 4)
    out = np.zeros((4, 4))
    LIBRARY.cc_expm4(_d(M), _d(out))
    return out


def cushion_force(k: float, c: float, L_free: float, s_seat: float, s: float, v: float) -> float:
    """The die cushion's force on the ram along its axis (N), by the components' C."""
    return LIBRARY.cc_cushion_force(k, c, L_free, s_seat, s, v)


def shaft_torque(k: float, c: float, twist: float, omega_a: float, omega_b: float) -> float:
    """The elastic shaft's torque from side a to side b (N.m), by the components' C."""
    return LIBRARY.cc_shaft_torque(k, c, twist, omega_a, omega_b)


def shaft_twist(twist: float, omega_a: float, omega_b: float, h: float, rate_a: float = 0.0,
                rate_b: float = 0.0) -> float:
    """The shaft's twist (rad) after ``h`` s, each side's speed a line (rates rad/s2), by the components' C."""
    return LIBRARY.cc_shaft_twist(twist, omega_a, omega_b, rate_a, rate_b, h)


def shaft_energy(k: float, twist: float) -> float:
    """The elastic energy the shaft's spring stores (J), by the components' C."""
    return LIBRARY.cc_shaft_energy(k, twist)


#: the rod string's scalars (crank_components.h's CS_*), in order
STRING_SCALARS = ("t", "load", "work", "damping_loss", "motion", "u_top", "u_bottom", "hydraulic", "friction_loss",
                  "stop_loss", "gas")


class StringSteps:
    """The rod string's explicit central-difference steps with its valve pump, by the components' C
    (cc_string_step, cc_string_advance): the grid's node masses and weights and segment
    stiffnesses, Gibbs' damping ``c`` and the pump's (Fo, friction, fillage). The state arrays and
    the scalars (STRING_SCALARS' order) are the caller's, changed in place."""

    def __init__(self, mass, weight, stiffness, c: float, pump):
        self.arrays = tuple(np.ascontiguousarray(a, dtype=float) for a in (mass, weight, stiffness, pump))
        self.n = self.arrays[0].shape[0]
        self.scratch = np.zeros(self.n)
        self._fixed = (self.n, *(_d(a) for a in self.arrays[:3]), float(c), _d(self.arrays[3]))
        self._scratch = _d(self.scratch)
        self._bound, self._addresses = (), ()
        self._step, self._advance = LIBRARY.cc_string_step, LIBRARY.cc_string_advance

    def _state(self, u, v, last_u, x) -> tuple:
        """The state arrays' addresses, taken again only when the caller gives other arrays (an
        address costs about a microsecond, a string step a few)."""
        bound = self._bound
        if len(bound) != 4 or bound[0] is not u or bound[1] is not v or bound[2] is not last_u or bound[3] is not x:
            if u.shape != (self.n,) or v.shape != (self.n,) or last_u.shape != (self.n,) or x.shape != (11,):
                raise CrankfmuError(f"the rod string's state must be {self.n} nodes and 11 scalars")
            self._bound = (u, v, last_u, x)          # kept alive while their addresses are in use
            self._addresses = (_d(u), _d(v), _d(last_u), _d(x))
        return self._addresses

    def step(self, u, v, last_u, x, top_next: float, dt: float):
        self._step(*self._fixed, *self._state(u, v, last_u, x), top_next, dt, self._scratch)

    def advance(self, u, v, last_u, x, top_end: float, h: float, dt_max: float):
        self._advance(*self._fixed, *self._state(u, v, last_u, x), top_end, h, dt_max, self._scratch)


class _Well(ctypes.Structure):
    """crank_well.h's CwWell."""
    _fields_ = [("S", ctypes.c_void_p), ("tables", ctypes.c_void_p), ("P", ctypes.c_void_p), ("row", ctypes.c_void_p),
                ("y", ctypes.c_void_p), ("i_port", ctypes.c_int), ("n_ports", ctypes.c_int),
                ("rope_x", ctypes.c_void_p), ("rope_cubics", ctypes.c_void_p), ("n_rope", ctypes.c_int),
                ("rope_h", ctypes.c_double), ("n", ctypes.c_int), ("mass", ctypes.c_void_p),
                ("weight", ctypes.c_void_p), ("stiffness", ctypes.c_void_p), ("c", ctypes.c_double),
                ("pump", ctypes.c_void_p), ("u", ctypes.c_void_p), ("v", ctypes.c_void_p), ("last_u", ctypes.c_void_p),
                ("x", ctypes.c_void_p), ("dt", ctypes.c_double), ("scratch", ctypes.c_void_p)]


#: a coupled well's sample after each step (crank_well.h's CW_SAMPLE_SIZE, crankfmu.well.FIELDS)
WELL_SAMPLE_SIZE = 14


class WellSteps:
    """The pumping well as one model stepped in C (crank_well.c): ``stepper`` the unit's
    FastStepper (its state, tables, parameters and row), ``y`` the unit's state, the rope's cubics
    (``rope_x`` breakpoints, ``rope_cubics`` (n, 4): c3, c2, c1, c0, intervals of ``rope_h``), the
    string's StringSteps and its state arrays (u, v, last_u, x), all changed in place."""

    def __init__(self, stepper, y, i_port: int, n_ports: int, rope_x, rope_cubics, rope_h: float,
                 string: StringSteps, c: float, u, v, last_u, x, dt: float):
        rope_x, rope_cubics = (np.ascontiguousarray(a, dtype=float) for a in (rope_x, rope_cubics))
        for array in (y, u, v, last_u, x):
            assert array.dtype == np.float64 and array.flags.c_contiguous
        n = string.n
        self.scratch = np.zeros(4 * n + len(STRING_SCALARS))
        self.clock = np.zeros(2)
        # kept alive while their addresses are in use
        self.arrays = (stepper.state, stepper.tables, stepper.P, stepper.row, y, rope_x, rope_cubics, string,
                       u, v, last_u, x, self.scratch)
        mass, weight, stiffness, pump = string.arrays
        self.struct = _Well(_d(stepper.state), stepper.tables.pointer, _d(stepper.P), _d(stepper.row), _d(y), i_port,
                            n_ports, _d(rope_x), _d(rope_cubics), rope_cubics.shape[0], rope_h, n, _d(mass),
                            _d(weight), _d(stiffness), c, _d(pump), _d(u), _d(v), _d(last_u), _d(x), dt,
                            _d(self.scratch))
        self.pointer = ctypes.addressof(self.struct)

    def rope_position(self, phi: float) -> float:
        return LIBRARY.cw_rope_position(self.pointer, phi)

    def run(self, t: float, load: float, phi_stop: float, max_steps: int, samples=None):
        """Steps from (t, the polished rod load there) until the crank angle reaches ``phi_stop`` or
        ``max_steps`` steps, one sample row each into ``samples`` (max_steps x WELL_SAMPLE_SIZE, or
        None). Returns (steps taken, t, load, the kernel's status: 0, or its refusal)."""
        self.clock[:] = (t, load)
        status = ctypes.c_int(0)
        if samples is not None:
            assert samples.shape == (max_steps, WELL_SAMPLE_SIZE) and samples.flags.c_contiguous
        k = LIBRARY.cw_run(self.pointer, _d(self.clock), phi_stop, max_steps,
                           None if samples is None else _d(samples), ctypes.byref(status))
        return k, float(self.clock[0]), float(self.clock[1]), status.value
