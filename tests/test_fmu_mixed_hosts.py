"""A host that runs a stock pythonfmu FMU and ours in one process exits normally, in either order.

Stock pythonfmu (0.7) frees its interpreter state twice at process exit: a namespace-scope
std::shared_ptr is destroyed by the C++ static destructors, then its library destructor
(finalizePythonInterpreter) resets it again, a use-after-free of a 128-byte block (valgrind:
"Invalid read of size 4 ... 8 bytes inside a block of size 128 free'd"). The first pythonfmu
binary loaded in a process owns libstdc++'s unique symbols and is never unloaded, so its
destructor always runs at exit; when that block sits in a malloc bin, the decrement corrupts the
bin's list and a later free aborts ("corrupted double-linked list"): 44 of 50 fmpy processes
that ran the stock FMU and then FourBar.fmu (with numba, which brought scipy's libgfortran whose
exit frees into that bin). Our shim now empties the state of every pythonfmu copy loaded before
it, from an exit handler that runs before their statics are destroyed (fmi/python/shim/fmu_shim.c). A
stock FMU loaded after ours is unloaded by fmpy before exit, in the safe order.

Whether the corruption aborts depends on the heap's shape, so the processes' exit codes alone
may not show a regression; valgrind shows the use-after-free every time. Each order runs in
``MIXED_RUNS`` fresh processes (50 by default, as the issue asks), and one process of each kind
runs under valgrind: the stock FMU alone has the fault (no FMU of ours loaded), and a host that
ran it before ours no longer reaches it."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUNS = int(os.environ.get("MIXED_RUNS", "50"))

HOST = """
import sys
import fmpy
for path in sys.argv[1:]:
    result = fmpy.simulate_fmu(path, stop_time=0.1, output_interval=0.01)
    assert len(result) > 5, path
import scipy.integrate  # a host that also uses scipy (libgfortran: its exit frees into the heap)
print("results written", flush=True)
"""


@pytest.fixture(scope="module")
def stock_fmu(tmp_path_factory):
    """A stock pythonfmu FMU, built by `pythonfmu build` from a do-nothing slave."""
    folder = tmp_path_factory.mktemp("stock")
    shutil.copy(ROOT / "benchmarks" / "fmus" / "NoOp.py", folder / "NoOp.py")
    subprocess.run([sys.executable, "-m", "pythonfmu", "build", "-f", "NoOp.py", "--dest", "."], cwd=folder,
                   check=True, capture_output=True)
    return folder / "NoOp.fmu"


def run_host(order, tmp_path, i):
    home = tmp_path / f"home{i}"
    home.mkdir()
    env = {**os.environ, "HOME": str(home), "CRANKFMU_CACHE": str(tmp_path / "cache")}
    return subprocess.run([sys.executable, "-c", HOST, *map(str, order)], capture_output=True, text=True,
                          timeout=300, env=env)


@pytest.mark.parametrize("stock_first", [True, False], ids=["stock then ours", "ours then stock"])
def test_no_abnormal_exit_with_a_stock_pythonfmu_fmu_in_the_same_process(stock_first, stock_fmu, fmu_path, tmp_path):
    order = (stock_fmu, fmu_path) if stock_first else (fmu_path, stock_fmu)
    with ThreadPoolExecutor(max_workers=2) as pool:
        runs = list(pool.map(lambda i: run_host(order, tmp_path, i), range(RUNS)))
    abnormal = [(r.returncode, r.stderr[-300:]) for r in runs
                if r.returncode != 0 or "results written" not in r.stdout]
    print(f"{len(runs) - len(abnormal)} of {len(runs)} processes exited normally")
    assert not abnormal, f"{len(abnormal)} of {len(runs)} abnormal: {abnormal[:3]}"


def valgrind_use_after_free(order, tmp_path) -> int:
    """How many times valgrind's memcheck reports an invalid read in pythonfmu's
    finalizePythonInterpreter when a host runs ``order`` (PYTHONMALLOC=malloc: every block is
    malloc's, so a freed one is seen)."""
    env = {**os.environ, "PYTHONMALLOC": "malloc", "HOME": str(tmp_path), "CRANKFMU_CACHE": str(tmp_path / "cache")}
    done = subprocess.run(["valgrind", sys.executable, "-c", HOST, *map(str, order)], capture_output=True, text=True,
                          timeout=600, env=env)
    assert "results written" in done.stdout, done.stderr[-2000:]
    return len(re.findall(r"Invalid read.*\n.*at 0x[0-9A-Fa-f]+: finalizePythonInterpreter", done.stderr))


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind shows the use-after-free")
def test_the_fault_is_stock_pythonfmus_and_our_shim_keeps_a_host_clear_of_it(stock_fmu, fmu_path, tmp_path):
    alone = valgrind_use_after_free((stock_fmu,), tmp_path)
    if alone == 0:
        pytest.skip("this pythonfmu no longer frees its interpreter state twice at exit")
    assert valgrind_use_after_free((stock_fmu, fmu_path), tmp_path) == 0
