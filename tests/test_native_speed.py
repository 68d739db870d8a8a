"""The native FMU in speed causality (``crankfmu fmu SCENARIO --native --causality speed``): the
host imposes omega1 and the FMU answers with tau_drive, the C kernel's speed step (ck_speed_advance)
behind the one FMI shell compiled with CAUSALITY_SPEED. Co-Simulation only.

Checked: the same numbers as the pythonfmu speed FMU (one kernel step behind both: bit for bit;
the [[outputs]] and the joint reactions from their tables); a speed ramp given with its derivative
(fmi2SetRealInputDerivatives) followed exactly, tau_drive equal to inverse dynamics from the table
evaluated in numpy; loud refusals with logging off and an FMU state restored bit for bit; the speed
SSP (FourBarSpeed + DriveSpeed) in ecos and libcosim with the native mechanism; the win64 DLL under
wine. test_causality.py runs its physics checks (the equilibrium moment, the torque-causal run
backwards, the energy balance) on this FMU too."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from crankfmu.cli import main
from test_causality import Host

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PRESS = HERE.parent / "validation" / "data" / "togglepress_scenario.toml"
#: the contract outputs of the speed-causal FMU the kernel's row gives
CONTRACT = ("phi1", "epsilon1", "tau_drive", "M_load", "J_red", "E_kin", "W_drive", "W_load", "W_ext")


@pytest.fixture(scope="module")
def press(tmp_path_factory):
    """The guide's press (ram port, [[outputs]], joints, a direction-dependent force) in speed
    causality: (pythonfmu FMU, native FMU)."""
    out = tmp_path_factory.mktemp("press_speed")
    assert main(["fmu", str(PRESS), "--causality", "speed", "--out", str(out / "python")]) == 0
    assert main(["fmu", str(PRESS), "--causality", "speed", "--native", "--out", str(out / "native")]) == 0
    return out / "python" / "TogglePressSpeed.fmu", out / "native" / "TogglePressSpeed.fmu"


def test_the_native_speed_fmu_gives_the_pythonfmu_fmus_numbers(press, tmp_path):
    """Both FMUs driven by the same omega1(t) (7 to 13 rad/s) and ram force (+-2 kN) for 1 s at
    1 ms, as a fixed-step master steps (from k h: its clock, which an FMU's own sum of steps drifts
    from by ulps): the contract's outputs are the kernel's row in both, so equal bit for bit; the [[outputs]]
    and ports' outputs from their tabulated transfer functions (1e-11 checked) within 1e-9 of each
    output's largest value; the joint reactions from their tabulated terms (1e-8 checked) against
    Newton-Euler, within 1e-8 of the largest reaction."""
    from fmpy.validation import validate_fmu

    python_fmu, native_fmu = press
    assert validate_fmu(str(native_fmu)) == []          # ports, reactions and speed causality in one
    a, b = Host(python_fmu, tmp_path / "a"), Host(native_fmu, tmp_path / "b")
    assert a.outputs == b.outputs and b.md.modelExchange is None
    reactions = [n for n in a.outputs if re.search(r"_(Fx|Fy|N|M)$", n) and n not in CONTRACT]
    quantities = [n for n in a.outputs if n not in CONTRACT and n not in reactions]
    assert "ram_s" in quantities and "ram_a" in quantities and "O_Fx" in reactions
    rows_a, rows_b = [], []
    for k in range(1000):
        t = k * 1e-3
        inputs = {"omega1": 10.0 + 3.0 * math.sin(2.0 * t), "ram_F": -2000.0 * math.sin(5.0 * t)}
        a.step_number(k, 1e-3, **inputs)
        b.step_number(k, 1e-3, **inputs)
        rows_a.append(a.get(*a.outputs))
        rows_b.append(b.get(*b.outputs))
    a.close()
    b.close()
    A, B = np.array(rows_a), np.array(rows_b)
    column = {n: i for i, n in enumerate(a.outputs)}
    for n in CONTRACT:
        assert np.array_equal(A[:, column[n]], B[:, column[n]]), n
    for n in quantities:
        scale = np.max(np.abs(A[:, column[n]]))
        assert np.max(np.abs(A[:, column[n]] - B[:, column[n]])) <= 1e-9 * scale, n
    scale = max(np.max(np.abs(A[:, column[n]])) for n in reactions)
    for n in reactions:
        assert np.max(np.abs(A[:, column[n]] - B[:, column[n]])) <= 1e-8 * scale, n


def test_a_ramp_given_with_its_derivative_is_followed_exactly(press, tmp_path):
    """omega1 = 8 + 20 t rad/s with its derivative given at every step (fmi2SetRealInputDerivatives,
    canInterpolateInputs): phi1 is the ramp's integral to rounding, epsilon1 is 20 from the first
    step on, and tau_drive equals J epsilon1 + 0.5 J' omega1^2 - Q - the port's torque from the
    design's table evaluated in numpy (another evaluation of the same cubics: 1e-10 of the largest
    value). Without the derivative, the backward difference gives epsilon1 = 0 over the first step
    and 20 from the second: a line's difference quotient is exact."""
    from crankfmu.dynamics import modes
    from crankfmu.dynamics.tabulated import table_of
    from crankfmu.integrators.fast import TABLE_TOLERANCE
    from crankfmu.scenario import load_scenario

    _, native_fmu = press
    w0, rate, F, h = 8.0, 20.0, 1500.0, 2e-3
    given, guessed = Host(native_fmu, tmp_path / "a", {"omega1": w0}), Host(native_fmu, tmp_path / "b", {"omega1": w0})
    times, rows = [], []
    for k in range(250):
        t = k * h
        given.fmu.setReal([given.vr["omega1"], given.vr["ram_F"]], [w0 + rate * t, F])
        given.fmu.setRealInputDerivatives([given.vr["omega1"]], [1], [rate])
        given.step_to((k + 1) * h)
        guessed.step_to((k + 1) * h, omega1=w0 + rate * t, ram_F=F)
        times.append(given.t)
        rows.append(given.get("phi1", "epsilon1", "tau_drive"))
        if k < 2:
            assert guessed.get("epsilon1")[0] == (0.0 if k == 0 else pytest.approx(rate, rel=1e-12)), k
    given.close()
    guessed.close()
    t, (phi, eps, tau) = np.array(times), np.array(rows).T
    scenario = load_scenario(str(PRESS))
    model = scenario.build()
    table = table_of(model.reduced, TABLE_TOLERANCE)
    phi_exact = scenario["phi1_start"] + w0 * t + 0.5 * rate * t * t
    assert np.max(np.abs(phi - phi_exact)) <= 1e-13 * np.max(np.abs(phi_exact))
    assert np.all(eps == rate)
    omega = w0 + rate * t
    values = table.evaluate(phi)
    J, half_dJ, Q = table.coefficients_at(phi, omega, model.reduced.J_flywheel, values)
    port_torque = F * values[len(values) - table.n_ports]
    expected = modes.drive_torque(J, half_dJ, Q, port_torque, omega, rate)
    assert np.max(np.abs(tau - expected)) <= 1e-10 * np.max(np.abs(expected))


def test_refusals_are_loud_with_logging_off(press, tmp_path):
    """Model Exchange is refused at fmi2Instantiate with the reason; NaN speed, phi1_start after
    initialisation, a second derivative, and a step of more than 1e9 degrees of crank angle give
    fmi2Error and a message, loggingOn false; an FMU state is restored bit for bit."""
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Model

    from fuzz_host import callbacks

    _, native_fmu = press
    md = read_model_description(str(native_fmu))
    messages = []
    keep = callbacks(lambda env, name, status, category, message: messages.append(message.decode()))
    model = FMU2Model(guid=md.guid, unzipDirectory=extract(str(native_fmu), str(tmp_path / "me")),
                      modelIdentifier="TogglePressSpeed")
    with pytest.raises(Exception):
        model.instantiate(loggingOn=False, callbacks=keep[0])
    assert re.search(r"Co-Simulation only: in speed causality tau_drive needs omega1's derivative", messages[-1])

    host = Host(native_fmu, tmp_path / "cs")
    vr = host.vr
    for call, expected in ((lambda: host.fmu.setReal([vr["omega1"]], [float("nan")]), r"^omega1: input omega1 = nan must be finite \(valid range \(-inf, inf\) rad/s\)"),
                           (lambda: host.fmu.setReal([vr["phi1_start"]], [1.0]),
                            r"phi1_start is a fixed parameter: it can be set before the end of initialisation only"),
                           (lambda: host.fmu.setRealInputDerivatives([vr["omega1"]], [2], [1.0]),
                            r"omega1: order 2; this FMU takes the first derivative only"),
                           (lambda: host.fmu.setReal([vr["tau_drive"]], [1.0]), r"tau_drive is computed by the FMU")):
        with pytest.raises(FMICallException):
            call()
        assert re.search(expected, host.messages[-1]), host.messages[-1]
    host.step_to(1e-3, omega1=12.0)
    state = host.fmu.getFMUstate()
    serialized = host.fmu.serializeFMUstate(state)
    for k in range(50):
        host.step_to((k + 2) * 1e-3, omega1=12.0 + math.sin(k * 1e-2), ram_F=100.0 * k)
    first = host.get(*host.outputs)
    host.fmu.setFMUstate(host.fmu.deSerializeFMUstate(serialized))
    host.t = 1e-3
    for k in range(50):
        host.step_to((k + 2) * 1e-3, omega1=12.0 + math.sin(k * 1e-2), ram_F=100.0 * k)
    assert host.get(*host.outputs) == first
    host.fmu.setReal([vr["omega1"]], [1e6])
    with pytest.raises(FMICallException):
        host.fmu.doStep(currentCommunicationPoint=host.t, communicationStepSize=1e5)
    assert re.search(r"^fmi2DoStep: step from t = .* s failed: non-finite values, or a step of over 1e9 degrees", host.messages[-1]), host.messages[-1]
    host.fmu.freeInstance()


@pytest.fixture(scope="module")
def fourbar_speed(tmp_path_factory):
    """A folder with the native FourBarSpeed.fmu and the pythonfmu DriveSpeed.fmu (the SSP's two)."""
    out = tmp_path_factory.mktemp("fourbar_speed")
    assert main(["fmu", "seed000", "--causality", "speed", "--native", "--out", str(out)]) == 0
    drive = ROOT / "build" / "fmus" / "DriveSpeed.fmu"
    if drive.is_file():
        shutil.copy2(drive, out / drive.name)
    else:
        assert main(["fmu", "dc_pi", "--drive", "--causality", "speed", "--out", str(out)]) == 0
    return out


def test_the_speed_ssp_runs_the_native_mechanism_in_ecos_and_libcosim(fourbar_speed, tmp_path):
    """FourBarDriveSpeed.ssp with the native FourBarSpeed.fmu (a C binary beside a pythonfmu FMU in
    one master process) at 1 ms: both masters agree to 2e-6 rad/s (ecos writes 6 decimals), and
    the crank speed is within the SSP's O(H) bound of the coupled model simulated in process
    (validation/hosts.py's 10 H relative, as for the Python FMUs)."""
    pytest.importorskip("ecospy")
    pytest.importorskip("libcosimpy")
    from crankfmu.fmi.ssp import SYSTEMS, write_ssp
    from crankfmu.validation import masters
    from validation import coupling

    ssp = write_ssp(fourbar_speed, tmp_path, system="FourBarDriveSpeed")
    stop, step = SYSTEMS["FourBarDriveSpeed"].stop_time, 1e-3
    reference = coupling.coupled_reference(np.round(np.arange(int(round(stop / step)) + 1) * step, 12))
    runs = {m: masters.run(m, ssp, stop, step, ["Drive.omega", "FourBar.tau_drive"], parameter_set="coupled")
            for m in ("ecos", "libcosim")}
    for master, run in runs.items():
        assert not run.error, run.output[-3000:]
        assert run.time[-1] == pytest.approx(stop, abs=1e-6)
        expected = np.interp(run.time, reference["time"], reference["omega1"])
        relative = np.max(np.abs(run.values["Drive.omega"] - expected)) / np.max(np.abs(expected))
        assert relative <= 10.0 * step, (master, relative)
    assert masters.largest_difference(runs["ecos"], runs["libcosim"], "Drive.omega", step) <= 2e-6


def test_the_win64_speed_dll_runs_under_wine(fourbar_speed, tmp_path):
    """The speed-causal shell's win64 DLL in fmpy's server under wine (test_fmu_native's
    run_win64_under_wine: fresh HOME and prefix) over the default experiment (omega1 held at its
    start) matches the linux64 binary to 1e-12 of each output's largest value."""
    import fmpy

    from wine import run_win64_under_wine

    fmu = fourbar_speed / "FourBarSpeed.fmu"
    fields = ("phi1", "tau_drive", "M_load", "J_red", "W_drive", "W_load")
    remote = run_win64_under_wine(fmu, tmp_path, fields)
    local = fmpy.simulate_fmu(str(fmu), output_interval=1e-3)
    assert remote.shape[1] == local.size
    for i, name in enumerate(fields, start=1):
        scale = np.max(np.abs(local[name]))
        assert np.max(np.abs(remote[i] - local[name])) <= 1e-12 * scale, name
