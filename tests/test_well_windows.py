"""PumpingWell.ssp on Windows: the SSP's two native FMUs (PumpJack.fmu built for the well's unit,
RodString.fmu) run together by the project's C master (tests/c_host/system_driver.c: the SSP's
connections and parameter set, a fixed step) compiled with MinGW, their win64 DLLs under wine64;
against the same master compiled for Linux on their linux64 binaries. The two platforms' binaries
are compiled from the same C with FMA contraction off, so they agree to 1e-12 of each output's
scale (measured: bit for bit). The Linux run is also held against libcosim on the same SSP, a
master we did not write: to 1e-9 of the scale (the same algorithm: outputs to inputs, then every
FMU steps; measured 2.3e-11 on the rod load, 7e-12 on omega1)."""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest

from crankfmu.cli import main
from crankfmu.fmi.ssp import write_ssp

ROOT = Path(__file__).resolve().parents[1]
STOP, STEP = 2.0, 1e-3
RECORDED = ("PumpJack.omega1", "PumpJack.rod_s", "RodString.F", "RodString.u_pump")
SSD = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
       "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues"}


def headers() -> Path:
    import fmpy

    return Path(fmpy.__file__).parent / "c-code"


@pytest.fixture(scope="module")
def system(tmp_path_factory):
    """(the unpacked SSP's folder, {component: (its extracted FMU folder, model identifier, GUID,
    value references by name)}, the connections, the set "coupled" by component)."""
    from fmpy import extract, read_model_description

    out = tmp_path_factory.mktemp("well_windows")
    fmus = out / "fmus"
    fmus.mkdir()
    for name, args in (("PumpJack", ["pumpjack"]), ("RodString", ["rp11l_guo", "--well"])):
        built = ROOT / "build" / "fmus" / "native" / f"{name}.fmu"
        if built.is_file():
            shutil.copy2(built, fmus)
        else:
            assert main(["fmu", *args, "--native", "--out", str(fmus)]) == 0
    ssp = write_ssp(fmus, out, system="PumpingWell", native=True)
    with zipfile.ZipFile(ssp) as z:
        z.extractall(out / "ssp")
    root = ET.parse(out / "ssp" / "SystemStructure.ssd").getroot()
    components = {}
    for element in root.iter(f"{{{SSD['ssd']}}}Component"):
        source = out / "ssp" / element.get("source")
        md = read_model_description(str(source))
        components[element.get("name")] = (Path(extract(str(source), str(out / "unzipped" / element.get("name")))),
                                           md.coSimulation.modelIdentifier, md.guid,
                                           {v.name: v.valueReference for v in md.modelVariables})
    connections = [(c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
                   for c in root.iter(f"{{{SSD['ssd']}}}Connection")]
    coupled = {}
    for name in components:
        values = ET.parse(out / "ssp" / "ssv" / f"coupled_{name}.ssv").getroot()
        coupled[name] = {p.get("name"): float(p.find("ssv:Real", SSD).get("value"))
                         for p in values.iter(f"{{{SSD['ssv']}}}Parameter")}
    return out / "ssp", components, connections, coupled


def plan(system, path_of) -> str:
    """The C master's plan for the system, its folders written by ``path_of`` (the platform's)."""
    _, components, connections, coupled = system
    lines = [f"fmu {name} {path_of(folder)} {model} {guid}" for name, (folder, model, guid, _) in components.items()]
    lines += [f"set {name} {components[name][3][p]} {value!r}" for name, values in coupled.items()
              for p, value in values.items()]
    lines += [f"connect {a} {components[a][3][b]} {c} {components[c][3][d]}" for a, b, c, d in connections]
    lines += [f"record {name.split('.')[0]} {components[name.split('.')[0]][3][name.split('.')[1]]}"
              for name in RECORDED]
    lines += [f"step {STEP!r}", f"stop {STOP!r}"]
    return "\n".join(lines) + "\n"


def rows(output: str) -> np.ndarray:
    """The master's rows (t, *RECORDED)."""
    table = [[float(x) for x in line[4:].split(",")] for line in output.splitlines() if line.startswith("row ")]
    return np.array(table)


@pytest.fixture(scope="module")
def linux_run(system, tmp_path_factory):
    where = tmp_path_factory.mktemp("linux_master")
    driver = where / "system_driver"
    subprocess.run(["gcc", "-std=c99", "-O2", f"-I{headers()}", "-o", str(driver),
                    str(ROOT / "tests" / "c_host" / "system_driver.c"), "-ldl"], check=True, capture_output=True)
    (where / "plan.txt").write_text(plan(system, str), encoding="utf-8")
    done = subprocess.run(["env", "-i", str(driver), str(where / "plan.txt")], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stdout[-3000:]
    return rows(done.stdout)


def test_the_well_runs_in_the_c_master_on_windows_as_on_linux(system, linux_run, tmp_path):
    from wine import run_in_session, wine_prefix, windows_path

    compiler = shutil.which("x86_64-w64-mingw32-gcc")
    if compiler is None:
        pytest.skip("MinGW-w64 is not installed (make installs it)")
    wine, env = wine_prefix(tmp_path)
    driver = tmp_path / "system_driver.exe"
    subprocess.run([compiler, "-O2", f"-I{headers()}", "-o", str(driver),
                    str(ROOT / "tests" / "c_host" / "system_driver.c"), "-static"], check=True, capture_output=True)
    (tmp_path / "plan.txt").write_text(plan(system, windows_path), encoding="utf-8")
    returncode = run_in_session([wine, str(driver), windows_path(tmp_path / "plan.txt")], env, tmp_path / "run.log")
    output = (tmp_path / "run.log").read_text(errors="replace")
    assert returncode == 0, output[-3000:]
    windows = rows(output)
    assert windows.shape == linux_run.shape == (int(round(STOP / STEP)) + 1, 1 + len(RECORDED))
    for k, name in enumerate(RECORDED, start=1):
        scale = np.max(np.abs(linux_run[:, k]))
        assert np.max(np.abs(windows[:, k] - linux_run[:, k])) <= 1e-12 * scale, name


def test_the_c_master_agrees_with_libcosim(system, linux_run):
    """The same SSP in libcosim (a master we did not write): every recorded output at every
    communication point to 1e-9 of its scale."""
    pytest.importorskip("libcosimpy")
    from crankfmu.validation import masters

    folder = system[0]
    ssp = folder.parent / "PumpingWell.ssp"
    run = masters.run("libcosim", ssp, STOP, STEP, list(RECORDED), parameter_set="coupled")
    assert not run.error, run.error
    # libcosim reports the points after each step; the master's first row is t = 0
    assert np.allclose(run.time, linux_run[1:, 0], rtol=0, atol=1e-9)
    for k, name in enumerate(RECORDED, start=1):
        scale = np.max(np.abs(linux_run[:, k]))
        assert np.max(np.abs(np.asarray(run[name]) - linux_run[1:, k])) <= 1e-9 * scale, name
