"""The native component FMUs (Drive.fmu, DriveSpeed.fmu, DieCushion.fmu, ElasticShaft.fmu,
RodString.fmu built with --native) and the components' physics in C (crank_components.c) that both
builds step.

- the C physics against dynamics.drive.DcDrive, dynamics.cushion and dynamics.shaft, the Python
  statements of the same models (the independent reference): the drive's exact steps, the 4 x 4
  matrix exponential against numerics.expm, the cushion's law, the shaft's law and step;
- each native FMU against the Python FMU of the same file on the same inputs: they step the same C,
  so they agree to rounding (1e-12 of each output's scale);
- what a host sees: the same variables as the Python FMU, fmpy's validation clean, refusals with
  fmi2Error and the message whatever loggingOn says, the FMU state (get, set, serialize) bit for
  bit, a binary that links only the C library, and the win64 DLL under wine matching linux64."""

from __future__ import annotations

import re
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from crankfmu.cli import main
from crankfmu.dynamics.cushion import cushion_force as python_cushion_force
from crankfmu.dynamics.drive import DRIVE_CONSTANTS, load_drive
from crankfmu.dynamics.shaft import shaft_energy as python_shaft_energy, shaft_torque as python_shaft_torque, \
    shaft_twist as python_shaft_twist
from crankfmu.native.physics import DriveSteps, cushion_force, expm4, shaft_energy, shaft_torque, shaft_twist
from crankfmu.numerics import expm

ROOT = Path(__file__).resolve().parents[1]
BUILDS = {"Drive": ["dc_pi", "--drive"], "DriveSpeed": ["dc_pi", "--drive", "--causality", "speed"],
          "DieCushion": ["die_cushion", "--cushion"], "ElasticShaft": ["elastic_shaft", "--shaft"],
          "RodString": ["rp11l_guo", "--well"]}
#: a changing input on each (a crank speed, a load torque, a ram moving, two sides turning, a
#: polished rod stroking)
INPUTS = {"Drive": ("omega",), "DriveSpeed": ("tau_load",), "DieCushion": ("s", "v"),
          "ElasticShaft": ("omega_a", "omega_b"), "RodString": ("s", "v")}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """{name: (native FMU, Python FMU)}, built from the packaged files."""
    out = tmp_path_factory.mktemp("components")
    built = {}
    for name, args in BUILDS.items():
        assert main(["fmu", *args, "--native", "--out", str(out / "native")]) == 0
        assert main(["fmu", *args, "--out", str(out / "python")]) == 0
        built[name] = (out / "native" / f"{name}.fmu", out / "python" / f"{name}.fmu")
    return built


def logged_instance(fmu_path: Path, folder: Path):
    """(an FMU2Slave instantiated with logging off, its value references by name, the messages it
    logs, what keeps its callbacks alive): how a host that shows only what an FMU logs sees it."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from fuzz_host import callbacks

    md = read_model_description(str(fmu_path))
    messages = []
    keep = callbacks(lambda env, name, status, category, message: messages.append(message.decode()))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu_path), str(folder)),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate(loggingOn=False, callbacks=keep[0])
    return fmu, {v.name: v.valueReference for v in md.modelVariables}, messages, keep


# ------------------------------------------------------------------------------------------------
# the C physics against the Python reference

def test_drive_steps_in_c_equal_the_python_drive():
    file = load_drive("dc_pi")
    values = {n: p.value for n, p in file.parameters.items()}
    python, c = file.drive(values), DriveSteps([values[k] for k in DRIVE_CONSTANTS])
    rng = np.random.default_rng(7)
    for _ in range(200):
        i, x, omega, omega_set, tau = rng.normal(0, [5, 1, 20, 20, 40])
        h = 10 ** rng.uniform(-5, -1)
        assert c.step(i, x, omega, omega_set, h) == pytest.approx(python.step(i, x, omega, omega_set, h), rel=1e-13,
                                                                 abs=1e-13)
        # the speed-causal step is a 4 x 4 matrix exponential in both, by the same series in another
        # summation order: they agree to a few units of 1e-12 of the state's scale
        a = python.step_with_rotor(i, x, omega, omega_set, tau, 1.0, h)
        scale = max(abs(v) for v in (i, x, omega, *a))
        assert np.max(np.abs(np.subtract(c.step_with_rotor(i, x, omega, omega_set, tau, 1.0, h), a))) <= 1e-11 * scale
        assert c.voltage(x, omega, omega_set) == pytest.approx(python.voltage(x, omega, omega_set), rel=1e-15)
        assert c.torque(i) == pytest.approx(python.torque(i), rel=1e-15)


def test_matrix_exponential_in_c_equals_numerics_expm():
    rng = np.random.default_rng(3)
    for scale in (1e-6, 1e-2, 1.0, 30.0, 300.0):
        M = rng.normal(size=(4, 4)) * scale
        reference = expm(M)
        assert np.max(np.abs(expm4(M) - reference)) <= 1e-12 * np.max(np.abs(reference))
    assert np.array_equal(expm4(np.zeros((4, 4))), np.eye(4))


def test_cushion_law_in_c_equals_the_data_files_law():
    values = {"k": 2e4, "c": 150.0, "L_free": 0.2, "s_seat": -0.3}
    for s, v in ((-0.05, 0.3), (-0.1, -1.0), (0.4, 0.0)):
        assert cushion_force(*values.values(), s, v) == python_cushion_force(values, s, v)


def test_shaft_law_and_step_in_c_equal_the_python_shaft():
    """The torque and the twist's step by the components' C against dynamics.shaft; the step
    against the integral of two speed lines (a quadrature exact for them: Simpson's rule)."""
    rng = np.random.default_rng(3)
    for _ in range(100):
        k, c, twist, omega_a, omega_b, rate_a, rate_b = rng.normal(0, [1e4, 10, 0.1, 20, 20, 500, 500])
        h = 10 ** rng.uniform(-5, -1)
        values = {"k": k, "c": c}
        assert shaft_torque(k, c, twist, omega_a, omega_b) == python_shaft_torque(values, twist, omega_a, omega_b)
        after = shaft_twist(twist, omega_a, omega_b, h, rate_a, rate_b)
        assert after == python_shaft_twist(twist, omega_a, omega_b, h, rate_a, rate_b)
        difference = lambda t: (omega_a + rate_a * t) - (omega_b + rate_b * t)  # noqa: E731
        simpson = h / 6 * (difference(0) + 4 * difference(h / 2) + difference(h))
        assert after == pytest.approx(twist + simpson, rel=1e-13, abs=1e-15)
        # the stored energy is the spring's work from no twist: k x integrated over [0, twist]
        # (Simpson's rule is exact for the line), C equal to Python bit for bit
        assert shaft_energy(k, twist) == python_shaft_energy(values, twist)
        assert shaft_energy(k, twist) == pytest.approx(twist / 6 * (0 + 4 * k * twist / 2 + k * twist), rel=1e-14)


# ------------------------------------------------------------------------------------------------
# the native FMUs against the Python ones, and what a host sees

def _signal(name, stop=2.0):
    t = np.linspace(0.0, stop, 401)
    names = INPUTS[name]
    sig = np.zeros(t.size, dtype=[("time", float)] + [(n, float) for n in names])
    sig["time"] = t
    if name == "RodString":               # a polished rod stroking 2 m at 9.5 strokes/min
        w = 2 * np.pi / 6.3
        sig["s"], sig["v"] = 1.0 - np.cos(w * t), w * np.sin(w * t)
        return sig
    for k, n in enumerate(names):
        sig[n] = 12.0 * np.sin((3.0 + k) * t) + 2.0 if n != "s" else -0.1 - 0.05 * np.sin(3.0 * t)
    return sig


@pytest.mark.parametrize("name", list(BUILDS))
def test_native_equals_python_on_the_same_inputs(fmus, name):
    import fmpy

    native, python = fmus[name]
    stop = 10.0 if name == "RodString" else 2.0
    signal = _signal(name, stop)
    a = fmpy.simulate_fmu(str(native), input=signal, output_interval=1e-3, stop_time=stop)
    b = fmpy.simulate_fmu(str(python), input=signal, output_interval=1e-3, stop_time=stop)
    assert a.dtype.names == b.dtype.names
    for column in a.dtype.names[1:]:
        scale = max(np.max(np.abs(b[column])), 1e-300)
        assert np.max(np.abs(a[column] - b[column])) <= 1e-12 * scale, column


@pytest.mark.parametrize("name", list(BUILDS))
def test_native_declares_what_the_python_fmu_declares(fmus, name):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    native, python = fmus[name]
    assert validate_fmu(str(native)) == []
    a, b = read_model_description(str(native)), read_model_description(str(python))
    assert a.modelExchange is None and a.coSimulation.canSerializeFMUstate
    declared = lambda md: [(v.name, v.causality, v.variability, v.unit, v.start, v.min, v.max)  # noqa: E731
                           for v in md.modelVariables if v.causality != "local"]
    assert declared(a) == declared(b)
    # the native drive adds its states' derivatives after every shared variable (a master's linear
    # system; the Python FMU gives no directional derivatives); the others have no smooth states
    states = {"Drive": ["i", "x"], "DriveSpeed": ["i", "x", "omega"], "ElasticShaft": ["twist"]}.get(name, [])
    assert [v.name for v in a.modelVariables][len(b.modelVariables):] == [f"der({s})" for s in states]
    assert [(d.variable.name, d.variable.derivative.name) for d in a.derivatives] == [(f"der({s})", s) for s in states]
    assert not [v for v in b.modelVariables if v.causality == "local"]
    assert (a.defaultExperiment.stopTime, a.defaultExperiment.stepSize) == (b.defaultExperiment.stopTime,
                                                                            b.defaultExperiment.stepSize)
    with zipfile.ZipFile(native) as z:
        names = set(z.namelist())
        page = z.read("documentation/index.html").decode()
    assert {"sources/fmi2_shell.c", "sources/crank_components.c", "sources/buildDescription.xml"} <= names
    assert "native: C" in page and "<math" in page


def test_the_binary_links_only_the_c_library(fmus, tmp_path):
    native, _ = fmus["DriveSpeed"]
    with zipfile.ZipFile(native) as z:
        z.extractall(tmp_path)
    linked = subprocess.run(["ldd", str(tmp_path / "binaries" / "linux64" / "DriveSpeed.so")], capture_output=True,
                            text=True).stdout
    libraries = {line.split()[0] for line in linked.splitlines() if line.strip()}
    assert libraries <= {"linux-vdso.so.1", "libm.so.6", "libc.so.6", "/lib64/ld-linux-x86-64.so.2"}, libraries


def test_refusals_are_loud_with_logging_off_and_the_state_round_trips(fmus, tmp_path):
    from fmpy.fmi1 import FMICallException

    fmu, vr, messages, keep = logged_instance(fmus["Drive"][0], tmp_path / "x")
    for name, value, expected in (("R", -1.0, r"parameter R = -1\.0 is out of range: valid range \(0, inf\) Ohm"),
                                  ("Kp", float("nan"), r"parameter Kp = nan is out of range"),
                                  ("omega", float("inf"), r"input omega = inf must be finite"),
                                  ("tau", 1.0, r"tau is an output of this FMU: it cannot be set")):
        with pytest.raises(FMICallException):
            fmu.setReal([vr[name]], [value])
        assert re.search(expected, messages[-1]), messages[-1]
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    with pytest.raises(FMICallException):              # R has no valid value yet
        fmu.exitInitializationMode()
    assert re.search(r"cannot initialise: no valid value set for omega, R, Kp", messages[-1]), messages[-1]
    fmu.reset()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["omega"]], [15.0])
    fmu.exitInitializationMode()
    with pytest.raises(FMICallException):
        fmu.setReal([vr["R"]], [3.0])
    assert "R is a fixed parameter" in messages[-1]
    fmu.setReal([vr["Kp"]], [6.0])                     # tunable: accepted between steps
    with pytest.raises(FMICallException):
        fmu.doStep(currentCommunicationPoint=0.5, communicationStepSize=1e-3)
    assert "is not this FMU's time 0.0 s" in messages[-1]
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    state = fmu.getFMUstate()
    serialized = fmu.serializeFMUstate(state)
    outputs = [vr[n] for n in ("tau", "i", "u", "P_el")]
    for k in range(1, 101):
        fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
    first = fmu.getReal(outputs)
    fmu.setFMUstate(fmu.deSerializeFMUstate(serialized))
    for k in range(1, 101):
        fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
    assert fmu.getReal(outputs) == first
    with pytest.raises(FMICallException):
        fmu.deSerializeFMUstate(bytes(len(serialized)))
    assert "not a state of this FMU" in messages[-1]
    fmu.freeFMUstate(state)
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.parametrize("name", ["DriveSpeed", "DieCushion", "ElasticShaft", "RodString"])
def test_the_win64_dll_runs_under_wine_through_fmpy_remoting(fmus, name, tmp_path):
    """The win64 DLL under wine matches the linux64 binary over the default experiment to 1e-12 of
    each output's scale (the two C libraries' exp may differ in the last bits)."""
    import fmpy
    from wine import run_win64_under_wine

    native, _ = fmus[name]
    with zipfile.ZipFile(native) as z:
        assert f"binaries/win64/{name}.dll" in z.namelist(), "make test installs MinGW-w64"
    fields = [v.name for v in fmpy.read_model_description(str(native)).modelVariables if v.causality == "output"]
    remote = run_win64_under_wine(native, tmp_path, fields)
    local = fmpy.simulate_fmu(str(native), output_interval=1e-3)
    assert np.array_equal(remote[0], local["time"])
    for k, field in enumerate(fields, start=1):
        scale = max(np.max(np.abs(local[field])), 1e-300)
        assert np.max(np.abs(remote[k] - local[field])) <= 1e-12 * scale, field


def test_the_rod_string_refuses_an_unbounded_step_and_its_state_round_trips(fmus, tmp_path):
    """taper1_E = 1e300 would make the internal steps unbounded: refused at initialisation with
    the value and its valid range (as the Python design says it), logging off; a valid string
    hung and stepped, then its state (node arrays included) serialized and restored, continues bit
    for bit; the instance is reset and initialised again with good values."""
    from fmpy.fmi1 import FMICallException

    fmu, vr, messages, keep = logged_instance(fmus["RodString"][0], tmp_path / "x")
    with pytest.raises(FMICallException):
        fmu.setReal([vr["courant"]], [1.5])
    assert re.search(r"parameter courant = 1\.5 is out of range: valid range \(0, 1\]", messages[-1]), messages[-1]
    fmu.setReal([vr["courant"]], [1.0])
    fmu.setReal([vr["taper1_E"]], [1e300])
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    with pytest.raises(FMICallException):
        fmu.exitInitializationMode()
    assert re.search(r"cannot initialise: courant = 1\.0 and taper 1 E = 1e\+300 Pa .* taper 1 E must be at most "
                     r"[\d.e+]+ Pa \(valid range \(0, ", messages[-1]), messages[-1]
    fmu.reset()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    outputs = [vr[n] for n in ("F", "u_pump", "F_pump", "W_polished", "W_hydraulic")]
    for k in range(50):
        fmu.setReal([vr["s"], vr["v"]], [0.01 * k, 0.5])
        fmu.doStep(currentCommunicationPoint=k * 0.02, communicationStepSize=0.02)
    serialized = fmu.serializeFMUstate(fmu.getFMUstate())
    for k in range(50, 100):
        fmu.setReal([vr["s"], vr["v"]], [0.01 * k, 0.5])
        fmu.doStep(currentCommunicationPoint=k * 0.02, communicationStepSize=0.02)
    first = fmu.getReal(outputs)
    fmu.setFMUstate(fmu.deSerializeFMUstate(serialized))
    for k in range(50, 100):
        fmu.setReal([vr["s"], vr["v"]], [0.01 * k, 0.5])
        fmu.doStep(currentCommunicationPoint=k * 0.02, communicationStepSize=0.02)
    assert fmu.getReal(outputs) == first
    assert np.all(np.isfinite(first)) and first[0] > 0
    fmu.terminate()
    fmu.freeInstance()


def test_the_string_grid_in_c_equals_the_python_design():
    """The grid the native RodString.fmu builds at initialisation (cc_string_grid) against
    dynamics.rodstring's grid and design: the same node masses, weights and stiffnesses, Gibbs' c,
    the fluid load, dt_max and Wrf, to the bit."""
    import ctypes

    from crankfmu.dynamics.rodstring import grid
    from crankfmu.dynamics.well import STRING_KEYS, TAPER_KEYS, load_well
    from crankfmu.native import LIBRARY

    well = load_well("rp11l_guo")
    for changes in ({}, {"segment": 3.7, "damping": 0.3, "fillage": 0.6, "p_tubing": 1e5}):
        values = {**well.values, **changes}
        design = well.design(values)
        tapers = np.array([[values[f"taper{i}_{k}"] for k in TAPER_KEYS] for i in range(1, well.n_tapers + 1)]).ravel()
        d = np.array([values[k] for k in STRING_KEYS])
        why = ctypes.create_string_buffer(512)
        n = LIBRARY.cc_string_nodes(well.n_tapers, tapers.ctypes.data, d.ctypes.data, why, 512)
        g = grid(design)
        assert n == g.mass.size, why.value
        mass, weight, stiffness, out = np.zeros(n), np.zeros(n), np.zeros(n - 1), np.zeros(4)
        LIBRARY.cc_string_grid(well.n_tapers, tapers.ctypes.data, d.ctypes.data, mass.ctypes.data,
                               weight.ctypes.data, stiffness.ctypes.data, out.ctypes.data)
        assert np.array_equal(mass, g.mass) and np.array_equal(weight, g.weight)
        assert np.array_equal(stiffness, g.stiffness)
        assert tuple(out) == (design.damping_coefficient, design.fluid_load, g.dt_max, design.buoyant_weight)


#: an input set in initialisation mode and the output that follows it there, with the value set
INITIAL_READS = {"DriveSpeed": ("omega_start", 7.5, "omega"), "DieCushion": ("s", -0.11, "F"),
                 "ElasticShaft": ("twist_start", 0.02, "tau"), "RodString": ("s", 0.4, "u_pump")}


@pytest.mark.parametrize("name", list(INITIAL_READS))
def test_outputs_read_in_initialisation_mode_follow_the_values_set_there(fmus, name, tmp_path):
    """A master reads outputs in initialisation mode after setting inputs and parameters (ecos and
    libcosim do, for the initial values of the SSP's connections): both builds answer with the
    model at the values set now, the values fmi2ExitInitializationMode then starts from, not the
    start values' (a native DriveSpeed.fmu read 0 rad/s there, a Python DieCushion.fmu the force at
    s = 0, each a different first step in a master)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    variable, value, output = INITIAL_READS[name]
    seen = []
    for path in fmus[name]:
        md = read_model_description(str(path))
        vr = {v.name: v.valueReference for v in md.modelVariables}
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), str(tmp_path / path.parent.name)),
                        modelIdentifier=md.coSimulation.modelIdentifier)
        fmu.instantiate(loggingOn=False)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        before = fmu.getReal([vr[output]])[0]
        fmu.setReal([vr[variable]], [value])
        during = fmu.getReal([vr[output]])[0]
        fmu.exitInitializationMode()
        after = fmu.getReal([vr[output]])[0]
        fmu.terminate()
        fmu.freeInstance()
        assert during == after and during != before, (path, before, during, after)
        seen.append(during)
    assert seen[0] == pytest.approx(seen[1], rel=1e-12)
