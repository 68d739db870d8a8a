"""The compiled kernel of the fast path, split by job:

  layout.py   what each float of the state and parameter arrays holds (numpy only)
  method.py   Dormand-Prince 5(4) on the tables, events located (the hybrid rules: dynamics.modes)
  drivers.py  the loops callers run: an FMU step, a run on an output grid, steady cycles

``method`` and ``drivers`` are imported from copies named by their content hash in the per-user
cache (crankfmu.cache: $CRANKFMU_CACHE, default ~/.cache/crankfmu). numba caches machine code beside
the source file, keyed on its path. An FMU runs its own copy of this package from wherever the host
extracted it (fmpy: a new temporary directory per run), so a kernel compiled there would be
compiled again on every run (about 15 s). The copy's path depends only on its content and on the
content of everything it reads (numba freezes other modules' constants and functions into its
machine code): every FMU and process with the same kernel shares one compilation, and a changed
rule gets a new one. Where that directory cannot be written the package's own file is used. The
module's name is the same in every copy of the package (numba's cache refers to its functions by
module name, and an FMU's package has a private name of its own), so a copy cannot import its
siblings: the modules it reads are put into its namespace before it runs.

Compiled ahead of time: ``crankfmu.precompile`` (run by the FMU build) compiles every kernel entry
point for a generic x86-64 CPU (``compiled.py`` sets NUMBA_CPU_NAME=generic) into
``precompiled/kernel_<digest>.zip`` beside this file, which the package and every FMU carry. A new
cache folder is unpacked from there (the source gets back the modification time numba's index
recorded), so a first run on a fresh machine loads machine code instead of compiling it for 20 s.
A precompiled kernel of another content hash is never used: a changed rule compiles afresh.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import shutil
import sys
from pathlib import Path

from ... import compiled
from ...cache import cache_root, install
from ...dynamics import modes
from .. import tableau
from . import layout

COMPILED = compiled.COMPILED


#: where the package carries its kernels compiled ahead of time (crankfmu.precompile writes it)
PRECOMPILED = Path(__file__).with_name("precompiled")


#: in a precompiled kernel's archive (precompiled/kernel_<digest>.zip: one file, which a host
#: extracting the FMU on every run writes faster than the forty of numba's cache): the source, each
#: source file's modification time (ns) when it was compiled, and numba's index and machine code
#: (its __pycache__ once in the cache)
STAMPS = "mtimes.json"
MACHINE_CODE = "numba"


def _seed(shipped: Path, folder: Path):
    """Unpack a precompiled kernel into the cache. numba's index holds its source file's
    modification time and size: the source gets back the time it was compiled with."""
    import json
    import zipfile

    def unpack(partial: Path):
        with zipfile.ZipFile(shipped) as archive:
            archive.extractall(partial)
        shutil.copytree(partial / MACHINE_CODE, partial / "__pycache__", dirs_exist_ok=True)
        shutil.rmtree(partial / MACHINE_CODE)
        for name, mtime_ns in json.loads((partial / STAMPS).read_text()).items():
            os.utime(partial / name, ns=(mtime_ns, mtime_ns))

    if not folder.is_dir():
        install(folder, unpack)         # a new folder, renamed into place whole
    else:                               # the source only, from a run without numba
        unpack(folder)


def _load(name: str, inputs: dict):
    """Module ``name``.py of this folder run from its content-named copy, with ``inputs`` (the
    modules it reads) in its namespace."""
    source = Path(__file__).with_name(f"{name}.py")
    text = source.read_bytes()
    digest = hashlib.sha256(text)
    for module in inputs.values():
        digest.update(getattr(module, "kernel_digest", None) or Path(module.__file__).read_bytes())
    digest = digest.hexdigest()[:16]
    module_name = f"crankfmu_kernel_{name}_{digest}"
    if module_name in sys.modules:
        return sys.modules[module_name]
    path = source
    try:
        folder = cache_root() / f"kernel_{digest}"
        target = folder / f"{name}.py"
        shipped = PRECOMPILED / f"{folder.name}.zip"
        # numba's machine code, where numba runs and has no index here yet (a run without numba
        # leaves only Python's bytecode in __pycache__)
        if COMPILED and shipped.is_file() and not any((folder / "__pycache__").glob("*.nbi")):
            _seed(shipped, folder)
        if not target.is_file() or target.read_bytes() != text:
            folder.mkdir(parents=True, exist_ok=True)
            partial = folder / f"{name}.py.{os.getpid()}"
            partial.write_bytes(text)
            os.replace(partial, target)          # atomic: a concurrent process sees all or nothing
        path = target
    except OSError:
        pass
    spec = importlib.util.spec_from_file_location(module_name, path)
    module = importlib.util.module_from_spec(spec)
    module.__dict__.update(inputs)
    module.kernel_digest = digest.encode()
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    return module


method = _load("method", {"layout": layout, "modes": modes, "tableau": tableau, "compiled": compiled})
drivers = _load("drivers", {"layout": layout, "method": method, "compiled": compiled})

__all__ = ["COMPILED", "drivers", "layout", "method"]
