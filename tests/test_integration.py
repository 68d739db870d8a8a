"""The movement equation integrated: energy, a second integrator, the papers' schemes."""

import math

import numpy as np
import pytest

import crankfmu
from crankfmu.dynamics.equation import OMEGA


def test_energy_balance_over_five_cycles(reference):
    """Work of the motor and the loads minus the change of kinetic energy, relative to the work
    done, over five cycles (the works ride along as states, E_kin comes from J(phi1))."""
    t5 = reference.cycle_bounds(5)[1]
    balance = reference.energy_balance(t5)
    assert abs(balance["residual"]) < 1e-8
    assert balance["W_motor"] > 100.0 and balance["W_load"] < -100.0


def test_energy_balance_with_gravity_from_rest(scenario):
    result = crankfmu.simulate(scenario.with_params(g=9.81, omega1_start=0.0), t_end=1.5)
    assert abs(result.energy_balance()["residual"]) < 1e-8


def test_reference_against_radau(reference, scenario):
    """An implicit Runge-Kutta method (Radau IIA) agrees with the DOP853 reference to 1e-9."""
    radau = crankfmu.simulate(scenario, method="radau")
    assert np.max(np.abs(radau.omega1 - reference.omega1)) < 1e-9
    assert np.max(np.abs(radau.phi1 - reference.phi1)) < 1e-9


def test_reference_converged_in_its_tolerance(reference, scenario):
    """Tightening the tolerance changes the answer by less than the test tolerances above."""
    tighter = crankfmu.simulate(scenario, rtol=1e-13)
    assert np.max(np.abs(tighter.omega1 - reference.omega1)) < 2e-10


def test_kink_is_located_as_an_event(reference):
    """The motor line's kink ends a step: the event sits on omega1 = omega_switch."""
    (t_kink, what), = reference.trajectory.events
    assert "omega_switch" in what
    assert reference.state([t_kink])[OMEGA][0] == pytest.approx(5.0, abs=1e-12)
    assert 0.0 < t_kink < 0.1


def test_stepping_across_the_kink_costs_accuracy(scenario, reference):
    """Why the event: the same solver without it, at the same tolerance, is much worse."""
    from scipy.integrate import solve_ivp
    model = scenario.build()
    eq = model.equation
    rhs = lambda t, y: eq.rhs(t, y, eq.mode_of_state(y))  # noqa: E731
    sol = solve_ivp(rhs, (0, 2.0), model.y0, method="RK45", rtol=1e-8, atol=1e-8, dense_output=True)
    err_no_event = np.max(np.abs(sol.sol(reference.time)[OMEGA] - reference.omega1))
    with_event = crankfmu.simulate(scenario, method="reference", rtol=1e-8)
    err_event = np.max(np.abs(with_event.omega1 - reference.omega1))
    assert err_event < err_no_event


@pytest.fixture(scope="module")
def scheme_errors(reference, scenario):
    """Max |omega1 error| against the reference over the 4th cycle, as a function of phi1."""
    errors = {}
    for method in ("badoiu-eq17", "lv-eq3"):
        for deg in (1.0, 0.1, 0.01):
            r = crankfmu.simulate(scenario, method=method, angle_step=math.radians(deg))
            phi = r.trajectory.y[0]
            sel = (phi >= 6 * math.pi) & (phi <= 8 * math.pi)
            errors[method, deg] = np.max(np.abs(r.trajectory.y[OMEGA][sel] - reference.omega_at_angle(phi[sel])))
    return errors


@pytest.mark.parametrize("method", ["badoiu-eq17", "lv-eq3"])
def test_crank_angle_schemes_converge_first_order(scheme_errors, method):
    e = [scheme_errors[method, d] for d in (1.0, 0.1, 0.01)]
    orders = [math.log10(e[0] / e[1]), math.log10(e[1] / e[2])]
    # explicit Euler in phi1: order 1
    for order in orders:
        assert 0.9 < order < 1.1, (method, e, orders)
    assert e[2] < 1e-3


def test_schemes_cycle_statistics_approach_the_reference(reference, scenario):
    ref = reference.cycle_stats(4)
    fine = crankfmu.simulate(scenario, method="badoiu-eq17", angle_step=math.radians(0.01)).cycle_stats(4)
    for key in ("omega1_min", "omega1_max", "omega1_mean"):
        assert fine[key] == pytest.approx(ref[key], abs=2e-3)


def test_start_from_rest_in_the_time_domain(scenario):
    result = crankfmu.simulate(scenario.with_params(omega1_start=0.0), t_end=1.0)
    assert result.omega1[0] == 0.0
    assert result.omega1[-1] > 15.0
    assert abs(result.energy_balance()["residual"]) < 1e-8


def test_stall_and_reversal(scenario):
    """A motor too weak to carry the crank past its load: omega1 crosses zero and the time-domain
    run goes on (the crank swings back), energy still balanced; the crank-angle schemes refuse."""
    # continuous line (29 N.m at omega_switch from both sides), far below the load's peaks
    weak = scenario.with_params(A=129.0, B=20.0, A_low=30.0, B_low=0.2, omega1_start=2.0)
    result = crankfmu.simulate(weak, t_end=3.0)
    assert np.min(result.omega1) < 0.0 < np.max(result.omega1)
    assert abs(result.energy_balance()["residual"]) < 1e-8
    for method in ("badoiu-eq17", "lv-eq3"):
        with pytest.raises(crankfmu.SchemeError, match="omega1 .* <= 0"):
            crankfmu.simulate(weak, method=method, t_end=3.0)


@pytest.mark.parametrize("method", ["badoiu-eq17", "lv-eq3"])
def test_schemes_refuse_to_start_from_rest(scenario, method):
    with pytest.raises(crankfmu.SchemeError, match="cannot run this case"):
        crankfmu.simulate(scenario.with_params(omega1_start=0.0), method=method)


def test_result_arrays_are_named_like_the_csv(reference):
    for name in crankfmu.COLUMNS:
        assert getattr(reference, name).shape == reference.time.shape
    assert reference.time[0] == 0.0 and reference.time[-1] == pytest.approx(2.0)
    np.testing.assert_allclose(reference.E_kin, 0.5 * reference.J_red * reference.omega1**2)


def test_output_times_are_honoured(scenario):
    times = np.linspace(0.0, 0.5, 11)
    result = crankfmu.simulate(scenario, t_end=0.5, output_times=times)
    np.testing.assert_array_equal(result.time, times)


def test_with_params_reaches_the_model(scenario):
    slow = crankfmu.simulate(scenario.with_params(A=380.0, J_flywheel=0.5), t_end=1.5)
    base = crankfmu.simulate(scenario, t_end=1.5)
    # a weaker motor line (20 N.m less) settles about 20/B = 1 rad/s lower
    drop = base.cycle_stats(4)["omega1_mean"] - slow.cycle_stats(4)["omega1_mean"]
    assert 0.8 < drop < 1.2
    grid = np.linspace(0, 2 * np.pi, 100)
    J_slow = slow.model.reduced.coefficients(grid)[0]
    J_base = base.model.reduced.coefficients(grid)[0]
    assert np.max(np.abs(J_base - J_slow - 0.5)) < 1e-12


def test_motor_line_with_a_jump_slides_on_the_switch(scenario):
    """A = 30 makes the line jump from 29 N.m (below omega_switch) to -70 N.m (above): both sides
    push the speed onto the switch, so omega1 must stay there (Filippov sliding) with the motor
    giving the equivalent torque, instead of chattering across it."""
    jump = scenario.with_params(A=30.0, B=20.0, A_low=30.0, B_low=0.2, omega1_start=2.0)
    result = crankfmu.simulate(jump, t_end=3.0)
    modes = [m for _, m in result.trajectory.modes]
    assert "slide" in modes
    sliding = result.trajectory.mode_at(result.time) == "slide"
    assert np.max(np.abs(result.omega1[sliding] - 5.0)) < 1e-9
    assert np.max(np.abs(result.epsilon1[sliding])) < 1e-9
    # the equivalent torque stays within the two lines' torques at the switch
    assert np.all(result.M_motor[sliding] <= 29.0 + 1e-9) and np.all(result.M_motor[sliding] >= -70.0 - 1e-9)
    assert len(result.trajectory.events) < 100
    assert abs(result.energy_balance()["residual"]) < 1e-8


def test_dopri5_through_the_common_interface_agrees_with_the_reference_and_ends_on_the_kink(reference, scenario):
    """scipy's RK45 segment by segment: error-controlled, event on omega_switch, rtol honoured."""
    d = crankfmu.simulate(scenario, method="dopri5", rtol=1e-10)
    assert np.max(np.abs(d.omega1 - reference.omega1) / np.abs(reference.omega1)) < 1e-7
    (t_kink, _), = d.trajectory.events
    assert t_kink == pytest.approx(reference.trajectory.events[0][0], abs=1e-10)
    coarse = crankfmu.simulate(scenario, method="dopri5", rtol=1e-6)
    err_coarse = np.max(np.abs(coarse.omega1 - reference.omega1))
    err_fine = np.max(np.abs(d.omega1 - reference.omega1))
    assert err_fine < err_coarse / 100        # tightening rtol buys accuracy
