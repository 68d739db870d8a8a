"""SliderCrank.fmu, QuickReturn.fmu, ThreeLoop.fmu and Shaper.fmu: their mechanism-specific outputs through fmpy against the
in-process kinematics, declared with units, and restored by rollback."""

import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree as ET
import zipfile

import numpy as np
import pytest

import crankfmu
from crankfmu.validation.fmu_runner import FmuUnderTest
from crankfmu.validation.reference import reference_run

ROOT = Path(__file__).resolve().parents[1]
EXPECTED = {"SliderCrank": ("seed002", {"x_B": "m", "v_B": "m/s", "a_B": "m/s2", "x_C": "m", "y_C": "m"}),
            "QuickReturn": ("seed004", {"phi3": "rad", "omega3": "rad/s", "eps3": "rad/s2", "s5": "m",
                                        "v5": "m/s", "a5": "m/s2"}),
            "ThreeLoop": ("seed001", {"s3": "m", "v3": "m/s", "s7": "m", "v7": "m/s", "phi5": "rad",
                                      "omega5": "rad/s"}),
            "Shaper": ("seed003", {"theta3": "rad", "omega3": "rad/s", "x_E": "m", "v_E": "m/s", "a_E": "m/s2"})}


@pytest.fixture(scope="module", params=list(EXPECTED))
def fmu(request):
    path = ROOT / "build" / "fmus" / f"{request.param}.fmu"
    if not path.exists():
        subprocess.run([sys.executable, str(ROOT / "fmu_build" / "build.py")], check=True)
    f = FmuUnderTest(path)
    yield f
    f.close()


def test_extra_outputs_declared_with_units(fmu):
    scenario, units = EXPECTED[fmu.name]
    assert fmu.scenario_name == scenario
    with zipfile.ZipFile(fmu.path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    declared = {sv.get("name"): sv.find("Real").get("unit") for sv in root.iter("ScalarVariable")}
    for name, unit in units.items():
        assert declared[name] == unit, name
    from fmpy.validation import validate_fmu
    assert validate_fmu(str(fmu.path)) == []


def test_extra_outputs_match_in_process_kinematics(fmu):
    scenario = crankfmu.load_scenario(fmu.scenario_name)
    run = fmu.run(1.0, 1e-3)
    assert run.error is None
    ref = reference_run(scenario, run.time)
    for name in EXPECTED[fmu.name][1]:
        scale = max(np.max(np.abs(ref[name])), 1e-12)
        assert np.max(np.abs(run[name] - ref[name])) < 1e-6 * scale, name


def test_rollback_restores_the_extra_outputs(fmu):
    from fmpy.fmi2 import FMU2Slave
    md = fmu.model_description
    vr = {v.name: v.valueReference for v in md.modelVariables}
    names = list(EXPECTED[fmu.name][1])
    slave = FMU2Slave(guid=md.guid, unzipDirectory=fmu.unzipdir, modelIdentifier=fmu.name, instanceName="r")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.doStep(0.0, 0.1)
    state = slave.getFMUstate()
    first = slave.getReal([vr[n] for n in names])
    slave.doStep(0.1, 0.1)
    assert slave.getReal([vr[n] for n in names]) != first
    slave.setFMUstate(state)
    assert slave.getReal([vr[n] for n in names]) == first
    slave.freeFMUstate(state)
    slave.terminate()
    slave.freeInstance()
