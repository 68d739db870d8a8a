"""The native FMU (``crankfmu fmu SCENARIO --native``): the C kernel behind one FMI 2.0 shell, the
scenario's tables as data. It needs nothing on the host: the same numbers as the pythonfmu FMU of
the same scenario (the same kernel and tables: bit for bit), fmpy's validation clean, binaries
that link nothing beyond the C library, run by a C host with an empty environment and no Python
on PATH, refusals that are loud with logging off, and an FMU state restored bit for bit."""

from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from crankfmu.cli import main

HERE = Path(__file__).resolve().parent
FIELDS = ("phi1", "omega1", "epsilon1", "M_motor", "M_load", "J_red", "E_kin", "W_motor", "W_load")


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    out = tmp_path_factory.mktemp("native")
    assert main(["fmu", "seed000", "--native", "--out", str(out)]) == 0
    return out / "FourBar.fmu"


def test_fmpy_finds_no_problem(native):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(native)) == []


def test_the_native_fmu_gives_the_pythonfmu_fmus_numbers(native, fmu_path):
    """Co-Simulation, default experiment, 1 ms: the same kernel on the same tables, so the same
    numbers to rounding; the issue's bar is 1e-9 relative."""
    import fmpy

    a, b = fmpy.simulate_fmu(str(native)), fmpy.simulate_fmu(str(fmu_path))
    assert a["time"][-1] == pytest.approx(2.0)
    for name in FIELDS:
        assert np.max(np.abs(a[name] - b[name])) <= 1e-9 * np.max(np.abs(b[name])), name


def test_the_binaries_link_nothing_beyond_the_c_library(native, tmp_path):
    with zipfile.ZipFile(native) as z:
        z.extractall(tmp_path)
        names = set(z.namelist())
    assert {"sources/crank_kernel.c", "sources/crank_fmi2.c", "sources/model_data.c",
            "sources/buildDescription.xml", "documentation/index.html",
            "extra/org.fmi-standard.fmi-ls-ref/FourBar_out.csv"} <= names
    linked = subprocess.run(["ldd", str(tmp_path / "binaries" / "linux64" / "FourBar.so")], capture_output=True,
                            text=True).stdout
    libraries = {line.split()[0] for line in linked.splitlines() if line.strip()}
    assert libraries <= {"linux-vdso.so.1", "libm.so.6", "libc.so.6", "/lib64/ld-linux-x86-64.so.2"}, libraries
    dll = tmp_path / "binaries" / "win64" / "FourBar.dll"
    if shutil.which("x86_64-w64-mingw32-objdump") and dll.exists():
        dump = subprocess.run(["x86_64-w64-mingw32-objdump", "-p", str(dll)], capture_output=True, text=True).stdout
        assert set(re.findall(r"DLL Name: (\S+)", dump)) <= {"KERNEL32.dll", "msvcrt.dll"}


def test_refusals_are_loud_with_logging_off(native, tmp_path):
    """A fixed parameter set to another value names the value the tables were built for and the
    rebuild command; a tunable out of its range names the range; NaN is refused; all with
    fmi2Error and a message, loggingOn false."""
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    from fuzz_host import callbacks

    md = read_model_description(str(native))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    messages = []
    keep = callbacks(lambda env, name, status, category, message: messages.append(message.decode()))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(native), str(tmp_path / "x")), modelIdentifier="FourBar")
    fmu.instantiate(loggingOn=False, callbacks=keep[0])

    for name, value, expected in (("l1", 0.3, r"built for l1 = 0\.2.*crankfmu fmu seed000 --native"),
                                  ("J_flywheel", -1.0, r"J_flywheel = -1 is out of range: valid range \[0, inf\) kg\.m2"),
                                  ("A", float("nan"), r"parameter A = nan is out of range"),
                                  ("omega1", 1.0, r"omega1 is an output")):
        with pytest.raises(FMICallException):
            fmu.setReal([vr[name]], [value])
        assert re.search(expected, messages[-1]), messages[-1]
    fmu.setReal([vr["l1"]], [0.2])                    # the value it was built for: accepted
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    with pytest.raises(FMICallException):
        fmu.doStep(currentCommunicationPoint=0.5, communicationStepSize=1e-3)
    assert "this instance is at t = 0" in messages[-1]
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    # the state: saved, stepped, restored and stepped again gives the same outputs bit for bit
    state = fmu.getFMUstate()
    serialized = fmu.serializeFMUstate(state)
    for k in range(100):
        fmu.doStep(currentCommunicationPoint=(k + 1) * 1e-3, communicationStepSize=1e-3)
    first = fmu.getReal([vr[n] for n in FIELDS])
    fmu.setFMUstate(fmu.deSerializeFMUstate(serialized))
    for k in range(100):
        fmu.doStep(currentCommunicationPoint=(k + 1) * 1e-3, communicationStepSize=1e-3)
    assert fmu.getReal([vr[n] for n in FIELDS]) == first
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc builds the C driver")
def test_a_c_host_runs_it_with_an_empty_environment_and_no_python(native, tmp_path, fmu_path):
    """tests/c_host/fmu_driver.c (dlopen, RTLD_LOCAL) under `env -i`: no PATH, no HOME, no Python."""
    import fmpy
    from fmpy import extract, read_model_description

    headers = Path(fmpy.__file__).parent / "c-code"
    driver = tmp_path / "fmu_driver"
    subprocess.run(["gcc", "-O1", "-Wall", "-Werror", f"-I{headers}", "-o", str(driver),
                    str(HERE / "c_host" / "fmu_driver.c"), "-ldl"], check=True)
    md = read_model_description(str(native))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    where = extract(str(native), str(tmp_path / "unzipped"))
    done = subprocess.run(["env", "-i", str(driver), where, "FourBar", md.guid, "2000", "0.001", str(vr["omega1"])],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout[-2000:]
    t, omega = map(float, re.search(r"result t=(\S+) value=(\S+)", done.stdout).groups())
    reference = fmpy.simulate_fmu(str(fmu_path))
    assert t == pytest.approx(2.0)
    assert abs(omega - reference["omega1"][-1]) <= 1e-9 * abs(reference["omega1"][-1])
