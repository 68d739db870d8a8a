"""Windows under wine: a native FMU's win64 DLL run by fmpy's remoting server (server_tcp.exe), or a
Windows program of the tests (a C master compiled with MinGW), under Debian's wine64, in a fresh
process with a fresh HOME and wine prefix."""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest


#: held while a remoting session runs: one machine-wide (the pytest workers share /tmp)
REMOTING_LOCK = Path(tempfile.gettempdir()) / "crankfmu-fmpy-remoting.lock"

#: run by the wine test in a fresh process: the FMU's win64 DLL in fmpy's win64 server under wine
REMOTE_RUN = """
import json, sys, numpy as np, fmpy
result = fmpy.simulate_fmu(sys.argv[1], remote_platform="win64", output_interval=1e-3,
                           start_values=json.loads(sys.argv[3]))
np.save(sys.argv[2], np.stack([result[n] for n in ("time",) + tuple(sys.argv[4:])]))
"""


def wine_prefix(tmp_path: Path) -> tuple[str, dict]:
    """(wine64, an environment with a fresh HOME, wine prefix and TMPDIR under ``tmp_path``), the
    prefix made and its services settled; skipped (failed on CI) where wine64 is missing."""
    wine = shutil.which("wine64") or shutil.which("wine64", path="/usr/lib/wine")
    if wine is None:
        if os.environ.get("CI"):
            pytest.fail("wine64 is missing: `make` installs Debian's wine64")
        pytest.skip("wine64 is not installed (make installs it)")
    for folder in ("home", "tmp"):
        (tmp_path / folder).mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "HOME": str(tmp_path / "home"), "WINEPREFIX": str(tmp_path / "home" / ".wine"),
           "WINEDEBUG": "-all", "TMPDIR": str(tmp_path / "tmp"),
           "PATH": f"{Path(wine).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    # the prefix first, its services settled (wineserver -w): made on the fly, under load, it can
    # outlast a program's wait for it
    subprocess.run([wine, "wineboot", "-i"], env=env, capture_output=True, timeout=300)
    subprocess.run([str(Path(wine).parent / "wineserver"), "-w"], env=env, capture_output=True, timeout=300)
    return wine, env


def run_in_session(command, env: dict, log: Path, timeout: float = 600) -> int:
    """``command``'s exit status, its output in ``log``. Output to a file, not a pipe: a wine
    process left behind keeps a pipe open, and a wait for its end would hang; everything of the
    run's session and the prefix's wineserver is stopped after it."""
    with open(log, "w") as out:
        child = subprocess.Popen(command, env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            return child.wait(timeout=timeout)
        finally:
            try:
                os.killpg(child.pid, 9)
            except ProcessLookupError:
                pass
            server = shutil.which("wineserver", path=env["PATH"])
            if server:
                subprocess.run([server, "-k"], env=env, capture_output=True, timeout=60)


def windows_path(path: Path) -> str:
    """A Linux path as a Windows program under wine sees it (wine maps Z: to /)."""
    return "Z:" + str(Path(path).resolve()).replace("/", "\\")


def run_win64_under_wine(fmu: Path, tmp_path: Path, fields, start_values=None) -> np.ndarray:
    """fmpy remotes an FMU that has no binary for the host's platform: a copy of ``fmu`` without
    binaries/linux64 runs its win64 DLL in fmpy's server_tcp.exe under Debian's wine64 (which
    `make` puts on PATH), in a fresh process with a fresh HOME and wine prefix, over its default
    experiment at 1 ms, with ``start_values`` (name -> value) set. Returns the rows time, *fields."""
    wine, env = wine_prefix(tmp_path)
    windows_only = tmp_path / fmu.name
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(windows_only, "w") as copy:
        for item in source.infolist():
            if not item.filename.startswith("binaries/linux64/"):
                copy.writestr(item, source.read(item))
    command = [sys.executable, "-c", REMOTE_RUN, str(windows_only), str(tmp_path / "remote.npy"),
               json.dumps(start_values or {}), *fields]
    if os.geteuid() == 0:
        # fmpy 0.3.32's client makes its lock file with mode 000 and holds an fcntl lock on it,
        # which wine cannot see; the server's watchdog opens the file for writing every 0.5 s and
        # exits when that succeeds, leaving the client waiting forever. Root's override of file
        # permissions makes it succeed at once: run as root without that capability (as any user)
        command = ["setpriv", "--bounding-set=-dac_override,-dac_read_search", "--", *command]
    # fmpy's client and server meet on one fixed localhost port: two sessions at once (two pytest
    # workers) take each other's connection ("Connection failed", then a hang), so one at a time
    with open(REMOTING_LOCK, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        returncode = run_in_session(command, env, tmp_path / "remote.log")
    assert returncode == 0, (tmp_path / "remote.log").read_text()[-3000:]
    return np.load(tmp_path / "remote.npy")
