"""The kernel library compiled with AddressSanitizer and UndefinedBehaviorSanitizer (every UB
report fatal), for the C model's tests that load it in a fresh Python through
CRANKFMU_NATIVE_LIBRARY; and what a run of it must not print."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

from crankfmu.native.sources import C_FILES, CFLAGS, HERE, digest, include_flags


def sanitized_library(library: Path, extra_sources=(), link_flags=()) -> dict:
    """The library compiled from its sources (and extra_sources, linked with link_flags) into
    library; the environment that loads it with the ASan runtime preloaded."""
    flags = [f for f in CFLAGS if f != "-O2"] + ["-O1", "-g", "-fno-omit-frame-pointer",
                                                  "-fsanitize=address,undefined", "-fno-sanitize-recover=undefined"]
    subprocess.run(["gcc", *flags, *include_flags(), f'-DCK_SOURCE_DIGEST="{digest()}"', "-shared", "-o", str(library),
                    *(str(HERE / n) for n in C_FILES), *(str(s) for s in extra_sources), *link_flags, "-lm"],
                   check=True)
    runtime = subprocess.run(["gcc", "-print-file-name=libasan.so"], capture_output=True, text=True).stdout.strip()
    # Python itself is not compiled for ASan: its allocations are not ours to report
    return {**os.environ, "CRANKFMU_NATIVE_LIBRARY": str(library), "LD_PRELOAD": runtime,
            "ASAN_OPTIONS": "detect_leaks=0:abort_on_error=1", "UBSAN_OPTIONS": "print_stacktrace=1"}


def assert_clean(done: subprocess.CompletedProcess) -> str:
    """The run's output, after checking it exited 0 with no sanitizer report."""
    report = done.stdout + done.stderr
    assert "ERROR: AddressSanitizer" not in report and "runtime error" not in report, report[-4000:]
    assert done.returncode == 0, report[-4000:]
    return report
