"""The one JIT of crankfmu: numba ``nopython`` where numba is installed, plain Python elsewhere.

The compiled kernel (``integrators.kernel``) and the hybrid rules it shares with the engine
(``dynamics.modes``) are decorated here, so both compile with the same options and both run
unchanged as plain Python where numba is absent or ``CRANKFMU_JIT=0`` is set: the same arithmetic
in the same order, hence the same numbers (tests compare the two). numba was chosen over a C
extension because the FMU already needs a Python interpreter and the model's tables come from
numpy; it needs no compiler on the user's machine and caches its machine code on disk.

numpy only at import (numba is imported only when enabled): the FMUs ship this module.
"""

from __future__ import annotations

import os

_USE_JIT = os.environ.get("CRANKFMU_JIT", "1") != "0"
try:
    if not _USE_JIT:
        raise ImportError
    # Machine code for a generic x86-64 CPU: the kernel compiled ahead of time (crankfmu.precompile)
    # then loads on any x86-64 machine, not only the one that built it (numba keys its cache on the
    # CPU's name and features). Measured on seed 000: the kernel is as fast as for the host CPU
    # (0.99 ms against 0.99 ms for 2 s), and without FMA contraction the numbers are the same.
    # A NUMBA_CPU_NAME already set is kept; where numba was configured before this import, the
    # precompiled kernel does not match and the kernel compiles once into the cache instead.
    os.environ.setdefault("NUMBA_CPU_NAME", "generic")
    import numba

    def jit(function):
        """Compile ``function`` (machine code cached on disk beside its file)."""
        return numba.njit(cache=True, nogil=True, error_model="numpy")(function)

    def jit_inline(function):
        """Compile ``function`` to be inlined in its compiled callers: a call between compiled
        functions with array arguments otherwise costs reference counting on each array
        (about 150 ns per right-hand side)."""
        return numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")(function)
    COMPILED = True
except ImportError:
    def jit(function):
        return function
    jit_inline = jit
    COMPILED = False


def python_function(function):
    """The plain-Python function behind a compiled one (itself where nothing is compiled): what a
    Python caller uses to run a shared rule without compiling it or paying numba's dispatch."""
    return getattr(function, "py_func", function)
