"""Joint friction in the FMUs (issue 69). The native ones: the C mechanism model tabulates the
frictions' relative rates and their joints' reaction terms when the FMU initialises (crank_engine.c,
at the values the host set), the kernel solves them (crank_friction.c), in FMI 2.0 and 3.0,
Co-Simulation and Model Exchange (W_friction a continuous state there) and in speed causality; the
Python FMU runs the same kernel. Checked against the independent body-by-body Newton-Euler of
tests/friction_reference.py, the engine's joint_reactions at the FMUs' own states, and the energy
balance with the friction's work."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import crankfmu
from crankfmu.cli import main
from crankfmu.dynamics.reactions import joint_reactions
from crankfmu.simulation import simulate

# the scenario and the independent reference's 3 s from rest, as the kernel's tests take them
from test_friction_kernel import SCENARIO, TIMES, expected, python_fmu, scenario  # noqa: F401  (fixtures)

ROOT = Path(__file__).resolve().parents[1]
OUTPUTS = ["phi1", "omega1", "epsilon1", "W_motor", "W_load", "W_friction", "E_kin", "M_friction", "slide_Ff",
           "slide_Pf", "O_Mf", "O_Pf", "A_Fx", "A_Fy", "slide_N"]


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    """The native FMUs of the scenario, FMI 2.0 and 3.0: make fmu's, or built here."""
    out = tmp_path_factory.mktemp("friction_native")
    fmus = {}
    for version, folder in (("2", "native"), ("3", "native3")):
        built = ROOT / "build" / "fmus" / folder / "SliderFriction.fmu"
        if not built.exists():
            assert main(["fmu", str(SCENARIO), "--native", "--fmi-version", version, "--out", str(out / folder)]) == 0
            built = out / folder / "SliderFriction.fmu"
        fmus[version] = built
    return fmus


def closing(r) -> float:
    """The energy balance's residual (J) at the end: motor + loads + friction - change of E_kin."""
    return r["W_motor"][-1] + r["W_load"][-1] + r["W_friction"][-1] - (r["E_kin"][-1] - r["E_kin"][0])


@pytest.mark.parametrize("version", ["python", "2", "3"])
def test_the_fmus_follow_the_independent_newton_euler(scenario, expected, native, python_fmu, version):
    """The Python FMU and the native FMI 2.0 and 3.0 ones in Co-Simulation over 3 s from rest at rtol
    1e-12: omega1 within 1e-8 rad/s of the independent reference (measured 2.8e-10 for the native
    ones), the energy balance with the friction's work within
    1e-9 of the motor's (measured 5e-13), and the joints' frictions and reactions the FMU reads are the
    engine's Newton-Euler with the frictions of the motion at the FMU's states (their tables are checked
    to 1e-11 and 1e-8 of their largest)."""
    from fmpy import simulate_fmu

    fmu = python_fmu if version == "python" else native[version]
    r = simulate_fmu(str(fmu), stop_time=3.0, output_interval=0.01, start_values={"rtol": 1e-12}, output=OUTPUTS)
    assert np.max(np.abs(r["omega1"] - expected[1])) < 1e-8
    assert abs(closing(r)) < 1e-9 * r["W_motor"][-1]
    assert r["W_friction"][-1] < -0.04 * r["W_motor"][-1]
    # friction dissipates: no joint's friction power is positive
    assert np.all(r["slide_Pf"] <= 0.0) and np.all(r["O_Pf"] <= 0.0)
    model = scenario.build()
    for k in (37, 150, 299):
        found = joint_reactions(model.reduced, np.array([r["phi1"][k]]), r["omega1"][k], r["epsilon1"][k])
        assert r["A_Fx"][k] == pytest.approx(found.force["A"][0][0], rel=1e-6)
        assert r["A_Fy"][k] == pytest.approx(found.force["A"][1][0], rel=1e-6)
        assert r["slide_N"][k] == pytest.approx(found.normal["slide"][0], rel=1e-6)
        assert r["slide_Ff"][k] == pytest.approx(found.friction["slide"][0], rel=1e-6)
        assert r["O_Mf"][k] == pytest.approx(found.friction["O"][0], rel=1e-6)


@pytest.mark.parametrize("version", ["2", "3"])
def test_in_model_exchange_the_friction_is_a_state_of_the_hosts_integrator(expected, native, version):
    """Model Exchange under fmpy's CVode at rtol 1e-12: six continuous states (W_friction the sixth),
    omega1 within 2e-7 of the reference (measured 4.3e-8: CVode's error, which also steps over the
    kinks of |N| where the guide's normal force changes sign, not events) and the energy balance
    within 1e-9 of the motor's work (measured 6e-11)."""
    from fmpy import read_model_description, simulate_fmu

    description = read_model_description(str(native[version]))
    assert [u.variable.derivative.name for u in description.derivatives][-1] == "W_friction"
    assert len(description.derivatives) == 6
    r = simulate_fmu(str(native[version]), fmi_type="ModelExchange", solver="CVode", relative_tolerance=1e-12,
                     stop_time=3.0, output_interval=0.01, output=OUTPUTS)
    assert np.max(np.abs(np.interp(TIMES, r["time"], r["omega1"]) - expected[1])) < 2e-7
    assert abs(closing(r)) < 1e-9 * r["W_motor"][-1]


@pytest.mark.parametrize("values", [{"mu_pin": 0.0, "mu_guide": 0.0}, {"mu_guide": 0.0},
                                    {"mu_pin": 0.2, "r_pin": 0.02, "mu_guide": 0.05}],
                         ids=["none", "pins only", "other values"])
def test_the_native_fmus_friction_parameters_are_set_before_initialisation(scenario, native, values):
    """mu and the pins' radius are parameters like any other: the FMU tabulates at the values the host
    set, the frictions whose mu is 0 are none (their outputs 0), and it runs the machine the fast path
    runs with the same values (the same kernel and tables built by the same C model): bit for bit
    without any friction (the kernel steps as it did before friction existed), within 1e-10 else."""
    from fmpy import simulate_fmu

    r = simulate_fmu(str(native["2"]), stop_time=1.0, output_interval=0.01, start_values={"rtol": 1e-11, **values},
                     output=["omega1", "W_friction", "M_friction", "slide_Ff", "O_Mf"])
    same = simulate(scenario.with_params(**values), t_end=1.0, method="fast", rtol=1e-11, output_times=r["time"])
    if values.get("mu_pin") == 0.0:
        assert np.array_equal(r["omega1"], same.omega1)
        assert np.all(r["W_friction"] == 0.0) and np.all(r["M_friction"] == 0.0) and same.W_friction is None
        return
    assert np.max(np.abs(r["omega1"] - same.omega1)) < 1e-10
    assert abs(r["W_friction"][-1] - same.W_friction[-1]) < 1e-10 * abs(same.W_friction[-1])
    if values.get("mu_guide") == 0.0:
        assert np.all(r["slide_Ff"] == 0.0) and np.max(np.abs(r["O_Mf"])) > 0.01


def test_the_speed_causal_native_fmu_outputs_the_friction(tmp_path):
    """A drive imposes omega1 = 5 + 4 t rad/s on the speed-causal native FMU through fmpy: its
    works close the energy balance with the friction's within 1e-9 of the drive's, and the friction's
    power is never positive."""
    from fmpy import simulate_fmu

    assert main(["fmu", str(SCENARIO), "--native", "--causality", "speed", "--out", str(tmp_path)]) == 0
    signal = np.array([(t, 5.0 + 4.0 * t) for t in np.linspace(0.0, 1.0, 1001)],
                      dtype=[("time", float), ("omega1", float)])
    r = simulate_fmu(str(tmp_path / "SliderFrictionSpeed.fmu"), stop_time=1.0, output_interval=1e-3, input=signal,
                     output=["W_drive", "W_load", "W_friction", "E_kin", "M_friction", "slide_Ff", "slide_Pf"])
    assert r["W_friction"][-1] < 0.0 and np.all(r["M_friction"][1:] <= 0.0) and np.all(r["slide_Pf"] <= 1e-12)
    assert np.max(np.abs(r["slide_Ff"])) > 1.0
    works = r["W_drive"][-1] + r["W_load"][-1] + r["W_friction"][-1] - (r["E_kin"][-1] - r["E_kin"][0])
    assert abs(works) < 1e-9 * abs(r["W_drive"][-1]), works


def test_the_win64_dll_runs_the_friction_under_wine(native, tmp_path):
    """The FMI 2.0 FMU's win64 DLL under wine through fmpy's remoting, mu and the pins' radius set by
    the host (the friction tabulated by the Windows build of the C model) at rtol 1e-12: omega1 within
    1e-8 rad/s of the independent reference with those values over its default 3 s, as the linux64
    binary's (measured: 2.0e-10 each, 2.3e-10 apart). (The two binaries' tables differ in their last bits, another compiler and libm, and a
    step that ends on a kink of |N| ends where each locates it: they agree to the integrator's
    error, 2.8e-8 rad/s apart at the default rtol 1e-11, not to the bit as a machine without kinks.)"""
    from fmpy import simulate_fmu

    from friction_reference import SliderCrankWithFriction
    from wine import run_win64_under_wine

    changes = {"mu_pin": 0.15, "r_pin": 0.012, "rtol": 1e-12}
    remote = run_win64_under_wine(native["2"], tmp_path, ("omega1", "W_friction"), changes)
    local = simulate_fmu(str(native["2"]), output_interval=1e-3, start_values=changes, output=["omega1"])
    reference = SliderCrankWithFriction(mu_pin=0.15, r_pin=0.012).run(float(remote[0][-1]), remote[0])
    assert remote[2][-1] < -1.0                                   # the friction did its work
    assert np.max(np.abs(remote[1] - reference[1])) < 1e-8
    assert np.max(np.abs(local["omega1"] - reference[1])) < 1e-8


def test_a_mu_beyond_1_is_refused_by_name_when_the_fmu_initialises(tmp_path):
    """A user's scenario whose mu parameter declares no upper bound: the native FMU takes the value
    (its range is the file's) and refuses the design when initialisation ends, naming the joint and
    the bound, with logging off, as the engine refuses it (mu in [0, 1]); the instance then takes a
    good value after a reset."""
    from fmpy.fmi1 import FMICallException

    from crankfmu.errors import ParameterError
    from fuzz_host import quiet_slave

    text = SCENARIO.read_text().replace('mu_guide = { value = 0.1, unit = "1", min = 0, max = 1,',
                                        'mu_guide = { value = 0.1, unit = "1", min = 0,')
    assert "max = 1, description = \"friction coefficient of the guide" not in text
    user = tmp_path / "unbounded_scenario.toml"
    user.write_text(text)
    assert main(["fmu", str(user), "--native", "--out", str(tmp_path / "fmu")]) == 0
    with pytest.raises(ParameterError, match=r"friction of joint slide: mu = mu_guide = 1.5 must be in \[0, 1\]"):
        crankfmu.load_scenario(user).with_params(mu_guide=1.5).build()
    fmu, vr, messages, keep = quiet_slave(tmp_path / "fmu" / "SliderFriction.fmu", tmp_path / "x", "SliderFriction")
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["mu_guide"]], [1.5])
    with pytest.raises(FMICallException):
        fmu.exitInitializationMode()
    assert "the friction of joint slide: 1 - mu = -0.5 must be >= 0" in messages[-1], messages
    fmu.reset()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["mu_guide"]], [0.5])
    fmu.exitInitializationMode()
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.1)
    assert fmu.getReal([vr["W_friction"]])[0] < 0.0
    fmu.terminate()
    fmu.freeInstance()


def test_the_aarch64_binary_runs_the_friction_under_qemu(expected, native, tmp_path):
    """The FMI 3.0 FMU's aarch64-linux binary in the project's C host under qemu-aarch64 (and the
    x86_64-linux one beside it), rtol 1e-12 set by the host: omega1 over 3 s at 10 ms steps within
    1e-8 rad/s of the independent reference on both (the friction tabulated on each by its own
    build of the C model; measured 2.8e-10 on each)."""
    from test_fmi3 import linux_and_arm_rows

    runs = linux_and_arm_rows(native["3"], "SliderFriction", 300, 0.01, "omega1", tmp_path, {"rtol": 1e-12})
    for platform, rows in runs.items():
        assert rows.shape == (300, 2), platform
        assert np.max(np.abs(rows[:, 1] - expected[1][1:])) < 1e-8, platform
