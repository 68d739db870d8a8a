"""Where a slider force is set-valued: the samples of a run that a comparison of joint reactions
with Newton-Euler leaves out."""

from __future__ import annotations

import math

import numpy as np


def away_from_switches(reduced, phi1, margin=1e-6):
    """Samples not within ``margin`` rad of a switched load's switch angle: there the load is
    set-valued (the kernel's schedule takes the next interval's value, the Newton-Euler solve at
    zero slider speed takes 0)."""
    phi1 = np.asarray(phi1, dtype=float)
    switch, _ = reduced.slider_schedule()
    if not len(switch):
        return np.ones(phi1.size, dtype=bool)
    gap = np.abs((np.mod(phi1, 2 * math.pi)[:, None] - switch[None, :] + math.pi) % (2 * math.pi) - math.pi)
    return np.all(gap > margin, axis=1)
