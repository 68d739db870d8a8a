"""A mechanism FMU in speed causality (``[crank] causality = "speed"`` in the scenario file, or
``crankfmu fmu --causality speed``): the drive imposes the crank speed and the FMU answers with the
torque that takes.

The FMU a user couples to a motor model that carries the rotor and flywheel inertia and outputs
speed (Drive.fmu's speed variant, or the user's own). Input ``omega1`` (rad/s) and the ports'
inputs; outputs ``tau_drive`` (N.m), by inverse dynamics from the same tables as the torque-causal
FMU (J epsilon1 + 0.5 J' omega1^2 - Q - the ports' torque), and phi1, the integral of omega1.

The step is the C kernel's (``ck_speed_advance``, crank_speed.c; the native FMU runs the same
code): omega1 linear in time over a communication step, with the slope of its last step (a
backward difference) since pythonfmu passes no input derivative; phi1 that line's integral; the
works Gauss-Legendre sums; a jump of the input at a communication point done by the drive,
0.5 J (omega1_new^2 - omega1_old^2), so that E_kin(t) - E_kin(0) = W_drive + W_load + W_ext holds
across communication points.
"""

from __future__ import annotations

import numpy as np

from ...contract import MOTOR_PARAMETERS, SPEED_INPUTS, SPEED_OUTPUTS
from ...integrators.fast import SpeedStepper
from ...native import SPEED_ROW_FIELDS
from ...parameters import Parameter
from .core import Declared, SlaveCore
from ..variables import friction_variables, output_quantities, quantity_variables, reaction_variables
from .slave import RowOutputs, build_design, fmu_scenario, lazy_outputs, output_reads

(OMEGA1,) = SPEED_INPUTS
#: parameters the speed-causal FMU does not have: the motor line (the drive is outside) and the
#: start speed (the input omega1 is the speed)
NOT_DECLARED = (*MOTOR_PARAMETERS, "omega1_start")


def declared(scenario) -> Declared:
    """The variables of the speed-causal FMU of ``scenario``."""
    outputs = [*SPEED_OUTPUTS, *quantity_variables(scenario), *reaction_variables(scenario),
               *friction_variables(scenario)]
    inputs = [Parameter(OMEGA1.name, scenario.parameters["omega1_start"].value, OMEGA1.unit, OMEGA1.description),
              *(Parameter(p.input_name, 0.0, p.input_unit, p.input_description) for p in scenario.ports)]
    parameters = [p for n, p in scenario.parameters.items() if n not in NOT_DECLARED]
    return Declared(outputs, inputs, parameters)


class SpeedCore(RowOutputs, SlaveCore):
    """Variables and model of a mechanism FMU in speed causality."""

    fields = SPEED_ROW_FIELDS

    def __init__(self, slave, scenario_name: str):
        self.scenario = fmu_scenario(scenario_name)
        super().__init__(slave, self.scenario.experiment.start_time)
        self.quantities = output_quantities(self.scenario)
        self.port_inputs = [p.input_name for p in self.scenario.ports]
        self.model = None
        self.stepper: SpeedStepper | None = None
        self.reads = (None, None)        # the output tables' readers (output_reads), once initialised
        self.row = np.zeros(len(SPEED_ROW_FIELDS))       # the kernel's output row at the current time
        self.lazy, getters = lazy_outputs(self, self._motion)
        getters.update({v.name: self._getter(v.name) for v in SPEED_OUTPUTS})
        self.declare(declared(self.scenario), getters)
        self.attach()

    # ------------------------------------------------------------------ model hooks
    def initialise(self):
        values = {**self.scenario.values, **{n: self.values[n] for n in self.scenario.parameters
                                             if n in self.values}}
        design = build_design(self.scenario, values)
        self.model = design.model
        self.quantities = output_quantities(self.scenario, self.model.reduced.ports)
        self.stepper = SpeedStepper(design.table, self.model.reduced.J_flywheel, row=self.row)
        self.reads = output_reads(design, self.quantities, self.stepper)
        self.stepper.set_port_inputs(self._ports(), t_input=self.time)
        self.stepper.start(self.time, self.values["phi1_start"], self.values[OMEGA1.name])
        self._clear()

    def _ports(self):
        return [self.values[n] for n in self.port_inputs]

    def inputs_set(self):
        self.stepper.set_port_inputs(self._ports(), t_input=self.time)
        self.stepper.refresh(self.values[OMEGA1.name])
        self._clear()

    def advance(self, target: float):
        # the ports' inputs held over the step from its start; omega1's slope from the last step
        self.stepper.set_port_inputs(self._ports(), t_input=self.time)
        self._clear()
        self.stepper.advance(target, self.values[OMEGA1.name])
