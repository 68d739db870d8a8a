"""What the installation carries of the per-user cache: the packaged scenarios' reference runs and
documentation figures, made when crankfmu's wheel is built (setup.py), as its runtimes are.

A native build on an empty per-user cache spends most of its time on the reference run (the
independent Python engine under DOP853 at 1e-12: scipy's import and some 4500 right-hand sides for
seed000) and on matplotlib (its import and two figures): about 1 s of CPU that no compiler is
involved in. Both depend only on the design's data and crankfmu's Python sources, which a wheel
fixes, so the wheel carries them for its packaged scenarios: ``crankfmu fmu seed000 --native`` then
draws and integrates nothing. A user's own design, or a packaged one at other values, is made in the
build as before and kept in the per-user cache (cache.kept reads the per-user cache, then these).

They are made by the real build: each packaged scenario's native FMU is built by the CLI of the
package being built, with the per-user cache pointed at a new folder; that folder's references/
and figures/ become the package's ``prebuilt/``. So their names are what a build looks up, whatever
the key's rule. The standard library only: setup.py loads this file by its path.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

#: the folder of the package that holds them (cache.INSTALLED)
FOLDER = "prebuilt"
#: the kinds of the cache they are
KINDS = ("references", "figures")


def prebuild(package: Path, lanes: int = 2) -> list[str]:
    """Fill ``package``/prebuilt (``package``: the crankfmu package being built, its kernel and
    runtimes in place) with the references and figures of every packaged scenario's native FMU
    build. Returns the scenarios' names; raises RuntimeError naming a build that failed."""
    package = Path(package)
    names = sorted(p.stem for p in (package / "scenarios").glob("*.toml"))
    into = package / FOLDER
    shutil.rmtree(into, ignore_errors=True)
    with tempfile.TemporaryDirectory(prefix="crankfmu-prebuild-") as work:
        work = Path(work)
        # the package being built first, then what the build's environment has on the path (pip's
        # isolated build environment is a PYTHONPATH entry: numpy, scipy, matplotlib and fmpy there)
        path = os.pathsep.join(p for p in (str(package.parent), os.environ.get("PYTHONPATH", "")) if p)
        env = {**os.environ, "PYTHONPATH": path, "CRANKFMU_CACHE": str(work / "cache"),
               "MPLCONFIGDIR": str(work / "matplotlib"), "MPLBACKEND": "Agg"}

        def build(name: str):
            return name, subprocess.run([sys.executable, "-m", "crankfmu", "fmu", name, "--native",
                                         "--out", str(work / "fmus" / name)],
                                        env=env, capture_output=True, text=True)
        # two lanes: the builds are one process each most of the time
        with ThreadPoolExecutor(max(1, lanes)) as pool:
            for name, run in pool.map(build, names):
                if run.returncode != 0:
                    lines = (run.stderr or run.stdout).strip().splitlines()
                    raise RuntimeError(f"crankfmu fmu {name} --native: {lines[-1] if lines else f'rc {run.returncode}'}")
        for kind in KINDS:
            shutil.copytree(work / "cache" / kind, into / kind)
    return names


if __name__ == "__main__":          # python prebuilt_results.py PACKAGE: what setup.py does
    print("prebuilt for " + ", ".join(prebuild(Path(sys.argv[1]))))
