"""The FMU's behaviour, kept in the package so the FMU runs the same model code as the CLI.

``FmuCore`` registers the variables of shared/FMU_CONTRACT.md (plus the scenario's geometry,
mass and load parameters) on a pythonfmu ``Fmi2Slave`` and implements its life cycle. The slave
scripts (generated from ``fmu_build/slave_template.py``) are thin: ``class FourBar(Fmi2Slave)``
delegating to ``FmuCore``. A scenario's ``[[outputs]]`` (slider position, arm speed, ...) become
extra outputs, computed from the analytic transfer functions only when the host reads them.

Inside ``fmi2DoStep`` the movement equation is integrated by the fast path: the reduced model is
tabulated once at initialisation (dynamics.tabulated, its error bound checked against the contour
engine) and the compiled Dormand-Prince kernel steps it with rtol honoured and every switch
located (the motor line's kink, the slider forces' switch angles and reversals). A whole
``fmi2DoStep`` is one call into the kernel; the outputs are one array the getters read, and the
link-level kinematics are computed only when a host reads a mechanism-specific output.
Communication points inside a step are served from the dense output, so the trajectory does not
depend on the communication step. A tunable parameter or the input ``tau_ext`` that changed since
the last step restarts the stepper at the communication point, so the change takes effect from
that step on.

Bad input never raises into the host: the failing call logs a message naming the variable and
its valid range with fmi2Error, and every later step fails the same way until a valid value is set.
"""

from __future__ import annotations

import math

import numpy as np

from .dynamics import MotorLine
from .errors import CrankfmuError, ParameterError
from .integrators.fast import TABLE_TOLERANCE, FastStepper, kn
from .scenario import Parameter, load_scenario
from .simulation import COLUMNS

#: contract outputs and their descriptions; units come from simulation.COLUMNS (one table)
OUTPUTS = {
    "phi1": "crank angle, unwrapped (keeps growing past 2*pi)",
    "omega1": "crank angular speed",
    "epsilon1": "crank angular acceleration",
    "M_motor": "motor torque on the crank",
    "M_load": "all external loads (weights, technological loads) reduced to the crank",
    "J_red": "reduced moment of inertia at the crank, flywheel included",
    "E_kin": "kinetic energy of the whole mechanism",
    # the work integrals ride along in the state: a host checks the energy balance
    # E_kin(t) - E_kin(0) = W_motor + W_load + W_ext without quadrature error
    "W_motor": "work done by the motor on the crank since the start",
    "W_load": "work done by the loads (weights, technological loads) since the start",
    "W_ext": "work done by tau_ext since the start",
}
#: where each output sits in the kernel's output row (E_kin is computed from J_red and omega1)
ROW = {name: i for i, name in enumerate(kn.ROW_FIELDS)}
TAU_EXT = ("N.m", "extra torque on the crank from outside (the coupling port)")
MOTOR = ("A", "B", "A_low", "B_low", "omega_switch")


class FmuCore:
    """Variables and life cycle of a crankfmu FMU for one scenario."""

    def __init__(self, slave, scenario_name: str):
        from pythonfmu.enums import Fmi2Causality, Fmi2Variability
        from pythonfmu.variables import Real

        self.slave = slave
        self.scenario = load_scenario(scenario_name)
        self.parameters = dict(self.scenario.parameters)
        self.parameters["rtol"] = Parameter(
            "rtol", self.scenario.experiment.tolerance, "1", min=0.0, min_inclusive=False,
            description="relative tolerance of the FMU's internal integrator (Dormand-Prince 5(4), compiled)")
        self.values = {n: p.value for n, p in self.parameters.items()}
        self.tau_ext = 0.0
        self.row = np.zeros(len(ROW))       # the kernel's output row at the current time
        # refused values by variable: stepping is blocked until each is corrected
        self.errors: dict[str, str] = {}
        self.model = None
        self.stepper: FastStepper | None = None
        self.time = self.scenario.experiment.start_time
        self.t_limit = math.inf
        self.pending = False                # a tunable parameter or input changed: restart
        self.rebuild = False                # the motor line changed
        self.units = {}
        self.quantities = self.scenario.quantities
        self._quantity_values: dict[str, float] | None = None    # filled on first read after a step

        for name, description in OUTPUTS.items():
            slave.register_variable(Real(name, causality=Fmi2Causality.output,
                                         variability=Fmi2Variability.continuous, description=description,
                                         getter=self._getter(name)))
            self.units[name] = COLUMNS[name]
        definition = self.scenario.mechanism_definition()
        for q in self.quantities:
            slave.register_variable(Real(q.name, causality=Fmi2Causality.output,
                                         variability=Fmi2Variability.continuous, description=q.description,
                                         getter=(lambda n=q.name: self._quantity(n))))
            self.units[q.name] = q.unit(definition)
        slave.register_variable(Real("tau_ext", causality=Fmi2Causality.input,
                                     variability=Fmi2Variability.continuous, description=TAU_EXT[1],
                                     getter=lambda: self.tau_ext, setter=self._set_input))
        self.units["tau_ext"] = TAU_EXT[0]
        for name, p in self.parameters.items():
            variability = Fmi2Variability.tunable if p.tunable else Fmi2Variability.fixed
            slave.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=variability,
                                         description=f"{p.description} (valid range {p.range_text()})",
                                         getter=(lambda n=name: self.values[n]),
                                         setter=(lambda v, n=name: self._set_parameter(n, v))))
            self.units[name] = p.unit

    def _getter(self, name: str):
        row = self.row
        if name == "E_kin":
            J, omega = ROW["J_red"], ROW["omega1"]
            return lambda: 0.5 * float(row[J]) * float(row[omega]) ** 2
        i = ROW[name]
        return lambda: float(row[i])

    # ------------------------------------------------------------------ setters
    def _refuse(self, message: str, name: str):
        """Log with fmi2Error status and block stepping. Never raise: pythonfmu turns any Python
        exception into fmi2Fatal, after which the host must drop the instance."""
        from pythonfmu.enums import Fmi2Status

        self.errors[name] = f"{name}: {message}"
        self.slave.log(self.errors[name], Fmi2Status.error)

    def _set_parameter(self, name: str, value):
        try:
            v = self.parameters[name].check(value)
        except ParameterError as exc:
            self._refuse(str(exc), name)
            return
        self.values[name] = v
        self.errors.pop(name, None)
        if self.model is not None:
            if name in MOTOR:
                self.pending = self.rebuild = True
            # fixed parameters cannot change after initialisation (the host is told so by FMI)

    def _set_input(self, value):
        v = float(value)
        if not math.isfinite(v):
            self._refuse(f"input tau_ext = {value!r} must be a finite torque in N.m", "tau_ext")
            return
        if v != self.tau_ext:
            self.tau_ext = v
            self.pending = True
        self.errors.pop("tau_ext", None)

    # ------------------------------------------------------------------ life cycle
    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self.time = float(start_time)
        self.t_limit = math.inf if stop_time is None else float(stop_time)

    def exit_initialization_mode(self):
        """Build the model from the parameters now set; refuse a design that cannot work."""
        try:
            scenario = self.scenario.with_params(**{k: v for k, v in self.values.items() if k != "rtol"})
            self.model = scenario.build()
            table = self.model.reduced.table(TABLE_TOLERANCE)
            if table.error_bound > table.tolerance:
                from pythonfmu.enums import Fmi2Status

                self.slave.log(f"the reduced model is tabulated to {table.error_bound:.2g} relative, not "
                               f"{table.tolerance:g}: the geometry is close to a dead point", Fmi2Status.warning)
            self.stepper = FastStepper(table, self.model.motor, self.model.reduced.J_flywheel, self.values["rtol"],
                                       self.tau_ext)
            self.row[:] = self.stepper.start(self.time, self.model.y0)
        except CrankfmuError as exc:
            self.model = None
            self._refuse(str(exc), "model")     # the message names the parameters involved
            return
        self._quantity_values = None
        self.pending = self.rebuild = False

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self.errors or self.model is None:
            from pythonfmu.enums import Fmi2Status

            reason = "; ".join(self.errors.values()) or "the model was not initialised"
            self.slave.log(f"cannot step: {reason}", Fmi2Status.error)
            return False
        try:
            if self.pending:
                if self.rebuild:
                    v = self.values
                    self.stepper.set_motor(MotorLine(v["A"], v["B"], v["A_low"], v["B_low"], v["omega_switch"]))
                self.stepper.set_tau_ext(self.tau_ext)
                self.stepper.restart(current_time)
                self.pending = self.rebuild = False
            target = current_time + step_size
            self.row[:] = self.stepper.advance(target, max(self.t_limit, target))
            self.time = target
            self._quantity_values = None
            return True
        except CrankfmuError as exc:
            self._refuse(f"step from t = {current_time:g} s failed: {exc}", "step")
            return False

    def _quantity(self, name: str) -> float:
        """A mechanism-specific output, computed on first read after a step (one kinematics call
        for all of them): a host that never reads them never pays for them."""
        if self.model is None:
            return 0.0
        if self._quantity_values is None:
            from .mechanisms.quantities import evaluate_all

            row = self.row
            kin = self.model.mechanism.kinematics(np.array([row[ROW["phi1"]]]))
            omega, eps = float(row[ROW["omega1"]]), float(row[ROW["epsilon1"]])
            self._quantity_values = {k: float(v[0]) for k, v in
                                     evaluate_all(self.quantities, kin, omega, eps).items()}
        return self._quantity_values[name]

    # ------------------------------------------------------------------ FMU state
    def get_state(self) -> dict:
        """Everything that determines the continuation, as plain floats and lists."""
        return {
            "values": dict(self.values), "tau_ext": self.tau_ext, "row": self.row.tolist(),
            "time": self.time, "errors": dict(self.errors), "pending": self.pending, "rebuild": self.rebuild,
            "stepper": None if self.stepper is None else self.stepper.state.tolist(),
            "stepper_parameters": None if self.stepper is None else self.stepper.P.tolist(),
        }

    def set_state(self, state: dict):
        self.values = dict(state["values"])
        self.tau_ext = state["tau_ext"]
        self.row[:] = state["row"]
        self._quantity_values = None
        self.time = state["time"]
        self.errors = dict(state["errors"])
        self.pending, self.rebuild = state["pending"], state["rebuild"]
        if state["stepper"] is not None and self.stepper is not None:
            self.stepper.state[:] = state["stepper"]
            self.stepper.P[:] = state["stepper_parameters"]
