"""The outputs a host reads besides the state, from the design's tables by the C kernel's rules
(``ck_quantity_values``, ``ck_reaction_values``: what the Python FMU and the native FMU both run),
against the Python engine's own statement of the same physics at the states the kernel reaches:
the [[outputs]] and ports' s, v, a from mechanisms.quantities on the contour engine's kinematics,
the joint reactions from Newton-Euler (dynamics.reactions) with the ports' inputs among the loads.

Tolerances: the quantities' tables are checked to 1e-11 of each function's scale, and an output
combines at most two of them with omega1 and epsilon1 (1e-9 of the output's scale leaves room);
the reactions' terms to 1e-8 (fmi.python.slave.REACTION_TOLERANCE), a reaction sums a few terms times
the state's weights (1e-8 of the mechanism's largest reaction, as for the native FMU). Samples
within 1e-6 rad of a slider force's switch angle are left out: there the force is set-valued."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from crankfmu.contract import MOTOR_PARAMETERS
from crankfmu.dynamics import MotorLine
from crankfmu.dynamics.reactions import joint_reactions, reaction_arrays
from crankfmu.fmi.python.slave import REACTION_TOLERANCE, build_design, output_reads
from crankfmu.fmi.variables import output_quantities, reaction_variables
from crankfmu.integrators.fast import FastStepper
from crankfmu.mechanisms.quantities import evaluate_all
from crankfmu.native import QuantityReads
from crankfmu.scenario import load_scenario
from switches import away_from_switches

USER = Path(__file__).resolve().parent / "data" / "user"
PRESS = Path(__file__).resolve().parents[1] / "validation" / "data" / "togglepress_scenario.toml"
CASES = [("seed002", None), ("seed003", None), ("seed004", None), (str(PRESS), -500.0),
         (str(USER / "whitworth_scenario.toml"), None)]


def run_states(name, port_input, steps=400, h=2e-3):
    """The kernel stepping the scenario's design: at each step's end (phi1, omega1, epsilon1), the
    quantities and the reactions the readers give, and the design."""
    scenario = load_scenario(name)
    v = scenario.values
    design = build_design(scenario, dict(v))
    stepper = FastStepper(design.table, MotorLine(*(v[n] for n in MOTOR_PARAMETERS)), design.model.reduced.J_flywheel,
                          1e-11)
    ports = design.model.reduced.ports
    stepper.set_port_inputs([port_input] * len(ports))
    y0 = np.array(design.model.y0, dtype=float)
    y0[0], y0[1] = v["phi1_start"], v["omega1_start"]
    stepper.start(0.0, y0)
    quantities = output_quantities(scenario, ports)
    reads = output_reads(design, quantities, stepper)
    states, q_values, r_values = [], [], []
    for k in range(1, steps + 1):
        row = stepper.advance(k * h, k * h)
        phi1, omega1, epsilon1 = float(row[0]), float(row[1]), float(row[5])
        states.append((phi1, omega1, epsilon1))
        if reads[0] is not None:
            q_values.append(reads[0].values(phi1, omega1, epsilon1).copy())
        if reads[1] is not None:
            r_values.append(reads[1].values(k * h, phi1, omega1, epsilon1).copy())
    return scenario, design, quantities, np.array(states), np.array(q_values), np.array(r_values)


@pytest.mark.parametrize("name, port_input", CASES)
def test_quantities_from_the_tables_equal_the_analytic_kinematics(name, port_input):
    scenario, design, quantities, states, values, _ = run_states(name, port_input)
    if not quantities:
        pytest.skip(f"{name} declares no [[outputs]] and no port")
    kin = design.model.mechanism.kinematics(states[:, 0])
    expected = evaluate_all(quantities, kin, states[:, 1], states[:, 2])
    for k, q in enumerate(quantities):
        scale = max(float(np.max(np.abs(expected[q.name]))), 1e-3)
        assert np.max(np.abs(values[:, k] - expected[q.name])) <= 1e-9 * scale, q.name


@pytest.mark.parametrize("name, port_input", CASES)
def test_reactions_from_the_tables_equal_newton_euler(name, port_input):
    scenario, design, _, states, _, values = run_states(name, port_input)
    reduced = design.model.reduced
    names = [v.name for v in reaction_variables(scenario)]
    extra = None
    if reduced.ports:
        extra = lambda kin: [f for port in reduced.ports for f in port.applied(kin, port_input)]  # noqa: E731
    expected = reaction_arrays(joint_reactions(reduced, states[:, 0], states[:, 1], states[:, 2], extra=extra))
    away = away_from_switches(reduced, states[:, 0])
    scale = max(float(np.max(np.abs(expected[n]))) for n in names)
    for k, n in enumerate(names):
        assert np.max(np.abs(values[:, k] - expected[n])[away]) <= REACTION_TOLERANCE * scale, n


def test_a_winding_coordinate_counts_its_turns():
    """The Whitworth lever turns fully: its angle read from the table keeps growing with the crank
    (winding times 2 pi per turn), as the analytic kinematics count it."""
    scenario, design, quantities, states, values, _ = run_states(str(USER / "whitworth_scenario.toml"), None,
                                                                 steps=1500, h=4e-3)
    angles = [k for k, q in enumerate(quantities) if q.is_angle(scenario.mechanism_definition()) and q.order == 0]
    assert angles, "the Whitworth scenario outputs no angle"
    turns = (states[-1, 0] - states[0, 0]) / (2 * math.pi)
    assert turns > 1.5, turns                   # the run crosses at least one whole crank turn
    assert np.all(np.abs(np.diff(values[:, angles[0]])) < 1.0)        # continuous, no 2 pi jumps


def test_a_table_of_other_terms_is_refused():
    """A reactions table whose terms are not the kernel's weights for these tables is refused with
    a message, not read out of bounds."""
    import dataclasses

    scenario, design, quantities, *_ = run_states("seed003", None, steps=1)
    v = scenario.values
    stepper = FastStepper(design.table, MotorLine(*(v[n] for n in MOTOR_PARAMETERS)), 1.0, 1e-11)
    stepper.start(0.0, np.array(design.model.y0, dtype=float))
    table = design.reaction_table
    wrong = dataclasses.replace(table, n_terms=table.n_terms - 1,
                                coefficients=table.coefficients[: (table.coefficients.shape[0] // table.n_terms)
                                                                 * (table.n_terms - 1)])
    from crankfmu.errors import CrankfmuError
    from crankfmu.native import ReactionReads

    with pytest.raises(CrankfmuError, match="does not match the kernel"):
        ReactionReads(wrong, stepper).values(0.0, 0.0, 1.0, 0.0)
    assert isinstance(output_reads(design, quantities, stepper)[0], (QuantityReads, type(None)))
