"""Reduced model and movement equation against independent computations."""

import math

import numpy as np
import pytest

ANGLES = np.radians(np.arange(360) + 0.25)


def test_half_dJ_is_half_the_derivative_of_J(model):
    """0.5 J' (= -S3, from the second transfer functions) against central differences of J (= -S2)."""
    red = model.reduced
    h = 1e-4
    J = lambda a: red.coefficients(a)[0]  # noqa: E731
    numeric = 0.5 * (J(ANGLES + h) - J(ANGLES - h)) / (2 * h)
    half_dJ = red.coefficients(ANGLES)[1]
    # 2nd-order differences: error ~ h^2 |J'''| / 6 ~ 1e-9 here
    assert np.max(np.abs(half_dJ - numeric)) < 1e-7 * np.max(np.abs(half_dJ))


def test_reduced_inertia_equals_link_kinetic_energy(model):
    """0.5 J omega^2 against the kinetic energy summed link by link (m v^2 + I w^2)."""
    omega = 7.3
    J = model.reduced.coefficients(ANGLES)[0]
    E_links = model.reduced.kinetic_energy_of_links(ANGLES, omega)
    assert np.max(np.abs(0.5 * J * omega**2 - E_links)) < 1e-12 * np.max(E_links)


@pytest.mark.parametrize("name", ["seed000", "seed001", "seed003", "pumpjack"])
def test_one_angle_sums_the_links_on_floats_to_the_bit_of_numpy(name):
    """The reference integrator asks for J and 0.5 J' at one crank angle at a time, and those link
    sums then run on Python floats: the same IEEE operations in the same order as numpy's on
    one-element arrays (eq. 13-14 written out below with numpy), so the same numbers to the bit."""
    from crankfmu.scenario import load_scenario

    red = load_scenario(name).build().reduced
    for a in ANGLES[::7]:
        kin = red.mechanism.kinematics(np.array([a]))
        J, half_dJ = red.coefficients(None, kin)[:2]
        J_numpy, half_dJ_numpy = np.full(1, red.J_flywheel), np.zeros(1)
        for link in red.links:
            _, _, t, p, tt, pp = kin.point(link.centre)
            _, q, qq = kin.link_angle(link.name)
            J_numpy += link.mass * (t * t + p * p) + link.inertia * q * q
            half_dJ_numpy += link.mass * (t * tt + p * pp) + link.inertia * q * qq
        assert J.shape == half_dJ.shape == (1,)
        assert J[0] == J_numpy[0] and half_dJ[0] == half_dJ_numpy[0], (name, a)


def test_flywheel_adds_a_constant(scenario):
    J1 = scenario.build().reduced.coefficients(ANGLES)[0]
    J0 = scenario.with_params(J_flywheel=0.0).build().reduced.coefficients(ANGLES)[0]
    assert np.max(np.abs(J1 - J0 - 1.0)) < 1e-13


def test_technological_moment_always_opposes_the_rocker(model):
    """docs/papers.md: M_ru on the rocker never has positive power (M_ru * omega3 <= 0)."""
    load = model.reduced.loads[1]
    kin = model.mechanism.kinematics(ANGLES)
    power_ratio = load.moment(ANGLES) * kin.link_angle("rocker")[1]
    assert np.all(power_ratio <= 1e-12)
    assert np.min(power_ratio) < -10.0   # and it is a real load


def test_weights_do_no_work_over_a_turn(scenario):
    """Gravity is conservative: its reduced torque integrates to zero over a closed cycle."""
    model = scenario.with_params(g=9.81, Mr=0.0).build()
    grid = np.linspace(0, 2 * math.pi, 4097)
    Q = model.reduced.coefficients(grid)[2]
    from scipy.integrate import simpson
    assert abs(simpson(Q, x=grid)) < 1e-9
    assert np.max(np.abs(Q)) > 1.0


def test_weights_torque_is_minus_potential_energy_gradient(scenario):
    """Q_weights = -dV/dphi1 with V = sum m g y_C, checked by differences of the positions."""
    model = scenario.with_params(g=9.81, Mr=0.0).build()
    red, mech = model.reduced, model.mechanism

    def V(a):
        kin = mech.kinematics(a)
        return sum(l.mass * 9.81 * kin.point(l.centre)[1] for l in red.links)
    h = 1e-5
    numeric = -(V(ANGLES + h) - V(ANGLES - h)) / (2 * h)
    assert np.max(np.abs(red.coefficients(ANGLES)[2] - numeric)) < 1e-7


def test_motor_line_is_continuous_at_the_switch(model):
    m = model.motor
    assert m.torque(m.omega_switch, True) == pytest.approx(m.torque(m.omega_switch, False), abs=1e-12)
    assert m.torque_at(4.0) == pytest.approx(301 - 0.2 * 4.0)
    assert m.torque_at(6.0) == pytest.approx(400 - 20 * 6.0)


def test_a_banded_slider_force_switches_where_the_slider_crosses_its_band():
    """Seed 003's cutting force acts over 0.05..0.95 of the ram's stroke: it switches at the two
    extremes (rate zero) and where the ram's position, evaluated again at each found angle,
    crosses the band's levels, once each way, to rounding of the stroke."""
    import crankfmu

    model = crankfmu.load_scenario("seed003").build()
    (ram,) = model.reduced.sliders
    angles = np.array(ram.switch_angles(model.mechanism))
    motion = model.mechanism.kinematics(angles).point(ram.point)
    x, rate = motion.along(ram.axis), motion.ratio(ram.axis)
    stroke = ram.high - ram.low
    levels = np.array([ram.low + f * stroke for f in ram.band])
    at_extreme = np.abs(rate) < 1e-9 * np.max(np.abs(rate))
    assert at_extreme.sum() == 2 and angles.size == 6
    assert np.max(np.min(np.abs(x[~at_extreme, None] - levels[None, :]), axis=1)) < 1e-12 * stroke
    assert sorted(np.argmin(np.abs(x[~at_extreme, None] - levels[None, :]), axis=1)) == [0, 0, 1, 1]
