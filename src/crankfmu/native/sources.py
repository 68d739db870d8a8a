"""The C kernel's sources and their content hash: what the library is compiled from and the name
of what it was compiled from; and the objects native FMUs link, compiled for every FMU compiler
when the package is installed (a first native build then compiles only its own files). The
standard library only: setup.py runs this file by its path before anything is installed."""

import hashlib
import os
import re
import shutil
import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: the mechanism's kernel: its stepper (crank_kernel.c), the drivers callers run (crank_drivers.c),
#: the speed-causal step (crank_speed.c), Model Exchange (crank_me.c), the outputs read from their
#: tables (crank_outputs.c), its constants and rules one by one (crank_facts.c); numbers in messages
KERNEL = ("crank_kernel.c", "crank_drivers.c", "crank_speed.c", "crank_me.c", "crank_outputs.c", "crank_facts.c",
          "crank_kernel.h", "crank_kernel_internal.h", "crank_modes.h", "crank_tableau.h", "crank_numbers.c",
          "crank_numbers.h")
#: the components' physics (the drive, the cushion, the rod string)
COMPONENTS = ("crank_components.c", "crank_components.h")
#: the pumping well as one model: the kernel and the string's steps coupled (crankfmu well runs it)
WELL = ("crank_well.c", "crank_well.h")
#: the mechanism model: a scenario's compiled program evaluated (crank_mechanism.c), checked and
#: searched (crank_assembly.c), its tables' functions (crank_engine.c) tabulated (crank_tabulator.c)
#: with Fourier series (crank_fourier.c)
MECHANISM = ("crank_mechanism.c", "crank_assembly.c", "crank_engine.c", "crank_tabulator.c", "crank_fourier.c",
             "crank_mechanism.h", "crank_mechanism_internal.h", "crank_fourier.h")
SOURCES = KERNEL + COMPONENTS + WELL + MECHANISM
#: the C files the library is compiled from (the mechanism's kernel, the components' physics, the well)
C_FILES = tuple(name for name in SOURCES if name.endswith(".c"))
#: the C files native FMUs link: the mechanism's kernel and model, the components' physics (the
#: well's coupling runs in process only)
FMU_C_FILES = tuple(name for name in KERNEL + COMPONENTS + MECHANISM if name.endswith(".c"))
#: how the library is compiled, by setup.py and by the fallback: C99, no FMA contraction (the
#: numbers do not depend on the CPU the library was compiled for)
CFLAGS = ["-std=c99", "-O2", "-ffp-contract=off", "-fPIC"]
WIN64_CC = "x86_64-w64-mingw32-gcc"
AARCH64_CC = "aarch64-linux-gnu-gcc"
#: the native FMUs' compilers, each with whether it makes a Windows DLL: Linux x86_64, and where they
#: are installed Windows x86_64 (MinGW-w64) and Linux aarch64 (FMI 3.0)
FMU_COMPILERS = {"gcc": False, WIN64_CC: True, AARCH64_CC: False}
#: the objects of this folder's C files compiled for native FMUs when the package was installed
#: (setup.py; make test again once MinGW is there), named as object_name names them
PREBUILT = HERE / "objects"


def digest(folder: Path = HERE) -> str:
    """The hash of the sources in ``folder``; the library returns the one it was compiled from
    (ck_source_digest), so a library and sources of different content are never paired."""
    h = hashlib.sha256()
    for name in SOURCES:
        h.update(name.encode() + b"\0" + (folder / name).read_bytes())
    return h.hexdigest()[:16]


def library_name(platform: str) -> str:
    return "crank_kernel.dll" if platform == "win32" else "crank_kernel.so"


def fmu_flags(windows: bool) -> list:
    """How a native FMU's sources are compiled, besides its -I folders: as the library, no -fPIC
    for a DLL, CK_API empty (the FMU exports its shell, not the kernel), and on Linux nothing
    visible but the FMI functions."""
    flags = [f for f in CFLAGS if not (windows and f == "-fPIC")] + ["-DCK_API="]
    return flags + ([] if windows else ["-fvisibility=hidden"])


_INCLUDE = re.compile(rb'^[ \t]*#[ \t]*include[ \t]*"([^"]+)"', re.MULTILINE)


def includes(source: Path, folders: list) -> set:
    """The files ``source`` includes by "name", each found first beside the file that includes it,
    then in ``folders`` (the -I folders), and what they include in turn: the list gcc -MM gives,
    read here instead of by one compiler process per source and platform (0.03 s each, in series
    with the compiles). An include under an #if counts either way: one dependency too many costs at
    most a cache miss, never a stale object."""
    found, todo = set(), [Path(source)]
    while todo:
        including = todo.pop()
        for name in _INCLUDE.findall(including.read_bytes()):
            for folder in (including.parent, *folders):
                candidate = Path(folder) / name.decode()
                if candidate.is_file():
                    if candidate not in found:
                        found.add(candidate)
                        todo.append(candidate)
                    break
    return found


def object_name(compiler: str, flags: list, made: list) -> str:
    """The name of the object a compiler makes of ``made`` (the source, then every file it
    includes) with ``flags``: the compiler, the flags and each file's name and content, not the
    folders (-I) they were read from, which differ between builds and installations."""
    h = hashlib.sha256(repr((compiler, [f for f in flags if not f.startswith("-I")])).encode())
    for dep in sorted(made, key=lambda p: (Path(p).name, str(p))):
        h.update(Path(dep).name.encode() + b"\0" + Path(dep).read_bytes())
    return f"{Path(made[0]).stem}_{h.hexdigest()[:20]}.o"


def compile_object(compiler: str, flags: list, source: Path, obj: Path, run=None) -> None:
    """Compile ``source`` to ``obj`` under a temporary name, then rename it: a reader sees a whole
    object or none. ``run(command)`` runs the compiler and raises where it fails (default: a
    RuntimeError with the compiler's message)."""
    partial = obj.with_name(f"{obj.name}.{os.getpid()}.{threading.get_ident()}")
    try:
        (run or _run)([compiler, *flags, "-c", "-o", str(partial), str(source)])
        os.replace(partial, obj)
    finally:
        partial.unlink(missing_ok=True)


def _run(command: list) -> None:
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{command[0]} failed on {Path(command[-1]).name}: {done.stderr.strip()}")


def prebuild(folder: Path = PREBUILT) -> list:
    """The objects of FMU_C_FILES compiled into ``folder`` for every FMU compiler installed, all at
    once: a first native build then compiles only its own generated files. Objects of earlier
    sources are removed. Returns the compilers used."""
    compilers = [cc for cc in FMU_COMPILERS if shutil.which(cc)]
    folder.mkdir(parents=True, exist_ok=True)
    jobs = {}
    for cc in compilers:
        flags = fmu_flags(FMU_COMPILERS[cc]) + [f"-I{HERE}"]
        for name in FMU_C_FILES:
            source = HERE / name
            obj = folder / object_name(cc, flags, [source, *includes(source, [HERE])])
            jobs[obj] = (cc, flags, source)
    for old in folder.glob("*.o"):
        if old not in jobs:
            old.unlink()
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        for done in [pool.submit(compile_object, *job, obj) for obj, job in jobs.items() if not obj.is_file()]:
            done.result()
    return compilers


if __name__ == "__main__":
    # python src/crankfmu/native/sources.py --prebuild (by its path, as setup.py reads it): the
    # objects again once a cross compiler is installed
    if sys.argv[1:] != ["--prebuild"]:
        sys.exit("usage: python sources.py --prebuild")
    try:
        used = prebuild()
    except (OSError, RuntimeError) as error:
        sys.exit(f"sources.py --prebuild: {error}")
    print(f"native FMU objects compiled for {', '.join(used) or 'no compiler found'} in {PREBUILT}")
