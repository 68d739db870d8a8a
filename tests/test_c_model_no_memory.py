"""The C model when memory runs out: every allocation the library makes while a design is bound,
checked and tabulated (the reduced table, the [[outputs]], the joint reactions, and the spline a
near-dead-point geometry takes) is made to fail in turn. Each run either ends as before or is
refused with MM_NO_MEMORY; none reads through a null pointer (the library is compiled with
AddressSanitizer and UndefinedBehaviorSanitizer, every report fatal). A host's FMU initialisation
in a process short of memory gets fmi2Error, not a crash."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from sanitized import assert_clean, sanitized_library

ROOT = Path(__file__).resolve().parents[1]

#: run in a fresh Python on the library below: each design's allocations counted, then failed in turn
SCRIPT = r"""
import ctypes, os
from crankfmu.dynamics.program import parameter_values
from crankfmu.dynamics.program_scenario import compile_scenario
from crankfmu.native.mechanism import QUANTITIES, REACTIONS, REDUCED, CModel, MechanismError
from crankfmu.scenario import load_scenario

lib = ctypes.CDLL(os.environ["CRANKFMU_NATIVE_LIBRARY"])
lib.failing_malloc_count.restype = ctypes.c_long

def design(scenario, tables):
    program = compile_scenario(scenario)
    model = CModel(program, parameter_values(program, scenario.values))
    return [model.cubics(table, 1e-11)[1] for table in tables]

for name, changes, tables in (("seed000", {}, (REDUCED, QUANTITIES, REACTIONS)),
                              ("seed004", {"e": 0.21}, (REDUCED,))):
    scenario = load_scenario(name).with_params(**changes)
    lib.failing_malloc_after(-1)
    whole = design(scenario, tables)
    count = lib.failing_malloc_count()
    refused = 0
    for n in range(count):
        lib.failing_malloc_after(n)
        try:
            assert design(scenario, tables) == whole, (name, n)
        except MechanismError as exc:
            assert exc.code == -14, (name, n, exc.code)         # MM_NO_MEMORY
            refused += 1
    lib.failing_malloc_after(-1)
    print(f"{name}: {count} allocations, each failed in turn: {refused} refused with MM_NO_MEMORY")
"""


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_every_allocation_failing_in_turn_is_refused_not_a_crash(tmp_path):
    env = sanitized_library(tmp_path / "crank_kernel.so", [ROOT / "tests" / "c_host" / "failing_malloc.c"],
                            ["-Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc"])
    done = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=900)
    assert_clean(done)
    counts = [line for line in done.stdout.splitlines() if "allocations, each failed in turn" in line]
    print("\n".join(counts))
    assert len(counts) == 2 and all(" 0 refused" not in line for line in counts), done.stdout
