"""FMI 3.0 for the native mechanism FMU (``crankfmu fmu SCENARIO --native --fmi-version 3``): the same
model and kernel as the FMI 2.0 FMU (``native/model/crank_model.c``, the same variables in the same
order: ``NativeModel.variables``) behind ``native/shells/fmi3_shell.c``. Here: its modelDescription
3.0 and its ``terminalsAndIcons/``.

- Variables are Float64, each of a ``Float64Type`` named after its quantity (Torque, Angle, ...)
  carrying the SI unit; the states' derivatives name their state (``derivative``); Model Exchange
  adds one variable per event indicator (the kernel's event slots: the motor's kink, its sliding
  mode, the two ends of the slider forces' switch interval, omega1 = 0) and every FMU the
  independent variable ``time``, after the FMI 2.0 variables (fmi3_shell.c's value references).
- ModelStructure: Output, ContinuousStateDerivative, InitialUnknown, EventIndicator.
- Co-Simulation: ``hasEventMode`` and ``mightReturnEarlyFromDoStep`` (fmi3_shell.c: a switch the
  kernel locates inside a step is the host's event, or ends the step early, as the host asks).
- terminalsAndIcons: the mechanism's drawing as the icon, and one terminal per port grouping its
  input and its outputs with each member's role (the force or couple flows in; the position,
  velocity and acceleration are signals).
"""

from __future__ import annotations

from xml.dom.minidom import parseString
from xml.etree import ElementTree as ET

from ... import units as si
from ..source import fmi3_annotations
from .model import (MAX_OUTPUT_DERIVATIVE_ORDER, N_EVENT_INDICATORS, NativeModel, default_experiment,
                           dependency_attributes, unit_definitions)

#: a unit's quantity, the name of its Float64Type (a unit not listed gets a type named after it)
QUANTITIES = {
    "rad": "Angle", "rad/s": "AngularVelocity", "rad/s2": "AngularAcceleration", "m": "Length", "m/s": "Velocity",
    "m/s2": "Acceleration", "N": "Force", "N.m": "Torque", "J": "Energy", "W": "Power", "kg": "Mass",
    "kg.m2": "MomentOfInertia", "s": "Time", "1": "Dimensionless", "N.m.s/rad": "RotationalDampingConstant",
    "N/m": "TranslationalSpringConstant", "N.s/m": "TranslationalDampingConstant"
}
#: what the Model Exchange event indicators are (crank_modes.h's slots, in order)
INDICATORS = ("the motor line's kink (omega1 - omega_switch)", "the end of sliding on the kink",
              "the lower end of the slider forces' switch interval", "the upper end of that interval",
              "omega1 = 0 (the crank coming to rest or leaving it)")


def type_name(unit: str) -> str:
    return QUANTITIES.get(unit) or "Unit_" + "".join(c if c.isalnum() else "_" for c in si.fmi_name(unit))


def model_description(model: NativeModel, sources: list[str]) -> bytes:
    """modelDescription.xml 3.0 of a native mechanism FMU: the variables of ``model.variables()``
    at the same value references as its FMI 2.0 FMU, the event indicators and time after them."""
    return describe(model.source, model.guid, model.scenario.title, model.scenario.experiment, model.variables(),
                    model_exchange=not model.speed, events=not model.speed,
                    indicators=0 if model.speed else N_EVENT_INDICATORS, reserved=N_EVENT_INDICATORS)


def describe(source, guid: str, title: str, experiment, table: list, model_exchange: bool, events: bool,
             indicators: int, reserved: int = 0, derivatives: bool = True) -> bytes:
    """modelDescription.xml 3.0 of a native FMU (a mechanism's or a component's): the variables of
    ``table`` (NativeVariable, in value-reference order), ``indicators`` event indicators (Model
    Exchange) and time after them, past the ``reserved`` value references the shell keeps for
    indicators (fmi3_shell.c: always the kernel's slots); Co-Simulation with event mode and early
    return where ``events`` (a switch the kernel locates); directional, adjoint and output
    derivatives where ``derivatives`` (every native FMU but the rod string)."""
    root = ET.Element("fmiModelDescription", fmiVersion="3.0", modelName=source.fmu, instantiationToken=guid,
                      description=title, generationTool="crankfmu (native)", variableNamingConvention="structured")
    common = dict(modelIdentifier=source.fmu, canGetAndSetFMUState="true", canSerializeFMUState="true",
                  providesDirectionalDerivatives=str(derivatives).lower(),
                  providesAdjointDerivatives=str(derivatives).lower())
    if model_exchange:
        ET.SubElement(root, "ModelExchange", **common, needsCompletedIntegratorStep="false")
    ET.SubElement(root, "CoSimulation", **common, canHandleVariableCommunicationStepSize="true",
                  maxOutputDerivativeOrder=str(MAX_OUTPUT_DERIVATIVE_ORDER if derivatives else 0),
                  hasEventMode="true" if events else "false", mightReturnEarlyFromDoStep="true" if events else "false",
                  canReturnEarlyAfterIntermediateUpdate="false", providesIntermediateUpdate="false")
    units = sorted({v.unit for v in table} | {"s"})
    unit_definitions(root, [u for u in units if u != "1"])
    types = ET.SubElement(root, "TypeDefinitions")
    for unit in sorted(units, key=type_name):
        attributes = {"name": type_name(unit), "quantity": type_name(unit)}
        if unit != "1":
            attributes["unit"] = si.fmi_name(unit)
        ET.SubElement(types, "Float64Type", **attributes)
    default_experiment(root, experiment)
    variables = ET.SubElement(root, "ModelVariables")
    vr_of = {v.name: vr for vr, v in enumerate(table)}
    for vr, v in enumerate(table):
        attributes = {"name": v.name, "valueReference": str(vr), "description": v.description,
                      "causality": v.causality, "variability": v.variability, "declaredType": type_name(v.unit)}
        attributes.update({k: getattr(v, k) for k in ("initial", "start", "min", "max") if getattr(v, k) is not None})
        if v.derivative_of:
            attributes["derivative"] = str(vr_of[v.derivative_of])
        ET.SubElement(variables, "Float64", **attributes)
    indicator_vrs = list(range(len(table), len(table) + indicators))
    for vr, what in zip(indicator_vrs, INDICATORS):
        ET.SubElement(variables, "Float64", name=f"eventIndicator{vr - len(table)}", valueReference=str(vr),
                      description=f"Model Exchange event indicator: {what}", causality="local",
                      variability="continuous", initial="calculated", declaredType=type_name("1"))
    # time: after every other variable (the shells' VR_TIME)
    ET.SubElement(variables, "Float64", name="time", valueReference=str(len(table) + max(indicators, reserved)),
                  description="simulation time", causality="independent", variability="continuous",
                  declaredType=type_name("s"))
    structure = ET.SubElement(root, "ModelStructure")
    for vr, v in enumerate(table):
        if v.causality == "output":
            ET.SubElement(structure, "Output", valueReference=str(vr), **dependency_attributes(v, vr_of))
    for vr, v in enumerate(table):
        if v.derivative_of:
            ET.SubElement(structure, "ContinuousStateDerivative", valueReference=str(vr),
                          **dependency_attributes(v, vr_of))
    for vr, v in enumerate(table):
        if v.causality == "output" or v.derivative_of:
            ET.SubElement(structure, "InitialUnknown", valueReference=str(vr))
    for vr in indicator_vrs:
        ET.SubElement(structure, "EventIndicator", valueReference=str(vr))
    root.append(fmi3_annotations(source, "native"))
    return parseString(ET.tostring(root, encoding="UTF-8")).toprettyxml(encoding="UTF-8", indent="  ")


def terminals_and_icons(model: NativeModel) -> str:
    """terminalsAndIcons/terminalsAndIcons.xml: the icon (icon.png beside it: the mechanism's drawing)
    and one terminal per port: its input (the force or couple on the mechanism: inflow) and its
    position, velocity and acceleration outputs (signals)."""
    root = ET.Element("fmiTerminalsAndIcons", fmiVersion="3.0")
    graphics = ET.SubElement(root, "GraphicalRepresentation")
    ET.SubElement(graphics, "CoordinateSystem", x1="-100", y1="-100", x2="100", y2="100",
                  suggestedScalingFactorTo_mm="0.1")
    ET.SubElement(graphics, "Icon", x1="-100", y1="-100", x2="100", y2="100")
    terminals = ET.SubElement(root, "Terminals")
    ports = list(model.ports)
    for k, port in enumerate(ports):
        terminal = ET.SubElement(terminals, "Terminal", name=port.name, matchingRule="bus",
                                 terminalKind=f"org.crankfmu.{port.kind}",
                                 description=port.input_description)
        ET.SubElement(terminal, "TerminalMemberVariable", variableName=port.input_name,
                      memberName=port.input_name.split("_")[-1], variableKind="inflow")
        for quantity in port.quantities:
            ET.SubElement(terminal, "TerminalMemberVariable", variableName=quantity.name,
                          memberName=quantity.name.split("_")[-1], variableKind="signal")
        # the terminals along the icon's right edge, top to bottom
        y = 80 - 160 * (k + 0.5) / len(ports)
        ET.SubElement(terminal, "TerminalGraphicalRepresentation", defaultConnectionColor="0 0 0",
                      x1="100", y1=f"{y - 10:g}", x2="120", y2=f"{y + 10:g}", description=port.name)
    if not ports:
        root.remove(terminals)
    return parseString(ET.tostring(root, encoding="UTF-8")).toprettyxml(encoding="UTF-8", indent="  ").decode()
