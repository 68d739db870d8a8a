"""Joint reactions as FMU outputs (``<joint>_Fx``, ``<joint>_Fy`` for a pin; ``<joint>_N``,
``<joint>_M`` for a slide): read from the design's tables by the C kernel (their terms tabulated to
REACTION_TOLERANCE of each term's scale, weighted at the FMU's state), so they equal Newton-Euler
at the FMU's state to that bound of the mechanism's largest reaction.

Checked by an independent statement of the same physics: the driving moment Newton-Euler finds
with those reactions equals the torque the movement equation puts on the crank (the motor's plus
tau_ext in torque causality; tau_drive, from the tables, in speed causality). The speed-causal
FMU at constant speed gives `crankfmu equilibrium`'s reactions at the same angles, and a port's
force enters the reactions as the same force written as a data-file load does."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from crankfmu.cli import main
from crankfmu.dynamics.reactions import joint_reactions, reaction_arrays, reaction_outputs
from crankfmu.fmi.python.slave import REACTION_TOLERANCE
from switches import away_from_switches
from crankfmu.scenario import Scenario, load_scenario

PRESS = Path(__file__).resolve().parents[1] / "validation" / "data" / "togglepress_scenario.toml"


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("reactions")
    assert main(["fmu", "seed003", "--out", str(out)]) == 0
    assert main(["fmu", "seed001", "--causality", "speed", "--out", str(out)]) == 0
    assert main(["fmu", str(PRESS), "--out", str(out)]) == 0
    return out


def _names(scenario):
    return [name for name, _, _ in reaction_outputs(scenario.mechanism_definition())]


def test_the_fmu_declares_every_joints_reaction_with_its_unit(fmus):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    path = fmus / "Shaper.fmu"
    assert validate_fmu(str(path)) == []
    variables = {v.name: v for v in read_model_description(str(path)).modelVariables}
    names = _names(load_scenario("seed003"))
    assert any(n.endswith("_Fx") for n in names) and any(n.endswith("_N") for n in names)
    for name in names:
        assert variables[name].causality == "output"
        assert variables[name].unit == ("N.m" if name.endswith("_M") else "N")


def test_newton_euler_on_the_fmus_reactions_gives_the_movement_equations_crank_torque(fmus):
    """Shaper.fmu (seed 003: a cutting force switching on and off with the stroke) over its default
    experiment at 1 ms, tau_ext = 5 N.m: the reactions the FMU outputs are Newton-Euler's at its
    (phi1, omega1, epsilon1) to the tables' bound (away from the cutting force's switch angles,
    where the force is set-valued), and the driving moment of that solve equals M_motor + tau_ext
    of the movement equation (the tables' J, 0.5 J', Q) to 1e-8 of max |M_motor| (measured 2e-13)."""
    import fmpy

    scenario = load_scenario("seed003")
    model = scenario.build()
    names = _names(scenario)
    inputs = np.array([(0.0, 5.0), (10.0, 5.0)], dtype=[("time", float), ("tau_ext", float)])
    run = fmpy.simulate_fmu(str(fmus / "Shaper.fmu"), output_interval=1e-3, input=inputs,
                            output=["phi1", "omega1", "epsilon1", "M_motor", *names])
    sol = joint_reactions(model.reduced, run["phi1"], run["omega1"], run["epsilon1"])
    expected = reaction_arrays(sol)
    scale = max(np.max(np.abs(expected[name])) for name in names)
    away = away_from_switches(model.reduced, run["phi1"])
    for name in names:
        assert np.max(np.abs(run[name] - expected[name])[away]) <= REACTION_TOLERANCE * scale, name
    assert len(model.reduced.slider_schedule()[0]) > 0          # the case has switches to cross
    residual = np.abs(sol.driving_moment - (run["M_motor"] + 5.0))
    assert np.max(residual) <= 1e-8 * np.max(np.abs(run["M_motor"])), np.max(residual)


def test_at_constant_speed_the_speed_causal_fmu_gives_the_equilibrium_studys_reactions(fmus, tmp_path):
    """ThreeLoopSpeed.fmu at 15 rad/s: its reactions at each 1 ms point equal the equilibrium
    study's (dynamics.reactions on the contour engine, at constant speed) at the same angles (to the
    tables' bound), and
    Newton-Euler's driving moment equals tau_drive (the tables' inverse dynamics) to 1e-8."""
    import fmpy

    scenario = load_scenario("seed001")
    model = scenario.build()
    names = _names(scenario)
    run = fmpy.simulate_fmu(str(fmus / "ThreeLoopSpeed.fmu"), output_interval=1e-3, stop_time=0.5,
                            start_values={"omega1": 15.0}, output=["phi1", "tau_drive", *names])
    study = reaction_arrays(joint_reactions(model.reduced, run["phi1"], 15.0))
    scale = max(np.max(np.abs(study[name])) for name in names)
    away = away_from_switches(model.reduced, run["phi1"])
    for name in names:
        assert np.max(np.abs(run[name] - study[name])[away]) <= REACTION_TOLERANCE * scale, name
    study = joint_reactions(model.reduced, run["phi1"], 15.0)
    assert np.max(np.abs(study.driving_moment - run["tau_drive"])) <= 1e-8 * np.max(np.abs(run["tau_drive"]))


def test_a_port_force_enters_the_reactions_as_the_same_data_file_force_does(fmus):
    """The press with ram_F = -800 N held, against Newton-Euler on the press whose data file
    writes the same force as a `force` load, at the FMU's states: the same reactions to the tables'
    bound."""
    import fmpy

    base = load_scenario(str(PRESS))
    data = copy.deepcopy(dict(base.data))
    data.pop("ports")
    data["loads"] = [*data["loads"], {"kind": "force", "link": "ram", "point": "E", "fx": "0", "fy": "-800"}]
    as_load = Scenario(data, base.where, base.path).build()
    names = _names(base)
    inputs = np.array([(0.0, -800.0), (10.0, -800.0)], dtype=[("time", float), ("ram_F", float)])
    run = fmpy.simulate_fmu(str(fmus / "TogglePress.fmu"), output_interval=1e-3, stop_time=0.5, input=inputs,
                            output=["phi1", "omega1", "epsilon1", *names])
    expected = reaction_arrays(joint_reactions(as_load.reduced, run["phi1"], run["omega1"], run["epsilon1"]))
    scale = max(np.max(np.abs(expected[name])) for name in names)
    for name in names:
        assert np.max(np.abs(run[name] - expected[name])) <= REACTION_TOLERANCE * scale, name


@pytest.mark.parametrize("omega1", [15.0, -15.0])
def test_on_a_sliders_extreme_the_reaction_takes_the_stroke_the_motion_enters(omega1):
    """On a slider's extreme itself (its rate zero to round-off) the slider force, and with it every
    joint reaction, is the force of the stroke the crank enters, turning either way: the rule of the
    integrators' modes and of the native FMU's tables. The harness found the engine taking the
    other stroke's by the sign of a 1e-16 rate: seed 001's O_Fx at t = 0 (phi1 = 0, an extreme)
    was 150 N, the backward force, off the native ThreeLoop.fmu's."""
    from crankfmu.dynamics.loads import SliderForce
    from crankfmu.dynamics.reactions import joint_reactions, reaction_values
    from crankfmu.scenario import load_scenario

    model = load_scenario("seed001").build()
    slider = next(load for load in model.reduced.loads if isinstance(load, SliderForce))
    for extreme in slider.extremes:
        at = reaction_values(joint_reactions(model.reduced, np.array([extreme]), omega1, 0.0))
        entered = extreme + 1e-7 * np.sign(omega1)
        just_after = reaction_values(joint_reactions(model.reduced, np.array([entered]), omega1, 0.0))
        for name, value in at.items():
            assert abs(value - just_after[name]) < 1e-2, (extreme, name, value, just_after[name])
