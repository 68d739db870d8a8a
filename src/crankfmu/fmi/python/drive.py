"""Drive.fmu: the DC motor drive of ``dynamics.drive`` as a co-simulation FMU, and its
speed-causal variant DriveSpeed.fmu (``DriveSpeedCore``).

Inputs: the crank speed ``omega`` and the set-point ``omega_set``; outputs: the torque on the crank
``tau``, the armature current ``i``, the armature voltage ``u``, the motor's electrical power
``P_el`` = u i and the PI controller's state ``x``. Each fmi2DoStep advances the drive's state by the exact solution with the inputs
held at their values (the co-simulation's zero-order hold), so the drive adds no error of its own:
a coupled run's error is the coupling's alone. The step is the components' C
(crank_components.c, through native.physics.DriveSteps), the one the native Drive.fmu compiles in;
dynamics.drive.DcDrive states the same model in Python, the reference the tests compare with.

DriveSpeed.fmu carries the rotor and flywheel (J_drive) and outputs the crank speed ``omega``
from the torque the mechanism takes, ``tau_load`` (a speed-causal mechanism FMU's tau_drive), with
the same outputs besides; its step is exact too (dynamics.drive.DcDrive.step_with_rotor).
"""

from __future__ import annotations

import numpy as np

from ...contract import DRIVE_OUTPUTS as OUTPUTS, DRIVE_SPEED_OUTPUTS
from ...dynamics.drive import DRIVE_CONSTANTS, load_drive
from ...native.physics import DriveSteps
from .core import ComponentCore, Declared


def declared(drive_file) -> Declared:
    """The variables of Drive.fmu: the contract's drive outputs, the drive file's inputs and parameters."""
    return Declared.of_file(OUTPUTS, drive_file)


class DriveCore(ComponentCore):
    """Drive.fmu: the speed is an input; the state is (i, x)."""

    state_size = 2                           # i A, x rad

    def __init__(self, slave, drive_name: str):
        self.file = load_drive(drive_name)
        super().__init__(slave, self.file.experiment.start_time)
        self.state = np.zeros(self.state_size)
        self.drive = None
        self.declare_array_outputs(self.declared())
        self.attach()

    def declared(self) -> Declared:
        return declared(self.file)

    def start_state(self):
        return self.values["i_start"], self.values["x_start"]

    def speed(self) -> float:
        return self.values["omega"]

    def step(self, h: float):
        return self.drive.step(*self.state, self.values["omega"], self.values["omega_set"], h)

    def output_row(self, omega, tau, i, u, x):
        """The outputs in the declared outputs' order."""
        return tau, i, u, u * i, x

    def _update_outputs(self):
        i, x = self.state[:2]
        omega = self.speed()
        u = self.drive.voltage(x, omega, self.values["omega_set"])
        self.out[:] = self.output_row(omega, self.drive.torque(i), i, u, x)

    def _drive(self) -> DriveSteps:
        return DriveSteps([self.values[k] for k in DRIVE_CONSTANTS])

    def initialise(self):
        self.drive = self._drive()
        self.state[:] = self.start_state()
        self._update_outputs()

    def advance(self, target: float):
        if self.pending & {"Kp", "Ki"}:
            self.drive = self._drive()
        self.state[:] = self.step(target - self.time)
        self._update_outputs()

    def model_state(self):
        return None if self.drive is None else self.state.tolist()

    def can_restore(self) -> bool:
        return self.drive is not None

    def restore_model_state(self, state):
        self.drive = self._drive()
        self.state[:] = state
        self._update_outputs()


def declared_speed(drive_file) -> Declared:
    """The variables of DriveSpeed.fmu: omega and the drive's outputs; the inputs omega_set and
    tau_load; the drive's parameters and J_drive, omega_start."""
    inputs = [p for n, p in drive_file.inputs.items() if n != "omega"] + list(drive_file.speed_inputs.values())
    return Declared(list(DRIVE_SPEED_OUTPUTS), inputs,
                    list(drive_file.parameters.values()) + list(drive_file.speed_parameters.values()))


class DriveSpeedCore(DriveCore):
    """DriveSpeed.fmu: the drive with its rotor and flywheel, in speed causality; the state is
    (i, x, omega)."""

    state_size = 3

    def declared(self) -> Declared:
        return declared_speed(self.file)

    def start_state(self):
        return self.values["i_start"], self.values["x_start"], self.values["omega_start"]

    def speed(self) -> float:
        return float(self.state[2])

    def output_row(self, omega, tau, i, u, x):
        return (omega, *super().output_row(omega, tau, i, u, x))

    def step(self, h: float):
        return self.drive.step_with_rotor(*self.state, self.values["omega_set"], self.values["tau_load"],
                                          self.values["J_drive"], h)
