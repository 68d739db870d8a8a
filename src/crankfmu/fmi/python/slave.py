"""The FMU's behaviour, kept in the package so the FMU runs the same model code as the CLI.

``FmuCore`` registers the variables of docs/fmu-contract.md (plus the scenario's geometry,
mass and load parameters) on a pythonfmu ``Fmi2Slave`` and implements its life cycle. The slave
scripts (generated from ``slave_script.py.in`` beside this file) are thin: ``class FourBar(Fmi2Slave)``
delegating to ``FmuCore``. A scenario's ``[[outputs]]`` (slider position, arm speed, ...) become
extra outputs, and so do each port's s, v, a (dynamics.ports), whose input (ram_F, arm_M) is held
over a step, and the joint reactions: each kind is computed on the host's first read after a step,
from the design's tables by the C kernel's rules (``ck_quantity_values``, ``ck_reaction_values``),
the tables and rules the native FMU compiles in.

Inside ``fmi2DoStep`` the movement equation is integrated by the fast path: the reduced model is
tabulated once at initialisation (dynamics.tabulated, its error bound checked against the contour
engine) and the C Dormand-Prince kernel (crankfmu.native) steps it with rtol honoured and every switch
located (the motor line's kink, the slider forces' switch angles and reversals). A whole
``fmi2DoStep`` is one call into the kernel; the outputs are one array the getters read; no
link-level kinematics are computed while stepping or reading.
Communication points inside a step are served from the dense output, so the trajectory does not
depend on the communication step. A tunable parameter or the input ``tau_ext`` that changed since
the last step restarts the stepper at the communication point, so the change takes effect from
that step on.

The life cycle, the refusals and the guards that keep Python exceptions away from pythonfmu are
``core.SlaveCore``'s, shared with Drive.fmu.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...contract import INPUTS, MOTOR_PARAMETERS as MOTOR, OUTPUTS
from ...dynamics import MotorLine
from ...dynamics import modes
from ...dynamics.reaction_table import tabulate_reactions
from ...dynamics.tabulated import c_output_tables, table_of, tabulate_quantities
from ...integrators.fast import TABLE_TOLERANCE, FastStepper
from ...native import ROW_FIELDS, QuantityReads, ReactionReads
from ...parameters import Parameter
from ...scenario import load_scenario
from ..variables import (friction_variables, output_quantities, quantity_variables, reaction_variables,
                         rtol_parameter)
from .core import Declared, SlaveCore

(TAU_EXT,) = INPUTS

#: built designs of this process, most recent last: an instance that is reset, or freed and
#: instantiated again, with the same design (a host's restart, a sweep over the motor line or the
#: start values) reuses its model and tables instead of tabulating again; they are only read
#: while stepping
_DESIGNS: dict = {}
_DESIGNS_KEPT = 8
#: the joint reactions' terms are tabulated to this (relative to each term's scale): read on demand,
#: they need not meet the movement equation's 1e-11
REACTION_TOLERANCE = 1e-8
#: what the tables do not depend on: the motor line and the start values (set on the stepper)
NOT_TABULATED = (*MOTOR, "phi1_start", "omega1_start")


def build_design(scenario, values: dict) -> "Design":
    """The model and every table of the scenario with these parameter values, built once per process.

    The model's motor line and start state are those of the first design built with these
    tables: take them from ``values``, not from the model."""
    key = (scenario.where, tuple(sorted((k, v) for k, v in values.items() if k not in NOT_TABULATED)))
    if key in _DESIGNS:
        _DESIGNS[key] = _DESIGNS.pop(key)           # most recent last
        return _DESIGNS[key]
    built = scenario.with_params(**values)
    model = built.build(table=TABLE_TOLERANCE)
    design = Design(model, table_of(model.reduced, TABLE_TOLERANCE), *output_tables(built, model))
    _DESIGNS[key] = design
    while len(_DESIGNS) > _DESIGNS_KEPT:
        del _DESIGNS[next(iter(_DESIGNS))]
    return design


class Design(NamedTuple):
    """A design's model and the tables every FMU of it runs on: the reduced model's (the stepper's),
    its [[outputs]] and ports' s, v, a (or None), its joint reactions' (or None)."""
    model: object
    table: object
    quantity_table: object
    reaction_table: object


def output_tables(scenario, model) -> tuple:
    """(the quantities' table or None, the joint reactions' table or None) of a design: what a host
    reads besides the state, tabulated as the native FMU compiles them in and the Python FMU reads
    them (the kernel's ck_quantity_values and ck_reaction_values), so the two FMUs share one rule
    and the Python FMU's read costs a few multiply-adds, not a Newton-Euler solve."""
    quantities = output_quantities(scenario, model.reduced.ports)
    reactions = bool(reaction_variables(scenario))
    # by the C model, as the native FMU builds them (the Python engine where it cannot)
    built = c_output_tables(scenario, model.reduced.source[1], quantities, TABLE_TOLERANCE, REACTION_TOLERANCE,
                            reactions, getattr(model.reduced, "c_model", None))
    if built is not None:
        return built
    quantity_table = (tabulate_quantities(model.mechanism, quantities, scenario.mechanism_definition(), TABLE_TOLERANCE)
                      if quantities else None)
    # the joint reactions: their terms tabulated (read on demand, so a looser tolerance than the
    # movement equation's); the kernel supplies the terms' weights
    reaction_table = tabulate_reactions(model.reduced, REACTION_TOLERANCE) if reactions else None
    return quantity_table, reaction_table


def declared(scenario) -> Declared:
    """The variables of the FMU of ``scenario``: the contract's outputs, the scenario's [[outputs]]
    and its ports' outputs, the inputs tau_ext and one per port, the scenario's parameters and the
    integrator's rtol."""
    definition = scenario.mechanism_definition()
    outputs = [*OUTPUTS, *quantity_variables(scenario), *reaction_variables(scenario), *friction_variables(scenario)]
    inputs = [Parameter(TAU_EXT.name, 0.0, TAU_EXT.unit, TAU_EXT.description),
              *(Parameter(p.input_name, 0.0, p.input_unit, p.input_description) for p in scenario.ports)]
    parameters = [*scenario.parameters.values(), rtol_parameter(scenario.experiment.tolerance)]
    return Declared(outputs, inputs, parameters)


def fmu_scenario(scenario_name: str):
    """The scenario an FMU's core runs: a packaged name, or a user's file the build put in the
    FMU's package (``user/<file>.toml``)."""
    if scenario_name.endswith(".toml"):
        scenario_name = str(Path(__file__).resolve().parents[2] / scenario_name)
    return load_scenario(scenario_name)


def start_values(scenario) -> dict:
    """Every variable's start value in the FMU of ``scenario`` (what an instance holds before a host
    sets anything): the parameters, rtol and the inputs."""
    found = declared(scenario)
    return {p.name: p.value for p in (*found.inputs, *found.parameters)}


def motor_line(values: dict) -> MotorLine:
    """The motor line of an FMU's values (its tunable parameters A, B, A_low, B_low, omega_switch)."""
    return MotorLine(*(values[n] for n in MOTOR))


def start_design(scenario, values: dict, time: float, row=None):
    """What the Python FMU does at fmi2ExitInitializationMode, for ``values`` (every variable's
    value by name): the design's model and tables, and its stepper started at ``time``. Returns
    (design, stepper, a warning or ""); raises CrankfmuError with the reason it cannot start. The
    builds run it at the FMU's start values before they report success (``initialises``)."""
    design = build_design(scenario, {n: values[n] for n in scenario.parameters})
    table = design.table
    warning = (f"the reduced model is tabulated to {table.error_bound:.2g} relative, not {table.tolerance:g}: "
               "the geometry is close to a dead point" if table.error_bound > table.tolerance else "")
    y0 = np.array(design.model.y0, dtype=float)
    y0[0], y0[1] = values["phi1_start"], values["omega1_start"]
    stepper = FastStepper(table, motor_line(values), design.model.reduced.J_flywheel,
                          values["rtol"], values[TAU_EXT.name], row=np.zeros(len(ROW_FIELDS)) if row is None else row)
    stepper.set_port_inputs([values[p.input_name] for p in scenario.ports])
    stepper.start(time, y0)
    return design, stepper, warning


def initialises(scenario) -> str:
    """Start the FMU's model at its start values and take one output interval of its default
    experiment, as a host's first step would: the words for a build's summary and check. Raises
    CrankfmuError (the message the FMU would give at fmi2ExitInitializationMode or its first
    fmi2DoStep) where a host could not run it."""
    from ...errors import CrankfmuError

    experiment = scenario.experiment
    _, stepper, warning = start_design(scenario, start_values(scenario), experiment.start_time)
    target = experiment.start_time + experiment.output_interval
    stepper.advance(target, target)
    if not np.all(np.isfinite(stepper.row)):
        raise CrankfmuError(f"the FMU's first step of {experiment.output_interval:g} s gives values that are not "
                            "finite: check the parameters")
    return (f"the Python FMU initialises at its start values and steps {experiment.output_interval:g} s"
            + (f" ({warning})" if warning else ""))


class Lazy:
    """A value computed on its first use after a step, then served from the cache until the next
    step (``clear``): a host that never reads an output never pays for it."""

    def __init__(self, compute):
        self.compute = compute
        self.value = None

    def clear(self):
        self.value = None

    def __call__(self):
        if self.value is None:
            self.value = self.compute()
        return self.value


def lazy_outputs(core, motion):
    """The outputs a mechanism core computes only when a host reads them: the quantities (its
    [[outputs]] and the ports' s, v, a) and the joint reactions, each kind all at once on the first
    read after a step, from the design's tables by the kernel's rules (``core.reads``: a
    QuantityReads and a ReactionReads, or None) at the state ``motion()`` gives, (phi1, omega1,
    epsilon1), and the core's time. Returns (the caches to clear after each step, the getters)."""

    def quantities():
        return core.reads[0].values(*motion()).tolist()

    def reactions():
        phi1, omega1, epsilon1 = motion()
        return core.reads[1].values(core.time, float(phi1), float(omega1), float(epsilon1)).tolist()

    def frictions():
        return friction_now(core)

    caches = (Lazy(quantities), Lazy(reactions), Lazy(frictions))

    def getter(cache, k):
        return lambda: cache()[k] if core.model is not None else 0.0

    getters = {q.name: getter(caches[0], k) for k, q in enumerate(core.quantities)}
    getters.update({v.name: getter(caches[1], k) for k, v in enumerate(reaction_variables(core.scenario))})
    getters.update({v.name: getter(caches[2], k) for k, v in enumerate(friction_variables(core.scenario))})
    return caches, getters


def friction_now(core) -> list:
    """The joints' friction's outputs now (friction_variables' order): M_friction and W_friction from
    the kernel's output row, each joint's friction by the kernel's solve at the state now
    (ck_friction_values) and its power with the rate's table; zeros for a design whose mu are 0."""
    from ...native import friction_values

    names = [v.name for v in friction_variables(core.scenario)]
    reduced = core.model.reduced
    if reduced.friction is None:
        return [0.0] * len(names)
    row = core.row
    values = {"M_friction": float(row[ROW_FIELDS.index("M_friction")]),
              "W_friction": float(row[ROW_FIELDS.index("W_friction")])}
    stepper, table = core.stepper, core.stepper.table
    epsilon = row[ROW_FIELDS.index("epsilon1")]
    f = friction_values(stepper.state[None, :], [core.time], [epsilon], stepper.tables, stepper.P)[:, :-1]
    values.update(table.friction.joint_outputs(reduced.friction, f, np.array([row[0]]), np.array([row[1]]), table.period))
    return [float(np.ravel(values.get(name, 0.0))[0]) for name in names]


def output_reads(design: Design, quantities, stepper) -> tuple:
    """(QuantityReads or None, ReactionReads or None): the kernel's readers of a design's output
    tables for an FMU's stepper."""
    return (QuantityReads(design.quantity_table, quantities) if design.quantity_table is not None else None,
            ReactionReads(design.reaction_table, stepper) if design.reaction_table is not None else None)


class RowOutputs:
    """What the mechanism cores in either causality share: the outputs are the kernel's output row
    (``row``, filled in place by ``stepper``, laid out as ``fields``), the state is the stepper's
    array, and the quantities and reactions are cached until the next step (``lazy``)."""

    fields: tuple = ROW_FIELDS

    def _getter(self, name: str):
        row, index = self.row, self.fields.index
        if name == "E_kin":
            J, omega = index("J_red"), index("omega1")
            kinetic_energy = modes.kinetic_energy
            return lambda: kinetic_energy(float(row[J]), float(row[omega]))
        i = index(name)
        return lambda: float(row[i])

    def _motion(self):
        """(phi1, omega1, epsilon1) now."""
        row = self.row
        return row[0], row[1], row[self.fields.index("epsilon1")]

    def _clear(self):
        for lazy in self.lazy:
            lazy.clear()

    def outputs_now(self) -> np.ndarray:
        return self.row

    def outputs_text(self) -> str:
        return ", ".join(f"{name} = {value:g}" for name, value in zip(self.fields, self.row))

    def model_state(self):
        if self.stepper is None:
            return None
        return {"row": self.row.tolist(), "stepper": self.stepper.state.tolist(),
                "stepper_parameters": self.stepper.P.tolist()}

    def can_restore(self) -> bool:
        return self.stepper is not None

    def restore_model_state(self, state):
        self.row[:] = state["row"]
        self._clear()
        self.stepper.state[:] = state["stepper"]
        self.stepper.P[:] = state["stepper_parameters"]


class FmuCore(RowOutputs, SlaveCore):
    """Variables and model of a crankfmu FMU for one scenario."""

    def __init__(self, slave, scenario_name: str):
        self.scenario = fmu_scenario(scenario_name)
        super().__init__(slave, self.scenario.experiment.start_time)
        self.row = np.zeros(len(ROW_FIELDS))       # the kernel's output row at the current time
        self.model = None
        self.stepper: FastStepper | None = None
        self.reads = (None, None)        # the output tables' readers (output_reads), once initialised
        self.quantities = output_quantities(self.scenario)
        self.port_inputs = [p.input_name for p in self.scenario.ports]
        # [[outputs]], the ports' s, v, a and the joint reactions: on a host's first read after a step
        self.lazy, getters = lazy_outputs(self, self._motion)
        getters.update({out.name: self._getter(out.name) for out in OUTPUTS})
        self.declare(declared(self.scenario), getters)
        self.attach()

    # ------------------------------------------------------------------ model hooks
    def initialise(self):
        design, self.stepper, warning = start_design(self.scenario, self.values, self.time, self.row)
        self.model = design.model
        if warning:
            self.log(warning, "warning")
        self.quantities = output_quantities(self.scenario, self.model.reduced.ports)
        self.reads = output_reads(design, self.quantities, self.stepper)
        self._clear()

    def inputs_set(self):
        self.stepper.set_tau_ext(self.values[TAU_EXT.name])
        self.stepper.set_port_inputs([self.values[n] for n in self.port_inputs])
        self.stepper.refresh(self.time)
        self._clear()

    def advance(self, target: float):
        if self.pending:
            # a tunable parameter or the input changed: it takes effect from this step on
            self.stepper.set_motor(motor_line(self.values))
            self.stepper.set_tau_ext(self.values[TAU_EXT.name])
            self.stepper.set_port_inputs([self.values[n] for n in self.port_inputs])
            self.stepper.restart(self.time)
        self._clear()
        self.stepper.advance(target, max(self.t_limit, target))      # fills self.row
