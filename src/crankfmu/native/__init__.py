"""The C kernel (crank_kernel.c and its drivers, speed-causal step and Model Exchange beside it;
crank_kernel.h, crank_modes.h, crank_tableau.h), the components' physics (crank_components.c) and
the coupled well (crank_well.c): the library and the kernel's binding (the components' and the
well's binding: native/physics.py).

The C files are the kernel's one home: the fast path (``integrators.fast``), the batch of steady
cycles, the pythonfmu FMUs (through this ctypes binding) and the native FMU (compiled in with its
FMI shell) run the same code. ``pip install`` compiles the library (``crank_kernel.so``, .dll on
Windows: setup.py); where it is missing or was compiled from other sources (a source checkout
whose C files changed since), it is compiled once with the machine's C compiler into the per-user
cache under its sources' hash. The library says which sources it was compiled from
(``ck_source_digest``), so a library is never paired with sources of other content.

The arrays' layout (what each float of the state, parameter and output arrays holds) is the C
header's, read from the library: ``T``, ``Y``, ``STATE_SIZE``, ...

numpy and ctypes only: the FMUs ship this package.
"""

from __future__ import annotations

import ctypes
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from ..errors import CrankfmuError
from .sources import C_FILES, CFLAGS, HERE, digest, include_flags, library_name

DIGEST = digest()


def _open(path: Path):
    """The library at ``path`` if it was compiled from these sources, else None."""
    try:
        lib = ctypes.CDLL(str(path))
    except OSError:
        return None
    lib.ck_source_digest.restype = ctypes.c_char_p
    return lib if lib.ck_source_digest().decode() == DIGEST else None


def _compile_into_cache() -> Path:
    from ..cache import cache_root, install

    folder = cache_root() / f"native_{DIGEST}"
    library = folder / library_name(sys.platform)
    if library.is_file():
        return library
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not compiler:
        raise CrankfmuError("crankfmu's C kernel is not built and no C compiler was found to build it: "
                            "reinstall crankfmu (pip install .) or install gcc")

    def build(partial: Path):
        partial.mkdir(parents=True, exist_ok=True)
        done = subprocess.run([compiler, *CFLAGS, *include_flags(), f'-DCK_SOURCE_DIGEST="{DIGEST}"', "-shared", "-o",
                               str(partial / library.name), *(str(HERE / n) for n in C_FILES), "-lm"],
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise CrankfmuError(f"compiling crankfmu's C kernel failed: {done.stderr.strip()}")

    install(folder, build)
    return library


def _load() -> ctypes.CDLL:
    # CRANKFMU_NATIVE_LIBRARY: a library compiled otherwise from these sources (the sanitizer test's)
    chosen = os.environ.get("CRANKFMU_NATIVE_LIBRARY")
    lib = _open(Path(chosen)) if chosen else _open(HERE / library_name(sys.platform))
    if chosen and lib is None:
        raise CrankfmuError(f"CRANKFMU_NATIVE_LIBRARY={chosen} is not a crankfmu kernel of these sources ({DIGEST})")
    if lib is None:
        lib = _open(_compile_into_cache())
    if lib is None:
        raise CrankfmuError(f"crankfmu's C kernel in the cache does not match its sources ({DIGEST})")
    # arrays go in as their addresses (c_void_p from a Python int): numpy's data_as() costs some
    # microseconds a call, which an FMU step would pay three times
    D, I = ctypes.c_void_p, ctypes.POINTER(ctypes.c_int)
    T = ctypes.c_void_p
    signatures = {
        "ck_layout": (ctypes.c_int, [I, ctypes.c_int]),
        "ck_begin": (None, [D, ctypes.c_double, D, T, D, D]),
        "ck_advance": (ctypes.c_int, [D, ctypes.c_double, ctypes.c_double, T, D, D]),
        "ck_dense": (None, [D, ctypes.c_double, D]),
        "ck_point": (None, [D, ctypes.c_double, D]),
        "ck_me_derivatives": (ctypes.c_int, [D, D, T, D, D, D]),
        "ck_speed_row": (None, [D, T, D, D]),
        "ck_speed_slope": (ctypes.c_double, [D, ctypes.c_double, ctypes.c_double, ctypes.c_int]),
        "ck_speed_begin": (None, [D, ctypes.c_double, ctypes.c_double, ctypes.c_double, T, D, D]),
        "ck_speed_advance": (ctypes.c_int, [D, ctypes.c_double, ctypes.c_double, ctypes.c_double, ctypes.c_int, T,
                                            D, D]),
        "ck_run_chunk": (ctypes.c_int, [D, ctypes.c_double, D, ctypes.c_int, I, D, D, ctypes.c_int, I, D,
                                        ctypes.c_int, I, D, ctypes.c_int, I, T, D]),
        "ck_dense_many": (None, [D, ctypes.c_int, D, ctypes.c_int, D]),
        "ck_steady_batch": (None, [D, ctypes.c_int, ctypes.c_double, D, ctypes.c_double, ctypes.c_int, T, D]),
        "ck_tableau": (ctypes.c_int, [D, ctypes.c_int]),
        "ck_status_text": (ctypes.c_char_p, [ctypes.c_int]),
        "ck_rule": (ctypes.c_double, [ctypes.c_int, D]),
        "cc_drive_voltage": (ctypes.c_double, [D, ctypes.c_double, ctypes.c_double, ctypes.c_double]),
        "cc_drive_torque": (ctypes.c_double, [D, ctypes.c_double]),
        "cc_drive_step": (None, [D, ctypes.c_double, ctypes.c_double, ctypes.c_double, ctypes.c_double,
                                 ctypes.c_double, D]),
        "cc_drive_step_with_rotor": (None, [D, ctypes.c_double, ctypes.c_double, ctypes.c_double, ctypes.c_double,
                                            ctypes.c_double, ctypes.c_double, ctypes.c_double, D]),
        "cc_expm4": (None, [D, D]),
        "cc_cushion_force": (ctypes.c_double, [ctypes.c_double] * 6),
        "cc_shaft_torque": (ctypes.c_double, [ctypes.c_double] * 5),
        "cc_shaft_twist": (ctypes.c_double, [ctypes.c_double] * 6),
        "cc_shaft_energy": (ctypes.c_double, [ctypes.c_double] * 2),
        "cc_string_step": (None, [ctypes.c_int, D, D, D, ctypes.c_double, D, D, D, D, D, ctypes.c_double,
                                  ctypes.c_double, D]),
        "cc_string_advance": (None, [ctypes.c_int, D, D, D, ctypes.c_double, D, D, D, D, D, ctypes.c_double,
                                     ctypes.c_double, ctypes.c_double, D]),
        "cc_string_nodes": (ctypes.c_int, [ctypes.c_int, D, D, ctypes.c_char_p, ctypes.c_int]),
        "cc_string_grid": (None, [ctypes.c_int, D, D, D, D, D, D]),
        "ck_quantity_values": (None, [D, ctypes.c_int, ctypes.c_int, D, ctypes.c_int, D, D, ctypes.c_double,
                                      ctypes.c_double, ctypes.c_double, D, D]),
        "ck_friction_values": (ctypes.c_int, [D, ctypes.c_double, D, ctypes.c_double, T, D, D]),
        "ck_reaction_values": (ctypes.c_int, [D, ctypes.c_int, ctypes.c_int, ctypes.c_int, D, ctypes.c_double,
                                              ctypes.c_double, ctypes.c_double, ctypes.c_double, T, D, D, D]),
        "ck_interval_of_rule": (ctypes.c_int, [D, ctypes.c_int, ctypes.c_double, ctypes.c_double, D]),
        "ck_next_interval_rule": (ctypes.c_int, [D, ctypes.c_int, ctypes.c_int, D, ctypes.c_int]),
        "cw_rope_position": (ctypes.c_double, [D, ctypes.c_double]),
        "cw_run": (ctypes.c_int, [D, D, ctypes.c_double, ctypes.c_int, D, I]),
        "mm_bind": (ctypes.c_int, [T, T, D, ctypes.c_int]),
        "mm_prepare": (ctypes.c_int, [T]),
        "mm_evaluate": (ctypes.c_int, [T, ctypes.c_double]),
        "mm_rows": (ctypes.c_int, [T, ctypes.c_int]),
        "mm_reaction_terms": (ctypes.c_int, [T]),
        "mm_engine": (ctypes.c_int, [T, ctypes.c_int, D, ctypes.c_int, D]),
        "mm_table_turns": (ctypes.c_int, [T, ctypes.c_int]),
        "mm_tabulate": (ctypes.c_int, [T, ctypes.c_int, ctypes.c_double, T, T, T, T]),
        "mm_free": (None, [T]),
        "mm_law": (ctypes.c_double, [T, ctypes.c_int, ctypes.c_double]),
        "mm_release": (None, [T]),
    }
    for name, (restype, argtypes) in signatures.items():
        function = getattr(lib, name)
        function.restype, function.argtypes = restype, argtypes
    return lib


class _Tables(ctypes.Structure):
    _fields_ = [("coefficients", ctypes.c_void_p), ("n_functions", ctypes.c_int),
                ("n", ctypes.c_int), ("switch_angles", ctypes.c_void_p), ("m", ctypes.c_int),
                ("forces", ctypes.c_void_p), ("n_sliders", ctypes.c_int), ("n_ports", ctypes.c_int),
                ("period", ctypes.c_double), ("powers", ctypes.c_void_p), ("law", ctypes.c_void_p),
                ("law_context", ctypes.c_void_p), ("friction", ctypes.c_void_p)]


class _Friction(ctypes.Structure):
    """crank_kernel.h's CkFriction."""
    _fields_ = [("n_f", ctypes.c_int), ("n_terms", ctypes.c_int), ("coefficients", ctypes.c_void_p),
                ("n", ctypes.c_int), ("components", ctypes.c_void_p), ("c", ctypes.c_void_p),
                ("signs", ctypes.c_void_p)]


#: crank_kernel.h's CkLaw: g(omega1) of a column of power LAW
_LAW = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_void_p, ctypes.c_int, ctypes.c_double)


def _law_callback(laws):
    """A C function the kernel calls for a column's law: ``laws(column, omega1)`` (speed_laws.ColumnLaws),
    NaN where it raises (the kernel then refuses the step as not finite, and no exception is lost
    inside ctypes)."""
    def law(_context, column, omega):
        try:
            return float(laws(column, omega))
        except Exception:          # noqa: BLE001 - reported as the step's non-finite value
            return math.nan
    return _LAW(law)


LIBRARY = _load()
#: the library file in use (the FMU build ships it)
LIBRARY_PATH = Path(LIBRARY._name)
_LAYOUT_NAMES = ("T", "Y", "F_", "H", "MOTOR", "DIRECTION", "INTERVAL", "PHI_LO", "PHI_HI", "T_PREV", "Y_PREV", "K",
                 "N_RHS", "STEP_MOTOR", "STEP_DIRECTION", "STEP_INTERVAL", "N_STEPS", "STATE_SIZE", "N_Y",
                 "PARAM_SIZE", "OUT_SIZE", "STEADY_SIZE", "N_STAGES", "N_SLOTS", "MAX_FUNCTIONS", "N_PLAIN",
                 "MAX_FRICTIONS", "MAX_FRICTION_FUNCTIONS")


def layout() -> dict[str, int]:
    """The C kernel's array layout, by name (the header's enums)."""
    out = (ctypes.c_int * 64)()
    count = LIBRARY.ck_layout(out, 64)
    return dict(zip(_LAYOUT_NAMES, out[:count]))


_LAYOUT = layout()
# ---- the state array: t, y[6] (phi1, omega1, W_motor, W_load, W_ext, W_friction), f[6], the proposed
# step, the mode (motor branch, direction, switch interval and its bounds), the last step (start,
# start state, 7x6 stages) for dense output, counters
T, Y, F_, H = _LAYOUT["T"], _LAYOUT["Y"], _LAYOUT["F_"], _LAYOUT["H"]
MOTOR, DIRECTION, INTERVAL = _LAYOUT["MOTOR"], _LAYOUT["DIRECTION"], _LAYOUT["INTERVAL"]
T_PREV, Y_PREV, K = _LAYOUT["T_PREV"], _LAYOUT["Y_PREV"], _LAYOUT["K"]
N_RHS, N_STEPS, STATE_SIZE, N_Y = _LAYOUT["N_RHS"], _LAYOUT["N_STEPS"], _LAYOUT["STATE_SIZE"], _LAYOUT["N_Y"]
#: y's states without joint friction (the sixth, W_friction, stays 0 without it)
N_PLAIN = _LAYOUT["N_PLAIN"]
STEP_MOTOR, STEP_DIRECTION = _LAYOUT["STEP_MOTOR"], _LAYOUT["STEP_DIRECTION"]
PARAM_SIZE, OUT_SIZE, STEADY_SIZE = _LAYOUT["PARAM_SIZE"], _LAYOUT["OUT_SIZE"], _LAYOUT["STEADY_SIZE"]
# ---- the parameter array (crank_kernel.h's order): the motor line, the inputs (value at T_INPUT
# and rate: tau_ext, then one per port), the flywheel and the stepper's settings
MAX_PORTS = 8
A_, B_, A_LOW, B_LOW, OMEGA_SWITCH, TAU_EXT, J_FLYWHEEL, RTOL, ATOL, H_MAX, T_INPUT, TAU_EXT_RATE = range(12)
PORT_INPUT, PORT_RATE = 12, 12 + MAX_PORTS
assert PARAM_SIZE == 12 + 2 * MAX_PORTS
# ---- the output row: the state, then the contract outputs the tables give, then the external torque
# on the crank (tau_ext and the ports', N.m: W_ext's rate over omega1), the joints' friction's work and
# its generalised force on the crank (J, N.m; 0 without friction)
ROW_FIELDS = ("phi1", "omega1", "W_motor", "W_load", "W_ext", "epsilon1", "M_motor", "M_load", "J_red", "tau_e",
              "W_friction", "M_friction")
#: the row's fields a model without joint friction has (the last two are 0 there)
PLAIN_ROW_FIELDS = ROW_FIELDS[:10]
assert OUT_SIZE == len(ROW_FIELDS)
#: the output row in speed causality (ck_speed_*): the same layout, the drive in the motor's place
SPEED_ROW_FIELDS = tuple({"W_motor": "W_drive", "M_motor": "tau_drive"}.get(n, n) for n in ROW_FIELDS)
#: what the stepping functions return besides an event slot
NO_EVENT, UNDERFLOW, BAD_STATE, TOO_MANY_STEPS = -1, -2, -3, -5


def parameters(motor, J_flywheel: float, tau_ext: float, rtol: float, atol: float,
               h_max: float = math.inf) -> np.ndarray:
    """The parameter array of one design."""
    P = np.zeros(PARAM_SIZE)
    set_motor(P, motor)
    P[TAU_EXT], P[J_FLYWHEEL] = tau_ext, J_flywheel
    P[RTOL], P[ATOL], P[H_MAX] = rtol, atol, h_max
    return P


def set_motor(P: np.ndarray, motor):
    """Write a MotorLine into a parameter array."""
    P[A_], P[B_], P[A_LOW], P[B_LOW], P[OMEGA_SWITCH] = (
        motor.A, motor.B, motor.A_low, motor.B_low, motor.omega_switch)


def set_port_inputs(P: np.ndarray, values, rates=None, t_input: float = 0.0):
    """Write the ports' inputs (N or N.m, in the ports' order) into a parameter array: held from
    t_input, or linear in time from there with ``rates`` (per s)."""
    n = len(values)
    P[PORT_INPUT:PORT_INPUT + n] = values
    P[PORT_RATE:PORT_RATE + n] = 0.0 if rates is None else rates
    P[T_INPUT] = t_input


def status_text(status: int) -> str:
    """What a stepping function's refusal says (crank_kernel.h's ck_status_text)."""
    return LIBRARY.ck_status_text(status).decode()


def tableau() -> dict[str, np.ndarray]:
    """The Dormand-Prince tableau the kernel steps with (crank_tableau.h): A, B, E, P, C."""
    out = np.zeros(128)
    LIBRARY.ck_tableau(_d(out), out.size)
    sizes = {"A": (6, 5), "B": (6,), "E": (7,), "P": (7, 4), "C": (6,)}
    result, at = {}, 0
    for name, shape in sizes.items():
        n = int(np.prod(shape))
        result[name] = out[at:at + n].reshape(shape)
        at += n
    return result


def _d(array: np.ndarray) -> int:
    """The address of a C-contiguous float64 array (the kernel reads and writes it in place)."""
    assert array.dtype == np.float64 and array.flags.c_contiguous
    return array.ctypes.data


class Tables:
    """A design's tables as the C kernel takes them; keeps the arrays alive while in use."""

    def __init__(self, coefficients, switch_angles, forces, n_ports: int = 0, period: float = 2.0 * math.pi,
                 powers=None, laws=None, friction=None):
        forces = np.ascontiguousarray(forces, dtype=float)
        columns = forces.shape[2] if forces.ndim == 3 else 0
        self.arrays = (np.ascontiguousarray(coefficients, dtype=float),
                       np.ascontiguousarray(switch_angles, dtype=float), forces,
                       np.ascontiguousarray(np.zeros(columns) if powers is None else powers, dtype=np.int32))
        C, sw, fo, pw = self.arrays
        if C.shape[0] > _LAYOUT["MAX_FUNCTIONS"]:
            raise CrankfmuError(f"the C kernel takes at most {_LAYOUT['MAX_FUNCTIONS']} tabulated functions "
                                f"(4, one per slider force and one per port), got {C.shape[0]}")
        if n_ports > MAX_PORTS:
            raise CrankfmuError(f"the C kernel takes at most {MAX_PORTS} ports, got {n_ports}")
        # the laws of the speed: evaluated in C by the C model's rule (mechanism.LawEvaluator), or where
        # a law does not compile to it, through a callback; either lives as long as the tables
        self.law, function, context = None, None, None
        if laws:
            from ..dynamics.program import Unsupported
            from .mechanism import LawEvaluator
            try:
                self.law = LawEvaluator(laws.sources, laws.env)
                function, context = self.law.function, self.law.context
            except Unsupported:     # a law the C model's instructions do not hold: through a callback
                self.law = _law_callback(laws)
                function = ctypes.cast(self.law, ctypes.c_void_p).value
        self.friction = None if friction is None else _friction_struct(friction, sw.shape[0])
        self.struct = _Tables(_d(C), C.shape[0], C.shape[1], _d(sw), sw.shape[0], _d(fo),
                              fo.shape[2] if fo.ndim == 3 else 0, n_ports, period, pw.ctypes.data,
                              function, context,
                              None if self.friction is None else ctypes.addressof(self.friction[0]))
        self.pointer = ctypes.addressof(self.struct)


def _friction_struct(friction, m: int):
    """(CkFriction, its arrays) of a FrictionTable (dynamics.tabulated), checked against the kernel's
    bounds."""
    coefficients = friction.interval_major            # (crank_kernel.h, CkFriction: interval-major)
    components = np.ascontiguousarray(friction.components, dtype=np.int32)
    c = np.ascontiguousarray(friction.c, dtype=float)
    signs = np.ascontiguousarray(friction.signs, dtype=float)
    n_f = components.size
    if n_f > _LAYOUT["MAX_FRICTIONS"] or coefficients.shape[1] > _LAYOUT["MAX_FRICTION_FUNCTIONS"]:
        raise CrankfmuError(f"the C kernel takes at most {_LAYOUT['MAX_FRICTIONS']} joint frictions and "
                            f"{_LAYOUT['MAX_FRICTION_FUNCTIONS']} tabulated friction functions, got {n_f} and "
                            f"{coefficients.shape[1]}: simulate with method='reference'")
    functions = n_f + int(components.sum()) * (friction.n_terms + n_f)
    if signs.shape != (max(m, 1), n_f) or coefficients.shape[1] != functions:
        raise CrankfmuError("the friction table does not match the reduced table (its signs or its functions)")
    struct = _Friction(n_f, friction.n_terms, _d(coefficients), coefficients.shape[0], components.ctypes.data,
                       _d(c), _d(signs))
    return struct, (coefficients, components, c, signs)


class Bound:
    """The arrays of one stepper (state, parameters, output row) and its tables, their addresses
    taken once: an FMU's step is one call with no conversion of its arrays."""

    def __init__(self, S, tables: "Tables", P, row):
        self.arrays = (S, P, row, tables)          # kept alive while bound
        self.S, self.P, self.row, self.tables = _d(S), _d(P), _d(row), tables.pointer
        self._advance = LIBRARY.ck_advance

    def advance(self, t_target: float, t_limit: float) -> int:
        return self._advance(self.S, t_target, t_limit, self.tables, self.P, self.row)

    def begin(self, t: float, y):
        """ck_begin at (t, y) with the bound arrays (y: the state, W_friction 0 where it is left out)."""
        LIBRARY.ck_begin(self.S, t, _d(state_vector(y)), self.tables, self.P, self.row)

    def speed_begin(self, t: float, phi1: float, omega1: float):
        LIBRARY.ck_speed_begin(self.S, t, phi1, omega1, self.tables, self.P, self.row)

    def speed_advance(self, t_target: float, omega1: float, rate: float | None) -> int:
        return LIBRARY.ck_speed_advance(self.S, t_target, omega1, 0.0 if rate is None else rate, rate is not None,
                                        self.tables, self.P, self.row)


def friction_values(store: np.ndarray, times, epsilon, tables: "Tables", P) -> np.ndarray:
    """(len(times), n_f + 1): the frictions f_i (N.m or N) and their generalised force on the crank
    (N.m) at each time, the crank's acceleration there ``epsilon`` (rad/s2, the output rows'), from
    the kernel's stored steps (one state per row, in time order; each time within one of their
    steps), in that step's mode (ck_friction_values)."""
    n_f = int(tables.friction[0].n_f)
    out = np.zeros((len(times), n_f + 1))
    y, row = np.zeros(N_Y), np.zeros(n_f + 1)
    ends = store[:, T]
    for i, (t, eps) in enumerate(zip(np.asarray(times, dtype=float), np.asarray(epsilon, dtype=float))):
        k = min(int(np.searchsorted(ends, t, side="left")), len(ends) - 1)
        S = np.ascontiguousarray(store[k])
        LIBRARY.ck_dense(_d(S), float(t), _d(y))
        if LIBRARY.ck_friction_values(_d(S), float(t), _d(y), float(eps), tables.pointer, _d(P), _d(row)) != n_f:
            raise CrankfmuError("the kernel's state is corrupted")
        out[i] = row
    return out


def state_vector(y) -> np.ndarray:
    """y as the kernel reads and writes it: N_Y float64s (phi1, omega1, W_motor, W_load, W_ext,
    W_friction), W_friction 0 where ``y`` has the five states of a model without friction. The
    kernel reads and writes all N_Y: a shorter array would be read and written past its end."""
    y = np.asarray(y, dtype=float).ravel()
    if y.size > N_Y:
        raise CrankfmuError(f"a kernel state has {N_Y} values, got {y.size}")
    out = np.zeros(N_Y)
    out[:y.size] = y
    return out


def dense(S, t, out):
    """The state at t within S's last step into ``out`` (N_Y float64s: ck_dense writes them all)."""
    if not (out.dtype == np.float64 and out.flags.c_contiguous and out.size >= N_Y):
        raise CrankfmuError(f"ck_dense writes {N_Y} float64s, got an array of {out.size} {out.dtype}")
    LIBRARY.ck_dense(_d(S), t, _d(out))


def row_at(S, t: float, tables: "Tables", P, row):
    """The output row at t within S's last step (or at its end) with the parameters and inputs P:
    the state there by the dense output, in that step's mode (ck_point, ck_me_derivatives)."""
    point = np.zeros(STATE_SIZE)
    LIBRARY.ck_point(_d(S), float(t), _d(point))
    if LIBRARY.ck_me_derivatives(_d(point), _d(point[Y:]), tables.pointer, _d(P), None, _d(row)) != 0:
        raise CrankfmuError("the kernel's state is corrupted")


def speed_row_at(S, omega: float, tables: "Tables", P, row):
    """The speed-causal output row at S's time with the input omega1 just set: what the next step
    starts from (its slope by the kernel's rule, ck_speed_slope; no derivative given)."""
    point = np.array(S, dtype=float)
    point[Y + 1] = omega
    point[F_ + 1] = LIBRARY.ck_speed_slope(_d(S), float(omega), 0.0, 0)
    LIBRARY.ck_speed_row(_d(point), tables.pointer, _d(P), _d(row))


def run_chunk(S, t_end, times, i_out, rows, step_store, n_store, events, n_events, modes, n_modes,
              tables: Tables, P):
    """Step towards t_end, filling output rows at ``times`` and storing each step's state for dense
    output (a full buffer returns status 1: call again to continue). Returns (status, i_out,
    n_store, n_events, n_modes); status 0: t_end reached, UNDERFLOW or BAD_STATE: refused."""
    counters = [ctypes.c_int(v) for v in (i_out, n_store, n_events, n_modes)]
    times = np.ascontiguousarray(times, dtype=float)
    status = LIBRARY.ck_run_chunk(_d(S), t_end, _d(times), times.shape[0], ctypes.byref(counters[0]), _d(rows),
                                  _d(step_store), step_store.shape[0], ctypes.byref(counters[1]), _d(events),
                                  events.shape[0], ctypes.byref(counters[2]), _d(modes), modes.shape[0],
                                  ctypes.byref(counters[3]), tables.pointer, _d(P))
    return (status, *(c.value for c in counters))


def dense_many(store, times, out):
    store = np.ascontiguousarray(store, dtype=float)
    times = np.ascontiguousarray(times, dtype=float)
    LIBRARY.ck_dense_many(_d(store), store.shape[0], _d(times), times.shape[0], _d(out))


def steady_batch(params, phi_start, omega_guess, rtol_shoot, max_turns, tables: Tables, out):
    params = np.ascontiguousarray(params, dtype=float)
    omega_guess = np.ascontiguousarray(omega_guess, dtype=float)
    LIBRARY.ck_steady_batch(_d(params), params.shape[0], phi_start, _d(omega_guess), rtol_shoot, int(max_turns),
                            tables.pointer, _d(out))


class QuantityReads:
    """A scenario's [[outputs]] and its ports' s, v, a from their table (dynamics.tabulated.
    QuantityTable) by the kernel's ck_quantity_values, the native FMU's rule: ``values(phi1,
    omega1, epsilon1)`` fills and returns one array, in ``quantities``' order."""

    def __init__(self, table, quantities):
        self.coefficients = np.ascontiguousarray(table.coefficients, dtype=float)
        self.winding = np.ascontiguousarray(table.winding, dtype=float)
        self.coordinate = np.ascontiguousarray([table.coordinates.index(q.of) for q in quantities], dtype=np.intc)
        self.order = np.ascontiguousarray([q.order for q in quantities], dtype=np.intc)
        self.scratch = np.zeros(self.coefficients.shape[0])
        self.out = np.zeros(len(quantities))
        self._call = LIBRARY.ck_quantity_values
        self._args = (_d(self.coefficients), len(table.coordinates), self.coefficients.shape[1], _d(self.winding),
                      len(quantities), self.coordinate.ctypes.data, self.order.ctypes.data)
        self._into = (_d(self.scratch), _d(self.out))

    def values(self, phi1: float, omega1: float, epsilon1: float) -> np.ndarray:
        self._call(*self._args, phi1, omega1, epsilon1, *self._into)
        return self.out


class ReactionReads:
    """The joint reactions from their table (dynamics.reaction_table.ReactionTable) by the kernel's
    ck_reaction_values, the native FMU's rule: the tabulated terms at phi1 times the weights of the
    stepper's mode and inputs at t (``stepper``: its state S, parameters P and tables)."""

    def __init__(self, table, stepper):
        self.coefficients = np.ascontiguousarray(table.coefficients, dtype=float)
        n_reactions = self.coefficients.shape[0] // table.n_terms
        self.scratch = np.zeros(n_reactions * table.n_terms + table.n_terms)
        self.out = np.zeros(n_reactions)
        self._call = LIBRARY.ck_reaction_values
        self._args = (_d(self.coefficients), n_reactions, table.n_terms, self.coefficients.shape[1],
                      _d(stepper.state))
        self._rest = (stepper.tables.pointer, _d(stepper.P), _d(self.scratch), _d(self.out))
        self._arrays = (stepper.state, stepper.P, stepper.tables)        # kept alive while in use

    def values(self, t: float, phi1: float, omega1: float, epsilon1: float) -> np.ndarray:
        if self._call(*self._args, t, phi1, omega1, epsilon1, *self._rest) != 0:
            raise CrankfmuError("the joint reactions' table does not match the kernel's tables (its terms "
                                "are not the kernel's weights)")
        return self.out
