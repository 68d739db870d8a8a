"""When a table cannot be built, `crankfmu check` names the cause, each from a user's file that
triggers it (the single-cylinder engine of tests/data/user with one thing changed):

- a load that repeats every two turns (a four-stroke engine's gas force, cos(phi1/2)): not
  periodic over one turn, with its values a turn apart, not a "discontinuity";
- a couple with a step that is no kink (atan2's cut): a jump, with its size and angle; one written
  with sign() is a kink, located (tests/test_kinks.py), and passes;
- a gas force so peaky that 2**16 intervals cannot follow it: continuous but steep, its slope and
  the intervals it would need, not a dead point;
- a force that divides by zero: not finite, with the expression and the angle;
- a rod barely longer than the crank: the kinematics steep, a dead point (the engine and the C
  tabulator both look inside the interval to tell it from a jump).
"""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from conftest import ROOT

ENGINE = (ROOT / "tests" / "data" / "user" / "engine2s_scenario.toml").read_text()
GAS = 'fx = "-F_gas*exp(k_peak*(cos(phi1 - phi_peak) - 1))"'
FORCE = '''kind = "force"                      # the gas force pushes the piston towards the crank (-x), once per turn
link = "slider"
point = "B"
''' + GAS + '\nfy = "0"'


def check(tmp_path, text: str, name: str):
    assert text != ENGINE
    path = tmp_path / f"{name}.toml"
    path.write_text(text.replace('name = "user_engine2s"', f'name = "{name}"'))
    run = subprocess.run([sys.executable, "-m", "crankfmu", "check", str(path)], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 1, run.stdout + run.stderr
    failed = [line for line in run.stdout.splitlines() if line.startswith("FAIL")]
    assert failed and "Traceback" not in run.stderr, run.stdout + run.stderr
    return " ".join(failed)


def test_a_load_of_two_turns_is_not_periodic_over_one_not_a_jump(tmp_path):
    said = check(tmp_path, ENGINE.replace(GAS, 'fx = "-F_gas*exp(k_peak*(cos(0.5*(phi1 - phi_peak)) - 1))"'),
                 "four_stroke")
    assert "the loads' generalized force is not periodic over one crank turn" in said, said
    assert "repeats every 2 turns" in said and "declare cycle_turns = 2" in said, said
    values = re.search(r"turn: (\S+) at phi1 = (\S+) deg but (\S+) a turn later", said)
    assert values and float(values.group(1)) != float(values.group(3)), said
    assert "discontinuity" not in said and "dead point" not in said, said


def test_no_build_writes_an_fmu_of_it_that_cannot_initialise(tmp_path):
    """crankfmu fmu (the Python FMU) starts the model at the FMU's start values before it writes
    anything (it wrote an FMU whose fmi2ExitInitializationMode failed); check says so too."""
    said = check(tmp_path, ENGINE.replace(GAS, 'fx = "-F_gas*exp(k_peak*(cos(0.5*(phi1 - phi_peak)) - 1))"'),
                 "four_stroke")
    assert "crankfmu fmu would refuse it: the FMU cannot initialise at its start values" in said, said
    out = tmp_path / "fmus"
    run = subprocess.run([sys.executable, "-m", "crankfmu", "fmu", str(tmp_path / "four_stroke.toml"), "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 1 and "initialising the model at the FMU's start values" in run.stderr, run.stderr
    assert "not periodic over one crank turn" in run.stderr and "Traceback" not in run.stderr, run.stderr
    assert not out.exists() or not any(out.iterdir())


SAWTOOTH = 'kind = "couple"\nlink = "crank"\nmoment = "-100*atan2(sin(phi1 - 1), cos(phi1 - 1))"'


def test_a_couple_with_a_step_jumps(tmp_path):
    """A step that is no kink (atan2's cut: a sawtooth) is a jump, sized and placed."""
    said = check(tmp_path, ENGINE.replace(FORCE, SAWTOOTH), "step")
    # at phi1 - 1 = pi (237.30 deg) atan2 falls from pi to -pi: -100 times that is +628.3
    assert "jumps by 628.3 between phi1 = 237.29 to 237.30 deg" in said, said
    assert "not a dead point" in said, said


def test_a_step_written_with_sign_is_a_located_kink_not_a_jump(tmp_path):
    path = tmp_path / "kink.toml"
    path.write_text(ENGINE.replace(FORCE, 'kind = "couple"\nlink = "crank"\nmoment = "-100*max(0, sign(sin(phi1 - 1)))"'))
    run = subprocess.run([sys.executable, "-m", "crankfmu", "check", str(path)], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    # sin(phi1 - 1) = 0 at 1 rad and 1 + pi rad
    assert "they switch at phi1 = 57.30, 237.30 deg" in run.stdout, run.stdout


def test_a_steep_continuous_load_says_its_slope_and_the_intervals_it_needs(tmp_path):
    said = check(tmp_path, ENGINE.replace("k_peak*(cos", "1000*k_peak*(cos"), "steep")
    assert "is continuous but steep, up to" in said and "intervals, beyond the limit of 65536" in said, said
    slope = float(re.search(r"up to (\S+) per rad", said).group(1))
    # the gas force's torque F_gas e^(k (cos u - 1)) dx/dphi1 (k = 4e5, u = phi1 - phi_peak) is steepest
    # at u = 1/sqrt(k): about F_gas sqrt(k) e^-1/2 * l1 sin(phi_peak) = 25e3 * 632 * 0.61 * 0.04 * 0.25
    # = 9.6e4 N.m/rad (the rod's obliquity adds a few per cent)
    assert 6e4 < slope < 1.5e5, slope
    assert "dead point" in said and "no dead point" in said, said


def test_a_load_that_divides_by_zero_is_not_finite(tmp_path):
    said = check(tmp_path, ENGINE.replace(GAS, 'fx = "-F_gas/sin(phi1)"'), "not_finite")
    assert "fx = '-F_gas/sin(phi1)' is not finite (-inf) at phi1 = 0.00 deg" in said, said
    assert "dead point" not in said, said


def test_a_rod_barely_longer_than_the_crank_is_near_a_dead_point(tmp_path):
    said = check(tmp_path, ENGINE.replace("l2 = { value = 0.14,", "l2 = { value = 0.0400001,"), "dead_point")
    assert "the mechanism is too close to a dead point" in said and "269.97 deg" in said, said
    assert "not periodic" not in said and "jumps" not in said, said


def test_the_native_fmu_calls_a_dead_point_a_dead_point_in_its_own_message(tmp_path):
    """The C tabulator looks inside the interval as the engine does: the native FMU, which tabulates
    when it initialises, says dead point too (it said "jumps ... a discontinuity" before)."""
    import crankfmu
    from crankfmu.native.mechanism import REDUCED, CModel, MechanismError
    from crankfmu.dynamics.program import parameter_values
    from crankfmu.dynamics.program_scenario import compile_scenario

    def c_verdict(text: str) -> int:
        """error_jumps of the C model's refusal to tabulate the file ``text``"""
        path = tmp_path / "c_verdict.toml"
        path.write_text(text)
        scenario = crankfmu.load_scenario(str(path))
        program = compile_scenario(scenario)
        model = CModel(program, parameter_values(program, scenario.values))
        with pytest.raises(MechanismError):
            model.cubics(REDUCED, 1e-11)
        return model._model.error_jumps

    assert c_verdict(ENGINE.replace("l2 = { value = 0.14,", "l2 = { value = 0.0400001,")) == 0
    assert c_verdict(ENGINE.replace(FORCE, SAWTOOTH)) == 1


@pytest.mark.parametrize("turns", [2, 3])
def test_the_period_found_is_the_loads(turns):
    """A function of k turns is refused with k named; one of one turn is not refused."""
    import numpy as np

    from crankfmu.dynamics.cubics import _not_periodic

    def engine(phi1):
        phi1 = np.asarray(phi1, dtype=float)
        return np.array([np.cos(phi1), np.sin(phi1 / turns)])

    said = _not_periodic(engine, ("the functions", ["J", "gas"]))
    assert said and "gas is not periodic" in said and f"repeats every {turns} turns" in said, said
    assert _not_periodic(lambda p: np.array([np.cos(np.asarray(p))]), ("the functions", ["J"])) is None


def test_the_native_build_initialises_its_fmu_before_it_reports_success(tmp_path):
    """crankfmu fmu --native runs the FMU it built once (instantiate, initialise at the start values,
    one step) in a fresh process before it writes it; an FMU that does not start is refused with
    the host's last words, and the build's own FMU passes."""
    import shutil

    from crankfmu.errors import CrankfmuError
    from crankfmu.fmi.native.build import initialises

    broken = tmp_path / "Broken.fmu"
    broken.write_bytes(b"not a zip")
    with pytest.raises(CrankfmuError, match="Broken: the FMU built does not initialise at its start values: "):
        initialises(broken, "Broken")
    built = ROOT / "build" / "fmus" / "native" / "FourBar.fmu"
    assert built.is_file(), "make test builds the FMUs (make fmu) before the tests"
    shutil.copy(built, tmp_path / "FourBar.fmu")
    initialises(tmp_path / "FourBar.fmu", "FourBar")
