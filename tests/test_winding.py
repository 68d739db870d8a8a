"""Angles that wind round: a link that turns fully with the crank (the slotted lever of a Whitworth
quick-return, tests/data/user/whitworth*.toml, a closed form with atan2's branch cut) counts its
whole turns on every path: the contour engine, `crankfmu simulate`, the Python FMU and the native
FMU (Co-Simulation and Model Exchange) agree beyond 2 pi. What cannot be made continuous is refused
by `crankfmu check` with its cause, and a table that cannot be built names its function."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from crankfmu.cli import main
from crankfmu.errors import SchemeError
from crankfmu.scenario import load_scenario

DATA = Path(__file__).parent / "data" / "user"
WHITWORTH = DATA / "whitworth_scenario.toml"


def lever(phi1, r=0.1, d=0.05):
    """The lever's angle in closed form, atan2 then made continuous by hand: the turns counted from
    the crank's, the branch from atan2 at phi1 = 0 (the engine's anchor)."""
    raw = np.arctan2(r * np.sin(phi1) - d, r * np.cos(phi1))
    return raw + 2 * math.pi * np.round((phi1 - raw - math.atan2(-d, r)) / (2 * math.pi))


def test_the_engine_counts_the_levers_turns():
    mechanism = load_scenario(str(WHITWORTH)).build().mechanism
    phi1 = np.linspace(-7.0, 40.0, 4701)
    angle = mechanism.kinematics(phi1).q["phi3"]
    assert np.max(np.abs(np.diff(angle))) < 0.05                       # continuous: no 2 pi jump
    assert np.max(np.abs(angle - lever(phi1))) < 1e-12
    assert abs((angle[-1] - angle[0]) - (phi1[-1] - phi1[0])) < 1.5           # one turn per turn
    grid, table, winding = mechanism.turn_table()
    assert list(winding) == [1.0, 0.0]                                # the lever turns, the link swings


def test_an_oscillating_closed_form_keeps_its_branch():
    """seed 004's arm (atan2 too, but oscillating): the same values turn after turn."""
    mechanism = load_scenario("seed004").build().mechanism
    phi1 = np.linspace(0.0, 2 * math.pi, 361)
    first = mechanism.kinematics(phi1).q["phi3"]
    later = mechanism.kinematics(phi1 + 6 * math.pi).q["phi3"]
    assert np.max(np.abs(first - later)) < 1e-12 and np.all(np.abs(first) <= math.pi)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("whitworth")
    assert main(["check", str(WHITWORTH)]) == 0
    assert main(["fmu", str(WHITWORTH), "--out", str(out / "python")]) == 0
    assert main(["fmu", str(WHITWORTH), "--native", "--out", str(out / "native")]) == 0
    assert main(["simulate", str(WHITWORTH), "--method", "fast", "--rtol", "1e-12", "--out", str(out / "cli")]) == 0
    return out


def _cli_column(folder: Path, name: str):
    with open(folder / "timeseries.csv") as f:
        rows = list(csv.DictReader(f))
    return np.array([float(r["time"]) for r in rows]), np.array([float(r[name]) for r in rows])


def test_the_cli_and_both_fmus_agree_beyond_two_pi(built):
    """3 s, 13 crank turns: lever_angle reaches 81 rad. The FMUs (Co-Simulation) and the CLI run
    the C kernel at rtol 1e-12: their lever angles agree to 1e-8 rad. Model Exchange (fmpy's CVode
    at rtol 1e-12, its events located by CVode) to 1e-6 of the angle. Each lever angle is also the
    closed form at its own phi1 (1e-10 relative: the native FMU's table is checked to 1e-11)."""
    from fmpy import simulate_fmu

    tight = {"rtol": 1e-12}
    runs = {"python": simulate_fmu(str(built / "python" / "Whitworth.fmu"), output_interval=1e-3, start_values=tight),
            "native": simulate_fmu(str(built / "native" / "Whitworth.fmu"), output_interval=1e-3, start_values=tight),
            "native ME": simulate_fmu(str(built / "native" / "Whitworth.fmu"), fmi_type="ModelExchange",
                                      output_interval=1e-3, relative_tolerance=1e-12)}
    t, cli = _cli_column(built / "cli", "lever_angle")
    assert cli[-1] > 12 * 2 * math.pi
    for label, run in runs.items():
        angle, phi1 = run["lever_angle"], run["phi1"]
        assert np.max(np.abs(angle - lever(phi1))) < 1e-10 * max(1.0, float(np.max(np.abs(angle)))), label
        on = np.isclose(run["time"], np.round(run["time"] / 1e-3) * 1e-3, atol=1e-12)
        at = np.unique(run["time"][on], return_index=True)[1]
        # the ME run's events add rows: compare at the output grid
        mine = np.interp(t, run["time"][on][at], angle[on][at])
        bar = 1e-8 if label != "native ME" else 1e-6 * float(np.max(np.abs(cli)))
        assert np.max(np.abs(mine - cli)) < bar, (label, np.max(np.abs(mine - cli)))


def test_validate_passes_both_fmus(built, tmp_path):
    from crankfmu.validation import harness

    checks, report = harness.validate([built / "python" / "Whitworth.fmu", built / "native" / "Whitworth.fmu"],
                                      tmp_path, echo=None, jobs=1)
    assert checks.failed == 0, [c.line() for c in checks.items if not c.passed and not c.skipped]
    names = {c.name for c in checks.items}
    assert {"Whitworth.python.cs.default.lever_angle_rel_error", "Whitworth.native.me.default.lever_angle_rel_error",
            "Whitworth.native_vs_python.lever_angle_rel_difference"} <= names


def test_a_closed_form_that_jumps_between_branches_is_refused_by_check(tmp_path, capsys):
    """The block's distance written with a sign that flips (and the lever half a turn round to
    match): the contours still close, but the motion jumps. check names the jump, and the native
    build, which check mirrors, refuses it too."""
    text = (DATA / "whitworth.toml").read_text()
    text = text.replace('"s3 = sqrt(r**2 - 2*r*d*sin(phi1) + d**2)"',
                        '"s3 = sign(cos(phi1) + 0.3)*sqrt(r**2 - 2*r*d*sin(phi1) + d**2)"')
    text = text.replace('"phi3 = atan2(r*sin(phi1) - d, r*cos(phi1))"',
                        '"phi3 = atan2(sign(cos(phi1) + 0.3)*(r*sin(phi1) - d), sign(cos(phi1) + 0.3)*r*cos(phi1))"')
    (tmp_path / "whitworth.toml").write_text(text)
    (tmp_path / "scenario.toml").write_text(WHITWORTH.read_text())
    assert main(["check", str(tmp_path / "scenario.toml")]) == 1
    out = capsys.readouterr().out
    assert "jumps between assembly branches" in out
    assert main(["fmu", str(tmp_path / "scenario.toml"), "--native", "--out", str(tmp_path / "n")]) == 1
    assert "jumps between assembly branches" in capsys.readouterr().err
    assert not (tmp_path / "n").exists()


def test_two_loops_that_swap_branches_together_are_refused_by_the_native_fmu_in_the_clis_words(tmp_path):
    """tests/data/user/whitworth_swap.toml: a jump the contours' determinant cannot see (both loops'
    branches swap where cos(phi1) < -a). Its native FMU, built where they never swap (a = 1.5),
    refuses a = 0.3 set by the host with fmi2Error and the CLI's words, logging off (the C model's
    rule is the engine's: tests/test_c_model.py), and runs again at a = 1.5 after a reset."""
    from fmpy.fmi1 import FMICallException

    from crankfmu.errors import DefinitionError
    from fuzz_host import quiet_slave

    path = DATA / "whitworth_swap_scenario.toml"
    with pytest.raises(DefinitionError) as cli:
        load_scenario(str(path)).with_params(a=0.3).build()
    assert "the closed form of s3 jumps by" in str(cli.value)
    assert main(["fmu", str(path), "--native", "--out", str(tmp_path / "n")]) == 0
    fmu, vr, messages, keep = quiet_slave(tmp_path / "n" / "WhitworthSwap.fmu", tmp_path / "x", "WhitworthSwap")
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["a"]], [0.3])
    with pytest.raises(FMICallException):
        fmu.exitInitializationMode()
    assert messages[-1] == f"fmi2ExitInitializationMode: {cli.value}"
    fmu.reset()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    assert math.isfinite(fmu.getReal([vr["omega1"]])[0])
    fmu.terminate()
    fmu.freeInstance()


def test_a_table_that_cannot_be_built_names_the_function_and_its_jump():
    """A function with a jump (what an angle with atan2's cut was before the engine made it
    continuous): no number of intervals follows it, and the message says it jumps, not that the
    mechanism is near a dead point."""
    from crankfmu.dynamics.cubics import build_cubics

    def engine(phi1):
        phi1 = np.asarray(phi1, dtype=float)
        return np.array([np.cos(phi1), np.where(np.mod(phi1, 2 * math.pi) < 3.0, 0.0, 2 * math.pi)])

    with pytest.raises(SchemeError) as refused:
        build_cubics(engine, 1e-11, 256, 1 << 10, 1e-8, ("the scenario's [[outputs]]", ["smooth", "lever_angle (phi3)"]))
    message = str(refused.value)
    assert "lever_angle (phi3)" in message and "jumps by 6.283" in message and "dead point" in message
    assert "not a dead point" in message and "1e-11" in message


def test_messages_print_numbers_as_written_and_tracebacks_on_request(built, tmp_path):
    """The native FMU refuses a ram line the lever cannot reach, naming the values as the file
    writes them (r = 0.1, not 0.10000000000000001) and the bound, in the CLI's words, with logging
    off too; the CLI's one-line failure shows its traceback with CRANKFMU_TRACEBACK=1, and only then."""
    import os
    import subprocess
    import sys

    from crankfmu.validation.fmu_runner import simulate_logged

    messages = []
    logger = lambda *args: messages.append(args[-1].decode() if isinstance(args[-1], bytes) else str(args[-1]))  # noqa: E731
    with pytest.raises(Exception):
        simulate_logged(str(built / "native" / "Whitworth.fmu"), stop_time=0.01, start_values={"h": 0.5},
                        logger=logger, debug_logging=False)
    refusal = next(m for m in messages if "h = 0.5" in m)
    assert "r = 0.1)" in refusal and "0.1000000" not in refusal
    assert "at phi1 = 8.750 deg the contour equations have no real solution" in refusal
    assert "crank turns fully only for h < 0.3 m (asked 0.5)" in refusal
    bad = tmp_path / "bad.toml"
    bad.write_text(WHITWORTH.read_text().replace('value = 0.1, unit = "m", min = 0', 'value = -0.1, unit = "m", min = 0'))
    (tmp_path / "whitworth.toml").write_text((DATA / "whitworth.toml").read_text())
    command = [sys.executable, "-m", "crankfmu", "fmu", str(bad), "--native", "--out", str(tmp_path / "o")]
    plain = subprocess.run(command, capture_output=True, text=True, env={**os.environ, "CRANKFMU_TRACEBACK": ""})
    traced = subprocess.run(command, capture_output=True, text=True, env={**os.environ, "CRANKFMU_TRACEBACK": "1"})
    assert plain.returncode == traced.returncode == 1
    assert "Traceback" not in plain.stderr and len(plain.stderr.strip().splitlines()) == 1
    assert "r = -0.1 is out of range: valid range (0, inf) m" in plain.stderr
    assert "Traceback (most recent call last)" in traced.stderr and plain.stderr.strip() in traced.stderr
