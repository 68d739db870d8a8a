"""The variables every crankfmu result and FMU exposes (shared/FMU_CONTRACT.md): the one home of
each output's and input's name, SI unit, description, causality and initial dependencies.

Read by ``simulation.Result`` and timeseries.csv (the columns), the FMU's variable registration
(``fmi.slave``), the modelDescription writer (``fmi.build``: units, UnitDefinitions,
InitialUnknowns) and the harness. A scenario's own parameters and ``[[outputs]]`` carry their units
in the scenario and mechanism files.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Variable:
    """One contract variable.

    ``initial``: what the output depends on at initialisation, as parameter names and the groups
    ``*geometry`` (lengths and masses of the mechanism file), ``*loads`` (the scenario's load
    parameters) and ``*all`` (every parameter and input); () for an output fixed at the start."""

    name: str
    unit: str
    description: str
    causality: str = "output"
    initial: tuple[str, ...] = ("*all",)


TIME = Variable("time", "s", "simulation time", "independent", ())

OUTPUTS = (
    Variable("phi1", "rad", "crank angle, unwrapped (keeps growing past 2*pi)", initial=("phi1_start",)),
    Variable("omega1", "rad/s", "crank angular speed", initial=("omega1_start",)),
    Variable("epsilon1", "rad/s2", "crank angular acceleration"),
    Variable("M_motor", "N.m", "motor torque on the crank",
             initial=("omega1_start", "A", "B", "A_low", "B_low", "omega_switch")),
    Variable("M_load", "N.m", "all external loads (weights, technological loads) reduced to the crank",
             initial=("phi1_start", "omega1_start", "*geometry", "*loads")),
    Variable("J_red", "kg.m2", "reduced moment of inertia at the crank, flywheel included",
             initial=("phi1_start", "J_flywheel", "*geometry")),
    Variable("E_kin", "J", "kinetic energy of the whole mechanism",
             initial=("phi1_start", "omega1_start", "J_flywheel", "*geometry")),
    # the work integrals ride along in the state: a host checks the energy balance
    # E_kin(t) - E_kin(0) = W_motor + W_load + W_ext without quadrature error
    Variable("W_motor", "J", "work done by the motor on the crank since the start", initial=()),
    Variable("W_load", "J", "work done by the loads (weights, technological loads) since the start", initial=()),
    Variable("W_ext", "J", "work done by tau_ext since the start", initial=()),
)

INPUTS = (
    Variable("tau_ext", "N.m", "extra torque on the crank from outside (the coupling port)", "input", ()),
)

#: Drive.fmu's outputs (its inputs and parameters are the drive file's)
DRIVE_OUTPUTS = (
    Variable("tau", "N.m", "torque of the drive on the crank (n_gear k_t i)"),
    Variable("i", "A", "armature current"),
    Variable("u", "V", "armature voltage from the PI controller"),
    Variable("P_el", "W", "electrical power into the armature (u i)"),
)

#: columns of timeseries.csv and fields of Result, in order, with their units
COLUMNS = {v.name: v.unit for v in (TIME, *OUTPUTS)}

#: the motor line's parameters (tunable in the FMU)
MOTOR_PARAMETERS = ("A", "B", "A_low", "B_low", "omega_switch")

#: parameters every scenario must declare, each with its value, unit and range in the scenario file
CONTRACT_PARAMETERS = (*MOTOR_PARAMETERS, "J_flywheel", "phi1_start", "omega1_start", "g")
