"""The packaged engines of a machine cycle of two turns (docs/papers.md, "engine1" and "engine4").

- Both pass `crankfmu check`.
- engine4's second method: its gas torque on the crank is the sum of its four cylinders', each
  one cylinder's (engine1's geometry and pressure) shifted by its firing angle (1-3-4-2 at 0, 180,
  360, 540 deg; the throws 0, 180, 180, 0 deg are the same shifts modulo a turn). The two sides are
  the same closed forms evaluated two ways, so they agree to round-off (1e-12 of the peak); the
  tables of engine4 (the C model's, over 720 deg) agree with the shifted sum to their checked
  bound (1e-11 relative, 1e-9 allowed).
- engine1's flywheel: the fast kernel's steady cycle (the search) and the crank-angle steady
  cycle on the engine (an independent integration) give the target delta to 1e-6.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import crankfmu
from crankfmu.check import check_scenario
from crankfmu.dynamics.tabulated import table_of
from crankfmu.studies.flywheel import design_flywheel

FIRING = {1: 0.0, 3: math.pi, 4: 2 * math.pi, 2: 3 * math.pi}     # rad: cylinder -> its firing TDC


@pytest.mark.parametrize("name", ["engine1", "engine4"])
def test_the_engines_pass_the_check(name):
    report = check_scenario(name)
    assert report.status == 0, report.text()
    assert "the machine's cycle is 2 crank turns" in report.text()


def gas_torque(scenario, phi):
    """The position's loads' torque on the crank (N.m): the gas forces (g = 0: no weights)."""
    assert scenario["g"] == 0.0
    return scenario.build().reduced.coefficients(phi)[2]


def test_engine4s_gas_torque_is_one_cylinders_shifted_by_the_firing_order():
    phi = np.linspace(0.0, 4 * math.pi, 2881)
    four = gas_torque(crankfmu.load_scenario("engine4"), phi)
    one = crankfmu.load_scenario("engine1")
    summed = sum(gas_torque(one, phi - fire) for fire in FIRING.values())
    peak = np.max(np.abs(four))
    assert np.max(np.abs(four - summed)) < 1e-12 * peak
    # four cylinders fire every 180 deg: the sum repeats every half turn, one cylinder's every 720 deg
    half = gas_torque(crankfmu.load_scenario("engine4"), phi + math.pi)
    assert np.max(np.abs(half - four)) < 1e-12 * peak
    table = table_of(crankfmu.load_scenario("engine4").build(table=1e-11).reduced)
    assert table.period == pytest.approx(4 * math.pi)
    assert np.max(np.abs(table.evaluate(phi)[2] - summed)) < 1e-9 * peak


def test_engine1s_flywheel_reaches_its_delta_by_two_integrations():
    design = design_flywheel(crankfmu.load_scenario("engine1"), 0.02)
    assert design.baseline_J_flywheel == 0.02          # it stalls without one: sized from its own
    assert design.delta_achieved == pytest.approx(0.02, rel=1e-6)
    assert design.delta_achieved_crank_angle == pytest.approx(0.02, rel=1e-6)
    assert design.without.angle == pytest.approx(4 * math.pi)
    # eq. 17 from the energy swing is close to the simulated flywheel (the motor line's slope is 0:
    # nothing but the flywheel regulates; the generator's slope does a little)
    assert design.J_F_eq17 == pytest.approx(design.J_F_simulated, rel=0.05)
