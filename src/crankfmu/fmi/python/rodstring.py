"""RodString.fmu: the rod string and pump of ``dynamics.rodstring`` as a co-simulation FMU, built
from a well file (``wells/*.toml``).

Inputs: the polished rod's position ``s`` and velocity ``v`` along the unit's rope port (downward;
a unit's rod_s and rod_v). Output: the polished rod load ``F`` (to the unit's rod_F), the plunger's
position and the rods' tension at the pump, and the work done at both ends. Inside a
communication step the string takes its own steps, as many as keep the Courant number at or below
the well file's ``courant``; the polished rod moves linearly from where it is to s + v h, the
position the inputs predict for the step's end (the host's v carries the motion between
communication points). F at a communication point is the first segment's tension plus the top
half-segment's buoyant weight. The string hangs at rest from the polished rod's position at the
first step (a master sets connected inputs after initialisation).
"""

from __future__ import annotations


import numpy as np

from ...contract import ROD_STRING_OUTPUTS
from ...dynamics.rodstring import RodString
from ...dynamics.well import load_well
from .core import ComponentCore, Declared


def declared(well_file) -> Declared:
    return Declared.of_file(ROD_STRING_OUTPUTS, well_file)


class RodStringCore(ComponentCore):
    def __init__(self, slave, well_name: str):
        self.file = load_well(well_name)
        super().__init__(slave, self.file.experiment.start_time)
        self.string: RodString | None = None
        self.declare_array_outputs(declared(self.file))
        self.attach()

    def _update_outputs(self):
        s = self.string
        self.out[:] = (s.static_load, s.pump_position, s.pump_load, s.work, s.pump.hydraulic)

    def initialise(self):
        design = self.file.design({k: v for k, v in self.values.items() if k in self.file.parameters})
        self.string = RodString(design).hang(self.time, self.values["s"])
        self.hung = False
        self._update_outputs()

    def advance(self, target: float):
        h = target - self.time
        if h <= 0:
            return
        if not self.hung:
            # a master sets the connected inputs after initialisation: the string hangs, at rest,
            # from the polished rod's position at the first step
            self.string.hang(self.time, self.values["s"])
            self.hung = True
        self.string.advance(self.values["s"] + self.values["v"] * h, h)
        self._update_outputs()

    def model_state(self):
        """The string's state as plain numbers and lists: the host may serialize it (canSerializeFMUstate)."""
        if self.string is None:
            return None
        return [self.hung, [x.tolist() if isinstance(x, np.ndarray) else x for x in self.string.state()]]

    def can_restore(self) -> bool:
        return self.string is not None

    def restore_model_state(self, state):
        self.hung, string = state
        self.string.restore(string)
        self._update_outputs()
