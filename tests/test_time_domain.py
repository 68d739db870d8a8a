"""The movement equation in the time domain (scipy's solve_ivp a segment per mode): energy balance,
a second integrator, the switches located, start from rest, stall, reversal and sliding."""

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
