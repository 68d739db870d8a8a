"""A machine cycle of several crank turns (``cycle_turns``): the single-cylinder four-stroke engine
of tests/data/user/engine4s_scenario.toml (its gas force repeats every two turns), every path
against the hand-written reference of tests/engine_reference.py (closed-form kinematics, its own
J, J' and generalized force, DOP853 at 1e-12, no crankfmu code).

Tolerances: the reference and the paths each integrate to about 1e-12 relative; over 1 s (about 25
cycles of a sharp gas peak) their omega1 differ by 1e-9 to 3e-9 of its largest value, so 1e-8 is
the bar the issue sets with a margin of 3. The steady cycle and the flywheel are found by a secant
or Brent search to 1e-12 on an integration at 1e-11 or 1e-12: 1e-6 is the issue's bar (2.6e-9 is
measured for the flywheel). Model Exchange adds CVode's own error: 1e-7 at its rtol 1e-12.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import crankfmu
from crankfmu.check import check_scenario
from crankfmu.studies.flywheel import design_flywheel
from engine_reference import FILE, Engine, flywheel_for

TIMES = np.linspace(0.0, 1.0, 1001)


@pytest.fixture(scope="module")
def scenario():
    return crankfmu.load_scenario(str(FILE))


@pytest.fixture(scope="module")
def hand():
    return Engine().run(TIMES)


def relative(omega, reference):
    return float(np.max(np.abs(np.asarray(omega) - reference)) / np.max(np.abs(reference)))


def test_the_four_stroke_passes_the_check(scenario):
    report = check_scenario(str(FILE))
    assert report.status == 0, report.text()
    assert "a cycle of 2 turns" in report.text()      # the native tables' construction says so


@pytest.mark.parametrize("method, rtol", [("fast", 1e-12), ("reference", None)])
def test_each_integrator_follows_the_hand_reference(scenario, hand, method, rtol):
    result = crankfmu.simulate(scenario, method=method, rtol=rtol, output_times=TIMES)
    assert relative(result.omega1, hand) < 1e-8


def test_the_summary_takes_its_cycle_over_two_turns(scenario):
    result = crankfmu.simulate(scenario, method="fast", rtol=1e-12)
    k = scenario.experiment.summary_cycle
    stats = result.cycle_stats(k)
    t0, t1 = stats["t_start"], stats["t_end"]
    phi = result.state([t0, t1])[0]
    assert phi[1] - phi[0] == pytest.approx(4.0 * math.pi, rel=1e-9)
    assert stats["omega1_mean"] == pytest.approx(4.0 * math.pi / (t1 - t0), rel=1e-12)
    energy = result.summary()["energy_balance"]
    assert abs(energy["residual"]) < 1e-8


def test_the_steady_cycle_and_the_flywheel_match_the_hand_reference(scenario):
    design = design_flywheel(scenario, 0.02)
    J_hand = flywheel_for(0.02)
    assert design.J_F_simulated == pytest.approx(J_hand, rel=1e-6)
    _, delta_free, period_free = Engine(J_flywheel=0.0).steady()
    assert design.delta_without_flywheel == pytest.approx(delta_free, rel=1e-6)
    assert design.without.period == pytest.approx(period_free, rel=1e-6)
    assert design.without.angle == pytest.approx(4.0 * math.pi)
    assert design.delta_achieved_crank_angle == pytest.approx(0.02, rel=1e-6)


def test_a_load_not_periodic_over_the_declared_cycle_names_the_cycle_that_holds_it(tmp_path):
    text = FILE.read_text().replace("cycle_turns = 2\n", "")
    path = tmp_path / "four_stroke_undeclared.toml"
    path.write_text(text)
    said = check_scenario(str(path)).text()
    assert "is not periodic over one crank turn" in said, said
    assert "declare cycle_turns = 2" in said, said
    lone = tmp_path / "three_turns.toml"
    lone.write_text(FILE.read_text().replace("cos(0.5*(phi1 - phi_peak))", "cos((phi1 - phi_peak)/3)"))
    said = check_scenario(str(lone)).text()
    assert "not periodic over the declared cycle of 2 turns (cycle_turns = 2)" in said, said
    assert "declare cycle_turns = 6" in said, said


@pytest.mark.parametrize("value", ["0", "1.5", "true", '"2"', "9"])
def test_cycle_turns_must_be_a_whole_number_of_turns(tmp_path, value):
    path = tmp_path / "bad.toml"
    path.write_text(FILE.read_text().replace("cycle_turns = 2", f"cycle_turns = {value}"))
    said = check_scenario(str(path)).text()
    assert "cycle_turns" in said and ("from 1 to 8" in said or "must be" in said), said


def build_three(path, out) -> dict:
    """The Python FMU and the native FMI 2 and 3 FMUs of the file at ``path``, by the CLI."""
    from crankfmu.cli import main

    built = {}
    for kind, extra in (("python", []), ("native2", ["--native"]), ("native3", ["--native", "--fmi-version", "3"])):
        assert main(["fmu", str(path), "--out", str(out / kind), *extra]) == 0
        built[kind] = next((out / kind).glob("*.fmu"))
    return built


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    return build_three(FILE, tmp_path_factory.mktemp("engine4s"))


@pytest.mark.parametrize("kind", ["python", "native2", "native3"])
def test_each_fmu_follows_the_hand_reference_in_co_simulation(fmus, hand, kind):
    import fmpy

    result = fmpy.simulate_fmu(str(fmus[kind]), stop_time=1.0, output_interval=0.001, output=["omega1"])
    assert relative(result["omega1"], hand) < 1e-8


@pytest.mark.parametrize("kind", ["native2", "native3"])
def test_each_native_fmu_follows_the_hand_reference_in_model_exchange(fmus, hand, kind):
    import fmpy

    result = fmpy.simulate_fmu(str(fmus[kind]), stop_time=1.0, output_interval=0.001, output=["omega1"],
                               fmi_type="ModelExchange", relative_tolerance=1e-12)
    assert relative(result["omega1"], hand) < 1e-7


# ---------------------------------------------------------------------------- a load of the speed
def as_couple(text: str, moment: str = "-c_brake*omega1") -> str:
    """The engine with its brake moved from the motor line (B omega1) to a couple on the crank."""
    text = text.replace('name = "user_engine4s"', 'name = "user_engine4s_couple"')
    text = text.replace('fmu = "Engine4S"', 'fmu = "Engine4SCouple"')
    text = text.replace('B = { value = 0.0128', 'B = { value = 0.0').replace('B_low = { value = 0.0128', 'B_low = { value = 0.0')
    text = text.replace('g = { value = 0.0,', 'c_brake = { value = 0.0128, unit = "N.m.s/rad", min = 0, '
                        'description = "the brake, a couple on the crank" }\ng = { value = 0.0,')
    return text.replace("[[ports]]", f'[[loads]]\nkind = "couple"\nlink = "crank"\nmoment = "{moment}"\n\n[[ports]]', 1)


COUPLE = FILE.parent / "engine4s_couple_scenario.toml"


@pytest.fixture(scope="module")
def couple_file():
    """The twin file make bench times: the engine's file with the brake moved, and its comments."""
    text = COUPLE.read_text()
    assert as_couple(FILE.read_text()) == "\n".join(line for line in text.splitlines() if not line.startswith(
        ("# This twin", "# instead of the motor", "# requires the two"))) + "\n"
    return COUPLE


@pytest.mark.parametrize("method, rtol", [("fast", 1e-12), ("reference", None)])
def test_the_brake_as_a_couple_of_omega1_gives_the_same_motion(couple_file, hand, method, rtol):
    scenario = crankfmu.load_scenario(str(couple_file))
    assert scenario["B"] == 0.0
    result = crankfmu.simulate(scenario, method=method, rtol=rtol, output_times=TIMES)
    assert relative(result.omega1, hand) < 1e-8
    energy = result.summary()["energy_balance"]
    assert energy["W_motor"] == 0.0 and energy["W_load"] > 0.0    # the brake's work is the loads' now
    assert abs(energy["residual"]) < 1e-8


@pytest.fixture(scope="module")
def couple_fmus(couple_file, tmp_path_factory):
    return build_three(couple_file, tmp_path_factory.mktemp("couple_fmus"))


REACTIONS = ["O_Fx", "O_Fy", "A_Fx", "A_Fy", "B_Fx", "B_Fy", "slide_N"]


@pytest.mark.parametrize("kind", ["python", "native2", "native3"])
def test_each_fmu_holds_the_couple_of_omega1_exactly(couple_fmus, fmus, hand, kind):
    """omega1 against the hand reference; the joint forces against the same FMU kind of the engine
    with the brake on the motor line: a couple on the crank moves no joint force, whatever acts it
    (both FMUs run at rtol 1e-12, so their motions agree to about 3e-9 and the forces with them)."""
    import fmpy

    couple = fmpy.simulate_fmu(str(couple_fmus[kind]), stop_time=1.0, output_interval=0.001,
                               output=["omega1", "M_motor", *REACTIONS])
    motor = fmpy.simulate_fmu(str(fmus[kind]), stop_time=1.0, output_interval=0.001, output=REACTIONS)
    assert relative(couple["omega1"], hand) < 1e-8
    assert np.all(couple["M_motor"] == 0.0)
    for name in REACTIONS:
        assert relative(couple[name], motor[name]) < 1e-7, name


def test_loads_of_the_speed_on_a_machine_of_two_turns(tmp_path):
    """A fan (omega1**2) passes, on a machine whose cycle is two turns too, and so does a cube (a law
    of the speed: speed_laws.py); a direction-dependent load that reads a speed is refused."""
    path = tmp_path / "cube.toml"
    path.write_text(as_couple(FILE.read_text(), "-c_brake*omega1**3"))
    report = check_scenario(str(path))
    assert report.status == 0, report.text()
    assert "the load on crank has a law of the speed, omega1 ** 3" in report.text(), report.text()
    (tmp_path / "fan.toml").write_text(as_couple(FILE.read_text(), "-c_brake*omega1**2"))
    report = check_scenario(str(tmp_path / "fan.toml"))
    assert report.status == 0, report.text()
    direction = FILE.read_text().replace(
        'fx = "-F_gas*exp(k_peak*(cos(0.5*(phi1 - phi_peak)) - 1))"\nfy = "0"',
        'direction_of = "B.x"\nincreasing = { fx = "-omega1" }\ndecreasing = { fx = "0" }')
    (tmp_path / "direction.toml").write_text(direction)
    said = check_scenario(str(tmp_path / "direction.toml")).text()
    assert "reads the speed(s) omega1: only a force or couple without direction_of may" in said, said


def test_a_damper_written_with_a_points_velocity_is_the_viscous_force(tmp_path):
    """fx = "-c*B_vx" on the piston against the packaged viscous_force kind (F = -c v along x), and
    a generator -(T0 + k omega1) on the crank against the motor line A = -T0, B = k: the same
    torques by two routes, so the same motion to the integrator's round-off."""
    extra = 'c_damp = { value = 2.0, unit = "N.s/m", min = 0, description = "a damper on the piston" }\ng = {'
    base = FILE.read_text().replace("g = {", extra, 1)
    written = base.replace("[[ports]]", '[[loads]]\nkind = "force"\nlink = "slider"\npoint = "B"\nfx = "-c_damp*B_vx"\n'
                           'fy = "0"\n\n[[ports]]', 1)
    packaged = base.replace("[[ports]]", '[[loads]]\nkind = "viscous_force"\nlink = "slider"\npoint = "B"\naxis = "x"\n'
                            'coefficient = "c_damp"\n\n[[ports]]', 1)
    generator = as_couple(FILE.read_text(), "-(T0 + c_brake*omega1)").replace(
        "g = {", 'T0 = { value = 1.5, unit = "N.m", description = "the generator at rest" }\ng = {', 1)
    line = FILE.read_text().replace('A = { value = 0.0,', 'A = { value = -1.5,').replace(
        'A_low = { value = 0.0,', 'A_low = { value = -1.5,')
    for one, other in ((written, packaged), (generator, line)):
        runs = []
        for i, text in enumerate((one, other)):
            path = tmp_path / f"engine_{len(runs)}_{i}.toml"
            path.write_text(text)
            runs.append(crankfmu.simulate(crankfmu.load_scenario(str(path)), method="fast", rtol=1e-12,
                                          output_times=TIMES))
        # the same torques; the works differ (the brake's is W_load on one side, W_motor on the
        # other) and enter the step control, so the steps differ: the integrator's error, 1e-9 at 1e-12
        assert relative(runs[0].omega1, runs[1].omega1) < 1e-9
        assert abs(runs[0].summary()["energy_balance"]["residual"]) < 1e-8


def test_a_sweep_of_the_flywheel_gives_the_hand_references_steady_cycles(tmp_path):
    """crankfmu sweep (the C kernel's batch of steady cycles over the two-turn cycle, shooting to
    1e-9) against the hand reference's crank-angle steady cycle: delta and the mean speed to 1e-6."""
    import csv

    from crankfmu.cli import main

    assert main(["sweep", str(FILE), "--param", "J_flywheel=0.05:0.1:2", "--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "steady.csv").open()))
    assert len(rows) == 2
    for row in rows:
        _, delta, period = Engine(J_flywheel=float(row["J_flywheel"])).steady()
        assert float(row["delta"]) == pytest.approx(delta, rel=1e-6)
        assert float(row["omega1_mean"]) == pytest.approx(4 * math.pi / period, rel=1e-6)


@pytest.mark.parametrize("native", [False, True])
def test_in_speed_causality_the_couple_of_omega1_is_in_the_drive_torque(tmp_path, native):
    """With the crank's speed imposed (an input, 240 rad/s at its default), the drive torque of the
    twin with the couple -c_brake omega1 exceeds the motor-line engine's (whose motor line a
    speed-causal FMU does not read) by exactly c_brake omega1 at every step."""
    import fmpy

    from crankfmu.cli import main

    runs = {}
    for name, path in (("motor", FILE), ("couple", COUPLE)):
        out = tmp_path / name
        assert main(["fmu", str(path), "--causality", "speed", "--out", str(out), *(["--native"] if native else [])]) == 0
        fmu = next(out.glob("*.fmu"))
        runs[name] = fmpy.simulate_fmu(str(fmu), stop_time=0.1, output_interval=0.001, output=["tau_drive", "M_load"])
    gap = runs["couple"]["tau_drive"] - runs["motor"]["tau_drive"]
    assert np.max(np.abs(gap - 0.0128 * 240.0)) < 1e-12 * np.max(np.abs(runs["motor"]["tau_drive"]))
