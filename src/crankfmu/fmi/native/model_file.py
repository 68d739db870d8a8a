"""A native FMU's model file (``resources/crankfmu-model.bin``): what the one prebuilt runtime needs of
a mechanism's scenario or of a component, written by ``crankfmu fmu --native`` and read by the
runtime when a host makes an instance (``native/model/crank_model_file.c``, which refuses a missing,
truncated, altered or other-format file by name).

The layout is stated once per side: here in ``payload``'s order, there in ``md_parse``'s (the two
are compared by tests/test_model_file.py, which reads every packaged scenario's file back through
the runtime). Little-endian throughout: int32 for integers and counts, float64 for reals, a string
as its UTF-8 length then its bytes, an array as its count then its items.
"""

from __future__ import annotations

import hashlib
import struct

import numpy as np

#: the file's name in the FMU's resources/ (crank_variables.h's CM_MODEL_FILE)
NAME = "crankfmu-model.bin"
MAGIC = b"crankfmu model\0\0"
#: the layout's version; a runtime reads only its own (crank_variables.h's CM_MODEL_FORMAT)
FORMAT = 5
#: what the file's model is (crank_variables.h's CM_MODEL_...): a mechanism, or a component by its
#: (data file kind, causality)
MECHANISM = 1
COMPONENTS = {("drive", "torque"): 2, ("drive", "speed"): 3, ("cushion", "torque"): 4, ("well", "torque"): 5,
              ("shaft", "torque"): 6}
#: the variables' kinds (crank_variables.h's KIND_...)
KINDS = {"OUTPUT": 0, "INPUT": 1, "TUNABLE": 2, "FIXED": 3, "QUANTITY": 4, "DERIVATIVE": 5, "REACTION": 6,
         "FRICTION": 7}
#: the program's int arrays and scalars, in the order md_parse reads them (mm_program's fields)
PROGRAM_ARRAYS = ("code", "sections", "terms", "angles", "chain_constants", "angle_column", "rows", "columns",
                  "searches", "checks", "coordinates", "links", "joints", "term_inertia", "applied", "column_powers",
                  "laws", "frictions")
PROGRAM_SCALARS = ("n_q", "n_contours", "n_chains", "closed_form", "guess", "phi1", "kinematics", "n_points",
                   "omega1", "crank", "cycle_turns", "law_speed")


class _Writer:
    def __init__(self):
        self.parts: list[bytes] = []

    def int(self, value) -> None:
        self.parts.append(struct.pack("<i", int(value)))

    def double(self, value) -> None:
        self.parts.append(struct.pack("<d", float(value)))

    def string(self, text: str) -> None:
        data = text.encode("utf-8")
        self.int(len(data))
        self.parts.append(data)

    def ints(self, values) -> None:
        a = np.asarray(values, dtype="<i4").ravel()
        self.int(a.size)
        self.parts.append(a.tobytes())

    def doubles(self, values) -> None:
        a = np.asarray(values, dtype="<f8").ravel()
        self.int(a.size)
        self.parts.append(a.tobytes())

    def strings(self, texts) -> None:
        texts = list(texts)
        self.int(len(texts))
        for t in texts:
            self.string(t)


def _common(w: _Writer, identifier: str, guid: str, start_time: float, variables: list) -> None:
    """Every kind's part: the identifier, the GUID, the start time and the variables, each (name,
    kind, start, has_min, min_inclusive, has_max, max_inclusive, min, max, range, unit, description)."""
    w.string(identifier)
    w.string(guid)
    w.double(start_time)
    w.int(len(variables))
    for (name, kind, start, has_min, min_inclusive, has_max, max_inclusive, low, high, range_text, unit,
         description) in variables:
        w.string(name)
        w.int(KINDS[kind])
        w.double(start)
        w.int(has_min)
        w.int(min_inclusive)
        w.int(has_max)
        w.int(max_inclusive)
        w.double(low)
        w.double(high)
        w.string(range_text)
        w.string(unit)
        w.string(description)


def payload(header: dict, variables: list, output_row, quantity_coordinate, quantity_order, program,
            parameter_vr, parameter_value, geometry_parameters, unknown_names) -> bytes:
    """A mechanism's bytes in md_parse's order. ``header``: the strings (identifier, guid,
    mechanism_name, mechanism_branch), the counts and the reals; ``variables``: as _common takes them."""
    w = _Writer()
    _common(w, header["identifier"], header["guid"], header["default_start_time"], variables)
    for key in ("mechanism_name", "mechanism_branch"):
        w.string(header[key])
    for key in ("causality_speed", "cycle_turns", "n_outputs", "n_fixed", "n_quantities", "n_ports", "n_reactions",
                "reaction_terms", "n_quantity_coordinates", "table_functions", "table_sliders", "vr_e_kin"):
        w.int(header[key])
    for key in ("table_tolerance", "reaction_tolerance"):
        w.double(header[key])
    w.ints(output_row)
    w.ints(quantity_coordinate)
    w.ints(quantity_order)
    w.int(program.n_registers)
    w.doubles(program.literals)
    for field in PROGRAM_ARRAYS:
        w.ints(getattr(program, field))
    for field in PROGRAM_SCALARS:
        w.int(getattr(program, field))
    w.double(program.min_conditioning)
    w.ints(parameter_vr)
    w.doubles(parameter_value)
    w.strings(program.parameters)
    w.strings(program.check_names)
    w.ints(geometry_parameters)
    w.ints(program.table_parameters)
    w.strings(unknown_names)
    return b"".join(w.parts)


def component_payload(identifier: str, guid: str, start_time: float, variables: list) -> bytes:
    """A component's bytes: every kind's part alone (its model finds its variables by name)."""
    w = _Writer()
    _common(w, identifier, guid, start_time, variables)
    return b"".join(w.parts)


def wrap(body: bytes, kind: int = MECHANISM) -> bytes:
    """The file: the magic, the format, the kind, the payload's size and SHA-256, the payload."""
    return MAGIC + struct.pack("<IIQ", FORMAT, kind, len(body)) + hashlib.sha256(body).digest() + body
