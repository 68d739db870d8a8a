"""A host that passes fmi2FreeFMUstate (fmi3FreeFMUState) the state itself instead of its address,
as fmusim (modelica/Reference-FMUs 0.0.39) does after saving a state to a file and after restoring
one, crashed every crankfmu FMU (SIGSEGV in the free). Each FMU now frees that state and goes on:
the Python FMU (its shim remembers the states pythonfmu hands out), the native mechanism and
component FMUs, FMI 2.0 and 3.0 (their states carry a mark, native/model/fmu_states.h). Each runs in
a fresh process, logging off; a crash is a non-zero exit."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from crankfmu.cli import main

BUILDS = [("FourBar", ["seed000"], "2"), ("FourBar", ["seed000", "--native"], "2"),
          ("FourBar", ["seed000", "--native", "--fmi-version", "3"], "3"),
          ("Drive", ["dc_pi", "--drive", "--native"], "2"), ("Drive", ["dc_pi", "--drive", "--native", "--fmi-version", "3"], "3")]

HOST = {"2": """
    from ctypes import POINTER, cast
    from fmpy.fmi2 import FMU2Slave, fmi2FMUstate
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate(loggingOn=False)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    free = lambda state: fmu.fmi2FreeFMUstate(fmu.component, state)
    step = lambda t: fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.01)
""", "3": """
    from ctypes import POINTER, cast
    from fmpy.fmi3 import FMU3Slave, fmi3FMUState
    fmi2FMUstate = fmi3FMUState
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate(loggingOn=False)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
    free = lambda state: fmu.fmi3FreeFMUState(fmu.component, state)
    step = lambda t: fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.01)
"""}

SLIPS = """
    state = fmu.getFMUState()
    blob = fmu.serializeFMUState(state)
    free(cast(state, POINTER(fmi2FMUstate)))          # the state itself, as fmusim passes it
    restored = fmu.deserializeFMUState(blob)
    fmu.setFMUState(restored)
    free(cast(restored, POINTER(fmi2FMUstate)))
    step(0.01)
    kept = fmu.getFMUState()                          # and the standard way still works
    fmu.freeFMUState(kept)
    step(0.02)
    fmu.terminate()
    fmu.freeInstance()
    print("went on")
"""


@pytest.mark.parametrize("fmu, args, version", BUILDS, ids=[" ".join(a) for _, a, _ in BUILDS])
def test_a_state_freed_by_its_value_is_freed_and_the_host_goes_on(tmp_path, fmu, args, version):
    assert main(["fmu", *args, "--out", str(tmp_path)]) == 0
    path = tmp_path / f"{fmu}.fmu"
    script = textwrap.dedent(f"""
        from fmpy import extract, read_model_description
        md = read_model_description({str(path)!r})
        unzipped = extract({str(path)!r})
    """) + textwrap.dedent(HOST[version]) + textwrap.dedent(SLIPS)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and "went on" in done.stdout, (done.returncode, done.stderr[-2000:])
