"""The native component FMUs: ``crankfmu fmu dc_pi --drive --native`` (Drive.fmu, and DriveSpeed.fmu
with ``--causality speed``), ``crankfmu fmu die_cushion --cushion --native`` (DieCushion.fmu) and
``crankfmu fmu rp11l_guo --well --native`` (RodString.fmu).

The same data files, variables (names, order, units, ranges, starts, descriptions), DefaultExperiment
and documentation as the Python FMU of the file (fmi.source's Source and Declared), but C: one
model for every component (native/fmu/component_model.c) behind an FMI 2.0 or 3.0 shell
(component_fmi2.c, component_fmi3.c), the components' models (native/fmu/component_models.c) on
the components' physics (native/crank_components.c, which the Python FMUs call too), and the
file's variables generated as data (component_config.h, component_data.c). Co-Simulation; FMI
2.0 for linux64 and, where Debian's MinGW-w64 is installed, win64; FMI 3.0 (``--fmi-version 3``)
for x86_64 Linux and Windows and aarch64 Linux; each binary links only the platform's C library.
"""

from __future__ import annotations

import hashlib
import math
import re
from contextlib import ExitStack
from pathlib import Path
from xml.dom.minidom import parseString
from xml.etree import ElementTree as ET

from .. import units as si
from ..errors import CrankfmuError
from ..native.sources import COMPONENTS, HERE as NATIVE

#: the components' physics and the numbers of their messages
PHYSICS_SOURCES = (*COMPONENTS, "crank_numbers.c", "crank_numbers.h")
from .source import preflight, vendor_annotations
from .native_build import package_native
from .native_model import c_double, c_string, default_experiment, unit_definitions

SHELL = NATIVE / "fmu"
#: the component's model behind either FMI shell, and each version's shell
MODEL_SOURCES = ("component_model.c", "component_model.h", "component_variables.h", "component_models.c",
                 "fmu_states.h")
SHELL_SOURCES = {"2.0": ("component_fmi2.c", "fmi2_messages.c", "fmi2_messages.h"),
                 "3.0": ("component_fmi3.c", "fmi3_refusals.c", "fmi3_refusals.h")}
#: which model of component_models.c a (kind, causality) builds
MODELS = {("drive", "torque"): "COMPONENT_DRIVE", ("drive", "speed"): "COMPONENT_DRIVE_SPEED",
          ("cushion", "torque"): "COMPONENT_CUSHION", ("well", "torque"): "COMPONENT_ROD_STRING"}
KINDS = {"OUTPUT": 0, "INPUT": 1, "TUNABLE": 2, "FIXED": 3}


class ComponentModel:
    """What a native component FMU is generated from: its Source and its declared variables."""

    def __init__(self, source):
        self.source = source
        self.declared = source.variables()
        key = (source.kind, source.causality)
        if key not in MODELS:
            raise CrankfmuError(f"a {source.kind} file has no native build in {source.causality} causality")
        self.model = MODELS[key]
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
        self.rows = rows
        digest = hashlib.sha256(repr((source.fmu, self.model, rows)).encode()).hexdigest()
        self.guid = "{" + f"{digest[:8]}-{digest[8:12]}-{digest[12:16]}-{digest[16:20]}-{digest[20:32]}" + "}"

    def parameters(self) -> dict:
        return {p.name: p for p in (*self.declared.inputs, *self.declared.parameters)}

    def variables(self) -> list:
        """The variables in value-reference order, as FMI 3.0's description takes them (NativeVariable)."""
        from .native_model import NativeVariable

        table = []
        for name, kind, start, lo, hi, _, _, unit, text, description in self.rows:
            bounds = {"min": repr(float(lo)) if math.isfinite(lo) else None,
                      "max": repr(float(hi)) if math.isfinite(hi) else None}
            if kind == "OUTPUT":
                table.append(NativeVariable(name, unit, description, "output", "continuous", initial="calculated",
                                            **bounds))
            elif kind == "INPUT":
                table.append(NativeVariable(name, unit, description, "input", "continuous", start=repr(float(start)),
                                            **bounds))
            else:
                table.append(NativeVariable(name, unit, f"{description} (valid range {text})".strip(), "parameter",
                                            "tunable" if kind == "TUNABLE" else "fixed", start=repr(float(start)),
                                            **bounds))
        return table

    # ------------------------------------------------------------------ generated C
    def _string_layout(self) -> str:
        """A rod string's value references of its tapers' and design's values, in the order of
        crank_components.h (TAPER_KEYS per taper, STRING_KEYS = its CD_* order)."""
        from ..dynamics.well import STRING_KEYS, TAPER_KEYS

        vr = {row[0]: k for k, row in enumerate(self.rows)}
        n = sum(1 for name in vr if re.fullmatch(r"taper\d+_length", name))
        tapers = ", ".join("{" + ", ".join(str(vr[f"taper{i}_{k}"]) for k in TAPER_KEYS) + "}" for i in range(1, n + 1))
        return (f"#define N_TAPERS {n}\n"
                f"static const int TAPER_VR[N_TAPERS][4] = {{{tapers}}};\n"
                f"static const int DESIGN_VR[] = {{{', '.join(str(vr[k]) for k in STRING_KEYS)}}};\n")

    def config_h(self) -> str:
        names = "\n".join(f"    VR_{row[0]} = {vr}," for vr, row in enumerate(self.rows))
        return (f"/* generated by crankfmu fmu {self.source.name} --native: {self.source.fmu}.fmu */\n"
                "#ifndef COMPONENT_CONFIG_H\n#define COMPONENT_CONFIG_H\n"
                f"#define MODEL_IDENTIFIER {c_string(self.source.fmu)}\n"
                f"#define MODEL_GUID {c_string(self.guid)}\n"
                f"#define {self.model} 1\n"
                f"#define N_VARIABLES {len(self.rows)}\n"
                f"#define DEFAULT_START_TIME {c_double(self.source.experiment.start_time)}\n"
                f"enum {{\n{names}\n}};\n"
                + (self._string_layout() if self.model == "COMPONENT_ROD_STRING" else "") + "#endif\n")

    def data_c(self) -> str:
        entries = ",\n".join(
            f"    {{{c_string(n)}, KIND_{kind}, {c_double(start)}, {c_double(lo)}, {c_double(hi)}, {int(lo_in)}, "
            f"{int(hi_in)}, {c_string(unit)}, {c_string(text)}, {c_string(description)}}}"
            for n, kind, start, lo, hi, lo_in, hi_in, unit, text, description in self.rows)
        return ('#include <math.h>\n\n#include "component_variables.h"\n\n'
                f"const Variable VARIABLES[N_VARIABLES] = {{\n{entries}\n}};\n")

    # ------------------------------------------------------------------ modelDescription
    def model_description(self, sources: list[str]) -> bytes:
        exp = self.source.experiment
        root = ET.Element("fmiModelDescription", fmiVersion="2.0", modelName=self.source.fmu, guid=self.guid,
                          description=self.source.title, generationTool="crankfmu (native)",
                          variableNamingConvention="structured", numberOfEventIndicators="0")
        cs = ET.SubElement(root, "CoSimulation", modelIdentifier=self.source.fmu, canGetAndSetFMUstate="true",
                           canSerializeFMUstate="true", canNotUseMemoryManagementFunctions="false",
                           canHandleVariableCommunicationStepSize="true", canInterpolateInputs="false")
        files = ET.SubElement(cs, "SourceFiles")
        for name in sources:
            if name.endswith(".c"):
                ET.SubElement(files, "File", name=name)
        unit_definitions(root, [row[7] for row in self.rows])
        default_experiment(root, exp)
        root.append(vendor_annotations(self.source, "native"))
        variables = ET.SubElement(root, "ModelVariables")
        outputs, knowns = [], []
        for vr, (name, kind, start, lo, hi, _, _, unit, text, description) in enumerate(self.rows):
            attributes = {"name": name, "valueReference": str(vr)}
            real = {}
            if kind == "OUTPUT":
                attributes.update(description=description, causality="output", variability="continuous",
                                  initial="calculated")
                outputs.append(vr + 1)
            elif kind == "INPUT":
                attributes.update(description=description, causality="input", variability="continuous")
                real["start"] = repr(float(start))
                knowns.append(vr + 1)
            else:
                attributes.update(description=f"{description} (valid range {text})".strip(), causality="parameter",
                                  variability="tunable" if kind == "TUNABLE" else "fixed")
                real["start"] = repr(float(start))
                knowns.append(vr + 1)
            if math.isfinite(lo):
                real["min"] = repr(float(lo))
            if math.isfinite(hi):
                real["max"] = repr(float(hi))
            element = ET.SubElement(ET.SubElement(variables, "ScalarVariable", **attributes), "Real", **real)
            if unit != "1":
                element.set("unit", si.fmi_name(unit))
        structure = ET.SubElement(root, "ModelStructure")
        listed = ET.SubElement(structure, "Outputs")
        for i in outputs:
            ET.SubElement(listed, "Unknown", index=str(i))
        initial = ET.SubElement(structure, "InitialUnknowns")
        for i in outputs:
            ET.SubElement(initial, "Unknown", index=str(i), dependencies=" ".join(str(k) for k in knowns))
        return parseString(ET.tostring(root, encoding="UTF-8")).toprettyxml(encoding="UTF-8", indent="  ")


def build_native_component(kind: str, data_name: str, dest: Path, name: str | None = None,
                           causality: str | None = None, win64: bool | None = None, fmi_version: str = "2.0") -> Path:
    """The native FMU of a drive file (``kind`` "drive", either causality), a cushion file
    ("cushion") or a well file ("well": the rod string) in ``dest``, from the same Source the
    Python FMU is built from; FMI ``fmi_version`` "2.0" or "3.0" (the same model behind the
    other shell)."""
    source = preflight(kind, data_name, name, causality)
    model = ComponentModel(source)
    describe = model.model_description
    if fmi_version == "3.0":
        from . import native_fmi3

        describe = lambda sources: native_fmi3.describe(source, model.guid, source.title, source.experiment,  # noqa: E731
                                                        model.variables(), model_exchange=False, events=False,
                                                        indicators=0)
    with ExitStack() as written:
        return package_native(source, dest, ((NATIVE, PHYSICS_SOURCES), (SHELL, MODEL_SOURCES + SHELL_SOURCES[fmi_version])),
                              {"component_config.h": model.config_h(), "component_data.c": model.data_c()},
                              describe, model.parameters(), win64, None, {}, {}, written, fmi_version)
