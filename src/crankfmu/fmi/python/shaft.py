"""ElasticShaft.fmu: the elastic shaft of ``dynamics.shaft`` as a co-simulation FMU.

Inputs: the speeds ``omega_a`` (the drive's side) and ``omega_b`` (the machine's crank); state: the
``twist``; outputs: the torque ``tau`` from side a to side b, the twist and the spring's energy.
Each step integrates the speed difference exactly with the inputs held (pythonfmu passes no input
derivatives; the native FMU takes them: lines in time); after a set, tau is the law at the inputs
as set. The law and the step are the components' C (crank_components.c, cc_shaft_*, which the
native ElasticShaft.fmu compiles in); dynamics.shaft states them in Python, the tests' reference.
"""

from __future__ import annotations

from ...contract import SHAFT_OUTPUTS
from ...dynamics.shaft import load_shaft
from ...native.physics import shaft_energy, shaft_torque, shaft_twist
from .core import ComponentCore, Declared


def declared(shaft_file) -> Declared:
    return Declared.of_file(SHAFT_OUTPUTS, shaft_file)


class ShaftCore(ComponentCore):
    def __init__(self, slave, shaft_name: str):
        self.file = load_shaft(shaft_name)
        super().__init__(slave, self.file.experiment.start_time)
        self.twist = None
        self.declare_array_outputs(declared(self.file))
        self.attach()

    def _update_outputs(self):
        v = self.values
        self.out[:] = (shaft_torque(v["k"], v["c"], self.twist, v["omega_a"], v["omega_b"]), self.twist,
                       shaft_energy(v["k"], self.twist))

    def initialise(self):
        self.twist = self.values["twist_start"]
        self._update_outputs()

    def advance(self, target: float):
        v = self.values
        self.twist = shaft_twist(self.twist, v["omega_a"], v["omega_b"], target - self.time)
        self._update_outputs()

    def inputs_set(self):
        if self.twist is not None:
            self._update_outputs()

    def model_state(self):
        return None if self.twist is None else [self.twist]

    def can_restore(self) -> bool:
        return self.twist is not None

    def restore_model_state(self, state):
        self.twist = state[0]
        self._update_outputs()
