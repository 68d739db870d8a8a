"""The C model's tests under AddressSanitizer and UndefinedBehaviorSanitizer: the kernel library
compiled from its sources with -fsanitize=address,undefined (every UB report fatal), loaded by a
fresh Python through CRANKFMU_NATIVE_LIBRARY with the ASan runtime preloaded, runs
tests/test_c_model.py (every packaged scenario, the users' mechanisms and the guide's, default and
changed geometry, refused values). No report, and the tests pass as they do unsanitized."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from crankfmu.native.sources import C_FILES, CFLAGS, HERE, digest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_the_c_model_tests_run_clean_under_asan_and_ubsan(tmp_path):
    library = tmp_path / "crank_kernel.so"
    flags = [f for f in CFLAGS if f != "-O2"] + ["-O1", "-g", "-fno-omit-frame-pointer",
                                                  "-fsanitize=address,undefined", "-fno-sanitize-recover=undefined"]
    subprocess.run(["gcc", *flags, f'-DCK_SOURCE_DIGEST="{digest()}"', "-shared", "-o", str(library),
                    *(str(HERE / n) for n in C_FILES), "-lm"], check=True)
    runtime = subprocess.run(["gcc", "-print-file-name=libasan.so"], capture_output=True, text=True).stdout.strip()
    env = {**os.environ, "CRANKFMU_NATIVE_LIBRARY": str(library), "LD_PRELOAD": runtime,
           # Python itself is not compiled for ASan: its allocations are not ours to report
           "ASAN_OPTIONS": "detect_leaks=0:abort_on_error=1", "UBSAN_OPTIONS": "print_stacktrace=1"}
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider",
                           str(ROOT / "tests" / "test_c_model.py"), "-k", "not steady_sweep"],
                          env=env, capture_output=True, text=True, timeout=900)
    report = done.stdout + done.stderr
    assert "ERROR: AddressSanitizer" not in report and "runtime error" not in report, report[-4000:]
    assert done.returncode == 0, report[-4000:]
    assert " passed" in report
