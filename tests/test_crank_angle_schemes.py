"""The papers' crank-angle schemes (seed 000 eq. 17, seed 003 eq. 3) against the time-domain reference."""

import math

import numpy as np
import pytest

import crankfmu
from crankfmu.dynamics.equation import OMEGA


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


@pytest.mark.parametrize("method", ["badoiu-eq17", "lv-eq3"])
def test_schemes_refuse_to_start_from_rest(scenario, method):
    with pytest.raises(crankfmu.SchemeError, match="cannot run this case"):
        crankfmu.simulate(scenario.with_params(omega1_start=0.0), method=method)
