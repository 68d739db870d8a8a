"""FourBar.fmu driven through fmpy: the FMU must agree with the in-process model."""

import io
import shutil
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import crankfmu
from crankfmu.integrators import reference as reference_integrator

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402
from fuzz_host import callbacks  # noqa: E402

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
        self._keep = callbacks(logger)
        return self._keep[0]

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
    # every start as the scenario file writes it (pythonfmu's 16 digits wrote rtol 1e-11 as
    # 9.999999999999999e-12, and the FMU's documentation showed that)
    assert starts["rtol"] == "1e-11" and starts["omega1_start"] == "0.1"
    assert all(start == repr(float(start)) for start in starts.values() if start is not None)


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


def _status_of(call):
    """The FMI status a call returned (fmpy raises on anything worse than a warning)."""
    try:
        call()
        return 0
    except FMICallException as exc:
        return exc.status


@pytest.mark.parametrize("name, value, refused_by", [
    ("J_flywheel", -1.0, "fmi2SetReal"),            # out of its declared range
    ("rtol", 0.0, "fmi2SetReal"),
    ("q2", 0.0, "fmi2SetReal"),
    ("l1", 0.5, "fmi2ExitInitializationMode"),     # in range, but the four-bar cannot be assembled
])
def test_bad_parameter_gives_fmi2Error_with_its_name_in_the_log(unzipped, name, value, refused_by):
    inst = Instance(unzipped)
    inst.fmu.setupExperiment(startTime=0.0)
    inst.fmu.enterInitializationMode()
    set_status = _status_of(lambda: inst.set(name, value))
    exit_status = _status_of(inst.fmu.exitInitializationMode)
    # a refused value is refused by the call that receives it; initialising with it pending is
    # refused too (it needs a valid model), never fmi2OK followed by a silent fmi2Discard
    assert (set_status, exit_status) == ((3, 3) if refused_by == "fmi2SetReal" else (0, 3))
    errors = [m for status, m in inst.logs if status == 3]
    assert any(m.startswith(f"{name}: ") or name in m for m in errors), inst.logs
    if refused_by == "fmi2SetReal":
        assert any("valid range" in m for m in errors)
    for _ in range(2):                          # later calls fail cleanly, the host goes on
        assert _status_of(lambda: inst.step(0.01)) == 3
    inst.free()


def test_a_valid_value_elsewhere_does_not_lift_a_refusal(unzipped):
    """Refusals are per variable: setting A correctly must not unblock a refused J_flywheel."""
    inst = Instance(unzipped)
    inst.fmu.setupExperiment(startTime=0.0)
    inst.fmu.enterInitializationMode()
    assert _status_of(lambda: inst.set("J_flywheel", -1.0)) == 3
    assert _status_of(lambda: inst.set("A", 390.0)) == 0
    assert _status_of(inst.fmu.exitInitializationMode) == 3
    assert any("J_flywheel" in m for s, m in inst.logs[-1:] if s == 3)      # the reason, again
    assert _status_of(lambda: inst.step(0.01)) == 3
    assert any("J_flywheel" in m for s, m in inst.logs[-1:] if s == 3)
    inst.free()


def test_nan_input_is_refused(unzipped):
    inst = Instance(unzipped).init()
    inst.step(0.01)
    assert _status_of(lambda: inst.set("tau_ext", float("nan"))) == 3
    assert any("tau_ext" in m for s, m in inst.logs if s == 3)
    assert _status_of(lambda: inst.step(0.01)) == 3
    inst.set("tau_ext", 0.0)                    # a valid value lets the run go on
    assert inst.step(0.01) > 0
    inst.free()


def test_fmu_runs_its_own_copy_of_the_package(fmu_path, tmp_path, monkeypatch):
    """Whatever this process imported (crankfmu, via an editable install), the FMU runs the package
    it carries, unpacked once into the cache under its content hash, also when loaded again from a
    new directory (the first extraction deleted); where the cache cannot be written, beside the
    archive in its own resources."""
    import sys
    with zipfile.ZipFile(fmu_path) as z, zipfile.ZipFile(io.BytesIO(z.read("resources/crankfmu_FourBar.zip"))) as p:
        digest = p.comment.decode()
    def forget():                       # as a new host process: the FMU's package not imported
        for key in [k for k in sys.modules if k == "crankfmu_FourBar" or k.startswith("crankfmu_FourBar.")]:
            del sys.modules[key]

    monkeypatch.setenv("CRANKFMU_CACHE", str(tmp_path / "cache"))
    forget()
    for _ in range(2):
        where = extract(fmu_path)
        inst = Instance((where, read_model_description(fmu_path))).init()
        inst.step(0.01)
        shipped = Path(sys.modules["crankfmu_FourBar"].__file__).resolve()
        assert shipped.is_relative_to((tmp_path / "cache" / f"fmu_{digest}").resolve())
        inst.free()
        shutil.rmtree(where)
    # a cache that cannot be written (a file where its folder should be; root ignores permissions)
    monkeypatch.setenv("CRANKFMU_CACHE", str(tmp_path / "not-a-folder"))
    (tmp_path / "not-a-folder").write_text("")
    forget()
    where = extract(fmu_path)
    inst = Instance((where, read_model_description(fmu_path))).init()
    inst.step(0.01)
    shipped = Path(sys.modules["crankfmu_FourBar"].__file__).resolve()
    assert shipped.is_relative_to(Path(where).resolve() / "resources" / "crankfmu_FourBar")
    inst.free()


def test_a_saved_state_set_into_a_fresh_instance_continues_bit_for_bit(unzipped):
    """fmusim's --initial-fmu-state-file sets a serialized state right after instantiation, as the
    Reference FMUs accept: the Python FMU builds the model for the state's values (J_flywheel = 2
    here, not the start value) and continues bit for bit (it refused: 'this instance is not
    initialised')."""
    a = Instance(unzipped, "a").init(J_flywheel=2.0)
    a.step(0.01, 30)
    blob, t_saved = a.fmu.serializeFMUState(a.fmu.getFMUState()), a.t
    first = [a.step(0.01) for _ in range(5)] + [a.get("M_load"), a.get("J_red")]
    b = Instance(unzipped, "b")                     # instantiated, never initialised
    b.fmu.setFMUState(b.fmu.deserializeFMUState(blob))
    b.t = t_saved
    assert [b.step(0.01) for _ in range(5)] + [b.get("M_load"), b.get("J_red")] == first
    assert b.get("J_flywheel") == 2.0
    a.free()
    b.free()


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


def test_fmu_reproduces_the_reference_result_it_carries(fmu_path):
    """As the Reference FMUs do: the default experiment's result travels in the FMU (fmi-ls-ref),
    declared by the manifest with role "result", and the cross-check files sit beside it."""
    import csv
    import zipfile
    from xml.etree import ElementTree as ET

    ls_ref = "extra/org.fmi-standard.fmi-ls-ref"
    with zipfile.ZipFile(fmu_path) as z:
        manifest = ET.fromstring(z.read(f"{ls_ref}/fmi-ls-manifest.xml"))
        ns = "{http://fmi-standard.org/fmi-ls-manifest}"
        assert manifest.get(f"{ns}fmi-ls-name") == "org.fmi-standard.fmi-ls-ref"
        (related,) = [r for r in manifest.iter("Related") if r.get("role") == "result"]
        rows = list(csv.reader(z.read(f"{ls_ref}/{related.get('source')}").decode().splitlines()))
    header, data = rows[0], np.array(rows[1:], dtype=float)
    assert header == list(crankfmu.COLUMNS)
    md = read_model_description(fmu_path)
    exp = md.defaultExperiment
    r = fmpy.simulate_fmu(fmu_path, start_time=float(exp.startTime), stop_time=float(exp.stopTime),
                          output_interval=float(exp.stepSize), output=header[1:])
    assert len(r) == len(data) and float(exp.stepSize) == pytest.approx(data[1, 0] - data[0, 0])
    np.testing.assert_allclose(r["time"], data[:, 0], rtol=0, atol=1e-12)
    for k, name in enumerate(header[1:], start=1):
        scale = np.max(np.abs(data[:, k]))
        assert np.max(np.abs(r[name] - data[:, k])) <= 1e-6 * scale, name     # W_ext is 0 throughout
    beside = Path(fmu_path).with_name("FourBar_ref.opt").read_text()
    assert f"StopTime, {float(exp.stopTime)!r}" in beside and f"StepSize, {float(exp.stepSize)!r}" in beside
    assert Path(fmu_path).with_name("FourBar_ref.csv").read_text().splitlines()[0] == ",".join(
        f'"{c}"' for c in header)


def test_tau_ext_input_is_used_over_the_step(unzipped, scenario):
    """tau_ext set at t = 1 s acts from that step on, as in the in-process model with it."""
    inst = Instance(unzipped).init()
    inst.step(0.01, 100)
    inst.set("tau_ext", -60.0)
    fmu_omega = [inst.step(0.01, 50), inst.step(0.01, 50)]
    inst.free()
    model = scenario.build()
    y1 = reference_integrator().run(model.equation, 0.0, model.y0, 1.0).y[:, -1]
    model.equation.tau_ext = -60.0
    ref = reference_integrator().run(model.equation, 1.0, y1, 2.0).dense(np.array([1.5, 2.0]))
    np.testing.assert_allclose(fmu_omega, ref[1], rtol=1e-6)
    assert ref[4, -1] < -100.0          # the external torque did work (W_ext, J): it was used


def test_a_second_fmu_beside_the_first(unzipped, tmp_path):
    """Another pythonfmu FMU loaded and stepped in the same process, interleaved with FourBar,
    leaves FourBar's run unchanged."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import fmu_step

    noop_path = fmu_step.build_noop(tmp_path)
    alone = Instance(unzipped, "alone").init()
    expected = [alone.step(0.01, 10) for _ in range(5)]
    alone.free()
    other = Instance((extract(str(noop_path)), read_model_description(str(noop_path))), "noop").init()
    four = Instance(unzipped, "beside").init()
    got = []
    for _ in range(5):
        got.append(four.step(0.01, 10))
        other.step(0.01, 10)
    four.free()
    other.free()
    assert got == expected


@pytest.mark.parametrize("step, stop", [(1e-5, 0.1), (0.5, 2.0)])
def test_extreme_communication_steps(fmu_path, reference, step, stop):
    """The issue's range ends: 1e-5 s (over 0.1 s, 10 000 steps) and 0.5 s."""
    r = fmpy.simulate_fmu(fmu_path, stop_time=stop, output_interval=step, output=["omega1"])
    ref = reference.state(r["time"])[1]
    assert np.max(np.abs(r["omega1"] - ref) / np.abs(ref)) < 1e-6


@pytest.mark.parametrize("params", [
    {"omega1_start": 0.0},                                                  # start from rest
    {"A": 129.0, "B": 20.0, "A_low": 30.0, "B_low": 0.2, "omega1_start": 2.0},  # stall and reversal
], ids=["from-rest", "stall-reversal"])
def test_time_domain_cases_in_the_fmu(fmu_path, scenario, params):
    r = fmpy.simulate_fmu(fmu_path, stop_time=2.0, output_interval=1e-2, output=["omega1"],
                          start_values=params)
    ref = crankfmu.simulate(scenario.with_params(**params), t_end=2.0, output_times=r["time"]).omega1
    assert np.max(np.abs(r["omega1"] - ref)) < 1e-6 * np.max(np.abs(ref))
    if "A_low" in params:
        assert r["omega1"].min() < 0.0 < r["omega1"].max()     # it did reverse


def test_outputs_read_in_initialisation_mode_are_those_of_the_values_set_there(unzipped):
    """A master reads outputs in initialisation mode after setting parameters (its initial values'
    fixed point): FourBar.fmu answers with the model at those values, built once and kept by
    fmi2ExitInitializationMode when nothing changed since; a geometry it would refuse leaves them
    as they were, and the refusal comes at fmi2ExitInitializationMode with its message."""
    a = Instance(unzipped)
    a.fmu.setupExperiment(startTime=0.0)
    a.fmu.enterInitializationMode()
    a.set("omega1_start", 3.25)
    a.set("phi1_start", 0.5)
    assert (a.get("omega1"), a.get("phi1")) == (3.25, 0.5)
    J = a.get("J_red")
    start = {v.name: v.start for v in a.md.modelVariables}
    a.set("J_flywheel", 7.0)
    assert a.get("J_red") == pytest.approx(J - float(start["J_flywheel"]) + 7.0, rel=1e-12)
    a.set("l1", 5.0)                   # does not assemble: the outputs stay, the refusal comes at the exit
    assert a.get("omega1") == 3.25
    with pytest.raises(Exception):
        a.fmu.exitInitializationMode()
    assert any("cannot be assembled" in message for _, message in a.logs)
    a.free()
