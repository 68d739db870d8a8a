"""A short soak (tests/soak.py): 36 host processes over the six FMUs, fmpy and the C driver, with
logging on and off, a refused parameter and a host exiting with the instance alive; none may exit
abnormally. ``make soak`` runs 1,800 (300 per FMU)."""

import shutil

import pytest

from soak import soak

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is needed to build the C driver")


def test_no_host_process_exits_abnormally(fmu_path, tmp_path):
    from pathlib import Path

    fmus = sorted(Path(fmu_path).parent.glob("*.fmu"))
    assert len(fmus) >= 5
    results = soak(fmus, per_fmu=6)
    assert sum(r["processes"] for r in results.values()) == 6 * len(fmus)
    assert {host for _, host in results} == {"fmpy", "c-driver"}
    assert {outcome for r in results.values() for outcome in r["cases"]} >= {"no-free", "refused", "quiet"}
    abnormal = {key: r["abnormal"] for key, r in results.items() if r["abnormal"]}
    assert not abnormal, abnormal
