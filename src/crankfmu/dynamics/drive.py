"""A DC motor drive with a PI speed controller, acting on the crank (Drive.fmu, drives/*.toml).

State: the armature current i (A) and the integral x (rad) of the crank speed error
e = omega_set - omega. With the crank speed omega and the set-point as inputs:

    u   = Kp e + Ki x                               armature voltage, V
    L di/dt = u - R i - k_t n_gear omega            the motor turns n_gear times faster than the crank
    dx/dt   = e
    tau = n_gear k_t i                              torque on the crank, N.m (an ideal reducer)

The motor's rotor inertia belongs to the crank side (reflected: n_gear**2 J_rotor, add it to
J_flywheel), so the drive never needs the crank's acceleration.

Between two communication points a co-simulation holds the inputs constant; the state then
follows a linear system with constant input, whose solution ``step`` evaluates exactly (x grows
linearly, i relaxes with the time constant L/R towards an affine function of time).

The speed-causal variant (DriveSpeed.fmu, the drive file's ``[speed_causality]``) carries the
rotor and the flywheel itself, J_drive at the crank (n_gear**2 J_rotor + J_flywheel), takes the
torque the mechanism needs (a speed-causal mechanism FMU's tau_drive) and outputs the speed:

    J_drive domega/dt = n_gear k_t i - tau_load

a third state of the same linear system, stepped exactly too (``step_with_rotor``: the matrix
exponential of the system with its held inputs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources

import numpy as np

from ..datafiles import read_toml
from ..errors import DefinitionError
from ..numerics import expm
from ..parameters import ComponentFile, Experiment, parse_parameters

_FILES = resources.files(__package__.rsplit(".", 1)[0]) / "drives"


#: the drive's constants, in DcDrive's order (a drive file must declare them as parameters)
DRIVE_CONSTANTS = ("R", "L", "k_t", "n_gear", "Kp", "Ki")


def available_drives() -> list[str]:
    from ..datafiles import packaged

    return packaged(_FILES)


@dataclass(frozen=True)
class DcDrive:
    R: float           # Ohm
    L: float           # H
    k_t: float         # N.m/A
    n_gear: float      # 1
    Kp: float          # V/(rad/s)
    Ki: float          # V/rad

    def voltage(self, x, omega, omega_set):
        return self.Kp * (omega_set - omega) + self.Ki * x

    def torque(self, i):
        return self.n_gear * self.k_t * i

    def rhs(self, i, x, omega, omega_set):
        """(di/dt, dx/dt)."""
        return ((self.voltage(x, omega, omega_set) - self.R * i - self.k_t * self.n_gear * omega) / self.L,
                omega_set - omega)

    def step(self, i, x, omega, omega_set, h):
        """(i, x) after h s with the inputs held constant: the exact solution."""
        e = omega_set - omega
        a = self.R / self.L
        p = (self.Kp * e + self.Ki * x - self.k_t * self.n_gear * omega) / self.L   # forcing at the start, A/s
        q = self.Ki * e / self.L                                                    # its slope, A/s2
        one_minus = -math.expm1(-a * h)                                             # 1 - exp(-a h)
        i_new = i * (1.0 - one_minus) + p * one_minus / a + q * (h / a - one_minus / (a * a))
        return i_new, x + e * h

    def rhs_with_rotor(self, i, x, omega, omega_set, tau_load, J_drive):
        """(di/dt, dx/dt, domega/dt) of the speed-causal drive."""
        di, dx = self.rhs(i, x, omega, omega_set)
        return di, dx, (self.torque(i) - tau_load) / J_drive

    def step_with_rotor(self, i, x, omega, omega_set, tau_load, J_drive, h):
        """(i, x, omega) after h s with omega_set and tau_load held: the exact solution of the
        linear system d(i, x, omega)/dt = A (i, x, omega) + b, as the matrix exponential of
        [[A h, b h], [0, 0]] applied to (i, x, omega, 1)."""
        nk = self.n_gear * self.k_t
        A = np.array([[-self.R / self.L, self.Ki / self.L, -(self.Kp + nk) / self.L, self.Kp * omega_set / self.L],
                      [0.0, 0.0, -1.0, omega_set],
                      [nk / J_drive, 0.0, 0.0, -tau_load / J_drive],
                      [0.0, 0.0, 0.0, 0.0]])
        z = expm(A * h) @ np.array([i, x, omega, 1.0])
        return float(z[0]), float(z[1]), float(z[2])


@dataclass
class DriveFile(ComponentFile):
    speed_parameters: dict | None = None    # [speed_causality]: J_drive, omega_start
    speed_inputs: dict | None = None        # [speed_causality.inputs]: tau_load
    speed_fmu: str = ""

    def drive(self, values: dict) -> DcDrive:
        return DcDrive(*(float(values[k]) for k in DRIVE_CONSTANTS))


def load_drive(name_or_path) -> DriveFile:
    """A drive file: a packaged name (``"dc_pi"``) or a path to a .toml file."""
    data, where, _ = read_toml(name_or_path, _FILES, "drive")
    try:
        params = parse_parameters(data["parameters"], where)
        inputs = parse_parameters(data.get("inputs", {}), where)
    except KeyError as exc:
        raise DefinitionError(f"{where}: missing {exc.args[0]!r}") from None
    missing = {*DRIVE_CONSTANTS, "i_start", "x_start"} - params.keys()
    if missing:
        raise DefinitionError(f"{where}: missing drive parameter(s) {', '.join(sorted(missing))}")
    speed = data.get("speed_causality")
    speed_parameters = speed_inputs = None
    if speed is not None:
        speed_parameters = parse_parameters(speed.get("parameters", {}), f"{where} [speed_causality]")
        speed_inputs = parse_parameters(speed.get("inputs", {}), f"{where} [speed_causality.inputs]")
        missing = {"J_drive", "omega_start"} - speed_parameters.keys() | {"tau_load"} - speed_inputs.keys()
        if missing:
            raise DefinitionError(f"{where}: [speed_causality] needs {', '.join(sorted(missing))}")
        if not speed_parameters["J_drive"].value > 0:
            raise DefinitionError(f"{where}: [speed_causality] J_drive must be > 0 kg.m2 (the drive carries the "
                                  "rotor and flywheel)")
    return DriveFile(data.get("name", str(name_or_path)), data.get("title", ""), params, inputs,
                     Experiment.from_dict(data.get("experiment", {})), where, str(data.get("fmu", "")),
                     speed_parameters, speed_inputs, str((speed or {}).get("fmu", "")))
