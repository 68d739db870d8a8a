"""``crankfmu ssp``: FourBarDrive.ssp, the four-bar driven by Drive.fmu, as an SSP 1.0 archive a
third-party master runs as it is (the ecos command, libcosim).

The system: FourBar.fmu with its own motor line switched off (A = B = A_low = B_low = 0) and
Drive.fmu; Drive.tau -> FourBar.tau_ext, FourBar.omega1 -> Drive.omega. Parameter sets (SSV files,
bound to each component):

- ``coupled``: the motor line off, the drive's data file values and its set-point;
- ``refused``: the same with FourBar's J_flywheel = -1, for checking that a master shows the
  FMU's refusal.

The default experiment (0 to 2 s) carries the Open Simulation Platform's fixed-step annotation
(1 ms), which both masters read.
"""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

from ..atomic import replacing
from ..errors import CrankfmuError

MOTOR_OFF = {"A": 0.0, "B": 0.0, "A_low": 0.0, "B_low": 0.0}
CONNECTIONS = (("Drive", "tau", "FourBar", "tau_ext"), ("FourBar", "omega1", "Drive", "omega"))
CONNECTORS = {"FourBar": (("omega1", "output"), ("tau_ext", "input")),
              "Drive": (("tau", "output"), ("omega", "input"), ("omega_set", "input"))}


def parameter_sets(drive_values: dict) -> dict[str, dict[str, dict[str, float]]]:
    """set name -> component -> parameter values."""
    coupled = {"FourBar": dict(MOTOR_OFF), "Drive": dict(drive_values)}
    refused = {"FourBar": {**MOTOR_OFF, "J_flywheel": -1.0}, "Drive": dict(drive_values)}
    return {"coupled": coupled, "refused": refused}


def _ssv(name: str, values: dict[str, float]) -> str:
    params = "\n".join(f'    <ssv:Parameter name={quoteattr(k)}><ssv:Real value="{v!r}"/></ssv:Parameter>'
                       for k, v in values.items())
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
            f'version="1.0" name="{name}">\n  <ssv:Parameters>\n{params}\n  </ssv:Parameters>\n</ssv:ParameterSet>\n')


def _ssd(sets: dict, stop_time: float, step: float) -> str:
    components = []
    for comp, connectors in CONNECTORS.items():
        conns = "\n".join(f'          <ssd:Connector name="{n}" kind="{k}"><ssc:Real/></ssd:Connector>'
                          for n, k in connectors)
        bindings = "\n".join(f'          <ssd:ParameterBinding source="ssv/{name}_{comp}.ssv"/>' for name in sets)
        components.append(f'''      <ssd:Component name="{comp}" source="resources/{comp}.fmu">
        <ssd:Connectors>
{conns}
        </ssd:Connectors>
        <ssd:ParameterBindings>
{bindings}
        </ssd:ParameterBindings>
      </ssd:Component>''')
    connections = "\n".join(f'      <ssd:Connection startElement="{a}" startConnector="{b}" endElement="{c}" endConnector="{d}"/>'
                            for a, b, c, d in CONNECTIONS)
    return f'''<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"
    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"
    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"
    xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations"
    name="FourBarDrive" version="1.0">
  <ssd:System name="FourBarDrive" description="seed-000 four-bar driven by a DC motor with a PI speed controller">
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


def write_ssp(fmus: Path, out: Path, stop_time: float = 2.0, step: float = 1e-3, drive_values: dict | None = None) -> Path:
    """``out``/FourBarDrive.ssp from ``fmus``/FourBar.fmu and Drive.fmu (``make fmu`` builds them)."""
    from ..dynamics.drive import load_drive

    fmus, out = Path(fmus), Path(out)
    for name in CONNECTORS:
        if not (fmus / f"{name}.fmu").is_file():
            raise CrankfmuError(f"no {name}.fmu in {fmus}: run `make fmu` first")
    if drive_values is None:
        drive = load_drive("dc_pi")
        drive_values = {n: p.value for n, p in {**drive.parameters, **drive.inputs}.items() if n != "omega"}
    sets = parameter_sets(drive_values)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "FourBarDrive.ssp"
    with replacing(path) as partial, zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd", _ssd(sets, stop_time, step))
        for name, per_component in sets.items():
            for comp, values in per_component.items():
                z.writestr(f"ssv/{name}_{comp}.ssv", _ssv(name, values))
        for comp in CONNECTORS:
            z.write(fmus / f"{comp}.fmu", f"resources/{comp}.fmu")
    return path


def unpack(ssp: Path, where: Path) -> Path:
    """The SSP unpacked (some masters take a folder)."""
    shutil.unpack_archive(str(ssp), str(where), "zip")
    return where
