"""The Python FMUs' linux64 shim (fmu_shim.c, find_python.c) compiled once, when crankfmu is
installed (setup.py runs this file by its path, before crankfmu can be imported), so that
`crankfmu fmu` needs no compiler: every Python FMU carries a copy, named for its model (the shim
finds pythonfmu's binary beside it by its own file name). ``digest`` names the sources a shim was
compiled from; a shim of other sources (an edited checkout) is compiled again where gcc is.
Only the standard library and fmpy (the FMI 2.0 headers)."""

from __future__ import annotations

import hashlib
import shutil
import subprocess
from pathlib import Path

HERE = Path(__file__).resolve().parent
SOURCES = ("fmu_shim.c", "find_python.c", "find_python.h")
#: where the installation keeps the shim, and the digest of the sources it came from
PREBUILT = HERE / "fmu_shim.so"
PREBUILT_DIGEST = HERE / "fmu_shim.digest"


def digest(folder: Path = HERE) -> str:
    h = hashlib.sha256()
    for name in SOURCES:
        h.update(name.encode() + b"\0" + (folder / name).read_bytes())
    return h.hexdigest()[:20]


def compile_shim(out: Path, folder: Path = HERE) -> Path:
    """gcc the shim of ``folder``'s sources into ``out`` (FileNotFoundError without gcc,
    subprocess.CalledProcessError when it does not compile); the FMI headers come with fmpy."""
    import fmpy

    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O2", "-Wall", "-Werror", f"-I{headers}", "-o", str(out),
                    str(folder / "fmu_shim.c"), str(folder / "find_python.c"), "-ldl"],
                   check=True, capture_output=True, text=True)
    return out


def prebuild(into: Path, folder: Path = HERE) -> Path:
    """The shim and its digest into the folder ``into`` (setup.py: the installed package's shim/)."""
    into.mkdir(parents=True, exist_ok=True)
    compile_shim(into / PREBUILT.name, folder)
    (into / PREBUILT_DIGEST.name).write_text(digest(folder) + "\n")
    return into / PREBUILT.name


def shim(out: Path) -> Path:
    """The shim at ``out``: the installation's, where it was compiled from these sources, else
    compiled now (gcc)."""
    if PREBUILT.is_file() and PREBUILT_DIGEST.is_file() and PREBUILT_DIGEST.read_text().strip() == digest():
        shutil.copy2(PREBUILT, out)
        return out
    return compile_shim(out)
