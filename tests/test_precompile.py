"""The kernel compiled ahead of time (crankfmu.precompile): a first run on a fresh machine loads
machine code and compiles nothing, in process and inside an FMU."""

import io
import json
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from crankfmu.integrators.kernel import COMPILED, MACHINE_CODE, STAMPS
from crankfmu.precompile import digests, ensure

pytestmark = pytest.mark.skipif(not COMPILED, reason="numba is not in use")

#: in a child with an empty cache: every entry point, then what numba found in and added to the cache
PROBE = """
import json
from crankfmu.precompile import kernel_dispatchers, run_entry_points
run_entry_points()
print(json.dumps({name: [len(d.stats.cache_hits), len(d.stats.cache_misses)]
                  for name, d in kernel_dispatchers().items()}))
"""


@pytest.fixture(scope="module")
def precompiled():
    assert ensure(quiet=True), "the package's kernel could not be precompiled"


@pytest.mark.parametrize("first_without_numba", [False, True])
def test_fresh_cache_compiles_nothing(precompiled, tmp_path, first_without_numba):
    """Also when a run without numba (CRANKFMU_JIT=0: a host's Python without it) filled the cache
    first: its folders then hold the kernel's source and bytecode, and numba's code is added."""
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path / "home"), "CRANKFMU_CACHE": str(tmp_path / "cache")}
    if first_without_numba:
        plain = subprocess.run([sys.executable, "-c", "from crankfmu.precompile import run_entry_points; run_entry_points()"],
                               env={**env, "CRANKFMU_JIT": "0"}, capture_output=True, text=True, timeout=600)
        assert plain.returncode == 0, plain.stderr
        assert not list((tmp_path / "cache").glob("kernel_*/__pycache__/*.nbi"))
    done = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    counts = json.loads(done.stdout.splitlines()[-1])
    missed = {name: c[1] for name, c in counts.items() if c[1]}
    assert not missed, f"compiled at run time despite the precompiled kernel: {missed}"
    # the entry points were loaded from the cache, not only absent
    for entry in ("drivers.run_chunk", "drivers.begin", "drivers.advance", "drivers.steady_batch", "drivers.dense_many"):
        assert counts[entry][0] >= 1, entry


def _package(fmu_path) -> zipfile.ZipFile:
    """The package archive an FMU carries (fmi.build.pack)."""
    with zipfile.ZipFile(fmu_path) as z:
        return zipfile.ZipFile(io.BytesIO(z.read("resources/crankfmu_FourBar.zip")))


def test_fmu_ships_the_kernel_it_runs(precompiled, fmu_path):
    with _package(fmu_path) as package:
        for digest in digests():
            with zipfile.ZipFile(io.BytesIO(package.read(f"integrators/kernel/precompiled/kernel_{digest}.zip"))) as kernel:
                inside = kernel.namelist()
            assert STAMPS in inside, digest
            assert any(n.startswith(f"{MACHINE_CODE}/") and n.endswith(".nbi") for n in inside), digest
            assert any(n.endswith(".nbc") for n in inside), digest


def test_fmu_first_run_with_empty_home_compiles_nothing(precompiled, fmu_path, tmp_path):
    """fmpy runs the FMU in a process with an empty HOME: the kernel cache it seeds holds the
    shipped index files unchanged (numba rewrites an index when it compiles a new signature)."""
    home = tmp_path / "home"
    code = f"import fmpy; r = fmpy.simulate_fmu({fmu_path!r}, output=['omega1']); print(r['omega1'][-1])"
    env = {"PATH": "/usr/bin:/bin", "HOME": str(home)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    shipped = {}
    with _package(fmu_path) as package:
        for archive in (n for n in package.namelist() if "/precompiled/kernel_" in n):
            with zipfile.ZipFile(io.BytesIO(package.read(archive))) as kernel:
                shipped.update({Path(n).name: kernel.read(n) for n in kernel.namelist() if n.endswith(".nbi")})
    seeded = {p.name: p.read_bytes() for d in digests() for p in (home / ".cache" / "crankfmu" / f"kernel_{d}" / "__pycache__").glob("*.nbi")}
    assert shipped and seeded == shipped

