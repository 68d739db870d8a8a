"""simulate() and its Result: named arrays, output times, parameter overrides."""

import numpy as np
import pytest

import crankfmu


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
