"""The native component FMUs: ``crankfmu fmu dc_pi --drive --native`` (Drive.fmu, and DriveSpeed.fmu
with ``--causality speed``), ``crankfmu fmu die_cushion --cushion --native`` (DieCushion.fmu), ``crankfmu fmu elastic_shaft --shaft
--native`` (ElasticShaft.fmu) and
``crankfmu fmu rp11l_guo --well --native`` (RodString.fmu).

The same data files, variables (names, order, units, ranges, starts, descriptions), DefaultExperiment
and documentation as the Python FMU of the file (fmi.source's Source and Declared), but C: the
native mechanism FMUs' runtime (fmi.native.build: one prebuilt binary per FMI version and
platform, nothing compiled), which reads the component's model file (fmi.native.model_file: its kind and
its variables) and runs its model (native/components/component_model.c, component_models.c) on the
components' physics (native/components/crank_components.c, which the Python FMUs call too). Co-Simulation;
FMI 2.0 for linux64 and win64, FMI 3.0 (``--fmi-version 3``) for x86_64 Linux and Windows and
aarch64 Linux, as the installation has them; each binary links only the platform's C library.
"""

from __future__ import annotations

import hashlib
import math
from contextlib import ExitStack
from pathlib import Path
from xml.dom.minidom import parseString
from xml.etree import ElementTree as ET

from ... import units as si
from ...contract import DRIVE_SPEED_STATE_DEPENDS, DRIVE_STATE_DEPENDS, SHAFT_STATE_DEPENDS, direct_dependencies
from ...errors import CrankfmuError
from . import model_file
from .build import native_runtimes, package_native
from .model import (MAX_OUTPUT_DERIVATIVE_ORDER, PER_SECOND, default_experiment, unit_definitions,
                           variables_and_structure)
from ..source import preflight, vendor_annotations


class ComponentModel:
    """What a native component FMU is generated from: its Source and its declared variables."""

    def __init__(self, source):
        self.source = source
        self.declared = source.variables()
        #: the continuous states the FMU declares with their derivatives: a drive's (i, x, and omega
        #: carrying the rotor), a shaft's twist, what each one's rate depends on; none for the cushion
        #: (a law of its inputs) and the rod string (its grid's explicit steps are no smooth equations)
        self.state_depends = {"drive": DRIVE_SPEED_STATE_DEPENDS if source.causality == "speed" else DRIVE_STATE_DEPENDS,
                              "shaft": SHAFT_STATE_DEPENDS}.get(source.kind, {})
        self.states = list(self.state_depends)
        key = (source.kind, source.causality)
        if key not in model_file.COMPONENTS:
            raise CrankfmuError(f"a {source.kind} file has no native build in {source.causality} causality")
        self.kind = model_file.COMPONENTS[key]
        # (name, kind, start, min, max, min_inclusive, max_inclusive, unit, range text, description)
        rows = [(v.name, "OUTPUT", 0.0, -math.inf, math.inf, True, True, v.unit, "", v.description)
                for v in self.declared.outputs]
        for p in self.declared.inputs:
            rows.append((p.name, "INPUT", p.value, -math.inf if p.min is None else p.min,
                         math.inf if p.max is None else p.max, p.min_inclusive, p.max_inclusive, p.unit,
                         p.range_text(), p.description))
        for p in self.declared.parameters:
            rows.append((p.name, "TUNABLE" if p.tunable else "FIXED", p.value, -math.inf if p.min is None else p.min,
                         math.inf if p.max is None else p.max, p.min_inclusive, p.max_inclusive, p.unit,
                         p.range_text(), p.description))
        # the states' derivatives, after every declared variable so that the variables the Python
        # FMU declares keep their value references
        units = {v.name: v.unit for v in self.declared.outputs}
        rows += [(f"der({name})", "DERIVATIVE", 0.0, -math.inf, math.inf, True, True, PER_SECOND[units[name]], "",
                  f"time derivative of {name}") for name in self.states]
        self.rows = rows
        digest = hashlib.sha256(repr((source.fmu, self.kind, rows)).encode()).hexdigest()
        self.guid = "{" + f"{digest[:8]}-{digest[8:12]}-{digest[12:16]}-{digest[16:20]}-{digest[20:32]}" + "}"

    def parameters(self) -> dict:
        return {p.name: p for p in (*self.declared.inputs, *self.declared.parameters)}

    @property
    def derivatives(self) -> bool:
        """Whether the FMU gives output and directional derivatives: a rod string's explicit grid
        has no smooth equations to take them of (the runtime refuses the calls)."""
        return self.source.kind != "well"

    def dependencies(self) -> dict[str, list[str]]:
        """Each output's and state derivative's direct dependencies: the states and inputs it reads."""
        inputs = [p.name for p in self.declared.inputs]
        found = {v.name: direct_dependencies(v.depends, self.declared.outputs, inputs, self.states)
                 for v in self.declared.outputs}
        for name, depends in self.state_depends.items():
            found[f"der({name})"] = direct_dependencies(depends, self.declared.outputs, inputs, self.states)
        return found

    def variables(self) -> list:
        """The variables in value-reference order, as FMI 3.0's description takes them (NativeVariable)."""
        from .model import NativeVariable

        table = []
        depends = self.dependencies()
        for name, kind, start, lo, hi, _, _, unit, text, description in self.rows:
            bounds = {"min": repr(float(lo)) if math.isfinite(lo) else None,
                      "max": repr(float(hi)) if math.isfinite(hi) else None}
            if kind == "OUTPUT":
                table.append(NativeVariable(name, unit, description, "output", "continuous", initial="calculated",
                                            depends=depends[name], **bounds))
            elif kind == "INPUT":
                table.append(NativeVariable(name, unit, description, "input", "continuous", start=repr(float(start)),
                                            **bounds))
            elif kind == "DERIVATIVE":
                table.append(NativeVariable(name, unit, description, "local", "continuous", initial="calculated",
                                            derivative_of=name[4:-1], depends=depends[name]))
            else:
                table.append(NativeVariable(name, unit, f"{description} (valid range {text})".strip(), "parameter",
                                            "tunable" if kind == "TUNABLE" else "fixed", start=repr(float(start)),
                                            **bounds))
        return table

    # ------------------------------------------------------------------ the model file
    def model_file(self) -> bytes:
        """resources/crankfmu-model.bin: the component's kind and variables, as the runtime reads them."""
        rows = [(name, kind, start, int(math.isfinite(lo)), int(lo_in), int(math.isfinite(hi)), int(hi_in),
                 lo if math.isfinite(lo) else 0.0, hi if math.isfinite(hi) else 0.0, text, unit, description)
                for name, kind, start, lo, hi, lo_in, hi_in, unit, text, description in self.rows]
        body = model_file.component_payload(self.source.fmu, self.guid, self.source.experiment.start_time, rows)
        return model_file.wrap(body, self.kind)

    # ------------------------------------------------------------------ modelDescription
    def model_description(self, sources: list[str]) -> bytes:
        exp = self.source.experiment
        root = ET.Element("fmiModelDescription", fmiVersion="2.0", modelName=self.source.fmu, guid=self.guid,
                          description=self.source.title, generationTool="crankfmu (native)",
                          variableNamingConvention="structured", numberOfEventIndicators="0")
        cs = ET.SubElement(root, "CoSimulation", modelIdentifier=self.source.fmu, canGetAndSetFMUstate="true",
                           canSerializeFMUstate="true", canNotUseMemoryManagementFunctions="false",
                           canHandleVariableCommunicationStepSize="true", canInterpolateInputs="true",
                           maxOutputDerivativeOrder=str(MAX_OUTPUT_DERIVATIVE_ORDER if self.derivatives else 0),
                           providesDirectionalDerivative=str(self.derivatives).lower())
        files = ET.SubElement(cs, "SourceFiles")
        for name in sources:
            if name.endswith(".c"):
                ET.SubElement(files, "File", name=name)
        unit_definitions(root, [row[7] for row in self.rows])
        default_experiment(root, exp)
        root.append(vendor_annotations(self.source, "native"))
        variables_and_structure(root, self.variables())
        return parseString(ET.tostring(root, encoding="UTF-8")).toprettyxml(encoding="UTF-8", indent="  ")


def build_native_component(kind: str, data_name: str, dest: Path, name: str | None = None,
                           causality: str | None = None, win64: bool | None = None, fmi_version: str = "2.0") -> Path:
    """The native FMU of a drive file (``kind`` "drive", either causality), a cushion file
    ("cushion") or a well file ("well": the rod string) in ``dest``, from the same Source the
    Python FMU is built from; FMI ``fmi_version`` "2.0" or "3.0" (the same runtime, the other
    shell). ``win64``: the Windows binary too (default: where the installation has it)."""
    source = preflight(kind, data_name, name, causality)
    model = ComponentModel(source)
    describe = model.model_description
    if fmi_version == "3.0":
        from . import fmi3

        describe = lambda sources: fmi3.describe(source, model.guid, source.title, source.experiment,  # noqa: E731
                                                        model.variables(), model_exchange=False, events=False,
                                                        indicators=0, derivatives=model.derivatives)
    runtimes = native_runtimes(fmi_version, win64)
    with ExitStack() as written:
        return package_native(source, dest, describe, model.parameters(), None,
                              {f"resources/{model_file.NAME}": model.model_file()}, {}, written, fmi_version, runtimes)
