"""The native FMU's joint reactions (``<joint>_Fx``, ``_Fy``; ``_N``, ``_M``): read on demand from
tabulated terms (dynamics.reaction_table.tabulate_reactions: Newton-Euler is linear in epsilon1,
omega1^2, the dampers' omega1, each switched load's value and each port's input, with
coefficients that are functions of phi1 alone) times the weights the C kernel gives at the state
(ck_reaction_weights). Checked against the Newton-Euler solve (dynamics.reactions, what
``crankfmu equilibrium`` and the pythonfmu FMU use) at the FMU's own states, in Co-Simulation and
Model Exchange, with slider forces (seed 001) and with a port's input (the guide's press)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import crankfmu
from crankfmu.cli import main
from crankfmu.dynamics.reactions import joint_reactions, reaction_arrays, reaction_outputs
from switches import away_from_switches

HERE = Path(__file__).resolve().parent
PRESS = HERE.parent / "validation" / "data" / "togglepress_scenario.toml"
#: the reactions' terms are tabulated to 1e-8 of each term's largest magnitude
#: (fmi.python.slave.REACTION_TOLERANCE); a reaction sums a few terms times the state's weights,
#: so 1e-8 of the mechanism's largest reaction bounds it with margin (measured 1.3e-10 on seed 001)
BOUND = 1e-8


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("native_reactions")
    built = ROOT_NATIVE / "ThreeLoop.fmu"
    if not built.exists():
        assert main(["fmu", "seed001", "--native", "--out", str(out)]) == 0
        built = out / "ThreeLoop.fmu"
    assert main(["fmu", str(PRESS), "--native", "--out", str(out)]) == 0
    return {"seed001": built, str(PRESS): out / "TogglePress.fmu"}


ROOT_NATIVE = HERE.parent / "build" / "fmus" / "native"


@pytest.mark.parametrize("scenario, ram_F", [("seed001", None), (str(PRESS), -500.0)])
@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_native_reactions_equal_newton_euler_at_the_fmus_states(fmus, scenario, ram_F, fmi_type):
    import fmpy

    reduced = crankfmu.load_scenario(scenario).build().reduced
    names = [n for n, _, _ in reaction_outputs(reduced.mechanism.definition)]
    stop = 1.0
    inputs = (np.array([(0.0, ram_F), (stop, ram_F)], dtype=[("time", float), ("ram_F", float)])
              if ram_F is not None else None)
    run = fmpy.simulate_fmu(str(fmus[scenario]), fmi_type=fmi_type, stop_time=stop, output_interval=1e-3,
                            input=inputs, output=["phi1", "omega1", "epsilon1", *names])
    extra = None
    if ram_F is not None:
        (port,) = reduced.ports
        extra = lambda kin: port.applied(kin, ram_F)  # noqa: E731
    expected = reaction_arrays(joint_reactions(reduced, run["phi1"], run["omega1"], run["epsilon1"], extra=extra))
    away = away_from_switches(reduced, run["phi1"])
    assert away.sum() >= 0.95 * away.size
    scale = max(np.max(np.abs(expected[n])) for n in names)
    worst = max(np.max(np.abs(run[n] - expected[n])[away]) for n in names)
    assert worst <= BOUND * scale, (worst / scale)


def test_native_reactions_are_declared_outputs_with_units(fmus):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    md = read_model_description(str(fmus["seed001"]))
    variables = {v.name: v for v in md.modelVariables}
    declared = reaction_outputs(crankfmu.load_scenario("seed001").mechanism_definition())
    assert len(declared) == 20
    for name, unit, _ in declared:
        assert (variables[name].causality, variables[name].unit) == ("output", unit)
    outputs = {u.variable.name for u in md.outputs}
    assert {name for name, _, _ in declared} <= outputs
    assert validate_fmu(str(fmus["seed001"])) == []
