"""What an FMU is built from, whichever build makes it (the Python FMU: fmi.python.build; the native
ones: fmi.native.build, fmi.native.components): the data file resolved to a Source (its model
identifier, the slave core that runs it, its declared variables, its documentation and reference
run), checked before anything is built (``preflight``, which ``crankfmu check`` runs too), and the
annotations by which the harness finds the file an FMU implements.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree as ET

from .. import units as si
from ..contract import OUTPUTS, SPEED_OUTPUTS
from ..errors import CrankfmuError
from .python import cushion as cushion_core
from .python import shaft as shaft_core
from . import documentation
from .python import drive as drive_core
from .python import rodstring as rodstring_core
from .python import slave, speed
from .reference import reference_result, speed_reference


#: a model identifier names the binary and the C symbols' prefix: a C identifier
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


@dataclass
class Source:
    """What an FMU is built from: its data file, the slave core that runs it, and what the
    modelDescription says of it."""

    kind: str                       # "scenario" or "drive"
    name: str                       # the data file's name
    fmu: str                        # the FMU's model identifier (the file's ``fmu`` key, or --name)
    title: str
    experiment: object              # parameters.Experiment
    core: str                       # "module:Class" inside the package
    depends: dict                   # output -> initial dependencies (contract.Variable.initial)
    groups: dict                    # "*geometry", "*loads" -> parameter names
    reference: object = None        # () -> the default experiment's outputs as CSV text, or None
    documentation: object = None    # (modelDescription, parameters, reference CSV) -> {path in FMU: bytes}
    variables: object = None        # () -> fmi.python.core.Declared: what the core registers
    load: str = ""                  # what the core loads: the packaged name, or "user/<file>.toml" in the FMU
    files: dict = field(default_factory=dict)   # a user's data files: path in the package -> text
    data: tuple = ()                # the packaged data files it reads: paths in the package
    causality: str = "torque"       # at the crank (a scenario) or the shaft (a drive): "torque" or "speed"
    scenario: object = None         # a scenario's Scenario, its --set values applied
    #: () -> words: what the FMU does at fmi2ExitInitializationMode and its first step, at its start
    #: values, in this process; raises CrankfmuError where a host's would fail (None: nothing to try)
    initialise: object = None


def source_of(kind: str, name: str, fmu_name: str | None = None, causality: str | None = None,
              values: dict | None = None) -> Source:
    """What to build: a packaged data file by name, or a user's scenario file by path (its
    mechanism file, when given by path, travels with it). ``causality`` ("torque" or "speed")
    overrides the scenario's [crank] causality; a speed-causal FMU of a torque-causal file is
    named with "Speed" appended unless ``fmu_name`` is given. ``values``: a scenario's parameters
    set to other values than its file's (each range-checked; a native FMU is built for them)."""
    if kind == "scenario":
        from ..scenario import CAUSALITIES, load_scenario

        scenario = load_scenario(name).with_params(**(values or {}))
        if causality is not None and causality not in CAUSALITIES:
            raise CrankfmuError(f"--causality must be one of {', '.join(CAUSALITIES)}, got {causality!r}")
        own = scenario.causality
        causality = causality or own
        definition = scenario.mechanism_definition()
        groups = {"*geometry": sorted(set(definition.geometry_parameters) | set(definition.mass_parameters)),
                  "*loads": sorted(scenario.load_parameters())}
        fmu = _fmu_name(fmu_name or scenario.data.get("fmu"), scenario.where)
        title, core, outputs, reference, core_module = (
            (scenario.title + " (speed causality)", "fmi.python.speed:SpeedCore", SPEED_OUTPUTS, speed_reference, speed)
            if causality == "speed" else
            (scenario.title, "fmi.python.slave:FmuCore", OUTPUTS, reference_result, slave))
        if causality == "speed" and not fmu_name and own != "speed":
            fmu += "Speed"
        source = Source(kind, scenario.name, fmu, title, scenario.experiment, core,
                        {v.name: v.initial for v in outputs}, groups, lambda: reference(scenario),
                        lambda f, md, params, ref, **about: documentation.scenario_documentation(
                            f, scenario, md, params, ref, speed=causality == "speed", **about),
                        lambda: core_module.declared(scenario), load=scenario.name, causality=causality,
                        scenario=scenario, initialise=None if causality == "speed" else lambda: slave.initialises(scenario))
        if _is_path(name):
            source.load, source.files = _user_files(scenario, name)
        else:
            source.data += (f"scenarios/{scenario.name}.toml",)
        if not str(scenario.mechanism_name).endswith(".toml"):
            source.data += (f"mechanisms/files/{scenario.mechanism_name}.toml",)
        return source
    if kind == "drive":
        from ..dynamics.drive import load_drive

        drive = load_drive(name)
        docs = lambda f, md, params, ref, **about: documentation.drive_documentation(  # noqa: E731
            f, drive, md, params, causality == "speed", **about)
        if causality == "speed":
            if drive.speed_parameters is None:
                raise CrankfmuError(f"{drive.where}: --causality speed needs the drive file's [speed_causality] "
                                    "(J_drive, omega_start and the input tau_load)")
            return Source(kind, drive.name, _fmu_name(fmu_name or drive.speed_fmu or drive.fmu + "Speed", drive.where),
                          drive.title + " (speed causality: it carries the rotor and flywheel)", drive.experiment,
                          "fmi.python.drive:DriveSpeedCore", {}, {}, documentation=docs,
                          variables=lambda: drive_core.declared_speed(drive), load=drive.name,
                          data=(f"drives/{drive.name}.toml",), causality="speed")
        if causality not in (None, "torque"):
            raise CrankfmuError(f"--causality must be torque or speed, got {causality!r}")
        return Source(kind, drive.name, _fmu_name(fmu_name or drive.fmu, drive.where),
                      drive.title, drive.experiment, "fmi.python.drive:DriveCore", {}, {},
                      documentation=docs,
                      variables=lambda: drive_core.declared(drive), load=drive.name, data=(f"drives/{drive.name}.toml",))
    if kind in COMPONENTS:
        load, folder, core, declared, document, takes = COMPONENTS[kind]()
        component = load(name)
        if causality is not None:
            raise CrankfmuError(f"--causality is for a mechanism's or a drive's FMU; {takes}")
        return Source(kind, component.name, _fmu_name(fmu_name or component.fmu, component.where), component.title,
                      component.experiment, core, {}, {},
                      documentation=lambda f, md, params, ref, **about: document(f, component, md, params, **about),
                      variables=lambda: declared(component), load=component.name,
                      data=(f"{folder}/{component.name}.toml",))
    raise CrankfmuError(f"build: unknown kind {kind!r}")


def _cushion():
    from ..dynamics.cushion import load_cushion

    return (load_cushion, "elements", "fmi.python.cushion:CushionCore", cushion_core.declared,
            documentation.cushion_documentation, "a cushion takes the ram's motion")


def _shaft():
    from ..dynamics.shaft import load_shaft

    return (load_shaft, "shafts", "fmi.python.shaft:ShaftCore", shaft_core.declared, documentation.shaft_documentation,
            "a shaft takes both sides' speeds")


def _well():
    from ..dynamics.well import load_well

    return (load_well, "wells", "fmi.python.rodstring:RodStringCore", rodstring_core.declared,
            documentation.rodstring_documentation, "a rod string takes the polished rod's motion")


#: the small models built from a data file that is not a mechanism's: kind -> () -> (loader, its
#: data folder, the FMU's core, its declared variables, its documentation, what it takes instead
#: of a causality at the crank)
COMPONENTS = {"cushion": _cushion, "shaft": _shaft, "well": _well}


def _is_path(name) -> bool:
    return str(name).endswith(".toml") and Path(name).is_file()


def _fmu_name(name, where: str) -> str:
    if not name:
        raise CrankfmuError(f"{where}: no FMU name: give --name NAME or write fmu = \"NAME\" in the scenario file")
    if not IDENTIFIER.match(str(name)):
        raise CrankfmuError(f"FMU name {name!r} (--name or the file's fmu key) must be a C identifier: a letter "
                            "or _ then letters, digits or _")
    return str(name)


def _user_files(scenario, path) -> tuple[str, dict]:
    """A user's scenario (and its mechanism file, when referenced by path) as files of the FMU's
    package under ``user/``: the core loads ``user/<scenario>.toml`` and the mechanism beside it."""
    files = {}
    text = Path(path).read_text(encoding="utf-8")
    mechanism = str(scenario.mechanism_name)
    if mechanism.endswith(".toml"):
        definition_path = Path(scenario.mechanism_source())
        files[f"user/{definition_path.name}"] = definition_path.read_text(encoding="utf-8")
        text, count = re.subn(r'^(\s*mechanism\s*=\s*)(["\']).*?\2', lambda m: f'{m.group(1)}"{definition_path.name}"',
                              text, count=1, flags=re.M)
        if count != 1:
            raise CrankfmuError(f"{path}: the line mechanism = \"...\" was not found to point it at the FMU's copy")
    load = f"user/{Path(path).name}"
    files[load] = text
    return load, files


#: where a native FMU carries a user's data files (a pythonfmu FMU packs them in its package)
NATIVE_USER_FILES = "resources/crankfmu"


def vendor_annotations(source: Source, build: str) -> ET.Element:
    """Which data file the FMU implements, so the harness runs the same file in process:
    ``<Tool name="crankfmu"><Scenario name=... causality=... file=... build=.../></Tool>``
    (Drive, Cushion, Well for the components). ``build`` is "python" or "native"; ``file``, for
    a user's scenario, is where the FMU carries it (in its package, or under NATIVE_USER_FILES)."""
    vendor = ET.Element("VendorAnnotations")
    tool = ET.SubElement(vendor, "Tool", name="crankfmu")
    annotation = ET.SubElement(tool, source.kind.capitalize(), name=source.name, build=build)
    if source.causality == "speed":
        annotation.set("causality", "speed")
    if source.files:
        annotation.set("file", source.load)
    return vendor


#: FMI 3.0's place for a tool's annotations: <Annotations><Annotation type=...>
FMI3_ANNOTATION = "org.crankfmu"


def fmi3_annotations(source: Source, build: str) -> ET.Element:
    """vendor_annotations as FMI 3.0 writes them: <Annotations><Annotation type="org.crankfmu"><Scenario .../>."""
    annotations = ET.Element("Annotations")
    ET.SubElement(annotations, "Annotation", type=FMI3_ANNOTATION).extend(list(vendor_annotations(source, build).find("Tool")))
    return annotations


def crankfmu_annotation(root: ET.Element) -> ET.Element | None:
    """The element holding what crankfmu built an FMU from (Scenario, Drive, ...) in an FMI 2.0 or 3.0
    modelDescription's root, or None for an FMU crankfmu did not build."""
    tool = root.find("VendorAnnotations/Tool[@name='crankfmu']")
    return tool if tool is not None else root.find(f"Annotations/Annotation[@type='{FMI3_ANNOTATION}']")


def preflight(kind: str, data_name: str, name: str | None = None, causality: str | None = None,
              values: dict | None = None) -> Source:
    """Everything the build would refuse in the files, before anything is built: the model
    identifier, each variable's name (a C identifier, declared once), its unit (``units``), its
    start inside its own range, and the DefaultExperiment. ``crankfmu check`` runs the same.
    Returns the Source; raises CrankfmuError listing every problem found."""
    source = source_of(kind, data_name, name, causality, values)
    declared = source.variables()
    problems = []
    seen: dict[str, str] = {}
    for role, variables in (("output", declared.outputs), ("input", declared.inputs),
                            ("parameter", declared.parameters)):
        for v in variables:
            if not IDENTIFIER.match(v.name):
                problems.append(f"{role} {v.name!r}: a variable's name must be a C identifier (hosts, SSP "
                                "connections and CSV columns use it)")
            if v.name in seen or v.name == "time":
                problems.append(f"{role} {v.name!r}: the name is taken by " + (f"the {seen[v.name]} of that name"
                                if v.name in seen else "the FMU's independent variable"))
            seen.setdefault(v.name, role)
            try:
                si.fmi_name(v.unit)
            except si.UnitError as exc:
                problems.append(f"{role} {v.name}: {exc}")
    exp = source.experiment
    for what, ok in (("stop_time > start_time", exp.stop_time > exp.start_time),
                     ("output_interval > 0", exp.output_interval > 0),
                     ("output_interval <= stop_time - start_time", exp.output_interval <= exp.stop_time - exp.start_time),
                     ("tolerance > 0", exp.tolerance > 0)):
        if not ok:
            problems.append(f"[experiment] needs {what} (the FMU's DefaultExperiment)")
    if problems:
        raise CrankfmuError(f"{source.name}: " + "; ".join(problems))
    return source
