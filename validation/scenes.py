"""The coupled scenes the masters of validation/cosim.py are measured on, each with its FMUs, its
coupling, its parameters and its one-model reference (validation/coupling.py):

- ``FourBarDrive``: the seed-000 four-bar (its motor line off) driven by Drive.fmu, torque causality
  (FourBarDrive.ssp);
- ``ShaftDrive``: DriveSpeed.fmu carrying the flywheel (J_drive = 1 kg.m2) on an elastic shaft (an
  equation of the master: stiffness k, 5 % damping of its torsional mode) to the four-bar without
  flywheel in torque causality; k = 1e5 N.m/rad unless given;
- ``FlywheelOnCrank``: speed causality with the flywheel on the crank side, FourBarSpeed.fmu with
  J_flywheel = 0.9 kg.m2 and DriveSpeed.fmu with J_drive = 0.1 kg.m2: the mechanism's tau_drive reads
  the drive's acceleration with nine times the drive's inertia, a loop no explicit master survives.

The error of a run is max |omega1 - reference| / max |omega1| over the communication points.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from crankfmu.fmi.ssp import MOTOR_OFF, _drive_values
from crankfmu.validation.cosim import Coupling, cosimulate
from crankfmu.validation.coupling import coupled_reference, machine_inertia, shaft_damping, shaft_reference

#: the native FMUs the scenes use: name -> crankfmu fmu's arguments (FMI 2.0)
BUILDS = {
    "FourBar": ["seed000", "--native"],
    "FourBarSpeed": ["seed000", "--native", "--causality", "speed"],
    "Drive": ["dc_pi", "--drive", "--native"],
    "DriveSpeed": ["dc_pi", "--drive", "--native", "--causality", "speed"],
}
#: a run whose crank speed passes this many times the reference's largest has diverged
DIVERGED = 10.0
#: the shaft's damping ratio, and the crank speed both sides start at (seed 000's omega1_start)
SHAFT_DAMPING_RATIO = 0.05
OMEGA_START = 0.1


@dataclass(frozen=True)
class Scene:
    name: str
    fmus: dict                 # component -> the FMU (a BUILDS name)
    coupling: Coupling
    parameters: dict           # component -> {variable: value}
    reference: Callable        # times -> {"omega1": ...}
    stop_time: float = 2.0
    omega: str = "FourBar.omega1"
    #: the power bonds, for libcosim's ECCO: (instance, output, input, instance, output, input), a
    #: torque and a speed on each side; none where the master's own equations couple (the shaft)
    bonds: tuple = ()


def scene(name: str, k: float = 1e5) -> Scene:
    """The scene ``name`` (the shaft's stiffness ``k`` N.m/rad for ShaftDrive)."""
    torque_drive = _drive_values(False)
    speed_drive = _drive_values(True)
    if name == "FourBarDrive":
        return Scene(name, {"FourBar": "FourBar", "Drive": "Drive"},
                     Coupling.connections((("Drive", "tau", "FourBar", "tau_ext"),
                                           ("FourBar", "omega1", "Drive", "omega"))),
                     {"FourBar": MOTOR_OFF, "Drive": torque_drive}, coupled_reference,
                     bonds=(("FourBar", "omega1", "tau_ext", "Drive", "tau", "omega"),))
    if name == "ShaftDrive":
        J_drive = 1.0
        c = shaft_damping(k, SHAFT_DAMPING_RATIO, J_drive, machine_inertia(J_flywheel=0.0))
        return Scene(name, {"Drive": "DriveSpeed", "FourBar": "FourBar"}, Coupling.shaft("Drive", "FourBar", k, c),
                     {"FourBar": {**MOTOR_OFF, "J_flywheel": 0.0},
                      "Drive": {**speed_drive, "J_drive": J_drive, "omega_start": OMEGA_START}},
                     lambda times: shaft_reference(times, k, c, J_drive))
    if name == "FlywheelOnCrank":
        return Scene(name, {"Drive": "DriveSpeed", "FourBar": "FourBarSpeed"},
                     Coupling.connections((("Drive", "omega", "FourBar", "omega1"),
                                           ("FourBar", "tau_drive", "Drive", "tau_load"))),
                     {"FourBar": {"J_flywheel": 0.9},
                      "Drive": {**speed_drive, "J_drive": 0.1, "omega_start": OMEGA_START}},
                     lambda times: coupled_reference(times, J_flywheel=1.0),
                     bonds=(("Drive", "omega", "tau_load", "FourBar", "tau_drive", "omega1"),))
    raise ValueError(f"no coupled scene {name!r}: FourBarDrive, ShaftDrive or FlywheelOnCrank")


def build(out: Path) -> dict:
    """The scenes' native FMUs built in ``out``: {BUILDS name: path}."""
    from crankfmu.cli import main

    paths = {}
    for name, args in BUILDS.items():
        if main(["fmu", *args, "--out", str(out)]) != 0:
            raise RuntimeError(f"crankfmu fmu {' '.join(args)} failed")
        paths[name] = Path(out) / f"{name}.fmu"
    return paths


@dataclass
class Measured:
    error: float               # relative to max omega1; inf where the run diverged
    steps: int                 # FMU steps taken (a rollback's trials counted)
    failure: str = ""          # what the FMU or the master said where the run diverged


def measure(s: Scene, built: dict, mode: str, step: float, theta: float = 0.5, folder: Path | None = None,
            references: dict | None = None) -> Measured:
    """One run of scene ``s`` on the FMUs ``built`` (build()) in ``mode`` at ``step``, against its
    reference (kept in ``references`` by the number of points, where given)."""
    fmus = {component: built[fmu] for component, fmu in s.fmus.items()}
    cache = references if references is not None else {}
    n = int(round(s.stop_time / step)) + 1
    if n not in cache:
        cache[n] = s.reference(np.arange(n) * step)
    reference = cache[n]["omega1"]
    try:
        run = cosimulate(fmus, s.coupling, s.parameters, s.stop_time, step, mode, record=(s.omega,), folder=folder,
                         theta=theta, bound=DIVERGED * np.max(np.abs(reference)))
    except Exception as exc:     # diverged: beyond the bound, or an FMU refused the state (fmi2Error)
        return Measured(np.inf, 0, str(exc))
    omega = run[s.omega]
    return Measured(float(np.max(np.abs(omega - reference)) / np.max(np.abs(reference))), run.steps)


def measure_ecco(s: Scene, built: dict, tolerance: float = 1e-4, min_step: float = 1e-4,
                 max_step: float = 1e-2) -> Measured:
    """Scene ``s`` run by libcosim's ECCO (validation/masters.py) on its power bonds, against its
    reference at the communication points ECCO chose."""
    from crankfmu.validation import masters

    fmus = {component: built[fmu] for component, fmu in s.fmus.items()}
    run = masters.ecco(fmus, s.coupling.links(), s.bonds, s.parameters, s.stop_time, [s.omega],
                       min_step=min_step, max_step=max_step, tolerance=tolerance)
    if run.error:
        return Measured(np.inf, 0, run.error)
    times = np.concatenate([[0.0], run.time])
    reference = s.reference(times)["omega1"]
    error = np.max(np.abs(run[s.omega] - reference[1:])) / np.max(np.abs(reference))
    return Measured(float(error), int(run.time.size))
