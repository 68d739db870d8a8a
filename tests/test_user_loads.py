"""Loads a user writes in the scenario file (force, couple, spring_damper, direction-dependent
force and couple): their reduced torque equals their power from the forces where they act (a second
method), the Newton-Euler driving moment agrees with the power balance, the fast path agrees with
the reference integrator and both close the energy balance, and bad load entries are refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from crankfmu import load_scenario, simulate
from crankfmu.dynamics.reactions import joint_reactions
from crankfmu.errors import DefinitionError

SCENARIO = Path(__file__).resolve().parent / "data" / "user" / "sixbar_loads_scenario.toml"


@pytest.fixture(scope="module")
def model():
    return load_scenario(str(SCENARIO)).build()


def power_of_applied_loads(model, phi1, omega1):
    """sum F . v_P + M w over every applied load, from the kinematics alone (not the reduced torque)."""
    kin = model.mechanism.kinematics(phi1)
    total = np.zeros_like(phi1)
    for load in model.reduced.loads:
        for f in load.applied(kin, omega1):
            if f.link == "ground":
                continue
            w = kin.link_angle(f.link)[1] * omega1
            power = np.asarray(f.moment) * w
            if f.point is not None:
                _, _, dx, dy, _, _ = kin.point(f.point)
                power = power + np.asarray(f.fx) * dx * omega1 + np.asarray(f.fy) * dy * omega1
            total = total + power
    return total


@pytest.mark.parametrize("omega1", [12.0, -7.0])
def test_reduced_torque_is_the_power_of_the_applied_loads(model, omega1):
    phi1 = np.linspace(0.0, 2 * np.pi, 181)[:-1] + 0.013      # off the switch angles
    _, _, q_position, kin = model.reduced.coefficients(phi1)
    Q = q_position + model.reduced.velocity_load(kin, omega1)
    assert np.allclose(Q * omega1, power_of_applied_loads(model, phi1, omega1), rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("omega1", [12.0, 3.0])
def test_newton_euler_driving_moment_equals_the_power_balance(model, omega1):
    """At constant crank speed the power balance gives M_e = 0.5 J' w^2 - Q; the joint reactions'
    square solve, which takes every load where it acts (the spring's frame end on the ground), gives
    the driving moment independently."""
    phi1 = np.linspace(0.0, 2 * np.pi, 91)[:-1] + 0.013
    J, half_dJ, q_position, kin = model.reduced.coefficients(phi1)
    Q = q_position + model.reduced.velocity_load(kin, omega1)
    r = joint_reactions(model.reduced, phi1, omega1)
    assert np.allclose(r.driving_moment, half_dJ * omega1 ** 2 - Q, rtol=1e-9, atol=1e-8)


def test_the_direction_dependent_force_follows_the_sliders_motion(model):
    phi1 = np.linspace(0.0, 2 * np.pi, 361)[:-1] + 0.013
    kin = model.mechanism.kinematics(phi1)
    slider = [load for load in model.reduced.loads if getattr(load, "direction_of", None) == "D.x"][0]
    dx = kin.point("D")[2]
    x = kin.point("D")[0]
    values = model.scenario.values
    expected = np.where(dx > 0, -values["F_up"], -values["F_down"] * (1 + x)) * dx
    assert np.allclose(slider.torque(kin, 1.0), expected, rtol=1e-13, atol=1e-12)
    # turning backwards flips which stroke is which
    assert np.allclose(slider.torque(kin, -1.0), np.where(dx < 0, -values["F_up"], -values["F_down"] * (1 + x)) * dx)


def test_fast_path_and_reference_agree_and_close_the_energy_balance():
    """The fast path tabulates the position-dependent torques of both directions and switches at the
    chosen coordinates' extremes; the reference evaluates every load on the contour engine."""
    scenario = load_scenario(str(SCENARIO))
    times = np.linspace(0.0, scenario.experiment.stop_time, 2001)
    fast = simulate(scenario, method="fast", output_times=times)
    reference = simulate(scenario, method="reference", output_times=times)
    assert np.max(np.abs(fast.omega1 - reference.omega1)) < 1e-7 * np.max(np.abs(reference.omega1))
    for run in (fast, reference):
        e = run.summary()["energy_balance"]
        assert abs(e["residual"]) < 1e-9 * (abs(e["W_motor"]) + abs(e["W_load"]) + 1.0)


BAD_LOADS = {
    "unknown name": ({"kind": "force", "link": "plate", "point": "P", "fx": "3*Q_x"},
                     "force fx = '3\\*Q_x' uses unknown name\\(s\\) Q_x"),
    "no component": ({"kind": "couple", "link": "crank"}, "couple needs moment"),
    "unknown link": ({"kind": "couple", "link": "wheel", "moment": "1"}, "couple needs link = one of the links"),
    "bad direction": ({"kind": "force", "link": "slider", "point": "D", "direction_of": "D.z",
                       "increasing": {"fx": "1"}, "decreasing": {"fx": "2"}}, "direction_of = 'D.z' must be"),
    "one side only": ({"kind": "couple", "link": "rocker", "direction_of": "phi3", "increasing": {"moment": "1"}},
                      "needs decreasing"),
    "spring without links": ({"kind": "spring_damper", "a": "C", "b": "P", "stiffness": "10"},
                             "spring_damper needs links"),
    "negative stiffness": ({"kind": "spring_damper", "links": ["ground", "plate"], "a": "C", "b": "P",
                            "stiffness": "-5"}, "stiffness = -5 must be finite and >= 0"),
}


@pytest.mark.parametrize("case", BAD_LOADS)
def test_bad_user_loads_are_refused_with_a_message(case):
    scenario = load_scenario(str(SCENARIO))
    spec, pattern = BAD_LOADS[case]
    data = dict(scenario.data)
    data["loads"] = [spec]
    from crankfmu.scenario import Scenario

    with pytest.raises(DefinitionError, match=pattern):
        Scenario(data, scenario.where, scenario.path).build()


# the engines' gas laws, the well's polished-rod load, Jansen's ground contact; seed003's closed form
@pytest.mark.parametrize("name", ["engine1", "engine4", "pumpjack", "jansen", "seed003"])
def test_a_load_at_one_crank_angle_is_its_value_in_an_array_to_the_bit(name):
    """The reference integrator evaluates the load expressions and closed-form positions at one crank
    angle on numpy scalars (a third of the cost of one-element arrays); an array of angles evaluates
    the same text on arrays (the tables, the figures). The same kinematics must give the same
    numbers to the bit either way, ** included (numpy's array power takes 2, 0.5 and -1 by other
    ufuncs than pow())."""
    from crankfmu.dynamics.user_loads import ExpressionLoad

    model = load_scenario(name).build()
    rng = np.random.default_rng(7)
    phis = rng.uniform(0.0, 2.0 * np.pi * model.reduced.cycle_turns, 48)
    mechanism = model.mechanism
    if mechanism._closed_form is not None:
        together = mechanism._closed_form_positions(phis.copy())
        alone = np.vstack([mechanism._closed_form_positions(phis[i:i + 1].copy()) for i in range(phis.size)])
        assert np.array_equal(together.view(np.int64), alone.view(np.int64))
    kin = mechanism.kinematics(phis)
    loads = [load for load in model.reduced.loads if isinstance(load, ExpressionLoad)]
    assert loads or mechanism._closed_form is not None, f"{name}: nothing written as expressions to compare"
    for load in loads:
        omega = None if load.position_only else np.linspace(-40.0, 90.0, phis.size)
        together = np.asarray(load.torque(kin, omega) if omega is not None else load.torque(kin))
        for i in range(phis.size):
            one = kin.subset(i)
            value = load.torque(one, omega[i:i + 1]) if omega is not None else load.torque(one)
            assert np.asarray(value).shape == (1,)
            assert np.asarray(value)[0].tobytes() == together[i].tobytes(), (name, load.link, i)


def test_a_power_on_a_numpy_scalar_is_numpys_power_on_an_array():
    """At one angle (numpy scalars) a power is the power ufunc's loop, as on an array: not pow(),
    which differs in the last bit for the square, sqrt and reciprocal everywhere, and for every
    exponent on a CPU with AVX-512 (numpy's vectorised pow)."""
    from crankfmu.expressions import Expression

    x = np.random.default_rng(3).uniform(1e-3, 1e3, 4000)
    names = {"n": 2.0, "m": 1.35}
    for exponent in ("2", "0.5", "-1", "3", "1.5", "1.35", "n", "m"):
        expression = Expression(f"x**{exponent}")
        together = expression.evaluate({"x": x, **names})
        alone = np.array([expression.evaluate({"x": value, **names}, one_angle=True) for value in x])   # numpy scalars
        assert np.array_equal(together, alone), exponent
        value = names[exponent] if exponent in names else float(exponent)
        assert np.array_equal(together, x ** value)
