"""The drop-in check's fast subset (``crankfmu hosts --quick``; ``make hosts`` runs it all):
FourBar.fmu's default experiment at 1 ms in fmpy, the ecos C++ command, ecospy and libcosim
matches the in-process reference to 1e-6; each master shows a refused parameter's message; the
ecos command and libcosim run FourBarDrive.ssp (FourBar + Drive) and FourBarDriveSpeed.ssp (the
same system with the crank in speed causality: FourBarSpeed + DriveSpeed) at 1 ms, and
DriveShaftFourBar.ssp (DriveSpeed, ElasticShaft, FourBar) at its 0.1 ms, and agree with each other
and, within the coupling's O(H) error, with the coupled model simulated in process."""

import re
import subprocess
import sys

import pytest

pytest.importorskip("ecospy")
pytest.importorskip("libcosimpy")


def test_every_master_runs_the_fmu_and_the_ssp(fmu_path, tmp_path):
    from pathlib import Path

    fmus = Path(fmu_path).parent
    assert (fmus / "Drive.fmu").is_file()
    done = subprocess.run([sys.executable, "-m", "crankfmu.cli", "hosts", "--quick", "--fmus", str(fmus),
                           "--out", str(tmp_path)], capture_output=True, text=True, timeout=1200)
    print(done.stdout)
    assert done.returncode == 0, done.stdout + done.stderr[-3000:]
    lines = [line for line in done.stdout.splitlines() if re.match(r"(PASS|FAIL|XFAIL) ", line)]
    for master in ("fmpy", "ecos", "ecospy", "libcosim"):
        assert f"PASS {master}.FourBar.default_experiment.max_relative_error" in done.stdout
        assert f"PASS {master}.FourBar.refused_parameter.message_shown" in done.stdout
    for system, step in (("FourBarDrive", "0.001"), ("FourBarDriveSpeed", "0.001"), ("DriveShaftFourBar", "0.0001")):
        assert f"PASS ecos_vs_libcosim.{system}.ssp.step_{step}" in done.stdout
        for master in ("ecos", "libcosim"):
            assert f"PASS {master}.{system}.ssp.step_{step}.omega1_relative_error" in done.stdout
    assert not any(line.startswith("FAIL") for line in lines)
    assert re.search(r"^\d+ passed, 0 failed$", done.stdout, re.M)
    assert (tmp_path / "FourBarDrive.ssp").is_file() and (tmp_path / "hosts.md").is_file()
    assert (tmp_path / "FourBarDriveSpeed.ssp").is_file()
