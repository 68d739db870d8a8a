"""DieCushion.fmu: the die cushion of ``dynamics.cushion`` as a co-simulation FMU.

Inputs: the ram's coordinate ``s`` and velocity ``v`` along its axis (a press's ram_s, ram_v);
output: the force ``F`` on the ram along that axis (to the press's ram_F). No state: after each
step F is the cushion's law at the inputs as the host had set them for it, and in initialisation
mode at the inputs as set now (a master sets s and v from the press and reads F there, before the
first step: fmi.python.core.SlaveCore._initial_outputs), by
the components' C (crank_components.c, which the native DieCushion.fmu compiles in);
dynamics.cushion states the same law in Python, the reference the tests compare with.
"""

from __future__ import annotations

from ...contract import CUSHION_OUTPUTS
from ...dynamics.cushion import load_cushion
from ...native.physics import cushion_force
from .core import ComponentCore, Declared


def declared(cushion_file) -> Declared:
    return Declared.of_file(CUSHION_OUTPUTS, cushion_file)


class CushionCore(ComponentCore):
    def __init__(self, slave, cushion_name: str):
        self.file = load_cushion(cushion_name)
        super().__init__(slave, self.file.experiment.start_time)
        self.declare_array_outputs(declared(self.file))
        self.attach()

    def _update_outputs(self):
        v = self.values
        self.out[0] = cushion_force(v["k"], v["c"], v["L_free"], v["s_seat"], v["s"], v["v"])

    def initialise(self):
        self._update_outputs()


    def advance(self, target: float):
        self._update_outputs()

    def model_state(self):
        return []

    def can_restore(self) -> bool:
        return True

    def restore_model_state(self, state):
        self._update_outputs()
