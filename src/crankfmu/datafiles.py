"""Reading crankfmu's data files (scenarios, mechanisms, drives): a packaged name or a path."""

from __future__ import annotations

import json
from pathlib import Path

from .errors import DefinitionError

try:
    import tomllib
except ImportError:         # Python 3.10, inside an FMU: the build ships each packaged file as JSON too
    tomllib = None


def packaged(folder) -> list[str]:
    """Names of the packaged .toml files in ``folder`` (an importlib.resources traversable)."""
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def read_toml(name_or_path, folder, kind: str, not_found=DefinitionError) -> tuple[dict, str, str]:
    """(data, where, origin) of a .toml file given by path, or packaged in ``folder`` by name.

    ``where`` names the file in messages ("scenario seed000", or the path); ``origin`` is its
    path. An unknown name raises ``not_found`` listing the packaged names; a syntax error
    DefinitionError with the file and the line."""
    path = Path(name_or_path)
    if path.suffix == ".toml" and path.exists():
        text, where, origin = path.read_text(encoding="utf-8"), str(path), str(path)
        if tomllib is None and path.with_suffix(".json").exists():     # a user's file inside an FMU
            return json.loads(path.with_suffix(".json").read_text(encoding="utf-8")), where, origin
    else:
        res = folder / f"{name_or_path}.toml"
        if not res.is_file():
            raise not_found(f"unknown {kind} {str(name_or_path)!r}: give a packaged name "
                            f"({', '.join(packaged(folder))}) or the path of a .toml {kind} file")
        text, where, origin = res.read_text(encoding="utf-8"), f"{kind} {name_or_path}", str(res)
        if tomllib is None:
            return json.loads((folder / f"{name_or_path}.json").read_text(encoding="utf-8")), where, origin
    if tomllib is None:
        raise DefinitionError(f"{where}: reading a .toml file needs Python 3.11 or newer")
    data = _parsed(text, where)
    # every key must be one the file's kind knows: a misspelt one is named, never ignored
    from .schema import SCHEMAS, check_keys
    if kind in SCHEMAS:
        check_keys(data, kind, text, where)
    return data, where, origin


#: text -> the parsed file, pickled: a data file read again in the same process (a sweep, an FMU's
#: reset, a second simulate()) is not parsed again; it is the text read now that is looked up, so
#: an edited file is parsed afresh, and each caller gets its own copy to change
_PARSED: dict[str, bytes] = {}


def _parsed(text: str, where: str) -> dict:
    import pickle

    if text not in _PARSED:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise DefinitionError(f"{where}: {exc}") from None
        if len(_PARSED) > 256:
            _PARSED.clear()
        _PARSED[text] = pickle.dumps(data)
    return pickle.loads(_PARSED[text])
