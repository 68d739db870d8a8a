"""The rod string (dynamics.rodstring): Gibbs' damped wave equation discretised, against its
closed form; its discrete energy balance; its pump's loads at vanishing speed; bad strings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from crankfmu.dynamics.pumps import LinearFoot
from crankfmu.dynamics.rodstring import (RodString, StringDesign, Taper,
                                         harmonic_solution)
from crankfmu.dynamics.well import load_well
from crankfmu.errors import DefinitionError

STEEL_3_4 = dict(diameter=0.01905, E=2.1029e11, mass_per_length=2.4317)   # API 3/4 in rod with couplings


def _uniform(segment, courant, damping=0.1, g=0.0, length=1500.0, **extra):
    return StringDesign((Taper(length, **STEEL_3_4),), 1000.0, 7850.0, 0.03175, length, damping=damping, g=g,
                        segment=segment, courant=courant, **extra)


def _harmonic_error(segment, courant, omega=4.0, amplitude=0.5, k=2e5, c=5e4, periods=2.0):
    """Largest error of the node displacements (over the amplitude) and of the polished rod
    load (over its amplitude) against the closed form, started on it (no transient)."""
    design = _uniform(segment, courant)
    rs = RodString(design, pump=LinearFoot(k, c))
    u_exact, tension = harmonic_solution(design, omega, amplitude, k, c)
    x, dt = rs.grid.x, rs.dt
    rs.u = u_exact(x, 0.0)
    rs.v = (rs.u - u_exact(x, -dt)) / dt
    err_u = err_F = F_max = 0.0
    for n in range(int(round(periods * 2 * math.pi / omega / dt))):
        rs.step(amplitude * math.sin(omega * (n + 1) * dt))
        err_u = max(err_u, float(np.max(np.abs(rs.u - u_exact(x, (n + 1) * dt)))))
        # the load computed in a step is the polished rod's at the step's start
        err_F = max(err_F, abs(rs.load - float(tension(0.0, n * dt))))
        F_max = max(F_max, abs(float(tension(0.0, n * dt))))
    return err_u / amplitude, err_F / F_max


def test_wave_solver_matches_the_damped_string_in_closed_form():
    """A 1500 m string of 3/4 in rods, Gibbs damping nu = 0.1, its top moved 0.5 sin(4 t) m (a
    quarter of its first resonance's wavelength: the wave matters), its foot on a spring-dashpot
    (2e5 N/m, 5e4 N.s/m). At Courant 0.5 the error falls by 4 per halving of the segment (second
    order, observed order within 0.1 of 2) and is below 1e-6 at 3.75 m, for the displacements;
    the polished rod load converges too and is below 1e-5 there."""
    errors = [_harmonic_error(seg, 0.5) for seg in (15.0, 7.5, 3.75)]
    u_err = [e[0] for e in errors]
    orders = [math.log2(a / b) for a, b in zip(u_err, u_err[1:])]
    assert all(abs(o - 2.0) < 0.1 for o in orders), orders
    assert u_err[-1] < 1e-6
    F_err = [e[1] for e in errors]
    assert F_err[2] < F_err[1] < F_err[0] and F_err[-1] < 1e-5


def test_courant_one_is_stable_and_converges():
    """At the Courant limit itself the scheme stays stable and converges (to 5e-7 at 1.875 m)."""
    u_err = [_harmonic_error(seg, 1.0)[0] for seg in (7.5, 3.75, 1.875)]
    assert u_err[2] < u_err[1] < u_err[0] and u_err[-1] < 1e-6


def test_energy_balance_closes_to_round_off_with_the_pump():
    """The polished rod's work equals the change of the string's kinetic, strain and weight
    energy plus damping, hydraulic, friction and plunger-stop work, in the discrete energy the
    leapfrog conserves: to 1e-10 of the work over three strokes of the RP 11L well's string with
    friction and partial fillage (fluid pound), its top moved harmonically."""
    well = load_well("rp11l_guo")
    design = well.design({"friction": 2000.0, "fillage": 0.7})
    rs = RodString(design).hang(0.0, 0.0)
    omega, half_stroke = 1.0, 1.09
    n = int(3 * 2 * math.pi / omega / rs.dt)
    for i in range(n):
        rs.step(half_stroke * (1 - math.cos(omega * (i + 1) * rs.dt)) * -1.0)
    pump = rs.pump
    assert rs.work > 0 and pump.hydraulic > 0 and pump.friction_loss > 0 and rs.damping_loss > 0
    assert abs(rs.balance()) < 1e-10 * rs.work


def test_loads_at_vanishing_speed_are_wrf_plus_fo_and_wrf():
    """A stroke taking 600 s: the polished rod carries Wrf + Fo + friction while the plunger
    rises and Wrf - friction while it falls, to 1e-3 of Wrf + Fo at mid-stroke: the damping force there,
    c m v, is 3e-4 of the load, the inertia 1e-6, and the ringing of the string's first mode
    after the load's pick-up (40 s before) has decayed by exp(-c t / 2) = 7e-4. 50 m segments:
    the grid does not matter at this speed."""
    well = load_well("rp11l_guo")
    friction = 1500.0
    design = well.design({"friction": friction, "damping": 0.1, "segment": 50.0})
    rs = RodString(design).hang(0.0, 0.0)
    omega, half_stroke = 2 * math.pi / 600.0, 1.0
    rising, falling = [], []
    dt = rs.dt
    for i in range(int(600.0 / dt)):
        t = (i + 1) * dt
        rs.step(-half_stroke * (1 - math.cos(omega * t)))
        phase = (omega * t) % (2 * math.pi)
        if 0.4 * math.pi < phase < 0.6 * math.pi and rs.pump.motion == 1:
            rising.append(rs.load)
        elif 1.4 * math.pi < phase < 1.6 * math.pi and rs.pump.motion == -1:
            falling.append(rs.load)
    wrf, fo = design.buoyant_weight, design.fluid_load
    assert rising and falling
    assert max(abs(f - (wrf + fo + friction)) for f in rising) < 1e-3 * (wrf + fo)
    assert max(abs(f - (wrf - friction)) for f in falling) < 1e-3 * (wrf + fo)


def test_a_hanging_string_is_at_rest():
    """hang() is the static solution: a step with the top held still moves no node (1e-12 m)."""
    design = load_well("rp11l_guo").design()
    rs = RodString(design).hang(0.0, 0.3)
    u0 = rs.u.copy()
    for _ in range(50):
        rs.step(0.3)
    assert np.max(np.abs(rs.u - u0)) < 1e-12
    assert rs.load == pytest.approx(design.buoyant_weight, rel=1e-12)


@pytest.mark.parametrize("change, message", [
    ({"courant": 1.5}, r"courant = 1.5 is out of range: valid range \(0, 1\]"),
    ({"fillage": 0.0}, r"fillage = 0.0 is out of range: valid range \(0, 1\]"),
    ({"taper1_length": -5.0}, r"taper 1 length = -5.0 must be > 0"),
    ({"fluid_level": 9000.0, "p_casing": 5e7}, r"the fluid load is negative"),
])
def test_a_bad_string_is_refused_by_name(change, message):
    with pytest.raises(DefinitionError, match=message):
        load_well("rp11l_guo").design(change)
