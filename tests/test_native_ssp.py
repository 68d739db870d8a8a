"""``crankfmu ssp --native``: the drive systems made of native FMUs only (FourBar.fmu or FourBarSpeed.fmu
with Drive.fmu or DriveSpeed.fmu, all C), run by third-party masters with no Python reachable and
an empty HOME (env -i), against the same SSP made of the Python FMUs.

Both builds step the same C (the mechanism's kernel on the same tables, the drive's exact step), so
at each communication step they agree to rounding: 1e-9 of the run's scale in libcosim, which
hands over every double; ecos writes its CSV with 6 decimals, so there the bar is that rounding.
An SSP that sets a native FMU's fixed value (PressCushion.ssp, PumpingWell.ssp: the well's own
unit), or holds a Python FMU, is refused with one line naming each problem."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from crankfmu.cli import main
from crankfmu.fmi.ssp import SYSTEMS, built_values, write_ssp

ROOT = Path(__file__).resolve().parents[1]
#: the FMUs of the two systems, and how each is built
BUILDS = {"FourBar": ["seed000"], "FourBarSpeed": ["seed000", "--causality", "speed"],
          "Drive": ["dc_pi", "--drive"], "DriveSpeed": ["dc_pi", "--drive", "--causality", "speed"]}
#: what each system's run records
RECORDED = {"FourBarDrive": ["FourBar.omega1", "Drive.tau"], "FourBarDriveSpeed": ["Drive.omega", "FourBar.tau_drive"]}


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    """(the native FMUs' folder, the Python FMUs' folder): make fmu's where they are built, else built here."""
    out = tmp_path_factory.mktemp("ssp_fmus")
    found = []
    for build, folder in (("native", ROOT / "build" / "fmus" / "native"), ("python", ROOT / "build" / "fmus")):
        target = out / build
        target.mkdir()
        for name, args in BUILDS.items():
            if (folder / f"{name}.fmu").is_file():
                shutil.copy2(folder / f"{name}.fmu", target)
            else:
                assert main(["fmu", *args, *(["--native"] if build == "native" else []), "--out", str(target)]) == 0
        found.append(target)
    return tuple(found)


def bare_environment(home: Path) -> dict:
    """env -i with an empty HOME: no PYTHONPATH, no virtual environment, no Python on PATH."""
    home.mkdir(parents=True, exist_ok=True)
    return {"HOME": str(home), "PATH": "/usr/bin:/bin"}


@pytest.mark.parametrize("system", ["FourBarDrive", "FourBarDriveSpeed"])
def test_native_ssp_runs_in_ecos_and_libcosim_with_no_python_and_matches_the_python_ssp(folders, system, tmp_path):
    pytest.importorskip("ecospy")
    pytest.importorskip("libcosimpy")
    from crankfmu.validation import masters

    native_fmus, python_fmus = folders
    native = write_ssp(native_fmus, tmp_path / "native", system=system, native=True)
    python = write_ssp(python_fmus, tmp_path / "python", system=system)
    with zipfile.ZipFile(native) as z:
        inside = [n for n in z.namelist() if n.endswith(".fmu")]
        for name in inside:
            z.extract(name, tmp_path / "inside")
    assert len(inside) == 2 and all(built_values(tmp_path / "inside" / n)[0] == "native" for n in inside)
    stop, step = 1.0, 1e-3
    recorded = RECORDED[system]
    for master in ("ecos", "libcosim"):
        bare = masters.run(master, native, stop, step, recorded, parameter_set="coupled",
                           env=bare_environment(tmp_path / f"home-{master}"))
        assert not bare.error, bare.output[-3000:]
        peer = masters.run(master, python, stop, step, recorded, parameter_set="coupled")
        assert not peer.error, peer.output[-3000:]
        assert np.array_equal(np.round(bare.time / step), np.round(peer.time / step))
        for name in recorded:
            scale = np.max(np.abs(peer[name]))
            bar = 1e-9 * scale if master == "libcosim" else 5e-7 + 1e-9 * scale     # ecos: 6 decimals in its CSV
            assert np.max(np.abs(bare[name] - peer[name])) <= bar, (master, name)


def test_a_refused_parameter_set_is_shown_by_the_master_and_crashes_nothing(folders, tmp_path):
    """The set "refused" gives the mechanism J_flywheel = -1: the ecos command (which applies an
    SSP's parameter sets) shows the native FMU's message, with no Python on the host, and its
    process is not killed by a signal."""
    pytest.importorskip("ecospy")
    from crankfmu.validation import masters

    native = write_ssp(folders[0], tmp_path, system="FourBarDrive", native=True)
    run = masters.run("ecos", native, 0.1, 1e-3, RECORDED["FourBarDrive"], parameter_set="refused",
                      env=bare_environment(tmp_path / "home"))
    assert "J_flywheel = -1.0 is out of range: valid range [0, inf) kg.m2" in run.output, run.output[-2000:]
    assert run.returncode >= 0


def test_an_ssp_the_native_fmus_cannot_make_is_refused_in_one_line(folders, tmp_path):
    # a Python FMU among them
    mixed = tmp_path / "mixed"
    shutil.copytree(folders[0], mixed)
    shutil.copy2(folders[1] / "Drive.fmu", mixed / "Drive.fmu")
    done = subprocess.run([sys.executable, "-m", "crankfmu", "ssp", "--native", "--fmus", str(mixed), "--out",
                           str(tmp_path / "out"), "--system", "FourBarDrive"], capture_output=True, text=True)
    assert done.returncode != 0 and done.stderr.count("\n") == 1
    assert "Drive.fmu" in done.stderr and "is not a native FMU (its build: python)" in done.stderr
    # the well's unit: its geometry and counterweights are the well file's, not the pump jack's
    for name, args in (("PumpJack", ["pumpjack"]), ("RodString", ["rp11l_guo", "--well"])):
        built = ROOT / "build" / "fmus" / "native" / f"{name}.fmu"
        if built.is_file():
            shutil.copy2(built, mixed / built.name)
        else:
            assert main(["fmu", *args, "--native", "--out", str(mixed)]) == 0
    done = subprocess.run([sys.executable, "-m", "crankfmu", "ssp", "--native", "--fmus", str(mixed), "--out",
                           str(tmp_path / "out"), "--system", "PumpingWell"], capture_output=True, text=True)
    assert done.returncode != 0 and done.stderr.count("\n") == 1
    assert "the SSP sets PumpJack.arm_A = 2.8321 (built for 1.8288)" in done.stderr and "PumpJack.crank_R = 0.944 (built for 0.6096)" in done.stderr, done.stderr
    assert not (tmp_path / "out").exists()


def test_a_value_the_native_fmu_was_not_built_for_is_refused(tmp_path):
    """PressCushion.ssp switches the press's own cushion off (k_cushion = c_cushion = 0): the native
    press was built with its cushion, so the SSP is refused, naming both values."""
    from crankfmu.errors import CrankfmuError

    press = ROOT / "tests" / "data" / "user" / "togglepress_scenario.toml"
    assert main(["fmu", str(press), "--native", "--out", str(tmp_path)]) == 0
    assert main(["fmu", "die_cushion", "--cushion", "--native", "--out", str(tmp_path)]) == 0
    with pytest.raises(CrankfmuError, match=r"the SSP sets Press\.k_cushion = 0\.0 \(built for 20000\.0\), "
                                            r"Press\.c_cushion = 0\.0 \(built for 150\.0\)"):
        write_ssp(tmp_path, tmp_path / "out", system="PressCushion", native=True)
    assert SYSTEMS["PressCushion"].sources["Cushion"] == "DieCushion"
