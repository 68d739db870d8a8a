"""``crankfmu ssp --native``: every SSP made of native FMUs only (the drive systems, the drive on the
four-bar through the elastic shaft, PressCushion and PumpingWell), run by third-party masters with no Python reachable and an empty HOME (env -i),
against the same SSP made of the Python FMUs.

Both builds step the same C (the mechanism's kernel on the same tables, the drive's exact step, the
cushion's law, the string's steps), so at each communication step they agree to rounding: 1e-9 of
the run's scale in libcosim, which hands over every double; ecos writes its CSV with 6 decimals,
so there the bar is that rounding (one unit of the last decimal). Where an SSP sets a native mechanism FMU's fixed values
(PressCushion.ssp switches the press's own cushion off; PumpingWell.ssp gives the pump jack the
well's geometry, counterweights and motor), that FMU is built again for them, into the SSP only,
from the data files it was built from. An SSP holding a Python FMU is refused in one line."""

from __future__ import annotations

import re
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
PRESS = ROOT / "validation" / "data" / "togglepress_scenario.toml"
#: the FMUs of the four systems, and how each is built
BUILDS = {"FourBar": ["seed000"], "FourBarSpeed": ["seed000", "--causality", "speed"],
          "Drive": ["dc_pi", "--drive"], "DriveSpeed": ["dc_pi", "--drive", "--causality", "speed"],
          "ElasticShaft": ["elastic_shaft", "--shaft"],
          "TogglePress": [str(PRESS)], "DieCushion": ["die_cushion", "--cushion"],
          "PumpJack": ["pumpjack"], "RodString": ["rp11l_guo", "--well"]}
#: what each system's run records, and for how long (s)
RECORDED = {"FourBarDrive": (["FourBar.omega1", "Drive.tau"], 1.0),
            "FourBarDriveSpeed": (["Drive.omega", "FourBar.tau_drive"], 1.0),
            "DriveShaftFourBar": (["FourBar.omega1", "Drive.omega", "Shaft.tau"], 0.5),
            "PressCushion": (["Press.omega1", "Press.ram_s", "Cushion.F"], 1.0),
            "PumpingWell": (["PumpJack.omega1", "PumpJack.rod_s", "RodString.F"], 3.0)}


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


@pytest.mark.parametrize("system", list(RECORDED))
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
    assert len(inside) == len(SYSTEMS[system].sources)
    assert all(built_values(tmp_path / "inside" / n)[0] == "native" for n in inside)
    step = SYSTEMS[system].step           # the shaft's: held inputs are stable only below 2c/k
    recorded, stop = RECORDED[system]
    for master in ("ecos", "libcosim"):
        bare = masters.run(master, native, stop, step, recorded, parameter_set="coupled",
                           env=bare_environment(tmp_path / f"home-{master}"))
        assert not bare.error, bare.output[-3000:]
        peer = masters.run(master, python, stop, step, recorded, parameter_set="coupled")
        assert not peer.error, peer.output[-3000:]
        assert np.array_equal(np.round(bare.time / step), np.round(peer.time / step))
        for name in recorded:
            scale = np.max(np.abs(peer[name]))
            # ecos writes 6 decimals in its CSV: two roundings of values a hair apart differ by one unit of the last
            bar = 1e-9 * scale if master == "libcosim" else 1e-6 + 1e-9 * scale
            assert np.max(np.abs(bare[name] - peer[name])) <= bar, (master, name)


def test_a_refused_parameter_set_is_shown_by_the_master_and_crashes_nothing(folders, tmp_path):
    """The set "refused" gives the mechanism J_flywheel = -1: the ecos command (which applies an
    SSP's parameter sets) shows the native FMU's message, with no Python on the host, and its
    process is not killed by a signal."""
    pytest.importorskip("ecospy")
    from crankfmu.validation import masters

    native = write_ssp(folders[0], tmp_path, system="FourBarDrive", native=True)
    run = masters.run("ecos", native, 0.1, 1e-3, RECORDED["FourBarDrive"][0], parameter_set="refused",
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
    assert not (tmp_path / "out").exists()


def test_a_native_fmu_takes_the_values_the_ssp_sets(folders, tmp_path):
    """PressCushion.ssp switches the press's own cushion off (k_cushion = c_cushion = 0): the SSP
    carries the folder's native press unchanged and its parameter set; the press takes the values
    when the master initialises it (its tables built then)."""
    folder = folders[0]
    before = (folder / "TogglePress.fmu").read_bytes()
    _, fixed = built_values(folder / "TogglePress.fmu")
    assert (fixed["k_cushion"], fixed["c_cushion"]) == (20000.0, 150.0)
    ssp = write_ssp(folder, tmp_path, system="PressCushion", native=True)
    with zipfile.ZipFile(ssp) as z:
        assert z.read("resources/TogglePress.fmu") == before
        sets = b"".join(z.read(n) for n in z.namelist() if n.startswith("ssv/"))
    assert re.search(rb'name="k_cushion".*?value="0(\.0)?"', sets, re.S) and b'name="c_cushion"' in sets
    assert SYSTEMS["PressCushion"].sources["Press"] == "TogglePress"


def test_crankfmu_fmu_native_set_builds_for_other_values_and_refuses_bad_ones(tmp_path):
    """`crankfmu fmu SCENARIO --native --set NAME=VALUE` builds the FMU with those start values (its
    reference result is the scenario's at them); a value out
    of its range, a geometry that does not assemble, or --set on an FMU whose host sets every
    parameter is one line, and nothing is written."""
    import fmpy

    import crankfmu
    from crankfmu.scenario import load_scenario

    assert main(["fmu", "seed000", "--native", "--set", "l1=0.11", "--set", "J_flywheel=3", "--out", str(tmp_path)]) == 0
    _, fixed = built_values(tmp_path / "FourBar.fmu")
    assert fixed["l1"] == 0.11
    run = fmpy.simulate_fmu(str(tmp_path / "FourBar.fmu"), stop_time=1.0, output_interval=0.01, output=["omega1"])
    ref = crankfmu.simulate(load_scenario("seed000").with_params(l1=0.11, J_flywheel=3.0), method="reference",
                            t_end=1.0, output_times=run["time"])
    assert np.max(np.abs(run["omega1"] - ref.omega1)) <= 1e-8 * np.max(np.abs(ref.omega1))
    for args, message in ((["seed000", "--native", "--set", "l1=-1"], "parameter l1 = -1.0 is out of range"),
                          (["seed000", "--native", "--set", "l1=5"], "cannot be assembled over the whole crank turn"),
                          (["seed000", "--set", "l1=0.2"], "--set: a native mechanism FMU's values only"),
                          (["dc_pi", "--drive", "--native", "--set", "R=1"], "--set: a native mechanism FMU's values only")):
        done = subprocess.run([sys.executable, "-m", "crankfmu", "fmu", *args, "--out", str(tmp_path / "bad")],
                              capture_output=True, text=True)
        assert done.returncode != 0 and done.stderr.count("\n") == 1 and message in done.stderr, done.stderr
        assert not (tmp_path / "bad").exists() or not any((tmp_path / "bad").iterdir())
