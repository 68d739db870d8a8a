"""``crankfmu ssp``: the four-bar driven by the DC drive, as SSP 1.0 archives a third-party master
runs as they are (the ecos command, libcosim), in either causality at the crank.

- ``FourBarDrive.ssp``: FourBar.fmu with its own motor line switched off (A = B = A_low = B_low =
  0) and Drive.fmu; Drive.tau -> FourBar.tau_ext, FourBar.omega1 -> Drive.omega.
- ``FourBarDriveSpeed.ssp``: FourBarSpeed.fmu (speed causality, its flywheel moved to the drive:
  J_flywheel = 0) and DriveSpeed.fmu (it carries rotor and flywheel, J_drive = seed 000's
  flywheel); Drive.omega -> FourBar.omega1, FourBar.tau_drive -> Drive.tau_load. The same system
  as the first, so one in-process reference serves both.

The components are named FourBar and Drive in both.

- ``PumpingWell.ssp``: PumpJack.fmu (its data-file rod loads off, the geometry, counterweights and
  NEMA D motor line of the well wells/rp11l_guo.toml: crankfmu.well.unit_scenario) and
  RodString.fmu on its rope port: PumpJack.rod_s -> RodString.s, PumpJack.rod_v -> RodString.v,
  RodString.F -> PumpJack.rod_F. The well as one model (crankfmu.well.CoupledWell) is the reference.

- ``DriveShaftFourBar.ssp``: DriveSpeed.fmu (it carries the rotor and flywheel) on ElasticShaft.fmu
  (shafts/elastic_shaft.toml: k = 1e4 N.m/rad, 5 % damping) to FourBar.fmu in torque causality
  without flywheel (its motor line off): Drive.omega -> Shaft.omega_a, FourBar.omega1 ->
  Shaft.omega_b, Shaft.tau -> Drive.tau_load and FourBar.tau_ext. The shaft's torsional mode (a
  period of 20 ms) makes inputs held over a step unstable above 2 c / k = 0.63 ms: its fixed step
  is 0.1 ms. The same system with the shaft as an equation (validation/coupling.py's
  shaft_reference) is the reference.

- ``PressCushion.ssp``: TogglePress.fmu (the knuckle-joint press of the tests, its data-file
  cushion switched off: k_cushion = c_cushion = 0) and DieCushion.fmu on its ram port:
  Press.ram_s -> Cushion.s, Press.ram_v -> Cushion.v, Cushion.F -> Press.ram_F. The same press
  with its cushion written as a data-file load is the reference.

Parameter sets (SSV files, bound to each component):

- ``coupled``: as above (the drive's data file values and its set-point);
- ``refused``: the same with the mechanism's J_flywheel = -1, for checking that a master shows
  the FMU's refusal.

The default experiment (0 to 2 s) carries the Open Simulation Platform's fixed-step annotation
(1 ms; the system's own where its coupling needs a smaller one), which both masters read.
"""

from __future__ import annotations

import shutil
import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

from ..atomic import replacing
from ..errors import CrankfmuError
from .archive import add_bytes, add_file

MOTOR_OFF = {"A": 0.0, "B": 0.0, "A_low": 0.0, "B_low": 0.0}
#: the well of PumpingWell.ssp
WELL = "rp11l_guo"


def drive_values(speed_causal: bool) -> dict[str, float]:
    """The drive file's parameters and set-point (not its speed input), with its speed-causal
    parameters for DriveSpeed.fmu."""
    from ..dynamics.drive import load_drive

    drive = load_drive("dc_pi")
    values = {n: p.value for n, p in {**drive.parameters, **drive.inputs}.items() if n != "omega"}
    if speed_causal:
        values.update({n: p.value for n, p in drive.speed_parameters.items()})
    return values


def _well_values(component: str) -> dict[str, float]:
    """PumpingWell: the unit's parameters for the well (crankfmu.well.unit_scenario: geometry,
    counterweights, motor line, rod loads off) or the string's (its well file's)."""
    from ..dynamics.well import load_well
    from ..well import unit_scenario

    well = load_well(WELL)
    if component == "RodString":
        return well.values
    scenario = unit_scenario(well)
    return {n: scenario.values[n] for n in scenario.parameters}


def _cushion_values() -> dict[str, float]:
    from ..dynamics.cushion import load_cushion

    return {n: p.value for n, p in load_cushion("die_cushion").parameters.items()}


def shaft_values() -> dict[str, float]:
    """The packaged shaft file's parameters (DriveShaftFourBar.ssp's shaft)."""
    from ..dynamics.shaft import load_shaft

    return {n: p.value for n, p in load_shaft("elastic_shaft").parameters.items()}



@dataclass(frozen=True)
class System:
    name: str
    description: str
    sources: dict          # component -> the FMU's file stem
    connectors: dict       # component -> ((variable, "input" | "output"), ...)
    connections: tuple     # (from component, variable, to component, variable)
    fixed: dict            # component -> its parameters in the set "coupled"
    files: dict            # component -> () -> its data file's parameter values, written out in every set
    mechanism: str = "FourBar"     # the component the set "refused" gives J_flywheel = -1
    stop_time: float = 2.0         # s, the DefaultExperiment's
    step: float = 1e-3             # s, the fixed step its annotation gives the masters


SYSTEMS = {s.name: s for s in (
    System("FourBarDrive", "seed-000 four-bar driven by a DC motor with a PI speed controller",
           {"FourBar": "FourBar", "Drive": "Drive"},
           {"FourBar": (("omega1", "output"), ("tau_ext", "input")),
            "Drive": (("tau", "output"), ("omega", "input"), ("omega_set", "input"))},
           (("Drive", "tau", "FourBar", "tau_ext"), ("FourBar", "omega1", "Drive", "omega")), {"FourBar": MOTOR_OFF},
           {"Drive": lambda: drive_values(False)}),
    System("FourBarDriveSpeed", "seed-000 four-bar in speed causality, driven by a DC motor that carries the "
           "rotor and flywheel", {"FourBar": "FourBarSpeed", "Drive": "DriveSpeed"},
           {"FourBar": (("tau_drive", "output"), ("omega1", "input")),
            "Drive": (("omega", "output"), ("tau_load", "input"), ("omega_set", "input"))},
           (("Drive", "omega", "FourBar", "omega1"), ("FourBar", "tau_drive", "Drive", "tau_load")),
           {"FourBar": {"J_flywheel": 0.0}}, {"Drive": lambda: drive_values(True)}),
    System("DriveShaftFourBar", "seed-000 four-bar driven through an elastic shaft by a DC motor that carries the "
           "rotor and flywheel", {"Drive": "DriveSpeed", "Shaft": "ElasticShaft", "FourBar": "FourBar"},
           {"Drive": (("omega", "output"), ("tau_load", "input"), ("omega_set", "input")),
            "Shaft": (("tau", "output"), ("omega_a", "input"), ("omega_b", "input")),
            "FourBar": (("omega1", "output"), ("tau_ext", "input"))},
           (("Drive", "omega", "Shaft", "omega_a"), ("FourBar", "omega1", "Shaft", "omega_b"),
            ("Shaft", "tau", "Drive", "tau_load"), ("Shaft", "tau", "FourBar", "tau_ext")),
           {"FourBar": {**MOTOR_OFF, "J_flywheel": 0.0}},
           {"Drive": lambda: drive_values(True), "Shaft": shaft_values}, step=1e-4),
    System("PressCushion", "knuckle-joint press with a die cushion FMU on its ram port",
           {"Press": "TogglePress", "Cushion": "DieCushion"},
           {"Press": (("ram_s", "output"), ("ram_v", "output"), ("omega1", "output"), ("ram_F", "input")),
            "Cushion": (("F", "output"), ("s", "input"), ("v", "input"))},
           (("Press", "ram_s", "Cushion", "s"), ("Press", "ram_v", "Cushion", "v"), ("Cushion", "F", "Press", "ram_F")),
           {"Press": {"k_cushion": 0.0, "c_cushion": 0.0}}, {"Cushion": _cushion_values}, mechanism="Press",
           stop_time=3.0),
    System("PumpingWell", "beam pumping unit with its motor line and the rod string of the RP 11L example hanging "
           "from its horsehead", {"PumpJack": "PumpJack", "RodString": "RodString"},
           {"PumpJack": (("rod_s", "output"), ("rod_v", "output"), ("omega1", "output"), ("rod_F", "input")),
            "RodString": (("F", "output"), ("s", "input"), ("v", "input"))},
           (("PumpJack", "rod_s", "RodString", "s"), ("PumpJack", "rod_v", "RodString", "v"),
            ("RodString", "F", "PumpJack", "rod_F")),
           {}, {"PumpJack": lambda: _well_values("PumpJack"), "RodString": lambda: _well_values("RodString")},
           mechanism="PumpJack", stop_time=20.0),
)}


def parameter_sets(system: System) -> dict[str, dict[str, dict[str, float]]]:
    """set name -> component -> parameter values."""
    coupled = {comp: {**system.fixed.get(comp, {}), **(system.files[comp]() if comp in system.files else {})}
               for comp in system.sources}
    refused = {comp: dict(values) for comp, values in coupled.items()}
    refused[system.mechanism]["J_flywheel"] = -1.0
    return {"coupled": coupled, "refused": refused}


def _ssv(name: str, values: dict[str, float]) -> str:
    params = "\n".join(f'    <ssv:Parameter name={quoteattr(k)}><ssv:Real value="{v!r}"/></ssv:Parameter>'
                       for k, v in values.items())
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
            f'version="1.0" name="{name}">\n  <ssv:Parameters>\n{params}\n  </ssv:Parameters>\n</ssv:ParameterSet>\n')


def _ssd(system: System, sets: dict, stop_time: float, step: float) -> str:
    components = []
    for comp, connectors in system.connectors.items():
        conns = "\n".join(f'          <ssd:Connector name="{n}" kind="{k}"><ssc:Real/></ssd:Connector>'
                          for n, k in connectors)
        bindings = "\n".join(f'          <ssd:ParameterBinding source="ssv/{name}_{comp}.ssv"/>' for name in sets)
        components.append(f'''      <ssd:Component name="{comp}" source="resources/{system.sources[comp]}.fmu">
        <ssd:Connectors>
{conns}
        </ssd:Connectors>
        <ssd:ParameterBindings>
{bindings}
        </ssd:ParameterBindings>
      </ssd:Component>''')
    connections = "\n".join(f'      <ssd:Connection startElement="{a}" startConnector="{b}" endElement="{c}" endConnector="{d}"/>'
                            for a, b, c, d in system.connections)
    return f'''<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"
    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"
    xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations"
    name="{system.name}" version="1.0">
  <ssd:System name="{system.name}" description={quoteattr(system.description)}>
    <ssd:Elements>
{chr(10).join(components)}
    </ssd:Elements>
    <ssd:Connections>
{connections}
    </ssd:Connections>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0.0" stopTime="{stop_time!r}">
    <ssd:Annotations>
      <ssc:Annotation type="com.opensimulationplatform">
        <osp:Algorithm><osp:FixedStepAlgorithm baseStepSize="{step!r}"/></osp:Algorithm>
      </ssc:Annotation>
    </ssd:Annotations>
  </ssd:DefaultExperiment>
</ssd:SystemStructureDescription>
'''


def built_values(fmu: Path) -> tuple[str, dict[str, float]]:
    """(the FMU's build as its VendorAnnotations say: "native", "python" or "" for an FMU crankfmu did
    not build, {parameter: its start value} for each fixed parameter: a mechanism FMU's geometry,
    masses, loads and gravity, which a host sets before the end of initialisation)."""
    root = _model_description(fmu)
    build = built_from(fmu).get("build", "")
    fixed = {}
    for sv in root.find("ModelVariables"):
        real = sv.find("Real")
        if (sv.get("causality") == "parameter" and sv.get("variability") == "fixed" and real is not None
                and real.get("start") is not None):
            fixed[sv.get("name")] = float(real.get("start"))
    return build, fixed


def _model_description(fmu: Path):
    from xml.etree import ElementTree as ET

    with zipfile.ZipFile(fmu) as z:
        return ET.fromstring(z.read("modelDescription.xml"))


def built_from(fmu: Path) -> dict[str, str]:
    """What crankfmu built the FMU from, as its annotations say (build.vendor_annotations, and FMI 3.0's):
    kind ("scenario", "drive", ...), name, build, and a user's file and the causality where given;
    {} for an FMU crankfmu did not build."""
    from .source import crankfmu_annotation

    tool = crankfmu_annotation(_model_description(fmu))
    element = next(iter(tool), None) if tool is not None else None
    return {} if element is None else {"kind": element.tag.lower(), **element.attrib}


def _native_components(spec: System, fmus: Path) -> dict[str, Path]:
    """{FMU stem: the folder's native FMU}: each takes the values the SSP sets (a native mechanism
    FMU builds its tables for them when it initialises). A Python FMU, or one crankfmu did not
    build, is refused: one CrankfmuError naming each."""
    problems = []
    for stem in spec.sources.values():
        build, _ = built_values(fmus / f"{stem}.fmu")
        if build != "native":
            problems.append(f"{stem}.fmu in {fmus} is not a native FMU (its build: {build or 'not crankfmu'})")
    if problems:
        raise CrankfmuError(f"{spec.name}.ssp cannot be made of native FMUs: " + "; ".join(problems))
    return {stem: fmus / f"{stem}.fmu" for stem in spec.sources.values()}


def write_ssp(fmus: Path, out: Path, stop_time: float | None = None, step: float | None = None,
              system: "str | System" = "FourBarDrive", native: bool = False) -> Path:
    """``out``/SYSTEM.ssp from the FMUs in ``fmus`` (``make fmu`` builds them). ``native``: every
    FMU must be native (no Python on the host)."""
    if isinstance(system, System):        # a system of the caller's (the tests': one FMU and its values)
        spec, system = system, system.name
    elif system not in SYSTEMS:
        raise CrankfmuError(f"unknown system {system!r}: one of {', '.join(SYSTEMS)}")
    else:
        spec = SYSTEMS[system]
    fmus, out = Path(fmus), Path(out)
    for stem in spec.sources.values():
        if not (fmus / f"{stem}.fmu").is_file():
            what = f": build it with `crankfmu fmu ... --native --out {fmus}`" if native else ": run `make fmu` first"
            raise CrankfmuError(f"no {stem}.fmu in {fmus}{what}")
    if stop_time is None:
        stop_time = spec.stop_time
    if step is None:
        step = spec.step
    sets = parameter_sets(spec)
    paths = (_native_components(spec, fmus) if native
             else {stem: fmus / f"{stem}.fmu" for stem in spec.sources.values()})
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{system}.ssp"
    with replacing(path) as partial, zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
        add_bytes(z, "SystemStructure.ssd", _ssd(spec, sets, stop_time, step))
        for name, per_component in sets.items():
            for comp, values in per_component.items():
                add_bytes(z, f"ssv/{name}_{comp}.ssv", _ssv(name, values))
        for stem, fmu in paths.items():
            add_file(z, fmu, f"resources/{stem}.fmu")
    return path


def unpack(ssp: Path, where: Path) -> Path:
    """The SSP unpacked (some masters take a folder)."""
    shutil.unpack_archive(str(ssp), str(where), "zip")
    return where
