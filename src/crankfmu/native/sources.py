"""The C kernel's sources and their content hash: what the library is compiled from and the name
of what it was compiled from. The standard library only: setup.py runs this file by its path
before anything is installed."""

import hashlib
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: the mechanism's kernel: its stepper (crank_kernel.c), the drivers callers run (crank_drivers.c),
#: the speed-causal step (crank_speed.c) and Model Exchange (crank_me.c); numbers in messages
KERNEL = ("crank_kernel.c", "crank_drivers.c", "crank_speed.c", "crank_me.c", "crank_kernel.h",
          "crank_kernel_internal.h", "crank_modes.h", "crank_tableau.h", "crank_numbers.c", "crank_numbers.h")
#: the components' physics (the drive, the cushion, the rod string)
COMPONENTS = ("crank_components.c", "crank_components.h")
#: the pumping well as one model: the kernel and the string's steps coupled (crankfmu well runs it)
WELL = ("crank_well.c", "crank_well.h")
#: the mechanism model: a scenario's compiled program evaluated (crank_mechanism.c), checked and
#: searched (crank_assembly.c), its tables' functions (crank_engine.c) tabulated (crank_tabulator.c)
MECHANISM = ("crank_mechanism.c", "crank_assembly.c", "crank_engine.c", "crank_tabulator.c", "crank_mechanism.h",
             "crank_mechanism_internal.h")
SOURCES = KERNEL + COMPONENTS + WELL + MECHANISM
#: the C files the library is compiled from (the mechanism's kernel, the components' physics, the well)
C_FILES = tuple(name for name in SOURCES if name.endswith(".c"))
#: how the library is compiled, by setup.py and by the fallback: C99, no FMA contraction (the
#: numbers do not depend on the CPU the library was compiled for)
CFLAGS = ["-std=c99", "-O2", "-ffp-contract=off", "-fPIC"]


def digest(folder: Path = HERE) -> str:
    """The hash of the sources in ``folder``; the library returns the one it was compiled from
    (ck_source_digest), so a library and sources of different content are never paired."""
    h = hashlib.sha256()
    for name in SOURCES:
        h.update(name.encode() + b"\0" + (folder / name).read_bytes())
    return h.hexdigest()[:16]


def library_name(platform: str) -> str:
    return "crank_kernel.dll" if platform == "win32" else "crank_kernel.so"
