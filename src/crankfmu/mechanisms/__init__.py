"""Mechanisms: geometry as data files and the contour engine that solves them."""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path

from ..errors import DefinitionError
from .contour import Kinematics, Mechanism, MechanismDefinition

__all__ = ["Kinematics", "Mechanism", "MechanismDefinition", "load_mechanism", "available_mechanisms"]

_FILES = resources.files(__package__) / "files"


def available_mechanisms() -> list[str]:
    return sorted(p.name[:-5] for p in _FILES.iterdir() if p.name.endswith(".toml"))


def load_mechanism(name_or_path: str | Path) -> MechanismDefinition:
    """Parse a mechanism file: a packaged name (``"fourbar"``) or a path to a .toml file."""
    path = Path(name_or_path)
    if path.suffix == ".toml" and path.exists():
        text, where = path.read_text(), str(path)
    else:
        res = _FILES / f"{name_or_path}.toml"
        if not res.is_file():
            raise DefinitionError(
                f"unknown mechanism {str(name_or_path)!r}; known: {', '.join(available_mechanisms())}"
            )
        text, where = res.read_text(), f"mechanism {name_or_path}"
    key = (where, text)
    if key not in _PARSED:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise DefinitionError(f"{where}: {exc}") from None
        _PARSED[key] = MechanismDefinition.from_dict(data, where)
    return _PARSED[key]


#: parsed definitions by (where, file text): a definition is never changed after parsing, and a
#: scenario asks for its mechanism's definition many times (every build, every FMU instance)
_PARSED: dict[tuple[str, str], MechanismDefinition] = {}
