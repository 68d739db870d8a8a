"""The beam pumping unit, written only as data (scenario and mechanism file pumpjack): its kinematics
against API Spec 11E's torque factor in closed form, its stroke against the unit's designation, the
rod loads' work per stroke against the lifted fluid, and the counterbalance's effect on the
gearbox torque."""

from __future__ import annotations

import math

import numpy as np
import pytest

from crankfmu import load_scenario, simulate
from crankfmu.studies.equilibrium import cycle_breaks, cycle_mean, technological_torque

INCH = 0.0254


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("pumpjack")


def test_torque_factor_matches_api_11e_closed_form(scenario):
    """TF = dx_polished_rod/dphi1 = A dtheta/dphi1 from the contour engine's transfer functions
    (linear solves on the contour Jacobian) against API 11E's TF = (A R / C) sin(alpha)/sin(beta),
    alpha between crank and pitman, beta between pitman and beam (signed with the vectors'
    angles), to 1e-9 of its largest value."""
    v = scenario.values
    mechanism = scenario.assembled_mechanism()[0]
    phi1 = np.linspace(0.0, 2 * math.pi, 3601)
    kin = mechanism.kinematics(phi1)
    tf_engine = v["arm_A"] * kin.dq["theta"]
    phi_p, theta = kin.q["phi_p"], kin.q["theta"]
    tf_api = v["arm_A"] * v["crank_R"] / v["arm_C"] * np.sin(phi_p - phi1) / np.sin(theta - phi_p)
    assert np.max(np.abs(tf_engine - tf_api)) <= 1e-9 * np.max(np.abs(tf_api))


def test_stroke_is_the_units_designation(scenario):
    """C-114D-133-54: a 54 in polished-rod stroke at the longest crank hole; the beam's swing
    times A, from the beam's exact extremes (API rounds the stroke: 5 %)."""
    mechanism = scenario.assembled_mechanism()[0]
    extremes = mechanism.stationary_angles(lambda kin: kin.dq["theta"])
    theta = mechanism.kinematics(np.array([a for a, _ in extremes])).q["theta"]
    stroke = scenario["arm_A"] * (theta.max() - theta.min())
    assert len(extremes) == 2
    assert stroke / INCH == pytest.approx(54.0, rel=0.05)


def test_rod_load_work_per_stroke_is_the_lift_of_rods_and_fluid(scenario):
    """Over one turn the rod loads take (W_rods + W_fluid) S on the upstroke and give back
    W_rods_buoyant S on the downstroke: the technological work per turn (Gauss-Legendre between the
    direction switches) equals -(W_rods + W_fluid - W_rods_buoyant) S with S from the beam's extremes."""
    model = scenario.build()
    mechanism = model.mechanism
    extremes = mechanism.stationary_angles(lambda kin: kin.dq["theta"])
    theta = mechanism.kinematics(np.array([a for a, _ in extremes])).q["theta"]
    stroke = scenario["arm_A"] * (theta.max() - theta.min())
    work = 2 * math.pi * cycle_mean(lambda p: technological_torque(model, p, 0.838), cycle_breaks(model))
    v = scenario.values
    assert work == pytest.approx(-(v["W_rods"] + v["W_fluid"] - v["W_rods_buoyant"]) * stroke, rel=1e-10)


def test_counterbalance_lowers_the_peak_gearbox_torque_and_the_speed_fluctuation(scenario):
    """The gearbox torque is the motor line's torque at the crank: its peak over the steady 4th
    stroke, and delta, with the counterweights and without them (m_cw = 0)."""
    def steady(s):
        result = simulate(s, method="fast")
        summary = result.summary()
        c = summary["cycle_4"]
        inside = (result.time >= c["t_start"]) & (result.time <= c["t_end"])
        return float(np.max(np.abs(result.M_motor[inside]))), c["delta"], summary["energy_balance"]

    peak, delta, energy = steady(scenario)
    peak0, delta0, _ = steady(scenario.with_params(m_cw=0.0))
    assert peak < 0.5 * peak0 and delta < 0.5 * delta0
    assert abs(energy["residual"]) < 1e-9 * abs(energy["W_motor"])
