"""The rod string's steps in C (crank_components.c: cc_string_step, cc_string_advance), which
RodString.fmu and the in-process well run, against this project's numpy statement of the same
scheme (dynamics.rodstring with in_c=False, the reference): the same operations in the same
order, so the same numbers; and the discrete energy balance closing on the C path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from crankfmu.dynamics.rodstring import RodString
from crankfmu.dynamics.well import load_well


def design(**changes):
    well = load_well("rp11l_guo")
    values = {k: p.value for k, p in well.parameters.items()}
    values.update(changes)
    return well.design(values)


@pytest.mark.parametrize("changes", [{}, {"fillage": 0.7, "friction": 500.0}])
def test_c_steps_equal_the_numpy_reference(changes):
    """A 15 s harmonic stroke of 2 m at 5 ms communication steps, with full and partial fillage
    (fluid pound) and plunger friction: positions, velocities, loads, works and the pump's state
    agree to 1e-13 of their scale (measured: bit for bit)."""
    d = design(**changes)
    c, ref = RodString(d).hang(0.0, 0.0), RodString(d, in_c=False).hang(0.0, 0.0)
    assert c._kernel is not None and ref._kernel is None
    for k in range(1, 3001):
        top = 1.0 - math.cos(2 * math.pi * k * 5e-3 / 6.3)
        c.advance(top, 5e-3)
        ref.advance(top, 5e-3)
    for name in ("u", "v"):
        a, b = getattr(c, name), getattr(ref, name)
        assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(b)), name
    for name in ("load", "work", "damping_loss", "t"):
        assert getattr(c, name) == pytest.approx(getattr(ref, name), rel=1e-13), name
    assert c.pump.state() == pytest.approx(ref.pump.state(), rel=1e-13)
    assert c.pump.motion == ref.pump.motion
    # the discrete energy balance closes on the C path as on the reference: to round-off of the work
    assert abs(c.balance()) <= 1e-9 * abs(c.work) + 1e-6
    if changes:
        assert c.pump.u_top < c.pump.u_bottom             # the strokes were seen (fillage needs them)


def test_a_restored_state_continues_bit_for_bit():
    """The state a coupled model saves and restores before its second pass (well.CoupledWell):
    restored into the arrays in use, the C steps continue exactly as the first time."""
    s = RodString(design(fillage=0.8)).hang(0.0, 0.0)
    for k in range(1, 200):
        s.step(0.002 * k, 0.01 / 3)
    saved = s.state()
    for k in range(200, 260):
        s.step(0.002 * k, 0.01 / 3)
    first = (s.u.copy(), s.v.copy(), s.load, s.work, s.pump.state())
    u_array = s.u
    s.restore(saved)
    assert s.u is u_array                                  # restored in place
    for k in range(200, 260):
        s.step(0.002 * k, 0.01 / 3)
    assert np.array_equal(s.u, first[0]) and np.array_equal(s.v, first[1])
    assert (s.load, s.work, s.pump.state()) == first[2:]


def test_the_c_steps_refuse_a_state_of_another_size():
    from crankfmu.errors import CrankfmuError

    s = RodString(design()).hang(0.0, 0.0)
    s.u = np.zeros(3)
    with pytest.raises(CrankfmuError, match="nodes and 11 scalars"):
        s.step(0.0, 1e-3)
