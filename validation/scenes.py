"""The coupled scenes the masters of validation/cosim.py are measured on, each with its FMUs, its
coupling, its parameters and its one-model reference (validation/coupling.py):

- ``FourBarDrive``: the seed-000 four-bar (its motor line off) driven by Drive.fmu, torque causality
  (FourBarDrive.ssp);
- ``FourBarDriveSpeed``: the same system in speed causality, the flywheel with the drive
  (FourBarDriveSpeed.ssp): DriveSpeed.fmu (J_drive = 1 kg.m2) imposes the crank speed on
  FourBarSpeed.fmu without flywheel and takes its tau_drive;
- ``ShaftDrive``: DriveSpeed.fmu carrying the flywheel (J_drive = 1 kg.m2) on ElasticShaft.fmu
  (stiffness k, 5 % damping of its torsional mode) to the four-bar without flywheel in torque
  causality (DriveShaftFourBar.ssp); k = 1e5 N.m/rad unless given;
- ``PumpingWell``: PumpJack.fmu on RodString.fmu (PumpingWell.ssp) over 10 s, against the well as
  one model (crankfmu.well.CoupledWell) with the string's grid and step the FMU takes at that
  communication step; the rod string gives no derivatives: the masters hold its outputs;
- ``PressCushion``: the knuckle-joint press of the tests (TogglePress.fmu, its data-file cushion
  off) on DieCushion.fmu at its ram port (PressCushion.ssp), against the press with the cushion
  as a data-file load;
- ``FlywheelOnCrank``: speed causality with the flywheel on the crank side, FourBarSpeed.fmu with
  J_flywheel = 0.9 kg.m2 and DriveSpeed.fmu with J_drive = 0.1 kg.m2: the mechanism's tau_drive reads
  the drive's acceleration with nine times the drive's inertia, a loop no explicit master survives.

The error of a run is max |omega1 - reference| / max |omega1| over the communication points.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np

from crankfmu.fmi.ssp import SYSTEMS, drive_values
from crankfmu.validation.cosim import Coupling, cosimulate
from crankfmu.validation.coupling import coupled_reference, machine_inertia, shaft_damping, shaft_reference

#: the knuckle-joint press, a user's scenario file beside the harness (PressCushion.ssp's press;
#: the tests read it there too): installed with crankfmu.validation, so the harness finds it anywhere
PRESS = Path(__file__).resolve().parent / "data" / "togglepress_scenario.toml"
#: the native FMUs the scenes use: name -> crankfmu fmu's arguments (FMI 2.0)
BUILDS = {
    "FourBar": ["seed000", "--native"],
    "FourBarSpeed": ["seed000", "--native", "--causality", "speed"],
    "Drive": ["dc_pi", "--drive", "--native"],
    "DriveSpeed": ["dc_pi", "--drive", "--native", "--causality", "speed"],
    "ElasticShaft": ["elastic_shaft", "--shaft", "--native"],
    "TogglePress": [str(PRESS), "--native"],
    "DieCushion": ["die_cushion", "--cushion", "--native"],
    "PumpJack": ["pumpjack", "--native"],
    "RodString": ["rp11l_guo", "--well", "--native"],
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
    #: torque and a speed on each side
    bonds: tuple = ()
    #: the smallest communication step worth its time (s): the well's 10 s at 0.1 ms would take the
    #: master minutes a run
    smallest_step: float = 1e-4


def _ssp(name: str, omega: str, reference, **kwargs) -> Scene:
    """The scene of the SSP ``name`` (fmi.ssp.SYSTEMS): its FMUs, connections and parameter set
    "coupled", the speed ``omega`` recorded."""
    system = SYSTEMS[name]
    parameters = {component: {**system.fixed.get(component, {}), **(system.files[component]()
                               if component in system.files else {})} for component in system.sources}
    return Scene(name, dict(system.sources), Coupling.connections(system.connections), parameters, reference,
                 stop_time=system.stop_time, omega=omega, **kwargs)


def _press_reference(times) -> dict:
    """The press with its cushion as a data-file load, in process (scipy's reference integrator)."""
    import crankfmu

    result = crankfmu.simulate(str(PRESS), method="reference", output_times=np.round(times, 12))
    return {"omega1": result.omega1}


#: the pumping well's span (s): its start and a stroke and a half
WELL_SPAN = 10.0


def _well_reference(times) -> dict:
    """The well as one model, its string stepped as RodString.fmu steps it at this communication
    step (an equal division of the step at or below the grid's largest stable step)."""
    import math

    from crankfmu.dynamics.rodstring import grid
    from crankfmu.dynamics.well import load_well
    from crankfmu.fmi.ssp import WELL
    from crankfmu.well import CoupledWell, unit_scenario

    well = load_well(WELL)
    design = well.design()
    step = float(times[1] - times[0])
    cw = CoupledWell(unit_scenario(well), design, dt=step / math.ceil(step / grid(design).dt_max - 1e-9))
    t, omega = [0.0], [cw.y[1]]
    while cw.t < times[-1] - 1e-9:
        cw.step()
        t.append(cw.t)
        omega.append(cw.y[1])
    return {"omega1": np.interp(times, t, omega)}


def scene(name: str, k: float = 1e5) -> Scene:
    """The scene ``name`` (the shaft's stiffness ``k`` N.m/rad for ShaftDrive)."""
    speed_drive = drive_values(True)
    if name == "FourBarDrive":
        return _ssp(name, "FourBar.omega1", coupled_reference,
                    bonds=(("FourBar", "omega1", "tau_ext", "Drive", "tau", "omega"),))
    if name == "FourBarDriveSpeed":
        return _ssp(name, "Drive.omega", coupled_reference,
                    bonds=(("Drive", "omega", "tau_load", "FourBar", "tau_drive", "omega1"),))
    if name == "ShaftDrive":
        s = _ssp("DriveShaftFourBar", "FourBar.omega1", None)
        J_drive = s.parameters["Drive"]["J_drive"]
        c = shaft_damping(k, SHAFT_DAMPING_RATIO, J_drive, machine_inertia(J_flywheel=0.0))
        s.parameters["Shaft"].update(k=k, c=c)
        return replace(s, name=name, reference=lambda times: shaft_reference(times, k, c, J_drive),
                       bonds=(("Drive", "omega", "tau_load", "Shaft", "tau", "omega_a"),
                              ("FourBar", "omega1", "tau_ext", "Shaft", "tau", "omega_b")))
    if name == "PressCushion":
        return _ssp(name, "Press.omega1", _press_reference)
    if name == "PumpingWell":
        return replace(_ssp(name, "PumpJack.omega1", _well_reference), stop_time=WELL_SPAN, smallest_step=1e-3)
    if name == "FlywheelOnCrank":
        return Scene(name, {"Drive": "DriveSpeed", "FourBar": "FourBarSpeed"},
                     Coupling.connections((("Drive", "omega", "FourBar", "omega1"),
                                           ("FourBar", "tau_drive", "Drive", "tau_load"))),
                     {"FourBar": {"J_flywheel": 0.9},
                      "Drive": {**speed_drive, "J_drive": 0.1, "omega_start": OMEGA_START}},
                     lambda times: coupled_reference(times, J_flywheel=1.0),
                     bonds=(("Drive", "omega", "tau_load", "FourBar", "tau_drive", "omega1"),))
    raise ValueError(f"no coupled scene {name!r}: FourBarDrive, FourBarDriveSpeed, ShaftDrive, FlywheelOnCrank, "
                     "PressCushion or PumpingWell")


def build(out: Path, names=None) -> dict:
    """The scenes' native FMUs (``names`` of BUILDS, default all) built in ``out``: {name: path}."""
    from crankfmu.cli import main

    paths = {}
    for name in names or BUILDS:
        args = BUILDS[name]
        if main(["fmu", *args, "--out", str(out)]) != 0:
            raise RuntimeError(f"crankfmu fmu {' '.join(args)} failed")
        paths[name] = Path(out) / f"{name}.fmu"
    return paths


@dataclass
class Measured:
    error: float               # relative to max omega1; inf where the run diverged
    steps: int                 # FMU steps taken (a rollback's trials counted)
    failure: str = ""          # what the FMU or the master said where the run diverged


#: the third-party masters measure() runs besides cosim's modes: CoFMPy's Jacobi, one pass a step
#: or iterated with rollback
COFMPY = {"cofmpy": False, "cofmpy-iterative": True}


def measure(s: Scene, built: dict, mode: str, step: float, theta: float = 0.5, folder: Path | None = None,
            references: dict | None = None) -> Measured:
    """One run of scene ``s`` on the FMUs ``built`` (build()) in ``mode`` (cosim's MODES, or COFMPY's)
    at ``step``, against its reference (kept in ``references`` by the number of points, where given)."""
    fmus = {component: built[fmu] for component, fmu in s.fmus.items()}
    cache = references if references is not None else {}
    n = int(round(s.stop_time / step)) + 1
    if n not in cache:
        cache[n] = s.reference(np.arange(n) * step)
    reference = cache[n]["omega1"]
    if mode in COFMPY:
        from crankfmu.validation import masters

        run = masters.cofmpy(fmus, s.coupling.links(), s.parameters, s.stop_time, step, [s.omega], COFMPY[mode],
                             bound=DIVERGED * np.max(np.abs(reference)))
        if run.error or run.time.size != n - 1:
            return Measured(np.inf, int(run.time.size), run.error or "CoFMPy stopped early")
        error = np.max(np.abs(run[s.omega] - reference[1:])) / np.max(np.abs(reference))
        return Measured(float(error), n - 1)
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
