"""Build the FMUs: ``python fmu_build/build.py [--dest build/fmus]`` (this module's ``main``).

On linux64 the FMU's binary is the shim of ``shim/fmu_shim.c`` beside this file (compiled here with gcc)
in front of pythonfmu's binary, renamed ``<model>_pythonfmu.so``: it makes the FMU load in plain
C/C++ hosts and turns refusals logged by the slave into fmi2Error. ``resources/python_env.txt``
records the Python that built the FMU, the last place the shim looks in a C host (README, "Using
the FMU elsewhere").

pythonfmu packs the slave script with crankfmu's own package in the resources (the same model
code and scenario files as the CLI, as one archive: ``pack``) and writes a modelDescription without units, unit
definitions or initial unknowns; this step completes it: each Real gets its SI unit (from the
scenario file), ``UnitDefinitions`` gives each unit's SI base exponents, ``InitialUnknowns``
lists the outputs with the parameters they depend on at initialisation, and the
``DefaultExperiment`` comes from the scenario's experiment. As the Reference FMUs do, the FMU
carries the default experiment's result (``extra/org.fmi-standard.fmi-ls-ref/<model>_out.csv``
with its manifest), written beside it too as the cross-check files ``<model>_ref.csv`` and
``<model>_ref.opt``; the result comes from the in-process reference integrator, an independent
method from the FMU's own stepper.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from contextlib import ExitStack, contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path
from xml.dom.minidom import parseString
from xml.etree import ElementTree as ET

from ..contract import OUTPUTS, SPEED_OUTPUTS
from ..errors import CrankfmuError
from .. import units as si
from ..atomic import replacing
from . import documentation
from .background import reference_beside
from . import cushion as cushion_core
from . import drive as drive_core
from . import rodstring as rodstring_core
from . import slave, speed

HERE = Path(__file__).resolve().parent
PACKAGE = HERE.parent           # the crankfmu package, shipped in every FMU's resources

#: what runs inside an FMU, relative to the package: the core on numpy alone and the FMI shell's
#: slave. Studies, plots, sweeps, the CLI, the harness, the build step and the scipy-based
#: integrators stay out (tests/test_fmu_dropin.py runs the FMUs where scipy cannot be imported).
RUNTIME = ("__init__.py", "cache.py", "contract.py", "errors.py", "expressions.py", "numerics.py", "scenario.py",
           "units.py",
           "mechanisms", "dynamics", "scenarios",
           "integrators/__init__.py", "integrators/base.py", "integrators/fast.py", "native",
           "fmi/__init__.py", "fmi/core.py", "fmi/slave.py", "fmi/speed.py", "fmi/drive.py", "fmi/cushion.py",
           "fmi/rodstring.py", "parameters.py", "datafiles.py", "drives", "elements", "wells")


#: the package's folders of data files: an FMU carries only the files it reads (Source.data)
DATA_FOLDERS = ("scenarios", "drives", "elements", "wells", "mechanisms/files")


def copy_runtime(dest: Path, files: dict | None = None, data=()):
    """The runtime part of the package (RUNTIME) into ``dest``, with the packaged data files
    ``data`` (paths in the package) and ``files`` (path -> text: a user's data files); each data
    file also as JSON, which an FMU reads where tomllib is missing (Python 3.10:
    datafiles.read_toml). The fewer the files, the faster a host that extracts the FMU on every
    run starts it."""
    import json
    import tomllib

    from .. import native
    from ..native.sources import PREBUILT

    # the C kernel travels compiled for linux64 (and its sources): the library this process loaded;
    # not the objects native FMUs link
    library = native.LIBRARY_PATH

    def ignore(folder, names):
        skip = {n for n in names if n == "__pycache__" or n.endswith((".so", ".dll", ".o"))}
        if Path(folder) == PREBUILT.parent:
            skip.add(PREBUILT.name)
        inside = Path(folder).relative_to(PACKAGE).as_posix()
        if inside in DATA_FOLDERS:
            skip |= {n for n in names if f"{inside}/{n}" not in data}
        return skip

    for entry in RUNTIME:
        source = PACKAGE / entry
        if source.is_dir():
            shutil.copytree(source, dest / entry, ignore=ignore)
        else:
            (dest / entry).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, dest / entry)
    shutil.copy2(library, dest / "native" / native.library_name(sys.platform))
    for path, text in (files or {}).items():
        (dest / path).parent.mkdir(parents=True, exist_ok=True)
        (dest / path).write_text(text, encoding="utf-8")
    for toml in dest.rglob("*.toml"):
        toml.with_suffix(".json").write_text(json.dumps(tomllib.loads(toml.read_text(encoding="utf-8"))), encoding="utf-8")


def pack(folder: Path) -> Path:
    """The package folder as one archive beside it (``<folder>.zip``), its content hash (every
    file's path and bytes) as the archive's comment: the FMU carries it as
    ``resources/crankfmu_<model>.zip`` and its slave script unpacks it once into the per-user cache,
    under that hash (slave_script.py.in). One file instead of some sixty: a host that extracts the
    FMU on every run (fmpy) spends about 0.15 ms per file."""
    import hashlib

    files = sorted(p for p in folder.rglob("*") if p.is_file())
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.relative_to(folder).as_posix().encode() + b"\0" + path.read_bytes())
    archive = folder.with_name(folder.name + ".zip")
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as out:
        for path in files:
            out.write(path, path.relative_to(folder).as_posix())
        out.comment = digest.hexdigest()[:16].encode()
    return archive


#: the data files the packaged FMUs are built from: every packaged scenario and drive file that
#: names its FMU (``fmu = "FourBar"``); the FMU's model identifier lives in the file
def packaged_sources() -> list[tuple[str, str]]:
    """(kind, name) of every packaged data file with an ``fmu`` key, in file order."""
    from ..dynamics.cushion import available_cushions, load_cushion
    from ..dynamics.drive import available_drives, load_drive
    from ..dynamics.well import available_wells, load_well
    from ..scenario import available_scenarios, load_scenario

    return ([("scenario", n) for n in available_scenarios() if load_scenario(n).data.get("fmu")]
            + [("drive", n) for n in available_drives() if load_drive(n).fmu]
            + [("cushion", n) for n in available_cushions() if load_cushion(n).fmu]
            + [("well", n) for n in available_wells() if load_well(n).fmu])


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
    variables: object = None        # () -> fmi.core.Declared: what the core registers
    load: str = ""                  # what the core loads: the packaged name, or "user/<file>.toml" in the FMU
    files: dict = field(default_factory=dict)   # a user's data files: path in the package -> text
    data: tuple = ()                # the packaged data files it reads: paths in the package
    causality: str = "torque"       # at the crank (a scenario) or the shaft (a drive): "torque" or "speed"
    scenario: object = None         # a scenario's Scenario, its --set values applied


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
            (scenario.title + " (speed causality)", "fmi.speed:SpeedCore", SPEED_OUTPUTS, speed_reference, speed)
            if causality == "speed" else
            (scenario.title, "fmi.slave:FmuCore", OUTPUTS, reference_result, slave))
        if causality == "speed" and not fmu_name and own != "speed":
            fmu += "Speed"
        source = Source(kind, scenario.name, fmu, title, scenario.experiment, core,
                        {v.name: v.initial for v in outputs}, groups, lambda: reference(scenario),
                        lambda f, md, params, ref, **about: documentation.scenario_documentation(
                            f, scenario, md, params, ref, speed=causality == "speed", **about),
                        lambda: core_module.declared(scenario), load=scenario.name, causality=causality,
                        scenario=scenario)
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
                          "fmi.drive:DriveSpeedCore", {}, {}, documentation=docs,
                          variables=lambda: drive_core.declared_speed(drive), load=drive.name,
                          data=(f"drives/{drive.name}.toml",), causality="speed")
        if causality not in (None, "torque"):
            raise CrankfmuError(f"--causality must be torque or speed, got {causality!r}")
        return Source(kind, drive.name, _fmu_name(fmu_name or drive.fmu, drive.where),
                      drive.title, drive.experiment, "fmi.drive:DriveCore", {}, {},
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

    return (load_cushion, "elements", "fmi.cushion:CushionCore", cushion_core.declared,
            documentation.cushion_documentation, "a cushion takes the ram's motion")


def _well():
    from ..dynamics.well import load_well

    return (load_well, "wells", "fmi.rodstring:RodStringCore", rodstring_core.declared,
            documentation.rodstring_documentation, "a rod string takes the polished rod's motion")


#: the small models built from a data file that is not a mechanism's: kind -> () -> (loader, its
#: data folder, the FMU's core, its declared variables, its documentation, what it takes instead
#: of a causality at the crank)
COMPONENTS = {"cushion": _cushion, "well": _well}


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


def complete_model_description(xml_bytes: bytes, units: dict[str, str], parameters: dict, source: Source) -> bytes:
    """pythonfmu's modelDescription with units, parameter ranges (min/max where a bound exists),
    UnitDefinitions, DefaultExperiment, the data file's name and InitialUnknowns."""
    root = ET.fromstring(xml_bytes)
    variables = root.find("ModelVariables")
    index = {}
    for i, sv in enumerate(variables.findall("ScalarVariable"), start=1):
        name = sv.get("name")
        index[name] = i
        real = sv.find("Real")
        unit = units.get(name)
        if unit is None:
            raise CrankfmuError(f"build: no unit for variable {name}")
        if real is not None and unit != "1":
            real.set("unit", si.fmi_name(unit))
        if real is not None and real.get("start") is not None:
            # pythonfmu writes 16 digits (rtol 1e-11 as 9.999999999999999e-12): the shortest text
            # of the same double, as the data file writes it (the native FMU's repr does too)
            real.set("start", repr(float(real.get("start"))))
        p = parameters.get(name)
        if real is not None and p is not None:
            # FMI's min/max are inclusive: an exclusive bound is declared as the bound itself and
            # refused by the FMU with its message
            if p.min is not None:
                real.set("min", repr(float(p.min)))
            if p.max is not None:
                real.set("max", repr(float(p.max)))
    # UnitDefinitions must come before ModelVariables (after LogCategories / DefaultExperiment order:
    # CoSimulation, UnitDefinitions, TypeDefinitions, LogCategories, DefaultExperiment, ...)
    unit_defs = ET.Element("UnitDefinitions")
    for unit in sorted({si.fmi_name(u) for u in units.values() if u != "1"}):
        u = ET.SubElement(unit_defs, "Unit", name=unit)
        ET.SubElement(u, "BaseUnit", {k: str(v) for k, v in si.base_units(unit).items()})
    children = list(root)
    position = [c.tag for c in children].index("CoSimulation") + 1
    root.insert(position, unit_defs)

    exp = source.experiment
    for old in root.findall("DefaultExperiment"):
        root.remove(old)
    default = ET.Element("DefaultExperiment", startTime=repr(exp.start_time), stopTime=repr(exp.stop_time),
                         tolerance=repr(exp.tolerance), stepSize=repr(exp.output_interval))
    position = [c.tag for c in root].index("ModelVariables")
    root.insert(position, default)
    for old in root.findall("VendorAnnotations"):
        root.remove(old)
    root.insert(position + 1, vendor_annotations(source, "python"))

    structure = root.find("ModelStructure")
    for old in structure.findall("InitialUnknowns"):
        structure.remove(old)
    initial = ET.SubElement(structure, "InitialUnknowns")
    outputs = [sv.get("name") for sv in variables.findall("ScalarVariable") if sv.get("causality") == "output"]
    everything = [sv.get("name") for sv in variables.findall("ScalarVariable")
                  if sv.get("causality") in ("parameter", "input")]
    for name in outputs:
        deps = []
        for d in source.depends.get(name, ("*all",)):
            deps += everything if d == "*all" else source.groups.get(d, [d])
        refs = sorted({index[d] for d in deps if d in index})
        ET.SubElement(initial, "Unknown", index=str(index[name]), dependencies=" ".join(map(str, refs)))
    for element in root.iter():           # drop pythonfmu's whitespace before re-indenting
        if element.text is not None and not element.text.strip():
            element.text = None
        element.tail = None
    text = ET.tostring(root, encoding="UTF-8")
    return parseString(text).toprettyxml(encoding="UTF-8", indent="  ")


def pythonfmu_binaries() -> dict[str, Path]:
    """pythonfmu's platform libraries, from its installed distribution's files: the pythonfmu that
    ``import`` finds may be the copy inside an FMU this process has loaded (pythonfmu puts an FMU's
    resources first on sys.path), which ships without its binaries, and FmuBuilder would then
    silently build an FMU without them."""
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        dist = distribution("pythonfmu")
    except PackageNotFoundError:
        raise CrankfmuError("build: pythonfmu is not installed (python -m pip install pythonfmu)") from None
    found = {Path(str(f)).parent.name: Path(dist.locate_file(f)) for f in dist.files or []
             if "resources/binaries/" in str(f) and Path(str(f)).suffix in (".so", ".dll", ".dylib")}
    if "linux64" not in found or not found["linux64"].is_file():
        raise CrankfmuError(f"build: pythonfmu's linux64 library is missing from its installation ({dist.locate_file('pythonfmu')})")
    return found


def compile_shim(name: str, out: Path) -> Path:
    """gcc the shim for model ``name``; the FMI headers come with fmpy."""
    import fmpy

    headers = Path(fmpy.__file__).parent / "c-code"
    cmd = ["gcc", "-shared", "-fPIC", "-O2", "-Wall", "-Werror", f"-I{headers}",
           f'-DINNER_LIBRARY="{name}_pythonfmu.so"', "-o", str(out), str(HERE / "shim" / "fmu_shim.c"), "-ldl"]
    try:
        subprocess.run(cmd, check=True, capture_output=True, text=True)
    except FileNotFoundError:
        raise CrankfmuError("build: gcc not found; it compiles the FMU's linux64 shim (apt-get install gcc)") from None
    except subprocess.CalledProcessError as exc:
        raise CrankfmuError(f"build: compiling the shim failed:\n{exc.stderr}") from None
    return out


def python_env() -> str:
    """The building Python, the last place the shim looks for one in a C host (README: "Using the
    FMU elsewhere"): key=value lines."""
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    return (f"executable={sys.executable}\nlibpython={libpython}\n"
            f"version={sys.version.split()[0]}\n")


LS_REF = "extra/org.fmi-standard.fmi-ls-ref"
LS_REF_MANIFEST = """<?xml version="1.0" encoding="UTF-8"?>
<fmiReferences xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest"
    fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref" fmi-ls:fmi-ls-version="1.0.0-alpha.1"
    fmi-ls:fmi-ls-description="Layered Standard providing information on related files included in an FMU.">
  <Related type="text/csv" source="{name}_out.csv" role="result"
      description="Outputs of the default experiment, from crankfmu's in-process reference integrator (DOP853, rtol = atol = 1e-12)"/>
</fmiReferences>
"""


def reference_result(scenario) -> str:
    """The default experiment's outputs (CSV, quoted header) from the in-process reference: run once
    per design and code (``make fmu`` builds three FMUs of each scenario), then read from the
    per-user cache under the hash of the scenario's data, its mechanism, its values and crankfmu's
    Python sources."""
    import hashlib

    import numpy as np

    from crankfmu import COLUMNS, simulate

    from ..cache import cache_root

    key = hashlib.sha256(repr((scenario.data, scenario.mechanism_definition(), sorted(scenario.values.items()),
                               _code_digest())).encode()).hexdigest()[:24]
    cached = cache_root() / "references" / f"{key}.csv"
    try:
        return cached.read_text(encoding="utf-8")
    except OSError:
        pass
    exp = scenario.experiment
    n = int(round((exp.stop_time - exp.start_time) / exp.output_interval))
    times = exp.start_time + exp.output_interval * np.arange(n + 1)
    result = simulate(scenario, t_end=exp.stop_time, output_times=times)
    lines = [",".join(f'"{c}"' for c in COLUMNS)]
    lines += [",".join(f"{getattr(result, c)[i]:.17g}" for c in COLUMNS) for i in range(times.size)]
    text = "\n".join(lines) + "\n"
    try:
        cached.parent.mkdir(parents=True, exist_ok=True)
        partial = cached.with_name(f"{cached.name}.{os.getpid()}")
        partial.write_text(text, encoding="utf-8")
        os.replace(partial, cached)
    except OSError:                   # a cache that cannot be written: the run is not kept
        pass
    return text


_CODE_DIGEST = []


def _code_digest() -> str:
    """The hash of crankfmu's Python sources (what the reference run's numbers depend on), once per process."""
    import hashlib

    if not _CODE_DIGEST:
        digest = hashlib.sha256()
        for path in sorted(PACKAGE.rglob("*.py")):
            digest.update(path.relative_to(PACKAGE).as_posix().encode() + b"\0" + path.read_bytes())
        _CODE_DIGEST.append(digest.hexdigest())
    return _CODE_DIGEST[0]


def speed_reference(scenario) -> str:
    """The speed-causal FMU's default experiment (omega1 held at omega1_start) by another method:
    phi1 = phi1_start + omega1 t, and the drive torque as the equilibrium moment M_e of the power
    balance (dynamics.inverse, seed 001 eq. 1) on the contour engine, not the tables."""
    import numpy as np

    from ..dynamics.inverse import equilibrium_moment

    exp = scenario.experiment
    n = int(round((exp.stop_time - exp.start_time) / exp.output_interval))
    times = exp.start_time + exp.output_interval * np.arange(n + 1)
    values = scenario.values
    omega = values["omega1_start"]
    if omega == 0.0:
        return ""
    model = scenario.build()
    phi = values["phi1_start"] + omega * (times - exp.start_time)
    m = equilibrium_moment(model.reduced, phi, omega)
    J = model.reduced.coefficients(phi)[0]
    columns = {"time": times, "phi1": phi, "epsilon1": np.zeros_like(phi), "tau_drive": m.total,
               "M_load": -(m.weights + m.technological), "J_red": J, "E_kin": 0.5 * J * omega * omega}
    lines = [",".join(f'"{c}"' for c in columns)]
    lines += [",".join(f"{columns[c][i]:.17g}" for c in columns) for i in range(times.size)]
    return "\n".join(lines) + "\n"


def cross_check_options(source: Source) -> str:
    exp = source.experiment
    return (f"StartTime, {exp.start_time!r}\nStopTime, {exp.stop_time!r}\n"
            f"StepSize, {exp.output_interval!r}\nRelTol, {exp.tolerance!r}\n")


def slave_script(name: str, source: Source, digest: str) -> str:
    """The slave script of one FMU, from the one template; ``digest``: its package's content hash."""
    from string import Template

    module, cls = source.core.split(":")
    template = Template((HERE / "slave_script.py.in").read_text(encoding="utf-8"))
    return template.substitute(NAME=name, SOURCE=source.load, CORE_MODULE=module, CORE_CLASS=cls,
                               DESCRIPTION=repr(source.title), DIGEST=digest)


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


class StageFailed(CrankfmuError):
    """A build's failure, named by the stage it happened in."""


#: who is told of each stage of a build as it starts (the CLI's progress line on a terminal)
_ON_STAGE: ContextVar = ContextVar("crankfmu_on_stage", default=None)


@contextmanager
def watching_stages(told):
    """Inside the block, ``told(fmu, what)`` hears of each build stage as it starts."""
    token = _ON_STAGE.set(told)
    try:
        yield
    finally:
        _ON_STAGE.reset(token)


@contextmanager
def stage(fmu: str, what: str):
    """Name the stage of the build in any failure inside it: the CLI prints one line. A stage inside
    another (the reference run, waited for by the documentation that plots it) names itself only."""
    told = _ON_STAGE.get()
    if told is not None:
        told(fmu, what)
    try:
        yield
    except StageFailed:
        raise
    except CrankfmuError as exc:
        raise StageFailed(f"{fmu}.fmu: {what}: {exc}") from exc
    except Exception as exc:        # anything else is a bug or the machine: the message says which stage
        raise StageFailed(f"{fmu}.fmu: {what} failed: {type(exc).__name__}: {exc}") from exc


def build(kind: str, data_name: str, dest: Path, name: str | None = None, causality: str | None = None) -> Path:
    """Build the FMU of a data file (a packaged name, or a user's scenario file by path) into
    ``dest``; ``name`` overrides the file's ``fmu`` key. Returns the FMU's path.

    Every file it writes (the FMU and its cross-check files) is written whole or not at all: a
    failure at any stage leaves ``dest`` as it was (``atomic.replacing``)."""
    from pythonfmu import FmuBuilder

    source = preflight(kind, data_name, name, causality)
    name = source.fmu
    dest.mkdir(parents=True, exist_ok=True)
    out = dest / f"{name}.fmu"
    # the reference run from now on, beside the packing and the shim's compiler (fmi.background)
    with tempfile.TemporaryDirectory() as tmp, ExitStack() as written, \
            reference_beside(source.reference) as reference_text:
        # the package travels under a private name (see slave_script.py.in)
        private = Path(tmp) / "pkg" / f"crankfmu_{name}"
        script_dir = Path(tmp) / "script"
        script_dir.mkdir()
        script = script_dir / f"{name}.py"
        with stage(name, "copying the package"):
            copy_runtime(private, source.files, source.data)
        with stage(name, "packing the package"):
            archive = pack(private)
            with zipfile.ZipFile(archive) as packed:
                script.write_text(slave_script(name, source, packed.comment.decode()), encoding="utf-8")
        sys.path.insert(0, str(private.parent))
        sys.path.insert(0, str(script_dir))
        try:
            with stage(name, "pythonfmu's build of the slave"):
                raw = FmuBuilder.build_FMU(script, dest=Path(tmp) / f"{name}.fmu",
                                           project_files=[archive],
                                           canGetAndSetFMUstate=True, canSerializeFMUstate=True)
        finally:
            sys.path.remove(str(private.parent))
            sys.path.remove(str(script_dir))
            sys.modules.pop(name, None)
        with stage(name, "declaring the variables"):
            declared = source.variables()
            slave_units, slave_parameters = declared.units, {p.name: p for p in declared.parameters}
        with stage(name, "compiling the linux64 shim"):
            shim = compile_shim(name, Path(tmp) / f"{name}.so")

        def reference_run():            # the documentation waits for it once it has drawn the mechanism
            with stage(name, "the reference run of the default experiment"):
                return reference_text()
        with stage(name, "finding pythonfmu's platform binaries"):
            platform_binaries = pythonfmu_binaries()
        binary = f"binaries/linux64/{name}.so"
        partial = written.enter_context(replacing(out))
        with zipfile.ZipFile(raw) as zin, zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                if item.filename.startswith("binaries/"):
                    continue                  # pythonfmu's binaries come from its installation, below
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml":
                    with stage(name, "completing the modelDescription"):
                        data = complete_model_description(data, slave_units, slave_parameters, source)
                    with stage(name, "the documentation"):
                        docs = source.documentation(name, data, slave_parameters, reference_run, build="python",
                                                    platforms=sorted(platform_binaries))
                zout.writestr(item, data)
            reference = reference_run()
            with stage(name, "writing the FMU"):
                for platform, library in platform_binaries.items():
                    inner = f"{name}_pythonfmu.so" if platform == "linux64" else f"{name}{library.suffix}"
                    zout.write(library, f"binaries/{platform}/{inner}")
                zout.write(shim, binary)
                zout.writestr("resources/python_env.txt", python_env())
                for path, content in docs.items():
                    zout.writestr(path, content)
                if reference is not None:
                    zout.writestr(f"{LS_REF}/fmi-ls-manifest.xml", LS_REF_MANIFEST.format(name=name))
                    zout.writestr(f"{LS_REF}/{name}_out.csv", reference)
        if reference is not None:
            with stage(name, "writing the cross-check files"):
                Path(written.enter_context(replacing(dest / f"{name}_ref.csv"))).write_text(reference, encoding="utf-8")
                Path(written.enter_context(replacing(dest / f"{name}_ref.opt"))).write_text(cross_check_options(source), encoding="utf-8")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--dest", default="build/fmus")
    args = parser.parse_args(argv)
    try:
        for kind, data_name in packaged_sources():
            path = build(kind, data_name, Path(args.dest))
            print(f"built {path}")
    except CrankfmuError as exc:
        print(f"build: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
