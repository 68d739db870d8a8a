"""Mechanisms: geometry as data files and the contour engine that solves them."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from ..datafiles import packaged, read_toml
from .contour import Mechanism
from .kinematics import Kinematics
from .definition import MechanismDefinition

__all__ = ["Kinematics", "Mechanism", "MechanismDefinition", "load_mechanism", "available_mechanisms"]

_FILES = resources.files(__package__) / "files"


def available_mechanisms() -> list[str]:
    return packaged(_FILES)


def load_mechanism(name_or_path: str | Path) -> MechanismDefinition:
    """Parse a mechanism file: a packaged name (``"fourbar"``) or a path to a .toml file."""
    data, where, origin = read_toml(name_or_path, _FILES, "mechanism")
    key = (where, origin, repr(data))
    if key not in _PARSED:
        _PARSED[key] = MechanismDefinition.from_dict(data, where)
    return _PARSED[key]


#: parsed definitions by (where, origin, contents): a definition is never changed after parsing, and a
#: scenario asks for its mechanism's definition many times (every build, every FMU instance)
_PARSED: dict[tuple[str, str, str], MechanismDefinition] = {}
