"""Drive.fmu: the DC motor drive of ``dynamics.drive`` as a co-simulation FMU.

Inputs: the crank speed ``omega`` and the set-point ``omega_set``; outputs: the torque on the crank
``tau``, the armature current ``i``, the armature voltage ``u`` and the motor's electrical power
``P_el`` = u i. Each fmi2DoStep advances the drive's state by the exact solution with the inputs
held at their values (the co-simulation's zero-order hold), so the drive adds no error of its own:
a coupled run's error is the coupling's alone.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.drive import load_drive
from .core import SlaveCore

OUTPUTS = (("tau", "N.m", "torque of the drive on the crank (n_gear k_t i)"),
           ("i", "A", "armature current"),
           ("u", "V", "armature voltage from the PI controller"),
           ("P_el", "W", "electrical power into the armature (u i)"))


class DriveCore(SlaveCore):
    def __init__(self, slave, drive_name: str):
        self.file = load_drive(drive_name)
        super().__init__(slave, self.file.experiment.start_time)
        self.state = np.zeros(2)             # i A, x rad
        self.out = np.zeros(len(OUTPUTS))    # the outputs at the current time, filled once per step
        self.drive = None
        for k, (name, unit, description) in enumerate(OUTPUTS):
            self.output(name, unit, description, lambda k=k: float(self.out[k]))
        for p in self.file.inputs.values():
            self.input(p)
        for p in self.file.parameters.values():
            self.parameter(p)
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
