"""The C kernel's sources and their content hash: what the library is compiled from and the name
of what it was compiled from; and the native FMUs' runtime, one binary per FMI version and platform
that reads its model (a mechanism's scenario or a component) from the FMU's resources (RUNTIME_*),
compiled for every platform whose compiler is installed when the package is built, so that
``crankfmu fmu --native`` compiles nothing. The standard library only: setup.py runs this file by
its path before anything is installed."""

import hashlib
import os
import shutil
import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: the C's parts, each a folder here (an FMU's sources/ holds them side by side; each folder is an
#: include path of the others): the kernel, the mechanism model, the components, the coupled well,
#: the native FMUs' model behind the one model API, and the FMI shells
FOLDERS = ("kernel", "mechanism", "components", "well", "model", "shells")


def _in(folder: str, names: tuple) -> tuple:
    return tuple(f"{folder}/{name}" for name in names)


#: the mechanism's kernel: its stepper (crank_kernel.c), the joints' friction's solve (crank_friction.c),
#: the drivers callers run (crank_drivers.c),
#: the speed-causal step (crank_speed.c), Model Exchange (crank_me.c), the outputs read from their
#: tables (crank_outputs.c), its constants and rules one by one (crank_facts.c); numbers in messages
KERNEL = _in("kernel", ("crank_kernel.c", "crank_friction.c", "crank_drivers.c", "crank_speed.c", "crank_me.c",
                        "crank_outputs.c", "crank_facts.c", "crank_kernel.h", "crank_kernel_internal.h", "crank_modes.h",
                        "crank_tableau.h", "crank_numbers.c", "crank_numbers.h"))
#: the components' physics (the drive, the cushion, the rod string)
COMPONENTS = _in("components", ("crank_components.c", "crank_components.h"))
#: the pumping well as one model: the kernel and the string's steps coupled (crankfmu well runs it)
WELL = _in("well", ("crank_well.c", "crank_well.h"))
#: the mechanism model: a scenario's compiled program evaluated (crank_mechanism.c), checked and
#: searched (crank_assembly.c), its tables' functions (crank_engine.c) tabulated (crank_tabulator.c)
#: with Fourier series (crank_fourier.c)
MECHANISM = _in("mechanism", ("crank_mechanism.c", "crank_assembly.c", "crank_engine.c", "crank_tabulator.c",
                              "crank_fourier.c", "crank_mechanism.h", "crank_mechanism_internal.h", "crank_fourier.h"))
SOURCES = KERNEL + COMPONENTS + WELL + MECHANISM
#: the C files the library is compiled from (the mechanism's kernel, the components' physics, the well)
C_FILES = tuple(name for name in SOURCES if name.endswith(".c"))
#: how the library is compiled, by setup.py and by the fallback: C99, no FMA contraction (the
#: numbers do not depend on the CPU the library was compiled for)
CFLAGS = ["-std=c99", "-O2", "-ffp-contract=off", "-fPIC"]
WIN64_CC = "x86_64-w64-mingw32-gcc"
AARCH64_CC = "aarch64-linux-gnu-gcc"
#: the native FMUs' compilers, each with whether it makes a Windows DLL: Linux x86_64, and where they
#: are installed Windows x86_64 (MinGW-w64) and Linux aarch64 (FMI 3.0)
FMU_COMPILERS = {"gcc": False, WIN64_CC: True, AARCH64_CC: False}


#: the native FMUs' runtime besides the kernel, the mechanism model and the components' physics: the
#: one model API (model/fmu_model.c) and its model file's reader, the mechanism's model and the
#: components' (components/component_model.c) behind it, and each FMI version's shell (shells/)
RUNTIME_MODEL = (_in("model", ("fmu_model.c", "model_status.c", "crank_model.c", "crank_model_variables.c",
                                "crank_model_me.c", "crank_model_refusals.c", "crank_model_file.c",
                                "crank_model_location.c", "sha256.c",
                                "crank_model_derivatives.c", "fmu_derivatives.c", "fmu_model.h", "model_status.h",
                                "crank_model.h", "crank_model_internal.h", "crank_variables.h", "sha256.h",
                                "fmu_states.h", "fmu_derivatives.h"))
                 + _in("components", ("component_model.c", "component_models.c", "component_derivatives.c",
                                      "component_model.h")))
RUNTIME_SHELL = {"2.0": _in("shells", ("fmi2_shell.c", "fmi2_messages.c", "fmi2_messages.h")),
                 "3.0": _in("shells", ("fmi3_shell.c", "fmi3_refusals.c", "fmi3_refusals.h"))}
#: the FMI headers each version's sources carry (from fmpy, BSD-2-Clause): a source build needs nothing else
FMI_HEADERS = {"2.0": ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
               "3.0": ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}
#: each FMI version's binaries: (platform folder, compiler; whether it makes a DLL is FMU_COMPILERS')
PLATFORMS = {"2.0": (("linux64", "gcc"), ("win64", WIN64_CC)),
             "3.0": (("x86_64-linux", "gcc"), ("x86_64-windows", WIN64_CC), ("aarch64-linux", AARCH64_CC))}
#: the runtimes compiled when the package is built: RUNTIMES/fmi<v>/<platform>/crankfmu-<digest>.so|dll
RUNTIMES = HERE / "runtimes"


def runtime_files(fmi_version: str) -> list[Path]:
    """Every file a runtime is compiled from, the FMI headers too: what an FMU's sources/ carry."""
    return ([HERE / n for n in KERNEL + COMPONENTS + MECHANISM + RUNTIME_MODEL + RUNTIME_SHELL[fmi_version]]
            + [fmi_headers() / n for n in FMI_HEADERS[fmi_version]])


def fmi_headers() -> Path:
    """fmpy's folder of the FMI headers (a build requirement; found without importing fmpy)."""
    import importlib.util

    spec = importlib.util.find_spec("fmpy")
    if spec is None or not spec.origin:
        raise RuntimeError("fmpy is not installed: its FMI headers compile the native FMUs' runtimes")
    return Path(spec.origin).parent / "c-code"


def runtime_flags(windows: bool) -> list:
    """How a runtime is compiled, besides its -I folder: as the library, no -fPIC for a DLL, CK_API
    empty (the runtime exports its shell, not the kernel), on Linux nothing visible but the FMI
    functions; a shared library with libgcc linked statically."""
    flags = [f for f in CFLAGS if not (windows and f == "-fPIC")] + ["-DCK_API="]
    return flags + ([] if windows else ["-fvisibility=hidden"]) + ["-shared", "-static-libgcc"]


def runtime_name(fmi_version: str, compiler: str, windows: bool) -> str:
    """The runtime's file name: its sources' content, the compiler and the flags, so an installed
    runtime is never paired with other sources."""
    h = hashlib.sha256(repr((fmi_version, compiler, runtime_flags(windows))).encode())
    for path in runtime_files(fmi_version):
        h.update(path.name.encode() + b"\0" + path.read_bytes())
    return f"crankfmu-{h.hexdigest()[:20]}{'.dll' if windows else '.so'}"


def compile_runtime(fmi_version: str, compiler: str, out: Path, run=None) -> Path:
    """One runtime compiled from its files (in a temporary folder, as an FMU's sources/ are laid out)
    to ``out``, written whole or not at all."""
    import tempfile

    windows = FMU_COMPILERS[compiler]
    with tempfile.TemporaryDirectory() as tmp:
        for path in runtime_files(fmi_version):
            shutil.copy2(path, Path(tmp) / path.name)
        sources = sorted(str(p) for p in Path(tmp).glob("*.c"))
        out.parent.mkdir(parents=True, exist_ok=True)
        partial = out.with_name(f"{out.name}.{os.getpid()}.{threading.get_ident()}")
        try:
            (run or _run)([compiler, *runtime_flags(windows), f"-I{tmp}", "-o", str(partial), *sources,
                           *([] if windows else ["-lm"])])
            os.replace(partial, out)
        finally:
            partial.unlink(missing_ok=True)
    return out


def runtime(fmi_version: str, folder: str, compiler: str, roots) -> Path | None:
    """The runtime of ``folder`` (a platform) for these sources in the first of ``roots`` that has it."""
    name = runtime_name(fmi_version, compiler, FMU_COMPILERS[compiler])
    for root in roots:
        path = Path(root) / f"fmi{fmi_version[0]}" / folder / name
        if path.is_file():
            return path
    return None


def prebuild_runtimes(root: Path = RUNTIMES) -> list:
    """Every runtime whose compiler is installed, compiled into ``root`` (the others' folders are
    left as they are; runtimes of earlier sources removed). Returns [(FMI version, platform)]."""
    jobs = {}
    for version, platforms in PLATFORMS.items():
        for folder, cc in platforms:
            if shutil.which(cc):
                name = runtime_name(version, cc, FMU_COMPILERS[cc])
                jobs[(version, folder)] = (cc, root / f"fmi{version[0]}" / folder / name)
    for version, folder in jobs:
        for old in (root / f"fmi{version[0]}" / folder).glob("crankfmu-*"):
            if old != jobs[(version, folder)][1]:
                old.unlink()
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        for done in [pool.submit(compile_runtime, version, cc, out) for (version, _), (cc, out) in jobs.items()
                     if not out.is_file()]:
            done.result()
    return sorted(jobs)


def include_flags() -> list:
    """The -I flags of the library's and the runtime's parts (FOLDERS): each part includes the others' headers."""
    return [f"-I{HERE / folder}" for folder in FOLDERS]


def digest(folder: Path = HERE) -> str:
    """The hash of the sources in ``folder``; the library returns the one it was compiled from
    (ck_source_digest), so a library and sources of different content are never paired."""
    h = hashlib.sha256()
    for name in SOURCES:
        h.update(name.encode() + b"\0" + (folder / name).read_bytes())
    return h.hexdigest()[:16]


def library_name(platform: str) -> str:
    return "crank_kernel.dll" if platform == "win32" else "crank_kernel.so"


def _run(command: list) -> None:
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{command[0]} failed compiling the native FMUs' runtime: {done.stderr.strip()}")


if __name__ == "__main__":
    # python src/crankfmu/native/sources.py --prebuild (by its path, as setup.py reads it): the
    # runtimes again once a cross compiler is installed, or the sources changed
    if sys.argv[1:] != ["--prebuild"]:
        sys.exit("usage: python sources.py --prebuild")
    try:
        runtimes = prebuild_runtimes()
    except (OSError, RuntimeError) as error:
        sys.exit(f"sources.py --prebuild: {error}")
    print(f"runtimes of the native FMUs: {', '.join(f'FMI {v} {p}' for v, p in runtimes) or 'none'} in {RUNTIMES}")
