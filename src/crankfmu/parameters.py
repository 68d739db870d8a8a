"""Named parameters with SI units and valid ranges, and the default experiment: what scenario files
and drive files declare, the FMUs expose and every refusal message quotes."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Mapping

from .errors import DefinitionError, ParameterError, format_value
from .units import check_unit


@dataclass(frozen=True)
class Parameter:
    """A named scenario parameter with its SI unit and valid range."""

    name: str
    value: float
    unit: str
    description: str = ""
    min: float | None = None
    max: float | None = None
    min_inclusive: bool = True
    max_inclusive: bool = True
    tunable: bool = False

    def range_text(self) -> str:
        # a bound as the file writes it: 0 and 1 (a whole bound without ".0"), 0.45, 1e-11
        lo = "(-inf" if self.min is None else ("[" if self.min_inclusive else "(") + format_value(self.min).removesuffix(".0")
        hi = "inf)" if self.max is None else format_value(self.max).removesuffix(".0") + ("]" if self.max_inclusive else ")")
        return f"{lo}, {hi} {'' if self.unit == '1' else self.unit}".rstrip()     # a pure number has no unit to say

    def check(self, value) -> float:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ParameterError(f"parameter {self.name} must be a number, got {value!r}", self.name) from None
        ok = math.isfinite(v)
        if ok and self.min is not None:
            ok = v >= self.min if self.min_inclusive else v > self.min
        if ok and self.max is not None:
            ok = v <= self.max if self.max_inclusive else v < self.max
        if not ok:
            raise ParameterError(
                f"parameter {self.name} = {format_value(value)} is out of range: valid range {self.range_text()} "
                f"({self.description})", self.name)
        return v


@dataclass(frozen=True)
class Experiment:
    start_time: float = 0.0          # s
    stop_time: float = 1.0           # s
    output_interval: float = 1e-3    # s
    tolerance: float = 1e-10         # 1
    cycles: int = 5
    summary_cycle: int = 4

    @classmethod
    def from_dict(cls, data: Mapping) -> "Experiment":
        return cls(**{k: data[k] for k in cls.__dataclass_fields__ if k in data})


#: a parameter's name: an expression reads it, the FMU exposes it, a C host and an SSP connect it
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")

#: the keys a parameter may have, each with the type its value must have
_KEYS = {"value": (int, float), "unit": str, "description": str, "min": (int, float), "max": (int, float),
         "min_inclusive": bool, "max_inclusive": bool, "tunable": bool}


def parse_parameters(raw: Mapping, where: str) -> dict[str, Parameter]:
    """``[parameters]`` of a data file: each ``name = { value, unit, description, min, max,
    min_inclusive, max_inclusive, tunable }``, the default checked against its own range. Every
    refusal names the file and the parameter (``crankfmu check`` finds its line from that)."""
    if not isinstance(raw, Mapping):
        raise DefinitionError(f"{where}: [parameters] must be a table of name = {{ value, unit, ... }}")
    params = {}
    for pname, spec in raw.items():
        if not NAME.match(pname):
            raise DefinitionError(f"{where}: parameter {pname}: a name is a letter or _ then letters, digits or _ "
                                  "(expressions, the FMU and its hosts use it)")
        if not isinstance(spec, Mapping) or "value" not in spec or "unit" not in spec:
            raise DefinitionError(f"{where}: parameter {pname} needs at least value and unit")
        for key, value in spec.items():
            if key not in _KEYS:
                raise DefinitionError(f"{where}: parameter {pname}: unknown key {key!r}; the keys are "
                                      f"{', '.join(_KEYS)}")
            if not isinstance(value, _KEYS[key]) or (_KEYS[key] != bool and isinstance(value, bool)):
                kind = {str: "a string", bool: "true or false"}.get(_KEYS[key], "a number")
                raise DefinitionError(f"{where}: parameter {pname}: {key} must be {kind}, got {value!r}")
        check_unit(spec["unit"], f"{where}: parameter {pname}")
        p = Parameter(pname, float(spec["value"]), spec["unit"], spec.get("description", ""),
                      spec.get("min"), spec.get("max"), spec.get("min_inclusive", True),
                      spec.get("max_inclusive", True), spec.get("tunable", False))
        if p.min is not None and p.max is not None and not p.min <= p.max:
            raise DefinitionError(f"{where}: parameter {pname}: min {p.min:g} exceeds max {p.max:g}")
        try:
            p.check(p.value)
        except ParameterError as exc:
            raise DefinitionError(f"{where}: parameter {pname}: its value is out of its own range: {exc}") from None
        params[pname] = p
    return params


@dataclass
class ComponentFile:
    """A data file of a small model that is not a mechanism (a drive, a cushion): its parameters
    and inputs (each a Parameter), its default experiment, and the FMU's model identifier."""

    name: str
    title: str
    parameters: dict
    inputs: dict
    experiment: Experiment
    where: str
    fmu: str = ""               # the model identifier of the FMU built from the file


def load_component(name_or_path, folder, kind: str, parameters: tuple, inputs: tuple) -> ComponentFile:
    """A component's data file (a cushion, a shaft): a packaged name in ``folder`` or a path to a
    .toml file, which must declare the ``parameters`` and ``inputs`` its model reads by name."""
    from .datafiles import read_toml

    data, where, _ = read_toml(name_or_path, folder, kind)
    params = parse_parameters(data.get("parameters", {}), where)
    values = parse_parameters(data.get("inputs", {}), where)
    missing = set(parameters) - params.keys() | set(inputs) - values.keys()
    if missing:
        raise DefinitionError(f"{where}: missing {', '.join(sorted(missing))} (parameters {', '.join(parameters)}; "
                              f"inputs {', '.join(inputs)})")
    return ComponentFile(data.get("name", str(name_or_path)), data.get("title", ""), params, values,
                         Experiment.from_dict(data.get("experiment", {})), where, str(data.get("fmu", "")))
