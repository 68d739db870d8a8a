"""One interface for every integrator: ``run(equation, t0, y0, t_end) -> Trajectory``."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..dynamics.equation import MovementEquation
from ..dynamics.modes import SLIDING, STUCK


@dataclass
class Trajectory:
    """What an integrator produced.

    ``t`` (s) and ``y`` (state rows phi1 rad, omega1 rad/s, W_motor J, W_load J, W_ext J) at the
    integrator's own nodes; ``dense(t)`` evaluates the state anywhere in the run (None for the
    crank-angle schemes, which are interpolated linearly between nodes: they are first order);
    ``epsilon`` holds the scheme's own angular acceleration at the nodes (eq. 10) when the scheme
    defines one; ``events`` lists (time s, description) of the located switches and ``modes``
    (start time s, name) where the mode's name changes: the motor branch "low", "high" or
    "slide", or "stuck" (at rest, held by the slider forces).
    """

    t: np.ndarray
    y: np.ndarray
    dense: Callable[[np.ndarray], np.ndarray] | None = None
    epsilon: np.ndarray | None = None
    events: list[tuple[float, str]] = field(default_factory=list)
    modes: list[tuple[float, str]] = field(default_factory=list)
    n_rhs: int = 0
    n_steps: int = 0
    #: the contract outputs at the requested output times, when the integrator computes them itself
    #: (the fast path, from its tables): "state" (5 x n) and epsilon1, M_motor, M_load, J_red, E_kin
    outputs: dict | None = None
    table: object = None           # the ReducedTable the fast path ran on

    def mode_at(self, times) -> np.ndarray | None:
        """Name of the mode (see ``modes``) at each time, or None when the run never slid on the
        motor switch nor got stuck (the outputs need the name only to tell those apart)."""
        if not any(m in (SLIDING, STUCK) for _, m in self.modes):
            return None
        starts = np.array([t for t, _ in self.modes])
        idx = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(starts) - 1)
        return np.array([m for _, m in self.modes])[idx]

    def sample(self, times) -> np.ndarray:
        times = np.atleast_1d(np.asarray(times, dtype=float))
        if self.dense is not None:
            return self.dense(times)
        return np.vstack([np.interp(times, self.t, row) for row in self.y])


class Integrator(ABC):
    """An integrator of the movement equation."""

    name: str = "?"
    #: whether ``run`` can pass omega1 <= 0 (time domain) or not (crank-angle schemes)
    time_domain: bool = True

    @abstractmethod
    def run(self, equation: MovementEquation, t0: float, y0: np.ndarray, t_end: float,
            progress: Callable[[float], None] | None = None, output_times=None) -> Trajectory:
        """Integrate from (t0, y0) to t_end (s).

        ``output_times`` (s) tells an integrator that computes the contract outputs itself where
        they are wanted (it fills ``Trajectory.outputs``); the others may ignore it.
        """
