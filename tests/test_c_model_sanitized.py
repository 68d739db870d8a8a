"""The C model's tests under AddressSanitizer and UndefinedBehaviorSanitizer: the kernel library
compiled from its sources with -fsanitize=address,undefined (every UB report fatal), loaded by a
fresh Python through CRANKFMU_NATIVE_LIBRARY with the ASan runtime preloaded, runs
tests/test_c_model.py (every packaged scenario, the users' mechanisms and the guide's, default and
changed geometry, refused values). No report, and the tests pass as they do unsanitized."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from sanitized import assert_clean, sanitized_library

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_the_c_model_tests_run_clean_under_asan_and_ubsan(tmp_path):
    env = sanitized_library(tmp_path / "crank_kernel.so")
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider",
                           str(ROOT / "tests" / "test_c_model.py"), "-k", "not steady_sweep"],
                          env=env, capture_output=True, text=True, timeout=900)
    assert " passed" in assert_clean(done)
