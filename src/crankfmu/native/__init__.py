"""The C kernel (crank_kernel.c, crank_kernel.h, crank_modes.h, crank_tableau.h) and its binding.

The C files are the kernel's one home: the fast path (``integrators.fast``), the batch of steady
cycles, the pythonfmu FMUs (through this ctypes binding) and the native FMU (compiled in with
its FMI shell) run the same code. ``pip install`` compiles the library
(``_crank_kernel<suffix>``, setup.py); where it is missing or older than its sources (a source
checkout run without installing), it is compiled once with the machine's C compiler into the
per-user cache under its sources' hash.

numpy and ctypes only: the FMUs ship this package.
"""

from __future__ import annotations

import ctypes
import hashlib
import importlib.machinery
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from ..errors import CrankfmuError

HERE = Path(__file__).resolve().parent
SOURCES = ("crank_kernel.c", "crank_kernel.h", "crank_modes.h", "crank_tableau.h")
#: how the library is compiled, here and by setup.py (no FMA contraction: the numbers do not
#: depend on the CPU the library was compiled for)
CFLAGS = ["-std=c99", "-O2", "-ffp-contract=off", "-fPIC"]


def digest() -> str:
    h = hashlib.sha256()
    for name in SOURCES:
        h.update((HERE / name).read_bytes())
    return h.hexdigest()[:16]


def _installed() -> Path | None:
    """The library setup.py built beside the sources, if it is there and not older than them."""
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = HERE / f"_crank_kernel{suffix}"
        if path.is_file() and path.stat().st_mtime >= max((HERE / s).stat().st_mtime for s in SOURCES):
            return path
    return None


def _compile_into_cache() -> Path:
    from ..cache import cache_root, install

    suffix = ".dll" if sys.platform == "win32" else ".so"
    folder = cache_root() / f"native_{digest()}"
    library = folder / f"crank_kernel{suffix}"
    if library.is_file():
        return library
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not compiler:
        raise CrankfmuError("crankfmu's C kernel is not built and no C compiler was found to build it: "
                            "reinstall crankfmu (pip install .) or install gcc")

    def build(partial: Path):
        partial.mkdir(parents=True, exist_ok=True)
        done = subprocess.run([compiler, *CFLAGS, "-shared", "-o", str(partial / library.name),
                               str(HERE / "crank_kernel.c"), "-lm"], capture_output=True, text=True)
        if done.returncode != 0:
            raise CrankfmuError(f"compiling crankfmu's C kernel failed: {done.stderr.strip()}")

    install(folder, build)
    return library


def _load() -> ctypes.CDLL:
    path = _installed() or _compile_into_cache()
    lib = ctypes.CDLL(str(path))
    D, I = ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int)
    T = ctypes.c_void_p
    signatures = {
        "ck_layout": (ctypes.c_int, [I, ctypes.c_int]),
        "ck_begin": (None, [D, ctypes.c_double, D, T, D, D]),
        "ck_step": (ctypes.c_int, [D, ctypes.c_double, T, D]),
        "ck_advance": (ctypes.c_int, [D, ctypes.c_double, ctypes.c_double, T, D, D]),
        "ck_output_row": (None, [D, ctypes.c_double, T, D, D]),
        "ck_dense": (None, [D, ctypes.c_double, D]),
        "ck_run_chunk": (ctypes.c_int, [D, ctypes.c_double, D, ctypes.c_int, I, D, D, ctypes.c_int, I, D,
                                        ctypes.c_int, I, D, ctypes.c_int, I, T, D]),
        "ck_dense_many": (None, [D, ctypes.c_int, D, ctypes.c_int, D]),
        "ck_steady_batch": (None, [D, ctypes.c_int, ctypes.c_double, D, ctypes.c_double, ctypes.c_int, T, D]),
    }
    for name, (restype, argtypes) in signatures.items():
        function = getattr(lib, name)
        function.restype, function.argtypes = restype, argtypes
    return lib


class _Tables(ctypes.Structure):
    _fields_ = [("coefficients", ctypes.POINTER(ctypes.c_double)), ("n_functions", ctypes.c_int),
                ("n", ctypes.c_int), ("switch_angles", ctypes.POINTER(ctypes.c_double)), ("m", ctypes.c_int),
                ("forces", ctypes.POINTER(ctypes.c_double)), ("n_sliders", ctypes.c_int)]


LIBRARY = _load()
_LAYOUT_NAMES = ("T", "Y", "F_", "H", "MOTOR", "DIRECTION", "INTERVAL", "PHI_LO", "PHI_HI", "T_PREV", "Y_PREV", "K",
                 "N_RHS", "STEP_MOTOR", "STEP_DIRECTION", "STEP_INTERVAL", "N_STEPS", "STATE_SIZE", "N_Y",
                 "PARAM_SIZE", "OUT_SIZE", "STEADY_SIZE", "N_STAGES", "N_SLOTS", "MAX_FUNCTIONS")


def layout() -> dict[str, int]:
    """The C kernel's array layout, by name (the header's enums)."""
    out = (ctypes.c_int * 64)()
    count = LIBRARY.ck_layout(out, 64)
    return dict(zip(_LAYOUT_NAMES, out[:count]))


def _d(array: np.ndarray):
    return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


class Tables:
    """A design's tables as the C kernel takes them; keeps the arrays alive while in use."""

    def __init__(self, coefficients, switch_angles, forces):
        self.arrays = (np.ascontiguousarray(coefficients, dtype=float),
                       np.ascontiguousarray(switch_angles, dtype=float),
                       np.ascontiguousarray(forces, dtype=float))
        C, sw, fo = self.arrays
        if C.shape[0] > layout()["MAX_FUNCTIONS"]:
            raise CrankfmuError(f"the C kernel takes at most {layout()['MAX_FUNCTIONS']} tabulated functions, "
                                f"got {C.shape[0]}")
        self.struct = _Tables(_d(C), C.shape[0], C.shape[1], _d(sw), sw.shape[0], _d(fo),
                              fo.shape[2] if fo.ndim == 3 else 0)
        self.pointer = ctypes.cast(ctypes.pointer(self.struct), ctypes.c_void_p)


def begin(S, t, y, tables: Tables, P, row):
    LIBRARY.ck_begin(_d(S), t, _d(np.ascontiguousarray(y, dtype=float)), tables.pointer, _d(P), _d(row))


def advance(S, t_target, t_limit, tables: Tables, P, row) -> int:
    return LIBRARY.ck_advance(_d(S), t_target, t_limit, tables.pointer, _d(P), _d(row))


def dense(S, t, out):
    LIBRARY.ck_dense(_d(S), t, _d(out))


def output_row(S, t, tables: Tables, P, row):
    LIBRARY.ck_output_row(_d(S), t, tables.pointer, _d(P), _d(row))


def run_chunk(S, t_end, times, i_out, rows, step_store, n_store, events, n_events, modes, n_modes,
              tables: Tables, P):
    """As the numba driver: returns (status, i_out, n_store, n_events, n_modes)."""
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
