"""A beam pumping well's data file (``wells/*.toml``): the rod string and pump
(dynamics.rodstring: its parameters, then each taper's as taper<i>_<key>) and the [unit] table
that ``crankfmu.well`` reads (the surface unit's scenario, parameters, counterbalance and motor).
RodString.fmu reads this file alone."""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

from ..datafiles import packaged, read_toml
from ..errors import DefinitionError
from ..parameters import Experiment, Parameter, parse_parameters
from .rodstring import StringDesign, Taper

_FILES = resources.files(__package__.rsplit(".", 1)[0]) / "wells"
TAPER_KEYS = ("length", "diameter", "E", "mass_per_length")
STRING_KEYS = ("rho_fluid", "rho_steel", "plunger_diameter", "fluid_level", "p_tubing", "p_casing", "damping",
               "friction", "fillage", "g", "segment", "courant")


def available_wells() -> list[str]:
    return packaged(_FILES)


@dataclass(frozen=True)
class WellFile:
    name: str
    title: str
    parameters: dict          # name -> Parameter: the string's, then taper<i>_<key>
    n_tapers: int
    unit: dict                # the [unit] table
    experiment: Experiment
    where: str
    fmu: str = ""
    source: str = ""

    @property
    def inputs(self) -> dict:
        """RodString.fmu's inputs: the polished rod's position and velocity along the port's axis."""
        return {"s": Parameter("s", 0.0, "m", "polished rod position, downward (the unit's rod_s)"),
                "v": Parameter("v", 0.0, "m/s", "polished rod velocity, downward (the unit's rod_v)")}

    @property
    def values(self) -> dict:
        return {n: p.value for n, p in self.parameters.items()}

    def design(self, values: dict | None = None) -> StringDesign:
        v = {**self.values, **(values or {})}
        tapers = tuple(Taper(*(v[f"taper{i}_{k}"] for k in TAPER_KEYS)) for i in range(1, self.n_tapers + 1))
        design = StringDesign(tapers, **{k: v[k] for k in STRING_KEYS})
        design.check(self.where)
        return design


def load_well(name_or_path) -> WellFile:
    """A well file: a packaged name (``"rp11l_guo"``) or a path to a .toml file."""
    data, where, _ = read_toml(name_or_path, _FILES, "well")
    params = parse_parameters(data.get("parameters", {}), where)
    missing = set(STRING_KEYS) - params.keys()
    if missing:
        raise DefinitionError(f"{where}: [parameters] misses {', '.join(sorted(missing))}")
    tapers = data.get("tapers")
    if not isinstance(tapers, list) or not tapers:
        raise DefinitionError(f"{where}: [[tapers]] must list the string's tapers, top first, each with "
                              f"{', '.join(TAPER_KEYS)}")
    for i, taper in enumerate(tapers, 1):
        if not isinstance(taper, dict) or set(taper) != set(TAPER_KEYS):
            got = sorted(taper) if isinstance(taper, dict) else taper
            raise DefinitionError(f"{where}: taper {i} needs exactly {', '.join(TAPER_KEYS)}, got {got}")
        for key, spec in parse_parameters({f"taper{i}_{k}": s for k, s in taper.items()}, where).items():
            if not spec.value > 0:
                raise DefinitionError(f"{where}: taper {i} {key.split('_', 1)[1]} = {spec.value!r} must be > 0 "
                                      f"(valid range (0, inf) {spec.unit})")
            params[key] = Parameter(key, spec.value, spec.unit, f"taper {i} (top first): {spec.description}",
                                    min=0.0, min_inclusive=False)
    unit = data.get("unit", {})
    if not isinstance(unit, dict):
        raise DefinitionError(f"{where}: [unit] must be a table (scenario, strokes_per_minute, ...)")
    well = WellFile(data.get("name", str(name_or_path)), data.get("title", ""), params, len(tapers), unit,
                    Experiment.from_dict(data.get("experiment", {})), where, str(data.get("fmu", "")),
                    str(data.get("source", "")))
    well.design()
    return well
