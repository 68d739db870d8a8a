"""The FMU's behaviour, kept in the package so the FMU runs the same model code as the CLI.

``FmuCore`` registers the variables of shared/FMU_CONTRACT.md (plus the scenario's geometry,
mass and load parameters) on a pythonfmu ``Fmi2Slave`` and implements its life cycle. The slave
scripts (generated from ``slave_script.py.in`` beside this file) are thin: ``class FourBar(Fmi2Slave)``
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

Nothing raises into pythonfmu, which would turn any Python exception into fmi2Fatal and release
the instance's Python objects: every FMI entry point of the slave is bound to a guarded method of
``FmuCore`` (``attach``). A refusal logs a message naming the variable and its valid range with
fmi2Error status (the shim in front of pythonfmu, ``shim/fmu_shim.c``, makes the call return
fmi2Error and passes the message to the host whatever its logging setting), and every later call
that needs a valid model fails the same way until a valid value is set. The life cycle is
checked here: a call out of order (a step before initialisation, a fixed parameter set after it)
is refused, not ignored.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from ..dynamics import MotorLine
from ..errors import CrankfmuError, ParameterError
from ..integrators.fast import TABLE_TOLERANCE, FastStepper, kn
from ..scenario import Parameter, load_scenario
from ..contract import INPUTS, MOTOR_PARAMETERS as MOTOR, OUTPUTS

#: where each output sits in the kernel's output row (E_kin is computed from J_red and omega1)
ROW = {name: i for i, name in enumerate(kn.ROW_FIELDS)}
(TAU_EXT,) = INPUTS

# life-cycle phases (FMI 2.0 co-simulation state machine, as far as the model needs it)
INSTANTIATED, INITIALIZATION, STEPPING, REFUSED, TERMINATED = (
    "instantiated", "initialization mode", "stepping", "refused", "terminated")
#: the slave's FMI entry points and what each returns when it fails (see FmuCore.attach)
ENTRY_POINTS = {
    "setup_experiment": None, "enter_initialization_mode": None, "exit_initialization_mode": None,
    "do_step": False, "terminate": None,
    "get_real": "nan", "set_real": None, "get_integer": 0, "set_integer": None,
    "get_boolean": False, "set_boolean": None, "get_string": "", "set_string": None,
    "_get_fmu_state": "state", "_set_fmu_state": None,
}


#: built designs of this process, most recent last: an instance that is reset, or freed and
#: instantiated again, with the same design (a host's restart, a sweep over the motor line or the
#: start values) reuses its model and tables instead of tabulating again; they are only read
#: while stepping
_DESIGNS: dict = {}
_DESIGNS_KEPT = 8
#: what the tables do not depend on: the motor line and the start values (set on the stepper)
NOT_TABULATED = (*MOTOR, "phi1_start", "omega1_start")


def build_design(scenario, values: dict):
    """(model, table) of the scenario with these parameter values, built once per process.

    The model's motor line and start state are those of the first design built with these
    tables: take them from ``values``, not from the model."""
    key = (scenario.where, tuple(sorted((k, v) for k, v in values.items() if k not in NOT_TABULATED)))
    if key in _DESIGNS:
        _DESIGNS[key] = _DESIGNS.pop(key)           # most recent last
        return _DESIGNS[key]
    model = scenario.with_params(**values).build()
    design = (model, model.reduced.table(TABLE_TOLERANCE))
    _DESIGNS[key] = design
    while len(_DESIGNS) > _DESIGNS_KEPT:
        del _DESIGNS[next(iter(_DESIGNS))]
    return design


def time_matches(t_host: float, t_own: float, step: float) -> bool:
    """Whether a host's communication point is the FMU's own time up to the host's rounding.

    A host that accumulates t += h drifts by rounding only (far below a step); one that skips or
    repeats a step is off by a whole step."""
    return abs(t_host - t_own) <= 1e-9 * max(1.0, abs(t_own)) + 1e-6 * step


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
        self.phase = INSTANTIATED
        self.model = None
        self.stepper: FastStepper | None = None
        self.time = self.scenario.experiment.start_time
        self.t_limit = math.inf
        self.pending = False                # a tunable parameter or input changed: restart
        self.rebuild = False                # the motor line changed
        self.units = {}
        self.quantities = self.scenario.quantities
        self._quantity_values: dict[str, float] | None = None    # filled on first read after a step

        for out in OUTPUTS:
            slave.register_variable(Real(out.name, causality=Fmi2Causality.output,
                                         variability=Fmi2Variability.continuous, description=out.description,
                                         getter=self._getter(out.name)))
            self.units[out.name] = out.unit
        definition = self.scenario.mechanism_definition()
        for q in self.quantities:
            slave.register_variable(Real(q.name, causality=Fmi2Causality.output,
                                         variability=Fmi2Variability.continuous, description=q.description,
                                         getter=(lambda n=q.name: self._quantity(n))))
            self.units[q.name] = q.unit(definition)
        slave.register_variable(Real(TAU_EXT.name, causality=Fmi2Causality.input,
                                     variability=Fmi2Variability.continuous, description=TAU_EXT.description,
                                     getter=lambda: self.tau_ext, setter=self._set_input))
        self.units[TAU_EXT.name] = TAU_EXT.unit
        for name, p in self.parameters.items():
            variability = Fmi2Variability.tunable if p.tunable else Fmi2Variability.fixed
            slave.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=variability,
                                         description=f"{p.description} (valid range {p.range_text()})",
                                         getter=(lambda n=name: self.values[n]),
                                         setter=(lambda v, n=name: self._set_parameter(n, v))))
            self.units[name] = p.unit
        self.outputs = {vr for vr, v in slave.vars.items() if v.causality == Fmi2Causality.output}
        self.attach()
        if not kn.COMPILED:
            from pythonfmu.enums import Fmi2Status

            slave.log(f"numba is not in use in the Python at {sys.prefix} (not importable, or CRANKFMU_JIT=0): "
                      "the FMU steps its compiled kernel as plain Python, correct but about 10x slower per "
                      "step; to enable it: python -m pip install numba (in that Python)", Fmi2Status.warning)

    def attach(self):
        """Bind every FMI entry point of the slave to its guarded method here.

        pythonfmu calls them by attribute on the instance, so instance attributes take precedence
        over Fmi2Slave's methods. A Python exception must never reach pythonfmu: it returns
        fmi2Fatal and releases the instance's Python objects, and a later fmi2FreeInstance frees
        them again. An unexpected exception is logged as fmi2Error with its text instead."""
        for name, failed in ENTRY_POINTS.items():
            setattr(self.slave, name, self._guarded(name, getattr(self, name.lstrip("_")), failed))

    def _guarded(self, name, method, failed):
        def entry(*args):
            try:
                # no floating-point warnings on the host's stderr: non-finite results are checked
                # and refused with a message instead
                with np.errstate(all="ignore"):
                    return method(*args)
            except Exception as exc:        # noqa: BLE001 - the host gets fmi2Error and the text
                self._error(f"{name}: internal error {type(exc).__name__}: {exc}")
                if failed == "nan":
                    return [math.nan] * len(args[0])
                if failed == "state":
                    return {"invalid": f"{type(exc).__name__}: {exc}"}
                if failed in (0, False, "") and args and isinstance(args[0], (list, tuple)):
                    return [failed] * len(args[0])
                return failed
        return entry

    def _getter(self, name: str):
        row = self.row
        if name == "E_kin":
            J, omega = ROW["J_red"], ROW["omega1"]
            return lambda: 0.5 * float(row[J]) * float(row[omega]) ** 2
        i = ROW[name]
        return lambda: float(row[i])

    # ------------------------------------------------------------------ messages
    def _error(self, message: str):
        """Log with fmi2Error status: the shim makes the current call return fmi2Error."""
        from pythonfmu.enums import Fmi2Status

        self.slave.log(message, Fmi2Status.error)

    def _refuse(self, message: str, name: str):
        """Log with fmi2Error status and block stepping until the value is corrected."""
        self.errors[name] = f"{name}: {message}"
        self._error(self.errors[name])

    def _fail(self, message: str):
        """The model can no longer go on (a refused design, a failed step): every later call that
        needs it fails with this reason."""
        self.phase = REFUSED
        self._refuse(message, "model")

    # ------------------------------------------------------------------ variables
    def _variable(self, vr, kind: str):
        var = self.slave.vars.get(vr) if isinstance(vr, int) else None
        if var is None:
            self._error(f"unknown value reference {vr!r}: this FMU's {kind} variables are 0..{len(self.slave.vars) - 1}")
        return var

    def get_real(self, vrs):
        values = []
        for vr in vrs:
            var = self._variable(vr, "Real")
            if var is None:
                values.append(math.nan)
            elif vr in self.outputs and self.phase == REFUSED:
                self._error(f"{var.name}: no valid model to read it from ({self.errors.get('model', 'refused')})")
                values.append(math.nan)
            else:
                values.append(float(var.getter()))
        return values

    def set_real(self, vrs, values):
        if len(vrs) != len(values):
            self._error(f"fmi2SetReal: {len(vrs)} value references but {len(values)} values")
        for vr, value in zip(vrs, values):
            var = self._variable(vr, "Real")
            if var is None:
                continue
            if var.setter is None:
                self._error(f"{var.name} is an output of this FMU: it cannot be set")
                continue
            var.setter(value)

    def _no_variables(self, kind):
        def refuse(vrs, values=None):
            for vr in vrs:
                self._error(f"unknown value reference {vr!r} of type {kind}: this FMU has Real variables only")
            return None if values is not None else []
        return refuse

    def get_integer(self, vrs):
        self._no_variables("Integer")(vrs)
        return [0] * len(vrs)

    def set_integer(self, vrs, values):
        self._no_variables("Integer")(vrs, values)

    def get_boolean(self, vrs):
        self._no_variables("Boolean")(vrs)
        return [False] * len(vrs)

    def set_boolean(self, vrs, values):
        self._no_variables("Boolean")(vrs, values)

    def get_string(self, vrs):
        self._no_variables("String")(vrs)
        return [""] * len(vrs)

    def set_string(self, vrs, values):
        self._no_variables("String")(vrs, values)

    # ------------------------------------------------------------------ setters
    def _set_parameter(self, name: str, value):
        p = self.parameters[name]
        if self.phase in (STEPPING, TERMINATED) and not p.tunable:
            self._error(f"{name} is a fixed parameter: it can only be set before fmi2ExitInitializationMode "
                        f"(value kept: {self.values[name]!r}; valid range {p.range_text()})")
            return
        try:
            v = p.check(value)
        except ParameterError as exc:
            self._refuse(str(exc), name)
            return
        self.values[name] = v
        self.errors.pop(name, None)
        if self.model is not None and name in MOTOR:
            self.pending = self.rebuild = True

    def _set_input(self, value):
        v = float(value)
        if not math.isfinite(v):
            self._refuse(f"input tau_ext = {value!r} must be a finite torque in N.m (valid range (-inf, inf) N.m)",
                         "tau_ext")
            return
        if v != self.tau_ext:
            self.tau_ext = v
            self.pending = True
        self.errors.pop("tau_ext", None)

    # ------------------------------------------------------------------ life cycle
    def _out_of_order(self, call: str, allowed: tuple) -> bool:
        if self.phase in allowed:
            return False
        self._error(f"{call} is not allowed in {self.phase} (only in {' or '.join(allowed)})")
        return True

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        if self._out_of_order("fmi2SetupExperiment", (INSTANTIATED,)):
            return
        start = float(start_time)
        stop = math.inf if stop_time is None else float(stop_time)
        if not math.isfinite(start):
            self._refuse(f"startTime = {start_time!r} must be a finite time in s", "startTime")
            return
        if math.isnan(stop) or stop < start:
            self._refuse(f"stopTime = {stop_time!r} must be >= startTime = {start!r} s", "stopTime")
            return
        self.errors.pop("startTime", None)
        self.errors.pop("stopTime", None)
        self.time, self.t_limit = start, stop

    def enter_initialization_mode(self):
        if not self._out_of_order("fmi2EnterInitializationMode", (INSTANTIATED,)):
            self.phase = INITIALIZATION

    def exit_initialization_mode(self):
        """Build the model from the parameters now set; refuse a design that cannot work."""
        if self._out_of_order("fmi2ExitInitializationMode", (INITIALIZATION,)):
            return
        if self.errors:
            self._fail("cannot initialise: " + "; ".join(self.errors.values()))
            return
        try:
            v = self.values
            self.model, table = build_design(self.scenario, {k: x for k, x in v.items() if k != "rtol"})
            y0 = np.array(self.model.y0, dtype=float)
            y0[0], y0[1] = v["phi1_start"], v["omega1_start"]
            motor = MotorLine(v["A"], v["B"], v["A_low"], v["B_low"], v["omega_switch"])
            if table.error_bound > table.tolerance:
                from pythonfmu.enums import Fmi2Status

                self.slave.log(f"the reduced model is tabulated to {table.error_bound:.2g} relative, not "
                               f"{table.tolerance:g}: the geometry is close to a dead point", Fmi2Status.warning)
            self.stepper = FastStepper(table, motor, self.model.reduced.J_flywheel, v["rtol"], self.tau_ext)
            self.row[:] = self.stepper.start(self.time, y0)
        except CrankfmuError as exc:
            self._fail(str(exc))     # the message names the parameters involved
            return
        if not np.all(np.isfinite(self.row)):
            self._fail(f"the initial state is not finite ({self._row_text()}): check the parameters")
            return
        self._quantity_values = None
        self.pending = self.rebuild = False
        self.phase = STEPPING

    def _row_text(self) -> str:
        return ", ".join(f"{name} = {self.row[i]:g}" for name, i in ROW.items())

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self.phase != STEPPING:
            reason = {INSTANTIATED: "the model is not initialised (call fmi2ExitInitializationMode first)",
                      INITIALIZATION: "the model is not initialised (call fmi2ExitInitializationMode first)",
                      TERMINATED: "the instance was terminated"}.get(self.phase)
            reason = reason or "; ".join(self.errors.values()) or "the model was refused"
            self._error(f"fmi2DoStep: cannot step: {reason}")
            return False
        if self.errors:
            self._error("fmi2DoStep: cannot step: " + "; ".join(self.errors.values()))
            return False
        if not (math.isfinite(step_size) and step_size > 0.0) or not math.isfinite(current_time):
            self._error(f"fmi2DoStep: currentCommunicationPoint = {current_time!r} s must be finite and "
                        f"communicationStepSize = {step_size!r} s finite and > 0")
            return False
        if not time_matches(current_time, self.time, step_size):
            self._error(f"fmi2DoStep: currentCommunicationPoint = {current_time!r} s is not this FMU's time "
                        f"{self.time!r} s (a step was skipped or repeated; roll back with fmi2SetFMUstate)")
            return False
        try:
            if self.pending:
                if self.rebuild:
                    v = self.values
                    self.stepper.set_motor(MotorLine(v["A"], v["B"], v["A_low"], v["B_low"], v["omega_switch"]))
                self.stepper.set_tau_ext(self.tau_ext)
                self.stepper.restart(self.time)
                self.pending = self.rebuild = False
            target = current_time + step_size
            self.row[:] = self.stepper.advance(target, max(self.t_limit, target))
        except CrankfmuError as exc:
            self._fail(f"step from t = {current_time:g} s failed: {exc}")
            return False
        self._quantity_values = None
        if not np.all(np.isfinite(self.row)):
            self._fail(f"step from t = {current_time:g} s gave non-finite values ({self._row_text()})")
            return False
        self.time = target
        return True

    def terminate(self):
        self.phase = TERMINATED

    def _quantity(self, name: str) -> float:
        """A mechanism-specific output, computed on first read after a step (one kinematics call
        for all of them): a host that never reads them never pays for them."""
        if self.model is None:
            return 0.0
        if self._quantity_values is None:
            from ..mechanisms.quantities import evaluate_all

            row = self.row
            kin = self.model.mechanism.kinematics(np.array([row[ROW["phi1"]]]))
            omega, eps = float(row[ROW["omega1"]]), float(row[ROW["epsilon1"]])
            self._quantity_values = {k: float(v[0]) for k, v in
                                     evaluate_all(self.quantities, kin, omega, eps).items()}
        return self._quantity_values[name]

    # ------------------------------------------------------------------ FMU state
    def get_fmu_state(self) -> dict:
        """Everything that determines the continuation, as plain floats and lists."""
        return {
            "values": dict(self.values), "tau_ext": self.tau_ext, "row": self.row.tolist(),
            "time": self.time, "errors": dict(self.errors), "pending": self.pending, "rebuild": self.rebuild,
            "phase": self.phase,
            "stepper": None if self.stepper is None else self.stepper.state.tolist(),
            "stepper_parameters": None if self.stepper is None else self.stepper.P.tolist(),
        }

    def set_fmu_state(self, state: dict):
        if not isinstance(state, dict) or "invalid" in state or set(state) != set(self.get_fmu_state()):
            self._error(f"fmi2SetFMUstate: not a state of this FMU ({str(state)[:200]})")
            return
        if state["stepper"] is not None and self.stepper is None:
            self._error("fmi2SetFMUstate: the state was taken after initialisation; this instance is not initialised")
            return
        self.values = dict(state["values"])
        self.tau_ext = state["tau_ext"]
        self.row[:] = state["row"]
        self._quantity_values = None
        self.time = state["time"]
        self.errors = dict(state["errors"])
        self.pending, self.rebuild = state["pending"], state["rebuild"]
        self.phase = state["phase"]
        if state["stepper"] is not None:
            self.stepper.state[:] = state["stepper"]
            self.stepper.P[:] = state["stepper_parameters"]
