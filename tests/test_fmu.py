"""FourBar.fmu driven through fmpy: the FMU must agree with the in-process model."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import crankfmu
from crankfmu.integrators import reference as reference_integrator

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,  # noqa: E402
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

ROOT = Path(__file__).resolve().parents[1]
FMU = ROOT / "build" / "fmus" / "FourBar.fmu"


@pytest.fixture(scope="session")
def fmu_path():
    if not FMU.exists():      # `make test` builds it first; build here when pytest runs alone
        subprocess.run([sys.executable, str(ROOT / "fmu_build" / "build.py")], check=True)
    return str(FMU)


@pytest.fixture(scope="session")
def unzipped(fmu_path):
    return extract(fmu_path), read_model_description(fmu_path)


class Instance:
    """An FMU instance with its log captured."""

    def __init__(self, unzipped, name="a"):
        self.dir, self.md = unzipped
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.logs = []
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=self._callbacks(), loggingOn=True)
        self.t = 0.0

    def _callbacks(self):
        def logger(env, instance, status, category, message):
            self.logs.append((status, message.decode()))
        from fmpy import calloc, free
        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(logger)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._keep = (cb, logger)
        return cb

    def init(self, **params):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for k, v in params.items():
            self.set(k, v)
        self.fmu.exitInitializationMode()
        return self

    def set(self, name, value):
        self.fmu.setReal([self.vr[name]], [float(value)])

    def get(self, name):
        return self.fmu.getReal([self.vr[name]])[0]

    def step(self, h, n=1):
        for _ in range(n):
            self.fmu.doStep(currentCommunicationPoint=self.t, communicationStepSize=h)
            self.t += h
        return self.get("omega1")

    def free(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def test_fmpy_validate_is_clean(fmu_path):
    from fmpy.validation import validate_fmu
    assert validate_fmu(fmu_path) == []


def test_units_and_default_experiment(unzipped):
    _, md = unzipped
    units = {v.name: v.unit for v in md.modelVariables}
    assert units["omega1"] == "rad/s" and units["J_red"] == "kg.m2" and units["B"] == "N.m.s/rad"
    assert {u.name for u in md.unitDefinitions} >= {"rad", "rad/s", "N.m", "kg.m2", "J"}
    assert md.defaultExperiment.stopTime == "2.0"
    starts = {v.name: v.start for v in md.modelVariables}
    assert float(starts["A"]) == 400.0 and float(starts["omega1_start"]) == 0.1


@pytest.mark.parametrize("step", [1e-4, 1e-3, 1e-2, 1e-1])
def test_fmu_matches_reference_at_any_communication_step(fmu_path, reference, step):
    r = fmpy.simulate_fmu(fmu_path, stop_time=2.0, output_interval=step, output=["phi1", "omega1"])
    ref = reference.state(r["time"])
    assert np.max(np.abs(r["omega1"] - ref[1]) / np.abs(ref[1])) < 1e-6
    assert np.max(np.abs(r["phi1"] - ref[0])) < 1e-6


def test_rollback_is_bit_for_bit(unzipped):
    inst = Instance(unzipped).init()
    inst.step(0.01, 30)
    state, t_saved = inst.fmu.getFMUState(), inst.t
    first = [inst.step(0.01) for _ in range(5)]
    inst.fmu.setFMUState(state)
    inst.t = t_saved
    again = [inst.step(0.01) for _ in range(5)]
    assert first == again
    # the same through serialisation
    blob = inst.fmu.serializeFMUState(state)
    inst.fmu.setFMUState(inst.fmu.deserializeFMUState(blob))
    inst.t = t_saved
    assert [inst.step(0.01) for _ in range(5)] == first
    inst.free()


def test_mid_run_change_of_the_motor_line(unzipped, scenario):
    inst = Instance(unzipped).init()
    inst.step(0.01, 100)
    inst.set("A", 380.0)
    inst.set("B", 18.0)
    fmu_omega = [inst.step(0.01, 50), inst.step(0.01, 50)]
    inst.free()
    first = scenario.build()
    y1 = reference_integrator().run(first.equation, 0.0, first.y0, 1.0).y[:, -1]
    second = scenario.with_params(A=380.0, B=18.0).build()
    tr = reference_integrator().run(second.equation, 1.0, y1, 2.0)
    ref = tr.dense(np.array([1.5, 2.0]))[1]
    np.testing.assert_allclose(fmu_omega, ref, rtol=1e-6)
    unchanged = crankfmu.simulate(scenario, output_times=[1.5, 2.0]).omega1
    assert np.all(np.abs(ref - unchanged) > 1e-2)   # the change did something


@pytest.mark.parametrize("name, value, expected", [
    ("J_flywheel", -1.0, "J_flywheel"),
    ("rtol", 0.0, "rtol"),
    ("l1", 0.5, "l1"),
    ("q2", 0.0, "q2"),
])
def test_bad_parameter_is_refused_with_its_name_in_the_log(unzipped, name, value, expected):
    inst = Instance(unzipped).init(**{name: value})
    errors = [m for status, m in inst.logs if status >= 3]
    assert any(expected in m for m in errors), inst.logs
    with pytest.raises(FMICallException):
        inst.step(0.01)
    with pytest.raises(FMICallException):      # later calls fail cleanly too
        inst.step(0.01)
    inst.free()


def test_a_valid_value_elsewhere_does_not_lift_a_refusal(unzipped):
    """Refusals are per variable: setting A correctly must not unblock a refused J_flywheel."""
    inst = Instance(unzipped).init(J_flywheel=-1.0, A=390.0)
    with pytest.raises(FMICallException):
        inst.step(0.01)
    assert any("J_flywheel" in m for s, m in inst.logs if s >= 3)
    inst.free()


def test_nan_input_is_refused(unzipped):
    inst = Instance(unzipped).init()
    inst.step(0.01)
    inst.set("tau_ext", float("nan"))
    assert any("tau_ext" in m for s, m in inst.logs if s >= 3)
    with pytest.raises(FMICallException):
        inst.step(0.01)
    inst.set("tau_ext", 0.0)                    # a valid value lets the run go on
    assert inst.step(0.01) > 0
    inst.free()


def test_fmu_runs_its_own_copy_of_the_package(fmu_path):
    """Whatever this process imported (crankfmu, via an editable install), the FMU runs the copy in
    the resources it was extracted to, also when loaded again from a new directory."""
    import sys
    for _ in range(2):
        where = extract(fmu_path)
        inst = Instance((where, read_model_description(fmu_path))).init()
        inst.step(0.01)
        shipped = Path(sys.modules["crankfmu_FourBar"].__file__).resolve()
        assert shipped.is_relative_to(Path(where).resolve() / "resources")
        inst.free()


def test_two_instances_reset_and_reload(unzipped):
    a, b = Instance(unzipped, "a").init(), Instance(unzipped, "b").init(J_flywheel=2.0)
    wa, wb = a.step(0.01, 50), b.step(0.01, 50)
    assert wa != wb                          # independent instances
    a.fmu.reset()
    a.t = 0.0
    a.init()
    assert a.step(0.01, 50) == wa            # reset gives the same run again
    a.free()
    b.free()
    c = Instance(unzipped, "c").init()       # load again after freeing
    assert c.step(0.01, 50) == wa
    c.free()
