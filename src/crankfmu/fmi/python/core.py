"""What every crankfmu FMU does the same way: variables with units and ranges, the life cycle, the
refusals and the FMU state. A model's slave (``slave.FmuCore`` for a mechanism, ``drive.DriveCore``
for Drive.fmu) declares its variables and implements three hooks: ``initialise`` (build the model
from the values set), ``advance`` (one communication step) and the model part of the state.

Nothing raises into pythonfmu, which would turn any Python exception into fmi2Fatal and release
the instance's Python objects: every FMI entry point of the slave is bound to a guarded method
here (``attach``). A refusal logs a message naming the variable and its valid range with
fmi2Error status (the shim in front of pythonfmu, ``shim/fmu_shim.c``, makes the call return
fmi2Error and passes the message to the host whatever its logging setting), and every later call
that needs a valid model fails the same way until a valid value is set. The life cycle is checked
here: a call out of order (a step before initialisation, a fixed parameter set after it) is
refused, not ignored.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...errors import CrankfmuError, ParameterError
from ...parameters import Parameter

# life-cycle phases (FMI 2.0 co-simulation state machine, as far as a model needs it)
INSTANTIATED, INITIALIZATION, STEPPING, REFUSED, TERMINATED = (
    "instantiated", "initialization mode", "stepping", "refused", "terminated")
#: the slave's FMI entry points and what each returns when it fails (see SlaveCore.attach)
ENTRY_POINTS = {
    "setup_experiment": None, "enter_initialization_mode": None, "exit_initialization_mode": None,
    "do_step": False, "terminate": None,
    "get_real": "nan", "set_real": None, "get_integer": 0, "set_integer": None,
    "get_boolean": False, "set_boolean": None, "get_string": "", "set_string": None,
    "_get_fmu_state": "state", "_set_fmu_state": None,
}


#: the entry points that change nothing: any other call drops the reads kept since the last one
READS = {"get_real", "get_integer", "get_boolean", "get_string", "_get_fmu_state"}

#: the keys of an FMU state (SlaveCore.get_fmu_state): anything else is refused at fmi2SetFMUstate
STATE_KEYS = {"values", "time", "errors", "failure", "pending", "phase", "model"}


def all_finite(values: np.ndarray) -> bool:
    """Whether every value is finite: one Python sum on the hot path (NaN and inf propagate into
    it; cheaper than numpy's reductions on a few values), the elementwise test only when the sum is
    not finite (it may have overflowed)."""
    return math.isfinite(sum(values.tolist())) or bool(np.all(np.isfinite(values)))


def time_matches(t_host: float, t_own: float, step: float) -> bool:
    """Whether a host's communication point is the FMU's own time up to the host's rounding.

    A host that accumulates t += h drifts by rounding only (far below a step); one that skips or
    repeats a step is off by a whole step."""
    return abs(t_host - t_own) <= 1e-9 * max(1.0, abs(t_own)) + 1e-6 * step


class Declared(NamedTuple):
    """The variables an FMU declares, in order: what its core registers with pythonfmu and what the
    build writes into modelDescription.xml (units, ranges), from one list."""

    outputs: list                  # contract.Variable
    inputs: list                   # parameters.Parameter (a start value and a range)
    parameters: list               # parameters.Parameter

    @property
    def units(self) -> dict[str, str]:
        return {v.name: v.unit for v in (*self.outputs, *self.inputs, *self.parameters)}

    @classmethod
    def of_file(cls, outputs, data_file) -> "Declared":
        """A component FMU's variables (a drive, a cushion, a rod string): the contract's
        ``outputs``, then its data file's inputs and parameters."""
        return cls(list(outputs), list(data_file.inputs.values()), list(data_file.parameters.values()))


class SlaveCore:
    """Variables, life cycle, refusals and state of one FMU instance.

    Subclasses declare variables with ``output``, ``input`` and ``parameter`` in their __init__,
    then call ``attach``; they implement ``initialise()``, ``advance(t, target)`` (raise
    CrankfmuError to refuse) and ``outputs_now()`` (the values whose finiteness is checked), and
    extend ``get_fmu_state``/``set_fmu_state`` with their model's state."""

    def __init__(self, slave, start_time: float = 0.0):
        self.slave = slave
        self.parameters: dict[str, Parameter] = {}
        self.values: dict[str, float] = {}           # parameters and inputs
        self.inputs: dict[str, Parameter] = {}
        self.errors: dict[str, str] = {}              # refused values by variable: they block stepping
        self.failure = ""                             # why the model cannot go on ("fmi2DoStep: ..."), once it cannot
        self.phase = INSTANTIATED
        self.time = start_time
        self.t_limit = math.inf
        self.pending: set[str] = set()                # tunable parameters and inputs changed since the last step
        self.units: dict[str, str] = {}
        self.outputs: set[int] = set()
        self._initialised_for = None                  # the values initialise() last succeeded for
        self._outputs_stale = False                   # an input was set since the outputs were computed

    # ------------------------------------------------------------------ declaring variables
    def declare(self, declared: "Declared", getters: dict):
        """Register every declared variable; an output's value comes from ``getters[name]``."""
        for v in declared.outputs:
            self.output(v.name, v.unit, v.description, getters[v.name])
        for p in declared.inputs:
            self.input(p)
        for p in declared.parameters:
            self.parameter(p)

    def declare_array_outputs(self, declared: "Declared"):
        """``declare`` for a component FMU (a drive, a cushion, a rod string): its outputs are read
        from ``self.out``, an array in the declared outputs' order that the model fills once per
        step."""
        self.out = np.zeros(len(declared.outputs))
        self.declare(declared, {v.name: (lambda k=k: float(self.out[k])) for k, v in enumerate(declared.outputs)})

    def output(self, name, unit, description, getter):
        from pythonfmu.enums import Fmi2Causality, Fmi2Variability
        from pythonfmu.variables import Real

        self.slave.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                          description=description, getter=getter))
        self.units[name] = unit
        self.outputs.add(len(self.slave.vars) - 1)

    def input(self, p: Parameter):
        """A continuous input with a start value; a non-finite value is refused."""
        from pythonfmu.enums import Fmi2Causality, Fmi2Variability
        from pythonfmu.variables import Real

        self.inputs[p.name] = p
        self.values[p.name] = p.value
        self.slave.register_variable(Real(p.name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                          description=p.description, getter=lambda n=p.name: self.values[n],
                                          setter=lambda v, n=p.name: self._set_input(n, v)))
        self.units[p.name] = p.unit

    def parameter(self, p: Parameter):
        from pythonfmu.enums import Fmi2Causality, Fmi2Variability
        from pythonfmu.variables import Real

        self.parameters[p.name] = p
        self.values[p.name] = p.value
        variability = Fmi2Variability.tunable if p.tunable else Fmi2Variability.fixed
        self.slave.register_variable(Real(p.name, causality=Fmi2Causality.parameter, variability=variability,
                                          description=f"{p.description} (valid range {p.range_text()})",
                                          getter=lambda n=p.name: self.values[n],
                                          setter=lambda v, n=p.name: self._set_parameter(n, v)))
        self.units[p.name] = p.unit

    #: entry points whose numpy work may warn on extreme values (overflow while building a model):
    #: run with numpy's warnings off, so nothing reaches the host's stderr; non-finite results are
    #: refused with a message instead. A subclass adds "do_step" where its stepping is numpy code.
    quiet_entry_points = ("exit_initialization_mode",)

    def attach(self):
        """Bind every FMI entry point of the slave to its guarded method here.

        pythonfmu calls them by attribute on the instance, so instance attributes take precedence
        over Fmi2Slave's methods. A Python exception must never reach pythonfmu: it returns
        fmi2Fatal and releases the instance's Python objects, and a later fmi2FreeInstance frees
        them again. An unexpected exception is logged as fmi2Error with its text instead."""
        self._getters = {vr: v.getter for vr, v in self.slave.vars.items()}
        self._reads = {}                    # (value references) -> values, until the next other call
        for name, failed in ENTRY_POINTS.items():
            setattr(self.slave, name, self._guarded(name, getattr(self, name.lstrip("_")), failed))

    def _guarded(self, name, method, failed):
        if name in self.quiet_entry_points:
            loud = method

            def method(*args):
                with np.errstate(all="ignore"):
                    return loud(*args)

        keeps_reads = name in READS

        def entry(*args):
            if not keeps_reads:
                self._reads = {}
            try:
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

    # ------------------------------------------------------------------ messages
    def log(self, message: str, status: str = "error"):
        from pythonfmu.enums import Fmi2Status

        self.slave.log(message, getattr(Fmi2Status, status))

    def _error(self, message: str):
        """Log with fmi2Error status: the shim makes the current call return fmi2Error."""
        self.log(message, "error")

    def _refuse(self, message: str, name: str):
        """Log with fmi2Error status and block stepping until the value is corrected."""
        self.errors[name] = f"{name}: {message}"
        self._error(self.errors[name])

    def _fail(self, message: str, call: str):
        """The model can no longer go on (a refused design, a failed step): every later call that
        needs it fails with this reason, prefixed with the call that failed (the native FMU's words,
        crank_model.c's cm_stop)."""
        self.phase = REFUSED
        self.failure = f"{call}: {message}"
        self._error(self.failure)

    # ------------------------------------------------------------------ variables
    def _variable(self, vr, kind: str):
        var = self.slave.vars.get(vr) if isinstance(vr, int) else None
        if var is None:
            self._error(f"unknown value reference {vr!r}: this FMU's {kind} variables are 0..{len(self.slave.vars) - 1}")
        return var

    def get_real(self, vrs):
        if self.phase == INITIALIZATION:
            self._initial_outputs()
        if self._outputs_stale:             # an input set since the last step: read at its value
            self._outputs_stale = False
            self.inputs_set()
        if self.phase != REFUSED:           # the hot path: hosts read outputs after every step
            # a host that reads the same variables twice between two other calls (ecos: every
            # variable, twice a step) gets the values kept from the first read
            kept = self._reads if self.phase == STEPPING else None
            key = tuple(vrs)
            if kept is not None and key in kept:
                return list(kept[key])
            getters = self._getters
            try:
                values = [float(getters[vr]()) for vr in vrs]
            except KeyError:
                pass                        # an unknown value reference: named below
            else:
                if kept is not None:
                    kept[key] = values
                    return list(values)
                return values
        values = []
        for vr in vrs:
            var = self._variable(vr, "Real")
            if var is None:
                values.append(math.nan)
            elif vr in self.outputs and self.phase == REFUSED:
                self._error(f"{var.name}: no valid model to read it from ({self.failure or 'refused'})")
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

    def _no_variables(self, kind, vrs):
        for vr in vrs:
            self._error(f"unknown value reference {vr!r} of type {kind}: this FMU has Real variables only")

    def get_integer(self, vrs):
        self._no_variables("Integer", vrs)
        return [0] * len(vrs)

    def set_integer(self, vrs, values):
        self._no_variables("Integer", vrs)

    def get_boolean(self, vrs):
        self._no_variables("Boolean", vrs)
        return [False] * len(vrs)

    def set_boolean(self, vrs, values):
        self._no_variables("Boolean", vrs)

    def get_string(self, vrs):
        self._no_variables("String", vrs)
        return [""] * len(vrs)

    def set_string(self, vrs, values):
        self._no_variables("String", vrs)

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
        if v != self.values[name] and self.phase == STEPPING:
            self.pending.add(name)
        self.values[name] = v
        self.errors.pop(name, None)

    def _set_input(self, name: str, value):
        v = float(value)
        if not math.isfinite(v):
            p = self.inputs[name]
            self._refuse(f"input {name} = {value!r} must be finite (valid range {p.range_text()})", name)
            return
        if v != self.values[name]:
            self.values[name] = v
            self.pending.add(name)
            self._outputs_stale |= self.phase == STEPPING and not self.errors
        self.errors.pop(name, None)

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

    def _values_key(self) -> str:
        return repr(sorted(self.values.items()))

    def _initial_outputs(self):
        """Outputs read in initialisation mode are those of the values as set now. A master reads
        them there (its initial values' fixed point: a press's ram_s to a cushion's s, the cushion's
        F back) before fmi2ExitInitializationMode, so the model is initialised for those values
        when they change; a design that would be refused leaves the outputs as they were, and
        fmi2ExitInitializationMode refuses it with its message."""
        key = self._values_key()
        if self.errors or key == self._initialised_for:
            return
        try:
            self.initialise()
        except CrankfmuError:
            self._initialised_for = None
            return
        self._initialised_for = key

    def exit_initialization_mode(self):
        """Build the model from the values now set (unless a read in initialisation mode has built it
        for the same values); refuse a design that cannot work."""
        if self._out_of_order("fmi2ExitInitializationMode", (INITIALIZATION,)):
            return
        call = "fmi2ExitInitializationMode"
        if self.errors:
            self._fail("cannot initialise: " + "; ".join(self.errors.values()), call)
            return
        try:
            if self._initialised_for != self._values_key():
                self.initialise()
        except CrankfmuError as exc:
            self._fail(str(exc), call)     # the message names the parameters involved
            return
        finally:
            self._initialised_for = None
        if not all_finite(self.outputs_now()):
            self._fail(f"the initial state gives non-finite outputs ({self.outputs_text()}): check the parameters",
                       call)
            return
        self.pending.clear()
        self.phase = STEPPING

    def _cannot_step(self) -> bool:
        reason = {INSTANTIATED: "the model is not initialised (call fmi2ExitInitializationMode first)",
                  INITIALIZATION: "the model is not initialised (call fmi2ExitInitializationMode first)",
                  TERMINATED: "the instance was terminated"}.get(self.phase)
        if reason is None and self.phase == REFUSED:
            reason = self.failure
        reason = reason or "; ".join(self.errors.values()) or "the model was refused"
        self._error(f"fmi2DoStep: cannot step: {reason}")
        return False

    def _bad_step_arguments(self, current_time, step_size) -> bool:
        if not (math.isfinite(step_size) and step_size > 0.0) or not math.isfinite(current_time):
            self._error(f"fmi2DoStep: currentCommunicationPoint = {current_time!r} s must be finite and "
                        f"communicationStepSize = {step_size!r} s finite and > 0")
        else:
            self._error(f"fmi2DoStep: currentCommunicationPoint = {current_time!r} s is not this FMU's time "
                        f"{self.time!r} s (a step was skipped or repeated; roll back with fmi2SetFMUstate)")
        return False

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self.phase != STEPPING or self.errors:
            return self._cannot_step()
        target = current_time + step_size
        # one test on the hot path: NaN or inf in either argument makes the target non-finite
        if not (step_size > 0.0 and math.isfinite(target) and time_matches(current_time, self.time, step_size)):
            return self._bad_step_arguments(current_time, step_size)
        self._outputs_stale = False         # the step computes them
        try:
            self.advance(target)
        except CrankfmuError as exc:
            # the kernel's words, as the native FMU's ("fast: " names the method in a run's message)
            self._fail(f"step from t = {current_time:g} s failed: {str(exc).removeprefix('fast: ')}", "fmi2DoStep")
            return False
        if self.pending:
            self.pending.clear()
        if not all_finite(self.outputs_now()):
            self._fail(f"step from t = {current_time:g} s failed: non-finite outputs ({self.outputs_text()})",
                       "fmi2DoStep")
            return False
        self.time = target
        return True

    def terminate(self):
        self.phase = TERMINATED

    # ------------------------------------------------------------------ model hooks
    def initialise(self):
        raise NotImplementedError

    def advance(self, target: float):
        raise NotImplementedError

    def outputs_now(self) -> np.ndarray:
        raise NotImplementedError

    def inputs_set(self):
        """An input changed between two steps: the outputs that depend on it at once are computed
        again, at the first read (a master that solves a loop by setting inputs and reading outputs
        reads them at the values it set; one that sets and steps pays nothing); the state moves at
        the next step."""

    def outputs_text(self) -> str:
        return ", ".join(f"{v:g}" for v in self.outputs_now())

    # ------------------------------------------------------------------ FMU state
    def get_fmu_state(self) -> dict:
        """Everything that determines the continuation, as plain floats, strings and lists (the
        keys are STATE_KEYS)."""
        return {"values": dict(self.values), "time": self.time, "errors": dict(self.errors), "failure": self.failure,
                "pending": sorted(self.pending), "phase": self.phase, "model": self.model_state()}

    def set_fmu_state(self, state: dict):
        if not isinstance(state, dict) or set(state) != STATE_KEYS:
            self._error(f"fmi2SetFMUstate: not a state of this FMU ({str(state)[:200]})")
            return
        if state["model"] is not None and not self.can_restore():
            # a state taken after initialisation, set into an instance that is not initialised (as
            # fmusim's --initial-fmu-state-file does right after instantiation; the Reference FMUs
            # accept it): build the model for the state's values, as fmi2ExitInitializationMode
            # would, then take the state's own integrator state (the continuation is bit for bit)
            kept = (self.values, self.time)
            self.values, self.time = dict(state["values"]), state["time"]
            try:
                self.initialise()
            except CrankfmuError as exc:
                self.values, self.time = kept
                self._error(f"fmi2SetFMUstate: the state's model cannot be built for its values: {exc}")
                return
        self.values = dict(state["values"])
        self.time = state["time"]
        self.errors = dict(state["errors"])
        self.failure = state["failure"]
        self.pending = set(state["pending"])
        self.phase = state["phase"]
        if state["model"] is not None:
            self.restore_model_state(state["model"])
        # the outputs kept are the last step's: an input set since is read at its value
        self._outputs_stale = self.phase == STEPPING and any(n in self.inputs for n in self.pending)

    def model_state(self):
        raise NotImplementedError

    def can_restore(self) -> bool:
        raise NotImplementedError

    def restore_model_state(self, state):
        raise NotImplementedError


class ComponentCore(SlaveCore):
    """A component's core (drive, cushion, shaft, rod string): its outputs are the array ``out``,
    which ``_update_outputs`` computes from the state and the inputs, again whenever an input is
    set (the outputs that depend on an input at once follow it)."""

    def _update_outputs(self):
        raise NotImplementedError

    def inputs_set(self):
        self._update_outputs()

    def outputs_now(self) -> np.ndarray:
        return self.out
