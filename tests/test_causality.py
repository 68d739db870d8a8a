"""The crank in speed causality (fmi.python.speed): the FMU takes omega1 and answers with tau_drive, the
torque the drive must apply (inverse dynamics from the tables). Checked against the equilibrium
moment of the power balance (dynamics.inverse on the contour engine: another method and another
code path), against the torque-causal reference run backwards (its motor torque), and by the
energy balance. A bad causality is refused by name."""

from __future__ import annotations

import copy
import math
import re
from pathlib import Path

import numpy as np
import pytest

import crankfmu
from crankfmu.cli import main
from crankfmu.errors import DefinitionError
from crankfmu.scenario import Scenario, load_scenario


@pytest.fixture(scope="module", params=["python", "native"])
def speed_fmu(request, tmp_path_factory):
    """Seed 001's speed-causal FMU, the pythonfmu one and the native one: one kernel step
    (ck_speed_advance) behind either, so each check below holds for both."""
    out = tmp_path_factory.mktemp(f"speed_{request.param}")
    native = ["--native"] if request.param == "native" else []
    assert main(["fmu", "seed001", "--causality", "speed", *native, "--out", str(out)]) == 0
    return out / "ThreeLoopSpeed.fmu"


class Host:
    """fmpy's low-level API on one Co-Simulation instance of a speed-causal FMU, logging off, every
    message kept (test_native_speed.py uses it too)."""

    def __init__(self, path, tmp_path, start_values=None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        from fuzz_host import callbacks

        md = read_model_description(str(path))
        self.md = md
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.outputs = [v.name for v in md.modelVariables if v.causality == "output"]
        self.messages = []
        self._keep = callbacks(lambda env, name, status, category, message: self.messages.append(message.decode()))
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), str(tmp_path / "x")),
                             modelIdentifier=md.coSimulation.modelIdentifier)
        self.fmu.instantiate(loggingOn=False, callbacks=self._keep[0])
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for name, value in (start_values or {}).items():
            self.fmu.setReal([self.vr[name]], [value])
        self.fmu.exitInitializationMode()
        self.t = 0.0

    def step_to(self, t, omega=None, **inputs):
        """One step to t, the inputs (omega1 and any other by name) set first."""
        if omega is not None:
            inputs["omega1"] = omega
        if inputs:
            self.fmu.setReal([self.vr[n] for n in inputs], list(inputs.values()))
        self.fmu.doStep(currentCommunicationPoint=self.t, communicationStepSize=t - self.t)
        self.t = t

    def step_number(self, k, h, **inputs):
        """Step k of a fixed-step master: from k h to (k + 1) h, on the master's clock (k h, not
        the sum of the steps before)."""
        if inputs:
            self.fmu.setReal([self.vr[n] for n in inputs], list(inputs.values()))
        self.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
        self.t = (k + 1) * h

    def get(self, *names):
        return self.fmu.getReal([self.vr[n] for n in names])

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def test_at_constant_speed_tau_drive_has_the_equilibrium_moments_extremes(speed_fmu, tmp_path):
    """Seed 001 at 15 rad/s: `crankfmu equilibrium` locates M_e's extremes over a cycle (the power
    balance on the contour engine); the FMU, stepped to the times the crank passes those angles,
    gives tau_drive equal to them to 1e-8 (the tables' checked error is 1e-11)."""
    from crankfmu.studies.equilibrium import cycle_breaks, located_extremes

    scenario = load_scenario("seed001")
    model = scenario.build()
    omega = 15.0
    extremes = located_extremes(model, omega, cycle_breaks(model))
    phi0 = scenario["phi1_start"]
    host = Host(speed_fmu, tmp_path, {"omega1": omega})
    found = {}
    for key in ("Me_min", "Me_max"):
        angle = math.radians(extremes[f"{key}_at_deg"])
        found[key] = ((angle - phi0) % (2 * math.pi)) / omega
    for key, t in sorted(found.items(), key=lambda item: item[1]):
        while host.t + 1e-3 < t:
            host.step_to(host.t + 1e-3)
        host.step_to(t)
        (tau,) = host.get("tau_drive")
        assert abs(tau - extremes[key]) <= 1e-8 * max(abs(extremes["Me_min"]), abs(extremes["Me_max"])), key
    host.close()


def test_the_torque_causal_run_backwards_gives_its_motor_torque(speed_fmu, tmp_path):
    """The reference run of seed 001 (torque causality, its motor line) gives omega1(t); imposed on
    the speed-causal FMU every 0.1 ms, tau_drive is the torque that produced it: the motor torque.
    The FMU takes omega1's slope from its last step (a backward difference): at the step's end
    epsilon1 is that of 1.5 steps earlier, off by 1.5 h |d epsilon1/dt|, and tau_drive by J times
    that (0.3 N.m measured on seed 001's 95 N.m); the bar is 1e-2 of max |M_motor|."""
    h = 1e-4
    times = np.arange(0.0, 0.3 + h / 2, h)
    reference = crankfmu.simulate("seed001", method="reference", output_times=times)
    host = Host(speed_fmu, tmp_path, {"omega1": float(reference.omega1[0])})
    tau = [host.get("tau_drive")[0]]
    for k in range(1, times.size):
        host.step_to(times[k], float(reference.omega1[k - 1]) if k > 1 else None)
        tau.append(host.get("tau_drive")[0])
    host.close()
    tau = np.array(tau)
    # from the third point on, the backward difference has a step behind it
    error = np.abs(tau[3:] - reference.M_motor[3:])
    assert np.max(error) <= 1e-2 * np.max(np.abs(reference.M_motor)), np.max(error)


def test_the_energy_balance_closes_in_speed_causality(speed_fmu, tmp_path):
    """omega1 varying (10 to 20 rad/s): W_drive + W_load + W_ext = E_kin(t) - E_kin(0), the works
    by Gauss-Legendre over each step (5 points per degree), to 1e-8 of the work done."""
    host = Host(speed_fmu, tmp_path, {"omega1": 15.0})
    (E0,) = host.get("E_kin")
    for k in range(1, 2001):
        t = k * 1e-3
        host.step_to(t, 15.0 + 5.0 * math.sin(3.0 * t))
    W_drive, W_load, W_ext, E1 = host.get("W_drive", "W_load", "W_ext", "E_kin")
    host.close()
    assert abs(W_drive + W_load + W_ext - (E1 - E0)) <= 1e-8 * (abs(W_drive) + abs(W_load))


def test_the_kernels_works_are_the_integrals_of_the_powers():
    """The kernel's speed step (ck_speed_advance) on seed 001 (slider forces: Q jumps at their
    switch angles) over 0.25 s from 2.5 rad with omega1 = 14 - 100 t given with its derivative:
    the crank turns forward, stops at 0.14 s and turns back, crossing switch angles both ways. Its works against
    scipy's quad of the powers (tau_drive, Q and 0 times omega1, evaluated in numpy from the same
    table) split at the reversal and at every switch crossing (found here by brentq): 1e-10 of
    the largest work; and phi1 is the line's integral."""
    from scipy.integrate import quad
    from scipy.optimize import brentq

    from crankfmu.dynamics import modes
    from crankfmu.dynamics.tabulated import table_of
    from crankfmu.integrators.fast import TABLE_TOLERANCE, SpeedStepper

    model = load_scenario("seed001").build()
    table = table_of(model.reduced, TABLE_TOLERANCE)
    J_flywheel = model.reduced.J_flywheel
    phi0, w0, rate, h = 2.5, 14.0, -100.0, 0.25
    stepper = SpeedStepper(table, J_flywheel)
    stepper.start(0.0, phi0, w0)
    row = stepper.advance(h, w0, rate).copy()
    phi = lambda s: phi0 + w0 * s + 0.5 * rate * s * s          # noqa: E731
    omega = lambda s: w0 + rate * s                               # noqa: E731

    def powers(s):
        p, w = np.array([phi(s)]), np.array([omega(s)])
        J, half_dJ, Q = table.coefficients_at(p, w, J_flywheel)
        return float(modes.drive_torque(J, half_dJ, Q, 0.0, w, rate)[0] * w[0]), float(Q[0] * w[0])

    s_turn = -w0 / rate
    cuts = [0.0, s_turn, h]
    for sa, sb in ((0.0, s_turn), (s_turn, h)):
        lo, hi = sorted((phi(sa), phi(sb)))
        for angle in table.switch_angles:
            for n in range(int(np.floor((lo - angle) / (2 * np.pi))), int(np.ceil((hi - angle) / (2 * np.pi))) + 1):
                theta = angle + 2 * np.pi * n
                if lo < theta < hi:
                    cuts.append(brentq(lambda s: phi(s) - theta, sa, sb, xtol=1e-15, rtol=1e-15))
    cuts = sorted(cuts)
    assert len(cuts) > 4                                # switches crossed on both sides of the reversal
    expected = np.zeros(2)
    for a, b in zip(cuts, cuts[1:]):
        for j in range(2):
            expected[j] += quad(lambda s: powers(s)[j], a, b, epsabs=1e-13, epsrel=1e-13, limit=200)[0]
    W_drive, W_load, W_ext = row[2], row[3], row[4]
    scale = np.max(np.abs(expected))
    assert abs(W_drive - expected[0]) <= 1e-10 * scale and abs(W_load - expected[1]) <= 1e-10 * scale, \
        (W_drive - expected[0], W_load - expected[1], scale)
    assert W_ext == 0.0
    assert row[0] == pytest.approx(phi(h), rel=1e-15) and row[1] == pytest.approx(omega(h), rel=1e-15)


def test_fmpy_finds_no_problem_and_the_variables_are_the_speed_causal_ones(speed_fmu):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(speed_fmu)) == []
    variables = {v.name: v for v in read_model_description(str(speed_fmu)).modelVariables}
    assert (variables["omega1"].causality, variables["omega1"].unit) == ("input", "rad/s")
    assert (variables["tau_drive"].causality, variables["tau_drive"].unit) == ("output", "N.m")
    assert not {"A", "B", "M_motor", "tau_ext", "omega1_start"} & set(variables)


def test_a_bad_causality_is_refused(tmp_path, capsys):
    base = load_scenario("seed000")
    data = copy.deepcopy(dict(base.data))
    data["crank"] = {"causality": "position"}
    with pytest.raises(DefinitionError, match=r"causality must be one of torque, speed, got 'position'"):
        Scenario(data, base.where, base.path).causality
    # a user's file with that causality: both builds refuse it in one line, and write nothing
    text = (Path(crankfmu.__file__).parent / "scenarios" / "seed000.toml").read_text()
    bad = tmp_path / "position.toml"
    bad.write_text(text.replace("[parameters]", '[crank]\ncausality = "position"\n\n[parameters]', 1))
    for native in ([], ["--native"]):
        assert main(["fmu", str(bad), *native, "--out", str(tmp_path / "n")]) != 0
        assert re.search(r"causality must be one of torque, speed, got 'position'", capsys.readouterr().err), native
        assert not (tmp_path / "n").exists()


# ------------------------------------------------------------------ the drive's speed-causal variant
def test_the_drive_with_its_rotor_steps_exactly():
    """DcDrive.step_with_rotor (the matrix exponential of the held-input linear system) against
    scipy's DOP853 at rtol 1e-13 on the same right-hand side, over steps of 0.1 to 10 ms; and the
    numpy matrix exponential itself against scipy's."""
    from scipy.integrate import solve_ivp
    from scipy.linalg import expm as scipy_expm

    from crankfmu.dynamics.drive import load_drive
    from crankfmu.numerics import expm

    rng = np.random.default_rng(3)
    for _ in range(5):
        M = rng.normal(size=(4, 4)) * rng.uniform(0.01, 30.0)
        assert np.max(np.abs(expm(M) - scipy_expm(M))) <= 1e-12 * np.max(np.abs(scipy_expm(M)))
    file = load_drive("dc_pi")
    drive = file.drive({n: p.value for n, p in file.parameters.items()})
    start = (3.0, 0.2, 15.0)
    for h in (1e-4, 1e-3, 1e-2):
        exact = drive.step_with_rotor(*start, 20.0, 12.0, 1.0, h)
        sol = solve_ivp(lambda t, y: drive.rhs_with_rotor(*y, 20.0, 12.0, 1.0), (0.0, h), start, method="DOP853",
                        rtol=1e-13, atol=1e-13)
        assert np.max(np.abs(np.array(exact) - sol.y[:, -1])) <= 1e-10 * max(map(abs, start)), h


def test_the_speed_causal_drive_fmu_is_valid_and_refuses_a_file_without_its_section(tmp_path, capsys):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert main(["fmu", "dc_pi", "--drive", "--causality", "speed", "--out", str(tmp_path)]) == 0
    path = tmp_path / "DriveSpeed.fmu"
    assert validate_fmu(str(path)) == []
    variables = {v.name: v for v in read_model_description(str(path)).modelVariables}
    assert (variables["omega"].causality, variables["tau_load"].causality) == ("output", "input")
    assert variables["J_drive"].unit == "kg.m2"
    from crankfmu.dynamics.drive import _FILES
    text = (_FILES / "dc_pi.toml").read_text()
    plain = tmp_path / "plain.toml"
    plain.write_text(text[:text.index("[speed_causality]")] + text[text.index("[experiment]"):])
    assert main(["fmu", str(plain), "--drive", "--causality", "speed", "--out", str(tmp_path / "no")]) != 0
    assert "[speed_causality]" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()
