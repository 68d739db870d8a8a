"""The kernel compiled ahead of time (crankfmu.precompile): a first run on a fresh machine loads
machine code and compiles nothing, in process and inside an FMU."""

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


def test_fresh_cache_compiles_nothing(precompiled, tmp_path):
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path / "home"), "CRANKFMU_CACHE": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    counts = json.loads(done.stdout.splitlines()[-1])
    missed = {name: c[1] for name, c in counts.items() if c[1]}
    assert not missed, f"compiled at run time despite the precompiled kernel: {missed}"
    # the entry points were loaded from the cache, not only absent
    for entry in ("drivers.run_chunk", "drivers.begin", "drivers.advance", "drivers.steady_batch", "drivers.dense_many"):
        assert counts[entry][0] >= 1, entry


def test_fmu_ships_the_kernel_it_runs(precompiled, fmu_path):
    with zipfile.ZipFile(fmu_path) as z:
        names = z.namelist()
    for digest in digests():
        folder = [n for n in names if f"/precompiled/kernel_{digest}/" in n]
        assert any(n.endswith(STAMPS) for n in folder), digest
        assert any(n.endswith(".nbi") and f"/{MACHINE_CODE}/" in n for n in folder), digest
        assert any(n.endswith(".nbc") for n in folder), digest


def test_fmu_first_run_with_empty_home_compiles_nothing(precompiled, fmu_path, tmp_path):
    """fmpy runs the FMU in a process with an empty HOME: the kernel cache it seeds holds the
    shipped index files unchanged (numba rewrites an index when it compiles a new signature)."""
    home = tmp_path / "home"
    code = f"import fmpy; r = fmpy.simulate_fmu({fmu_path!r}, output=['omega1']); print(r['omega1'][-1])"
    env = {"PATH": "/usr/bin:/bin", "HOME": str(home)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    with zipfile.ZipFile(fmu_path) as z:
        shipped = {Path(n).name: z.read(n) for n in z.namelist() if n.endswith(".nbi")}
    seeded = {p.name: p.read_bytes() for d in digests() for p in (home / ".cache" / "crankfmu" / f"kernel_{d}" / "__pycache__").glob("*.nbi")}
    assert shipped and seeded == shipped

