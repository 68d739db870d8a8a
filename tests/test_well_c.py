"""The pumping well's coupled steps in C (crank_well.c: cw_run), what `crankfmu well` runs, against
crankfmu.well.CoupledWell.step, the same step in Python (the reference): the same kernel calls and
string steps in the same order, so the same numbers, bit for bit; the run to steady state and its
RP 11L figures the same from both; and a kernel refusal inside the C loop raised as the Python
loop raises it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from crankfmu.dynamics.well import load_well
from crankfmu.errors import CrankfmuError
from crankfmu.well import FIELDS, CoupledWell, run_to_steady, unit_scenario


@pytest.fixture(scope="module")
def well():
    well = load_well("rp11l_guo")
    design = well.design()
    # the counterweights of RP 11L's counterbalance effect: no balancing runs, the same unit for both
    return well, unit_scenario(well, design=design, m_cw=9000.0), design


def test_the_c_steps_equal_the_python_steps_to_the_bit(well):
    """Two strokes and a half from rest (the start-up, where the load moves most): every sample of
    every field, the unit's state and the string's state equal to the bit."""
    _, scenario, design = well
    c, python = CoupledWell(scenario, design), CoupledWell(scenario, design, in_c=False)
    for stop in (2.0, 2.0 + 2 * math.pi, 2.0 + 5 * math.pi):
        a, b = c.run_until(stop, record=True), python.run_until(stop, record=True)
        assert a.shape == b.shape and a.shape[0] > 1000 and a.shape[1] == len(FIELDS)
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(c.y, python.y)
    np.testing.assert_array_equal(c.row, python.row)
    assert (c.t, c.load_end) == (python.t, python.load_end)
    for name in ("u", "v"):
        np.testing.assert_array_equal(getattr(c.string, name), getattr(python.string, name))
    for name in ("t", "load", "work", "damping_loss"):
        assert getattr(c.string, name) == getattr(python.string, name), name
    assert c.string.pump.state() == python.string.pump.state()


def test_the_rope_position_is_the_same_cubic_in_c(well):
    """The rope's s(phi1) that the C steps read: the Python floats' cubic at any angle, whole
    turns and negative angles included (Python's modulo)."""
    _, scenario, design = well
    cw = CoupledWell(scenario, design)
    cw.run_until(0.0)
    steps = cw._bind_c()
    for phi in np.concatenate([np.linspace(-13.0, 40.0, 997), [0.0, 2 * math.pi, -2 * math.pi, 1e-300]]):
        assert steps.rope_position(float(phi)) == cw.rope.position(float(phi)), phi


def test_a_run_to_steady_state_is_the_same_from_both(well):
    """The sheave's correction and the strokes to steady state, in C and in Python: the same
    strokes, sample for sample (five strokes: the sheave tuned, the card repeating)."""
    w, scenario, design = well
    _, a = run_to_steady(w, scenario, design, max_strokes=5)
    _, b = run_to_steady(w, scenario, design, max_strokes=5, in_c=False)
    assert len(a) == len(b) == 5
    for sa, sb in zip(a, b):
        for name in FIELDS:
            np.testing.assert_array_equal(sa[name], sb[name])


def test_a_kernel_refusal_in_the_c_loop_is_raised(well):
    """A unit whose state the kernel cannot step (a crank speed of NaN) stops the C loop at the
    first step with the kernel's error, as the Python loop's."""
    _, scenario, design = well
    messages = []
    for in_c in (True, False):
        cw = CoupledWell(scenario, design, in_c=in_c)
        cw.y[1] = math.nan
        with pytest.raises(CrankfmuError) as caught:
            cw.run_until(10.0, record=True)
        messages.append(str(caught.value))
    assert messages[0] == messages[1] and "fast:" in messages[0]
