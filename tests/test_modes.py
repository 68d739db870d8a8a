"""The movement equation's hybrid rules (dynamics.modes): each rule on hand-worked cases, and the
C kernel's rules (native/kernel/crank_modes.h: what the fast path and the FMUs run) giving the engine's
answers (dynamics.modes: what the scipy reference runs), rule by rule, on every mode, slot and
edge (ties, zeros, NaN)."""

import math

import numpy as np
import pytest

from crankfmu import native
from crankfmu.dynamics import modes
from crankfmu.dynamics.modes import HIGH, LOW, SLIDE

rules = modes
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


def c_rule(number, *args):
    a = np.zeros(10)
    a[:len(args)] = args
    return native.LIBRARY.ck_rule(number, a.ctypes.data_as(native.ctypes.POINTER(native.ctypes.c_double)))


#: the engine's rule, and its number in ck_rule (crank_facts.c)
C_RULES = {"line_torque": 0, "acceleration": 1, "equivalent_torque": 2, "kinetic_energy": 3, "motor_of_speed": 4,
           "direction_of_speed": 5, "motor_on_switch": 6, "direction_at_rest": 7, "motor_at_rest": 8,
           "motor_after_sliding": 9, "turns_forces": 10, "event_active": 11, "event_value": 12,
           "event_rising": 13, "crosses": 14, "drive_torque": 15, "direction_imposed": 16,
           "column_factor": 17}


def same(a, b):
    return (math.isnan(a) and math.isnan(b)) or float(a) == float(b)


def test_the_c_kernels_rules_give_the_engines_answers_mode_by_mode():
    """Every rule on random values and on its edges: the motor branches and directions of every mode,
    every slot, zeros, ties between the two sides, a switch at zero speed, NaN (an inactive slot)."""
    rng = np.random.default_rng(7)
    edges = [0.0, -0.0, 1.0, -1.0, 5.0, math.nan, math.inf]
    for _ in range(300):
        a, b, c, d, e, f = rng.normal(size=6) * 10
        pick = lambda: rng.choice(edges) if rng.random() < 0.3 else rng.normal() * 10   # noqa: E731
        cases = {
            "line_torque": (a, b, c), "acceleration": (2.0 + abs(a), b, c, d, e, f),
            "equivalent_torque": (a, b, c, d), "kinetic_energy": (abs(a), b), "drive_torque": (a, b, c, d, e, f),
            "motor_of_speed": (pick(), pick()), "direction_of_speed": (pick(),), "direction_imposed": (pick(),),
            "motor_on_switch": (pick(), pick(), pick()), "direction_at_rest": (pick(), pick()),
            "column_factor": (pick(), rng.choice([pick(), a]), rng.choice([1.0, -1.0, 0.0, -0.0])),
        }
        for name, args in cases.items():
            assert same(getattr(rules, name)(*args), c_rule(C_RULES[name], *args)), (name, args)
        for motor in (LOW, HIGH, SLIDE):
            for direction in (1.0, -1.0, 0.0):
                ws = float(rng.choice([0.0, 5.0]))
                assert same(rules.motor_at_rest(motor, ws), c_rule(8, motor, ws))
                for slot in range(modes.N_SLOTS):
                    for has_sliders in (False, True):
                        phi_hi = float(rng.choice([3.0, math.inf]))
                        assert bool(rules.event_active(slot, motor, direction, phi_hi, has_sliders, ws)) == \
                            bool(c_rule(11, slot, motor, direction, phi_hi, has_sliders, ws)), (slot, motor, direction)
                    values = (slot, a, pick(), motor, b, c, ws, d, e, f)
                    assert same(rules.event_value(*values), c_rule(12, *values)), values
                    assert bool(rules.event_rising(slot, motor, direction)) == bool(c_rule(13, slot, motor, direction))
                    assert bool(rules.turns_forces(slot, ws, True)) == bool(c_rule(10, slot, ws, 1))
                    if slot <= modes.SLIDE_HIGH:
                        assert rules.motor_after_sliding(slot) == c_rule(9, slot)
        for rising in (True, False):
            g0, g1 = pick(), pick()
            assert bool(rules.crosses(g0, g1, rising)) == bool(c_rule(14, g0, g1, rising)), (g0, g1, rising)


def test_the_c_kernels_switch_intervals_are_the_engines():
    rng = np.random.default_rng(3)
    D = native.ctypes.POINTER(native.ctypes.c_double)
    for m in (1, 2, 4, 7):
        switch = np.sort(rng.uniform(0, TWO_PI, m))
        for phi in [*rng.uniform(-30, 30, 40), *switch, *(switch + TWO_PI), *(switch - 2 * TWO_PI)]:
            for direction in (1.0, -1.0):
                k, lo, hi = rules.interval_of(switch, float(phi), direction)
                bounds = np.zeros(2)
                kc = native.LIBRARY.ck_interval_of_rule(switch.ctypes.data_as(D), m, float(phi), direction,
                                                        bounds.ctypes.data_as(D))
                assert (kc, bounds[0], bounds[1]) == (k, lo, hi)
                for forward in (True, False):
                    k2, lo2, hi2 = rules.next_interval(switch, k, lo, hi, forward)
                    b = np.array([lo, hi])
                    kc2 = native.LIBRARY.ck_next_interval_rule(switch.ctypes.data_as(D), m, k, b.ctypes.data_as(D),
                                                               int(forward))
                    assert (kc2, b[0], b[1]) == (k2, lo2, hi2)


def test_the_tableau_has_order_five_with_an_order_four_estimate_and_a_consistent_dense_output():
    """crank_tableau.h's numbers checked by what they must satisfy, not against a copy: row sums
    are the nodes, B meets the order conditions up to order 5, B - E (the embedded solution,
    B_hat = B - E with B's FSAL entry 0) meets them to order 4, and the dense output at x = 1
    reproduces B (the step's end) with zero derivative error at x = 0 (it starts on f)."""
    t = native.tableau()
    A, B, E, P, C = t["A"], t["B"], t["E"], t["P"], t["C"]
    A6 = np.zeros((6, 6))
    A6[:, :5] = A
    assert np.allclose(A6.sum(axis=1), C, atol=1e-15)
    conditions = [lambda b: b.sum() - 1, lambda b: b @ C - 1 / 2, lambda b: b @ C**2 - 1 / 3,
                  lambda b: b @ (A6 @ C) - 1 / 6, lambda b: b @ C**3 - 1 / 4, lambda b: b @ (C * (A6 @ C)) - 1 / 8,
                  lambda b: b @ (A6 @ C**2) - 1 / 12, lambda b: b @ (A6 @ A6 @ C) - 1 / 24,
                  lambda b: b @ C**4 - 1 / 5, lambda b: b @ (C**2 * (A6 @ C)) - 1 / 10,
                  lambda b: b @ (A6 @ C**3) - 1 / 20, lambda b: b @ (A6 @ A6 @ A6 @ C) - 1 / 120]
    for condition in conditions:
        assert abs(condition(B)) < 1e-15
    B7 = np.append(B, 0.0)
    B_hat = B7 - E
    # the embedded 4th-order solution uses the FSAL stage (the 7th, at C = 1 with A's row = B)
    C7, A7 = np.append(C, 1.0), np.zeros((7, 7))
    A7[:6, :6], A7[6, :6] = A6, B
    for condition in ([lambda b: b.sum() - 1, lambda b: b @ C7 - 1 / 2, lambda b: b @ C7**2 - 1 / 3,
                       lambda b: b @ (A7 @ C7) - 1 / 6, lambda b: b @ C7**3 - 1 / 4,
                       lambda b: b @ (C7 * (A7 @ C7)) - 1 / 8, lambda b: b @ (A7 @ C7**2) - 1 / 12,
                       lambda b: b @ (A7 @ A7 @ C7) - 1 / 24]):
        assert abs(condition(B_hat)) < 1e-15
    assert np.allclose(P.sum(axis=1), B7, atol=1e-15)          # x = 1: the step's end
    assert np.array_equal(P[:, 0], [1, 0, 0, 0, 0, 0, 0])       # x -> 0: y' = K[0] = f
