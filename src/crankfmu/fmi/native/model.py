"""The native mechanism FMU's model, as its build writes it: the variables (in the runtime's
value-reference order), the model file the prebuilt runtime reads (``resources/crankfmu-model.bin``,
fmi.native.model_file: identifier, GUID, counts, causality, the scenario compiled into the C model's
program, dynamics/program_scenario.py, and the table of variables), and the FMI 2.0
modelDescription. fmi.native.fmi3 describes the same
variables in FMI 3.0; fmi.native.build compiles and packages them.

The geometry, masses, loads and gravity are fixed parameters: a host sets them before the end of
initialisation (and again after a reset), each in its range; a design that does not assemble over
the turn is refused when initialisation ends, with the engine's message. A, B, A_low, B_low,
omega_switch, J_flywheel and rtol are tunable, tau_ext is the input, phi1_start and omega1_start
set the initial state.

In speed causality (``--causality speed``, or the file's ``[crank] causality``) the same runtime
reads causality_speed from the model file: the input is omega1 (its derivative taken where the host gives
one), the outputs are fmi.python.speed's (tau_drive, W_drive, ...), J_flywheel is tunable and
phi1_start sets the initial state; Co-Simulation only.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from xml.dom.minidom import parseString
from xml.etree import ElementTree as ET

from ... import units as si
from ...contract import INPUTS, OUTPUTS, SPEED_INPUTS, SPEED_OUTPUTS, STATE_DERIVATIVE_DEPENDS, direct_dependencies
from ...errors import CrankfmuError
from ...native import N_PLAIN, ROW_FIELDS, SPEED_ROW_FIELDS, layout
from ..source import vendor_annotations
from . import model_file
from ..python.speed import NOT_DECLARED

#: the parameters the tables do not depend on, in the shell's value-reference order
TUNABLE = ("A", "B", "A_low", "B_low", "omega_switch", "J_flywheel", "phi1_start", "omega1_start", "rtol")
#: speed causality's tunables, in the shell's order (the motor line is outside, omega1 is the input)
SPEED_TUNABLE = ("J_flywheel", "phi1_start")
#: set before initialisation only: they are the initial state
INITIAL = ("phi1_start", "omega1_start")
#: the Model Exchange states: the kernel's y (phi1, omega1, W_motor, W_load, W_ext), and W_friction
#: where the joints have friction
STATES = (*ROW_FIELDS[:N_PLAIN], "W_friction")
#: event indicators: the kernel's event slots (crank_modes.h: the motor kink, its sliding mode,
#: the two ends of the switch interval, omega1 = 0)
N_EVENT_INDICATORS = layout()["N_SLOTS"]


def native_program(scenario):
    """(the scenario's program, {table: (checked error bound, construction)}): what a native FMU of
    ``scenario`` carries, and its tables built by the C model at the file's values, as the FMU
    builds them when it initialises. ``crankfmu check`` builds them too, so it refuses exactly what
    the build would; a refusal is the engine's message (the Python build names the cause)."""
    from ...dynamics.program import parameter_values
    from ...dynamics.program_scenario import compile_scenario
    from ...native.mechanism import FRICTION, QUANTITIES, REACTIONS, REDUCED, CModel, MechanismError
    from ..python.slave import REACTION_TOLERANCE, TABLE_TOLERANCE, build_design

    program = compile_scenario(scenario)
    if program is None:
        raise CrankfmuError(f"{scenario.name}: a load or port of this scenario is not one the C mechanism model "
                            "evaluates: use the Python FMU (crankfmu fmu without --native)")
    tables = {}
    try:
        model = CModel(program, parameter_values(program, scenario.values))
        for table, tolerance, needed in ((REDUCED, TABLE_TOLERANCE, True),
                                         (QUANTITIES, TABLE_TOLERANCE, len(program.coordinates) > 0),
                                         (REACTIONS, REACTION_TOLERANCE, len(program.joints) > 0),
                                         (FRICTION, TABLE_TOLERANCE, len(model.active_frictions) > 0)):
            if needed:
                tables[table] = model.cubics(table, tolerance)[1:]
    except MechanismError as exc:
        build_design(scenario, dict(scenario.values))       # the engine's message, where it refuses too
        raise CrankfmuError(f"{scenario.name}: the C mechanism model cannot build the tables: {exc}") from None
    return program, tables


@dataclass
class NativeVariable:
    """One variable of a native mechanism FMU, as either FMI version declares it (values as text)."""

    name: str
    unit: str
    description: str
    causality: str                  # "output", "input", "parameter", "local"
    variability: str                # "continuous", "fixed", "tunable"
    initial: str | None = None
    start: str | None = None
    min: str | None = None
    max: str | None = None
    derivative_of: str | None = None    # a Model Exchange derivative: its state's name
    #: an output's or a derivative's direct dependencies (ModelStructure): names of the FMU's
    #: continuous states and inputs (contract.direct_dependencies); None: not declared
    depends: list | None = None


#: what every native FMU offers a master besides its values (the runtime's fmu_derivatives.c): the
#: outputs' first and second time derivatives and directional derivatives (FMI 3.0 adjoint ones
#: too); a rod string's grid has no smooth equations, so it offers none
MAX_OUTPUT_DERIVATIVE_ORDER = 2

#: a state's unit -> its derivative's
PER_SECOND = {"rad": "rad/s", "rad/s": "rad/s2", "J": "W", "A": "A/s"}


def dependency_attributes(v: NativeVariable, reference: dict) -> dict:
    """ModelStructure's dependencies and dependenciesKind of ``v``, its knowns referred to by
    ``reference`` (name -> FMI 2.0 index or FMI 3.0 value reference): "constant" where the unknown is
    the known itself or der(phi1) of omega1, "dependent" otherwise (a factor that varies with the
    state)."""
    if v.depends is None:
        return {}
    constant = {(v.name, v.name), ("der(phi1)", "omega1")}
    return {"dependencies": " ".join(str(reference[n]) for n in v.depends),
            "dependenciesKind": " ".join("constant" if (v.name, n) in constant else "dependent" for n in v.depends)}


class NativeModel:
    """What a native FMU is generated from: the scenario, its tables and its variables."""

    def __init__(self, source, scenario_name, causality: str = "torque"):
        from ..variables import friction_variables, output_quantities, reaction_variables, rtol_parameter
        from ...scenario import load_scenario

        self.source = source
        self.speed = causality == "speed"
        self.scenario = source.scenario if source.scenario is not None else load_scenario(scenario_name)
        self.program, self.table_errors = native_program(self.scenario)
        definition = self.definition = self.scenario.mechanism_definition()
        self.quantities = output_quantities(self.scenario)
        self.ports = self.scenario.ports
        self.quantity_units = [q.unit(definition) for q in self.quantities]
        self.reactions = reaction_variables(self.scenario)
        self.frictions = friction_variables(self.scenario)
        assert len(self.frictions) == (2 + 2 * len(self.program.frictions) if len(self.program.frictions) else 0)
        assert self.program.reaction_names == tuple(v.name for v in self.reactions)
        assert len(self.program.rows) == 4 + len(self.program.columns) + len(self.ports)
        # the file's parameters at the values it is built for (its --set overrides)
        params = {n: replace(p, value=self.scenario.values[n]) for n, p in self.scenario.parameters.items()}
        params["rtol"] = rtol_parameter(self.scenario.experiment.tolerance, tunable=True)
        missing = [n for n in TUNABLE if n not in params]
        if missing:
            raise CrankfmuError(f"{self.scenario.name}: missing parameter(s) {', '.join(missing)}")
        tunable = SPEED_TUNABLE if self.speed else TUNABLE
        self.outputs = list(SPEED_OUTPUTS if self.speed else OUTPUTS)
        self.input = SPEED_INPUTS[0] if self.speed else INPUTS[0]
        # the speed's start is the scenario's start speed, as the Python FMU's
        self.input_start = float(params["omega1_start"].value) if self.speed else 0.0
        self.tunable = [params[n] for n in tunable]
        # a speed-causal FMU declares what the Python one does (fmi.python.speed.NOT_DECLARED), and no rtol:
        # its step has no error control to tune (the line's integral is exact, the works quadratures)
        undeclared = (*NOT_DECLARED, "rtol") if self.speed else ()
        self.fixed = [p for n, p in params.items() if n not in (*tunable, *undeclared)]
        text = repr((self.source.fmu, causality, self.program.code.tobytes(), self.program.literals.tobytes(),
                     [(p.name, p.value) for p in (*self.tunable, *self.fixed)], [q.name for q in self.quantities],
                     [v.name for v in self.reactions], [v.name for v in self.frictions]))
        digest = hashlib.sha256(text.encode()).hexdigest()
        self.guid = "{" + f"{digest[:8]}-{digest[8:12]}-{digest[12:16]}-{digest[16:20]}-{digest[20:32]}" + "}"

    # ------------------------------------------------------------------ the model file
    def geometry_parameters(self) -> list[int]:
        """The program's indices of the parameters the positions depend on (an assembly refusal names them)."""
        return [self.program.parameters.index(p) for p in self.definition.geometry_parameters
                if p in self.program.parameters]

    def model_file(self) -> bytes:
        """resources/crankfmu-model.bin (fmi.native.model_file): the scenario as the prebuilt runtime reads it,
        its identifier, GUID, counts, compiled program and every variable's start, range and unit."""
        from ..python.slave import REACTION_TOLERANCE, TABLE_TOLERANCE

        def variable(name, kind, start=0.0, p=None, unit=""):
            if p is None:
                return (name, kind, start, 0, 1, 0, 1, 0.0, 0.0, "", unit, "")
            return (name, kind, p.value, int(p.min is not None), int(p.min_inclusive), int(p.max is not None),
                    int(p.max_inclusive), p.min or 0.0, p.max or 0.0, p.range_text(), p.unit, p.description)

        rows = [variable(v.name, "OUTPUT", unit=v.unit) for v in self.outputs]
        rows.append(variable(self.input.name, "INPUT", self.input_start, unit=self.input.unit))
        rows += [variable(p.name, "TUNABLE", p=p) for p in self.tunable]
        rows += [variable(p.name, "FIXED", p=p) for p in self.fixed]
        rows += [variable(q.name, "QUANTITY", unit=u) for q, u in zip(self.quantities, self.quantity_units)]
        rows += [variable(f"der({name})", "DERIVATIVE", unit=unit) for name, unit in self.derivatives()]
        rows += [variable(p.input_name, "INPUT", 0.0, unit=p.input_unit) for p in self.ports]
        rows += [variable(v.name, "REACTION", unit=v.unit) for v in self.reactions]
        rows += [variable(v.name, "FRICTION", unit=v.unit) for v in self.frictions]
        program = self.program
        vr_of = {v.name: vr for vr, v in enumerate(self.variables())}
        header = {"identifier": self.source.fmu, "guid": self.guid, "mechanism_name": self.definition.name,
                  "mechanism_branch": self.definition.branch, "causality_speed": int(self.speed),
                  "cycle_turns": self.scenario.cycle_turns, "n_outputs": len(self.outputs), "n_fixed": len(self.fixed),
                  "n_quantities": len(self.quantities), "n_ports": len(self.ports),
                  "n_reactions": len(self.reactions), "reaction_terms": max(len(program.term_inertia), 1),
                  "n_quantity_coordinates": len(program.coordinates), "table_functions": len(program.rows),
                  "table_sliders": len(program.columns), "vr_e_kin": [v.name for v in self.outputs].index("E_kin"),
                  "default_start_time": self.scenario.experiment.start_time, "table_tolerance": TABLE_TOLERANCE,
                  "reaction_tolerance": REACTION_TOLERANCE}
        coordinates = program.coordinate_names
        body = model_file.payload(
            header, rows, self.output_rows(), [coordinates.index(q.of) for q in self.quantities],
            [q.order for q in self.quantities], program, [vr_of.get(name, -1) for name in program.parameters],
            [self.scenario.values[n] for n in program.parameters], self.geometry_parameters(),
            self.definition.unknowns)
        return model_file.wrap(body)

    def derivatives(self) -> list[tuple[str, str]]:
        """(state, unit of its derivative) of the Model Exchange states: the kernel's y (none in
        speed causality: Co-Simulation only)."""
        if self.speed:
            return []
        units = {v.name: v.unit for v in (*self.outputs, *self.frictions)}
        return [(name, PER_SECOND[units[name]]) for name in STATES[:N_PLAIN + bool(self.frictions)]]

    def dependencies(self) -> dict[str, list[str]]:
        """Each output's and state derivative's direct dependencies: names of the continuous states
        (Model Exchange's, declared with their derivatives in both interfaces; none in speed
        causality) and of the inputs."""
        from ..variables import quantity_variables

        inputs = [self.input.name, *(p.input_name for p in self.ports)]
        states = [name for name, _ in self.derivatives()]
        outputs = [*self.outputs, *quantity_variables(self.scenario), *self.reactions, *self.frictions]
        found = {v.name: direct_dependencies(v.depends, outputs, inputs, states) for v in outputs}
        for name in states:
            found[f"der({name})"] = direct_dependencies(STATE_DERIVATIVE_DEPENDS[name], outputs, inputs, states)
        return found

    def output_rows(self) -> list[int]:
        """Each contract output's place in the kernel's output row; -1 for E_kin (from J_red, omega1)."""
        fields = SPEED_ROW_FIELDS if self.speed else ROW_FIELDS
        return [fields.index(v.name) if v.name in fields else -1 for v in self.outputs]

    # ------------------------------------------------------------------ modelDescription
    def variables(self) -> list[NativeVariable]:
        """Every variable in value-reference order (the order of data_c's table, crank_variables.h's):
        what the FMI 2.0 and 3.0 modelDescriptions both declare."""
        table = [NativeVariable(v.name, v.unit, v.description, "output", "continuous", initial="calculated")
                 for v in self.outputs]
        table.append(NativeVariable(self.input.name, self.input.unit, self.input.description, "input", "continuous",
                                    start=repr(self.input_start)))
        for p in (*self.tunable, *self.fixed):
            fixed = p in self.fixed
            note = (f" (valid range {p.range_text()}; set before the end of initialisation: the FMU tabulates "
                    "its model then)" if fixed else f" (valid range {p.range_text()})")
            table.append(NativeVariable(
                p.name, p.unit, (p.description + note).strip(), "parameter",
                "fixed" if fixed or p.name in INITIAL else "tunable", start=repr(float(p.value)),
                min=None if p.min is None else repr(float(p.min)), max=None if p.max is None else repr(float(p.max))))
        table += [NativeVariable(q.name, unit, q.description, "output", "continuous", initial="calculated")
                  for q, unit in zip(self.quantities, self.quantity_units)]
        table += [NativeVariable(f"der({name})", unit, f"time derivative of {name} (Model Exchange)", "local",
                                 "continuous", initial="calculated", derivative_of=name)
                  for name, unit in self.derivatives()]
        table += [NativeVariable(p.input_name, p.input_unit, p.input_description, "input", "continuous", start="0.0")
                  for p in self.ports]
        table += [NativeVariable(v.name, v.unit, v.description, "output", "continuous", initial="calculated")
                  for v in (*self.reactions, *self.frictions)]
        depends = self.dependencies()
        return [replace(v, depends=depends[v.name]) if v.name in depends else v for v in table]

    def units_used(self) -> list[str]:
        return sorted({v.unit for v in self.variables() if v.unit != "1"})

    def model_description(self, sources: list[str]) -> bytes:
        exp = self.scenario.experiment
        root = ET.Element("fmiModelDescription", fmiVersion="2.0", modelName=self.source.fmu, guid=self.guid,
                          description=self.scenario.title, generationTool="crankfmu (native)",
                          variableNamingConvention="structured",
                          numberOfEventIndicators=str(0 if self.speed else N_EVENT_INDICATORS))
        common = dict(modelIdentifier=self.source.fmu, canGetAndSetFMUstate="true", canSerializeFMUstate="true",
                      canNotUseMemoryManagementFunctions="false", providesDirectionalDerivative="true")
        interfaces = (("ModelExchange", {"completedIntegratorStepNotNeeded": "true"}),
                      ("CoSimulation", {"canHandleVariableCommunicationStepSize": "true",
                                        "canInterpolateInputs": "true",
                                        "maxOutputDerivativeOrder": str(MAX_OUTPUT_DERIVATIVE_ORDER)}))
        for kind, extra in interfaces[1:] if self.speed else interfaces:
            files = ET.SubElement(ET.SubElement(root, kind, **common, **extra), "SourceFiles")
            for name in sources:
                if name.endswith(".c"):
                    ET.SubElement(files, "File", name=name)
        unit_definitions(root, self.units_used())
        default_experiment(root, exp)
        root.append(vendor_annotations(self.source, "native"))
        variables_and_structure(root, self.variables())
        return parseString(ET.tostring(root, encoding="UTF-8")).toprettyxml(encoding="UTF-8", indent="  ")

    def parameters(self) -> dict:
        return {p.name: p for p in (*self.tunable, *self.fixed)}


def variables_and_structure(root: ET.Element, table: list) -> None:
    """FMI 2.0's ModelVariables and ModelStructure of a native FMU (a mechanism or a component) from
    its variables in value-reference order: the outputs' and the states' derivatives' dependencies,
    and the initial unknowns (on every input and parameter)."""
    variables = ET.SubElement(root, "ModelVariables")
    index_of = {v.name: i + 1 for i, v in enumerate(table)}          # FMI 2.0 indices count from 1
    for vr, v in enumerate(table):
        attributes = {k: getattr(v, k) for k in ("initial",) if getattr(v, k) is not None}
        sv = ET.SubElement(variables, "ScalarVariable", name=v.name, valueReference=str(vr),
                           description=v.description, causality=v.causality, variability=v.variability,
                           **attributes)
        real = {k: getattr(v, k) for k in ("start", "min", "max") if getattr(v, k) is not None}
        if v.derivative_of:
            real["derivative"] = str(index_of[v.derivative_of])
        r = ET.SubElement(sv, "Real", **real)
        if v.unit != "1":
            r.set("unit", si.fmi_name(v.unit))
    outputs = [i + 1 for i, v in enumerate(table) if v.causality == "output"]
    derivative_indices = [i + 1 for i, v in enumerate(table) if v.derivative_of]
    inputs = [i + 1 for i, v in enumerate(table) if v.causality in ("input", "parameter")]
    structure = ET.SubElement(root, "ModelStructure")
    for tag, indices in (("Outputs", outputs), ("Derivatives", derivative_indices)):
        if not indices:
            continue           # (speed causality: no states; an empty element is not allowed)
        element = ET.SubElement(structure, tag)
        for i in indices:
            ET.SubElement(element, "Unknown", index=str(i), **dependency_attributes(table[i - 1], index_of))
    initial = ET.SubElement(structure, "InitialUnknowns")
    everything = " ".join(str(i) for i in inputs)
    for i in sorted(outputs + derivative_indices):
        ET.SubElement(initial, "Unknown", index=str(i), dependencies=everything)


def unit_definitions(root: ET.Element, units) -> None:
    """<UnitDefinitions>: each unit of ``units`` (crankfmu's names; "1" has none) with its SI base units."""
    element = ET.SubElement(root, "UnitDefinitions")
    for unit in sorted({si.fmi_name(u) for u in units if u != "1"}):
        ET.SubElement(ET.SubElement(element, "Unit", name=unit), "BaseUnit",
                      {k: str(v) for k, v in si.base_units(unit).items()})


def default_experiment(root: ET.Element, exp) -> None:
    """<DefaultExperiment> from a data file's [experiment] (parameters.Experiment)."""
    ET.SubElement(root, "DefaultExperiment", startTime=repr(exp.start_time), stopTime=repr(exp.stop_time),
                  tolerance=repr(exp.tolerance), stepSize=repr(exp.output_interval))
