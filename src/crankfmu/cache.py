"""crankfmu's per-user cache: where the C kernel compiled here and FMU packages are kept between processes.

The standard library only: an FMU's slave script loads this file by its path, before it has
imported anything of the package it carries.

``$CRANKFMU_CACHE``, default ``~/.cache/crankfmu``, holds

  native_<digest>/   the C kernel compiled from sources of that hash, where the installed
                     library does not match them (crankfmu.native)
  fmu_<digest>/      the package an FMU carries, unpacked from the archive in its resources
                     (fmi/python/slave_script.py.in)
  references/        each design's reference run (fmi.reference.reference_result)
  figures/           an FMU's documentation figures, by what they are drawn from (fmi.documentation)
  runtimes/          native FMUs' runtimes the installation did not compile (native/sources.py's
                     RUNTIMES), each named by its sources, compiler and flags

Each folder and file is named by the content hash of what it holds and written whole under a
temporary name, then renamed: a process sees a complete one or none, and a changed content gets a new
one.

An installation from the wheel also carries, read-only, the references/ and figures/ of its
packaged scenarios (``prebuilt/`` beside this file, fmi/prebuilt_results.py): ``kept`` reads them
where the per-user cache has none.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path


def cache_root() -> Path:
    """$CRANKFMU_CACHE, default ~/.cache/crankfmu."""
    return Path(os.environ.get("CRANKFMU_CACHE") or Path.home() / ".cache" / "crankfmu")


def install(folder: Path, fill) -> Path:
    """Put ``folder`` in place unless it is there: ``fill(partial)`` writes its content into a new
    folder, which is then renamed into place. Returns ``folder``; raises OSError where the cache
    cannot be written."""
    if folder.is_dir():
        return folder
    folder.parent.mkdir(parents=True, exist_ok=True)
    partial = folder.with_name(f"{folder.name}.{os.getpid()}")
    shutil.rmtree(partial, ignore_errors=True)
    partial.mkdir()
    fill(partial)
    try:
        os.replace(partial, folder)
    except OSError:                   # another process put it there first
        shutil.rmtree(partial, ignore_errors=True)
        if not folder.is_dir():
            raise
    return folder


#: what the installation carries of the cache (fmi/prebuilt_results.py): made when the wheel was built.
#: None where this file runs from its text (a Python FMU's slave script: it reads no results)
INSTALLED = Path(__file__).resolve().parent / "prebuilt" if "__file__" in globals() else None


def kept(kind: str, key: str, make, encoding: str | None = None):
    """What ``make()`` returns (bytes, or text where ``encoding`` is given), kept in the cache as
    ``<kind>/<key>``: read from it (or from what the installation carries) when it is there, else
    made and written whole. A cache that cannot be written keeps nothing (the value is returned all
    the same)."""
    path = cache_root() / kind / key
    for found in (path,) if INSTALLED is None else (path, INSTALLED / kind / key):
        try:
            data = found.read_bytes()
            return data.decode(encoding) if encoding else data
        except OSError:
            pass
    value = make()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_name(f"{path.name}.{os.getpid()}")
        partial.write_bytes(value.encode(encoding) if encoding else value)
        os.replace(partial, path)
    except OSError:
        pass
    return value
