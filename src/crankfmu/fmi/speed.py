"""A mechanism FMU in speed causality (``[crank] causality = "speed"`` in the scenario file, or
``crankfmu fmu --causality speed``): the drive imposes the crank speed and the FMU answers with the
torque that takes.

The FMU a user couples to a motor model that carries the rotor and flywheel inertia and outputs
speed (Drive.fmu's speed variant, or the user's own). Input ``omega1`` (rad/s) and the ports'
inputs; outputs ``tau_drive`` (N.m), by inverse dynamics from the same tables as the torque-causal
FMU (modes.drive_torque: J epsilon1 + 0.5 J' omega1^2 - Q - the ports' torque), and phi1, the
integral of omega1.

Over a communication step omega1 is linear in time: from the value set, with the derivative the
host gave (fmi2SetRealInputDerivatives, native FMU), else with the slope of its last step (a
backward difference: without it the mechanism's own inertia J epsilon1 would vanish from the
coupling, and the co-simulation would not converge as the step shrinks). phi1 is that line's
integral, exact; the works are Gauss-Legendre sums (5 points per degree of crank angle). Where
the host's omega1 differs from the last step's line at a communication point, the speed jumps
there and the drive does the jump's work, 0.5 J (omega1_new^2 - omega1_old^2), so the energy
balance E_kin(t) - E_kin(0) = W_drive + W_load + W_ext holds across communication points.
"""

from __future__ import annotations

import math
import numpy as np

from ..contract import MOTOR_PARAMETERS, SPEED_INPUTS, SPEED_OUTPUTS, Variable
from ..dynamics import modes
from ..parameters import Parameter
from .core import Declared, SlaveCore
from .slave import build_design, fmu_scenario, lazy_outputs, output_quantities, reaction_variables

(OMEGA1,) = SPEED_INPUTS
#: parameters the speed-causal FMU does not have: the motor line (the drive is outside) and the
#: start speed (the input omega1 is the speed)
NOT_DECLARED = (*MOTOR_PARAMETERS, "omega1_start")
#: Gauss-Legendre nodes and weights on [0, 1]
_NODES, _WEIGHTS = (lambda x, w: (0.5 * (x + 1.0), 0.5 * w))(*np.polynomial.legendre.leggauss(5))


def declared(scenario) -> Declared:
    """The variables of the speed-causal FMU of ``scenario``."""
    definition = scenario.mechanism_definition()
    outputs = [*SPEED_OUTPUTS,
               *(Variable(q.name, q.unit(definition), q.description) for q in output_quantities(scenario)),
               *reaction_variables(scenario)]
    inputs = [Parameter(OMEGA1.name, scenario.parameters["omega1_start"].value, OMEGA1.unit, OMEGA1.description),
              *(Parameter(p.input_name, 0.0, p.input_unit, p.input_description) for p in scenario.ports)]
    parameters = [p for n, p in scenario.parameters.items() if n not in NOT_DECLARED]
    return Declared(outputs, inputs, parameters)


def drive_torque_at(table, J_flywheel: float, phi1, omega1, epsilon1, port_inputs):
    """(tau_drive, Q, tau_ports, J, 0.5 J') (N.m, N.m, N.m, kg.m2, kg.m2/rad) at arrays of states,
    from the design's table: the slider forces' side from omega1's sign."""
    values = table.evaluate(phi1)
    J, half_dJ, Q = table.coefficients_at(phi1, omega1, J_flywheel, values)
    tau = np.zeros_like(J)
    for value, column in zip(port_inputs, values[len(values) - table.n_ports:]):
        tau = tau + value * column
    return modes.drive_torque(J, half_dJ, Q, tau, omega1, epsilon1), Q, tau, J, half_dJ


class SpeedCore(SlaveCore):
    """Variables and model of a mechanism FMU in speed causality."""

    def __init__(self, slave, scenario_name: str):
        self.scenario = fmu_scenario(scenario_name)
        super().__init__(slave, self.scenario.experiment.start_time)
        self.quantities = output_quantities(self.scenario)
        self.port_inputs = [p.input_name for p in self.scenario.ports]
        self.model = self.table = None
        # the state at the current time: phi1, omega1 there and its slope over the last step
        # (last_step s, None before the first), the works
        self.state = {"phi1": 0.0, "omega1": 0.0, "slope": 0.0, "last_step": None,
                      "W_drive": 0.0, "W_load": 0.0, "W_ext": 0.0}
        self.out = dict.fromkeys((v.name for v in SPEED_OUTPUTS), 0.0)   # before initialisation: 0
        state = self.state
        self.lazy, getters = lazy_outputs(self, lambda: (state["phi1"], state["omega1"], state["slope"]))
        getters.update({v.name: (lambda n=v.name: self.out[n]) for v in SPEED_OUTPUTS})
        self.declare(declared(self.scenario), getters)
        self.attach()

    # ------------------------------------------------------------------ model hooks
    def initialise(self):
        values = {**self.scenario.values, **{n: self.values[n] for n in self.scenario.parameters
                                             if n in self.values}}
        self.model, self.table = build_design(self.scenario, values)
        self.quantities = output_quantities(self.scenario, self.model.reduced.ports)
        omega = self.values[OMEGA1.name]
        self.state.update(phi1=self.values["phi1_start"], omega1=omega, slope=0.0, last_step=None,
                          W_drive=0.0, W_load=0.0, W_ext=0.0)
        self._update_outputs()

    def _ports(self):
        return [self.values[n] for n in self.port_inputs]

    def _update_outputs(self):
        st = self.state
        tau, Q, _, J, _ = drive_torque_at(self.table, self.model.reduced.J_flywheel, np.array([st["phi1"]]),
                                          np.array([st["omega1"]]), st["slope"], self._ports())
        self.out.update(phi1=st["phi1"], epsilon1=st["slope"], tau_drive=float(tau[0]), M_load=float(Q[0]),
                        J_red=float(J[0]), E_kin=modes.kinetic_energy(float(J[0]), st["omega1"]),
                        W_drive=st["W_drive"], W_load=st["W_load"], W_ext=st["W_ext"])
        for lazy in self.lazy:
            lazy.clear()

    def advance(self, target: float):
        st = self.state
        h = target - self.time
        omega = self.values[OMEGA1.name]
        # omega1's slope over this step: the input's change over the last step (0 on the first),
        # from the input at the last step's start, omega1 there less the line's rise
        last = st["last_step"]
        slope = 0.0 if last is None else (omega - (st["omega1"] - st["slope"] * last)) / last
        phi0 = st["phi1"]
        if omega != st["omega1"]:
            # the host's omega1 differs from the line of the last step at this point: the speed
            # jumps, and the drive does the jump's work, 0.5 J (omega1'^2 - omega1^2), J at phi0
            J = self.out["J_red"]
            st["W_drive"] += modes.kinetic_energy(J, omega) - modes.kinetic_energy(J, st["omega1"])
        turned = abs(omega * h + 0.5 * slope * h * h)
        pieces = max(1, int(math.ceil(turned / math.radians(1.0))))
        s = ((np.arange(pieces)[:, None] + _NODES[None, :]) * (h / pieces)).ravel()
        weights = np.tile(_WEIGHTS, pieces) * (h / pieces)
        w = omega + slope * s
        phi = phi0 + omega * s + 0.5 * slope * s * s
        tau, Q, tau_ports, _, _ = drive_torque_at(self.table, self.model.reduced.J_flywheel, phi, w, slope,
                                                  self._ports())
        st["W_drive"] += float(np.dot(weights, tau * w))
        st["W_load"] += float(np.dot(weights, Q * w))
        st["W_ext"] += float(np.dot(weights, tau_ports * w))
        st.update(phi1=phi0 + omega * h + 0.5 * slope * h * h, omega1=omega + slope * h, slope=slope, last_step=h)
        self._update_outputs()

    def outputs_now(self) -> np.ndarray:
        return np.array([self.out[v.name] for v in SPEED_OUTPUTS], dtype=float)

    # ------------------------------------------------------------------ FMU state
    def model_state(self):
        return None if self.model is None else dict(self.state)

    def can_restore(self) -> bool:
        return self.model is not None

    def restore_model_state(self, state):
        self.state.update(state)
        self._update_outputs()
