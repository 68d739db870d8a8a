"""Drive.fmu: the DC motor drive of ``dynamics.drive`` as a co-simulation FMU.

Inputs: the crank speed ``omega`` and the set-point ``omega_set``; outputs: the torque on the crank
``tau``, the armature current ``i``, the armature voltage ``u`` and the motor's electrical power
``P_el`` = u i. Each fmi2DoStep advances the drive's state by the exact solution with the inputs
held at their values (the co-simulation's zero-order hold), so the drive adds no error of its own:
a coupled run's error is the coupling's alone.
"""

from __future__ import annotations

import numpy as np

from ..contract import DRIVE_OUTPUTS as OUTPUTS
from ..dynamics.drive import load_drive
from .core import Declared, SlaveCore


def declared(drive_file) -> Declared:
    """The variables of Drive.fmu: the contract's drive outputs, the drive file's inputs and parameters."""
    return Declared(list(OUTPUTS), list(drive_file.inputs.values()), list(drive_file.parameters.values()))


class DriveCore(SlaveCore):
    def __init__(self, slave, drive_name: str):
        self.file = load_drive(drive_name)
        super().__init__(slave, self.file.experiment.start_time)
        self.state = np.zeros(2)             # i A, x rad
        self.out = np.zeros(len(OUTPUTS))    # the outputs at the current time, filled once per step
        self.drive = None
        self.declare(declared(self.file), {v.name: (lambda k=k: float(self.out[k])) for k, v in enumerate(OUTPUTS)})
        self.attach()

    def _update_outputs(self):
        i, x = self.state
        u = self.drive.voltage(x, self.values["omega"], self.values["omega_set"])
        self.out[:] = self.drive.torque(i), i, u, u * i

    def initialise(self):
        self.drive = self.file.drive(self.values)
        self.state[:] = self.values["i_start"], self.values["x_start"]
        self._update_outputs()

    def advance(self, target: float):
        if self.pending & {"Kp", "Ki"}:
            self.drive = self.file.drive(self.values)
        self.state[:] = self.drive.step(*self.state, self.values["omega"], self.values["omega_set"], target - self.time)
        self._update_outputs()

    def outputs_now(self) -> np.ndarray:
        return self.out

    def model_state(self):
        return None if self.drive is None else self.state.tolist()

    def can_restore(self) -> bool:
        return self.drive is not None

    def restore_model_state(self, state):
        self.drive = self.file.drive(self.values)
        self.state[:] = state
        self._update_outputs()
