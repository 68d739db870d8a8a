"""Many designs in one call: the steady cycle of each, for sweeps and flywheel sizing.

``steady_cycles(scenario, designs)`` takes a list of parameter dicts (``SteadyBatch`` does the same
and keeps its tables for the next call). Designs that differ only in
the motor line or the flywheel (``CHEAP``) share one tabulated reduced model and are integrated
together in one call of the C kernel (``native.steady_batch``); any other parameter
(geometry, masses, load amplitudes, g) gives its own table. Each design's steady cycle is found by
secant shooting on omega1 after one machine cycle (one crank turn, or the scenario's cycle_turns;
a cycle is integrated in time by the fast Dormand-Prince kernel, the motor kink and the slider
forces' switches located), then that cycle gives omega1 min, max (where the interpolant's slope
changes sign, located: as accurate as the tolerance), the time mean (the cycle's angle / period)
and the coefficient of speed fluctuation
delta = (max - min) / mean, defined as in ``Result.cycle_stats``.

A design that is out of range, cannot be assembled or stalls is returned in ``failed`` with the
reason; the others are computed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..dynamics import MotorLine
from ..errors import CrankfmuError
from ..dynamics.tabulated import c_table, table_of
from ..integrators.fast import TABLE_TOLERANCE
from .. import native as kernel
from ..scenario import load_scenario

#: parameters the kernel takes per design: designs differing only in these share a table
CHEAP = ("A", "B", "A_low", "B_low", "omega_switch", "J_flywheel")
STEADY_COLUMNS = ("omega1_mean", "omega1_min", "omega1_max", "delta", "period", "turns")
STATUS = {1: "the steady cycle was not found within the shooting turns (the speed keeps changing)",
          2: "the crank stalls or turns back: the motor cannot drive this design through a turn",
          3: "step size underflow"}


@dataclass
class BatchResult:
    rows: list[dict] = field(default_factory=list)        # design parameters + STEADY_COLUMNS
    failed: list[dict] = field(default_factory=list)      # design parameters + reason


def _omega_guess(table, J_flywheel, motor: MotorLine, phi_grid):
    """Mean speed at which the motor line balances the mean load torque (a start for shooting)."""
    A, B, A_low, B_low, ws = motor.A, motor.B, motor.A_low, motor.B_low, motor.omega_switch
    w = max(ws, 1.0) * 2.0
    phi_grid = phi_grid * (table.period / (2.0 * math.pi))      # over the machine's cycle
    values = table.evaluate(phi_grid)           # the table's functions do not depend on the speed
    for _ in range(3):
        Q = float(np.mean(table.coefficients_at(phi_grid, np.full_like(phi_grid, w), J_flywheel, values)[2]))
        high = (A + Q) / B if B > 0 else math.inf
        w_new = high if high > ws else ((A_low + Q) / B_low if B_low > 0 else ws)
        if not (math.isfinite(w_new) and w_new > 0):
            return max(ws, 1.0)
        w = w_new
    return w


class SteadyBatch:
    """Steady cycles of designs of one scenario, the tables kept between calls.

    Each geometry (the non-``CHEAP`` parameters) is built and tabulated once, on its first use, so
    a caller that asks again and again (a root search over J_flywheel) pays only for the kernel.
    """

    def __init__(self, scenario, rtol: float = 1e-9, shoot_tol: float = 1e-9, max_turns: int = 40,
                 keep: bool = True):
        self.scenario = load_scenario(scenario)
        self.rtol, self.shoot_tol, self.max_turns = float(rtol), float(shoot_tol), int(max_turns)
        # keep=False: a geometry's table is dropped once its designs ran (one call over many
        # geometries: a sweep chunk's 500 tables of 0.5 MB each would otherwise stay, and every
        # new table would take fresh pages from the system instead of the last one's)
        self.keep = keep
        self._models: dict[tuple, tuple] = {}          # geometry key -> (phi1_start, table) or the error
        self._phi_grid = np.linspace(0.0, 2.0 * math.pi, 256, endpoint=False)

    def _model(self, key):
        """(initial crank angle rad, table) of a geometry: the C model's table (a few ms), or the
        Python engine's where the C model does not take the scenario or refuses the values (it
        then says why, as every other command does), as where the joints have friction (c_model):
        the engine's table carries it, and the kernel's stepper, which the fast path shares, solves
        it at every step."""
        if key not in self._models:
            try:
                scenario = self.scenario.with_params(**dict(key))
                values = scenario.values
                table = c_table(scenario, values, TABLE_TOLERANCE)
                if table is None or not (values["J_flywheel"] > 0 or np.min(table.coefficients[0, :, 0]) > 0):
                    model = scenario.build()
                    table = table_of(model.reduced, TABLE_TOLERANCE)
                self._models[key] = (values["phi1_start"], table)
            except CrankfmuError as exc:
                self._models[key] = exc
        return self._models[key]

    def run(self, designs: list[dict]) -> BatchResult:
        """Steady-cycle statistics of every design (a dict of parameter overrides each)."""
        result = BatchResult()
        groups: dict[tuple, list[int]] = {}
        checked: list[dict | None] = []
        for i, design in enumerate(designs):
            try:
                full = self.scenario.with_params(**design).values
            except CrankfmuError as exc:
                result.failed.append({**design, "reason": str(exc)})
                checked.append(None)
                continue
            checked.append(full)
            key = tuple(sorted((k, v) for k, v in design.items() if k not in CHEAP))
            groups.setdefault(key, []).append(i)
        for key, members in groups.items():
            built = self._model(key)
            if isinstance(built, CrankfmuError):
                result.failed += [{**designs[i], "reason": str(built)} for i in members]
                continue
            phi1_start, table = built
            params = np.zeros((len(members), kernel.PARAM_SIZE))
            guesses = np.zeros(len(members))
            for row, i in enumerate(members):
                v = checked[i]
                motor = MotorLine(v["A"], v["B"], v["A_low"], v["B_low"], v["omega_switch"])
                params[row] = kernel.parameters(motor, v["J_flywheel"], 0.0, self.rtol, self.rtol)
                guesses[row] = _omega_guess(table, v["J_flywheel"], motor, self._phi_grid)
            out = np.zeros((len(members), kernel.STEADY_SIZE))
            kernel.steady_batch(params, float(phi1_start), guesses, self.shoot_tol, self.max_turns,
                                kernel.Tables(*table.arrays()), out)
            if not self.keep:
                del self._models[key], built, table
            for row, i in enumerate(members):
                status = int(out[row, 6])
                if status != 0:
                    result.failed.append({**designs[i], "reason": STATUS.get(status, f"status {status}")})
                    continue
                result.rows.append({**designs[i], **dict(zip(STEADY_COLUMNS, (float(x) for x in out[row, :6])))})
        return result


def steady_cycles(scenario, designs: list[dict], rtol: float = 1e-9, shoot_tol: float = 1e-9,
                  max_turns: int = 40) -> BatchResult:
    """Steady-cycle statistics of every design (a dict of parameter overrides each), in one call."""
    return SteadyBatch(scenario, rtol, shoot_tol, max_turns, keep=False).run(designs)
