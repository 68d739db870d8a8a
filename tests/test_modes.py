"""The movement equation's hybrid rules (dynamics.modes): each rule on hand-worked cases, and the
compiled rules (what the fast kernel runs) giving the plain-Python answers (what the engine runs)."""

import math

import numpy as np
import pytest

from crankfmu.compiled import COMPILED
from crankfmu.dynamics import modes
from crankfmu.dynamics.modes import HIGH, LOW, SLIDE

rules = modes.python
TWO_PI = 2 * math.pi


@pytest.mark.parametrize("m_low, m_high, rest, expected, why", [
    (30.0, 40.0, -10.0, HIGH, "both lines accelerate the crank at the switch: it passes upwards"),
    (5.0, 8.0, -10.0, LOW, "both lines decelerate it: it falls back below"),
    (29.0, -70.0, 0.0, SLIDE, "the line jumps down across the balance: both sides push onto the switch"),
    (-70.0, 29.0, 0.0, HIGH, "a jump up: both sides push away, it leaves upwards"),
])
def test_filippov_rule_on_the_motor_switch(m_low, m_high, rest, expected, why):
    assert rules.motor_on_switch(m_low, m_high, rest) == expected, why


def test_sliding_holds_the_speed_with_the_equivalent_torque():
    J, half_dJ, Q, tau, omega = 2.0, 0.3, -12.0, 1.5, 5.0
    M = rules.equivalent_torque(half_dJ, Q, tau, omega)
    assert rules.acceleration(J, half_dJ, Q, M, tau, omega) == pytest.approx(0.0, abs=1e-15)
    # the movement equation itself: J eps = M + Q + tau - 0.5 J' omega^2
    assert rules.acceleration(J, half_dJ, Q, 20.0, tau, omega) == pytest.approx((20.0 - 12.0 + 1.5 - 7.5) / 2.0)


@pytest.mark.parametrize("forward, backward, expected", [
    (0.4, 0.2, 1.0), (-0.4, -0.2, -1.0), (-0.4, 0.2, 0.0), (0.0, 0.0, 0.0)])
def test_direction_at_rest_is_where_the_crank_accelerates_or_stuck(forward, backward, expected):
    assert rules.direction_at_rest(forward, backward) == expected


def test_switch_interval_holds_the_angle_and_ties_go_to_the_interval_entered():
    switch = np.array([0.5, 2.0, 4.0])
    for phi in (0.7, 3.0, 5.0, 0.1, -3.0, 40.0):
        k, lo, hi = rules.interval_of(switch, phi, 1.0)
        assert lo <= phi < hi
        assert (lo - switch[k]) / TWO_PI == pytest.approx(round((lo - switch[k]) / TWO_PI), abs=1e-12)
    assert rules.interval_of(switch, 2.0, 1.0)[0] == 1          # forward: the one starting there
    assert rules.interval_of(switch, 2.0, -1.0)[0] == 0         # backward: the one ending there
    assert rules.interval_of(np.zeros(0), 1.0, 1.0) == (0, -math.inf, math.inf)


def test_neighbouring_intervals_by_counting_go_round_the_turn_and_back():
    switch = np.array([0.5, 2.0, 4.0])
    k, lo, hi = rules.interval_of(switch, 1.0, 1.0)
    start = (k, lo, hi)
    for _ in range(3):
        k, lo2, hi2 = rules.next_interval(switch, k, lo, hi, True)
        assert lo2 == hi                      # contiguous: the end of one is the start of the next
        lo, hi = lo2, hi2
    assert k == start[0] and lo == pytest.approx(start[1] + TWO_PI) and hi == pytest.approx(start[2] + TWO_PI)
    for _ in range(3):
        k, lo, hi = rules.next_interval(switch, k, lo, hi, False)
    assert (k, lo, hi) == pytest.approx(start)


def test_surfaces_of_a_mode_and_their_crossing_sense():
    ws = 5.0
    # running on the low line: the kink is crossed rising; slider surfaces only with switch angles
    active = [s for s in range(modes.N_SLOTS) if rules.event_active(s, LOW, 1.0, 3.0, True, ws)]
    assert active == [modes.MOTOR_SWITCH, modes.INTERVAL_END, modes.INTERVAL_START, modes.REST]
    assert rules.event_rising(modes.MOTOR_SWITCH, LOW, 1.0) and not rules.event_rising(modes.MOTOR_SWITCH, HIGH, 1.0)
    assert rules.crosses(-0.1, 0.0, True) and not rules.crosses(0.1, -0.1, True)
    assert not rules.crosses(math.nan, 1.0, True)            # an inactive slot never ends a mode
    # a kink at rest is one event that turns the slider forces too (no separate REST surface)
    assert not rules.event_active(modes.REST, LOW, 1.0, 3.0, True, 0.0)
    assert rules.turns_forces(modes.MOTOR_SWITCH, 0.0, True)
    # stuck: nothing changes until a restart
    assert not any(rules.event_active(s, LOW, 0.0, 3.0, True, ws) for s in range(modes.N_SLOTS))
    # while sliding both ends of sliding are surfaces; their values are the torque margins
    assert rules.event_value(modes.MOTOR_SWITCH, 0.0, ws, SLIDE, 0, 1, ws, 29.0, -70.0, 10.0) == 19.0
    assert rules.event_value(modes.SLIDE_HIGH, 0.0, ws, SLIDE, 0, 1, ws, 29.0, -70.0, 10.0) == 80.0


@pytest.mark.skipif(not COMPILED, reason="numba is not installed: only the plain-Python rules exist here")
def test_compiled_rules_give_the_plain_python_answers():
    rng = np.random.default_rng(7)
    switch = np.sort(rng.uniform(0, TWO_PI, 4))
    for _ in range(200):
        a, b, c = rng.normal(size=3) * 10
        assert modes.motor_on_switch(a, b, c) == rules.motor_on_switch(a, b, c)
        assert modes.direction_at_rest(a, b) == rules.direction_at_rest(a, b)
        assert modes.acceleration(2.0, a, b, c, 1.0, 3.0) == rules.acceleration(2.0, a, b, c, 1.0, 3.0)
        phi = rng.uniform(-20, 20)
        assert modes.interval_of(switch, phi, 1.0) == rules.interval_of(switch, phi, 1.0)
