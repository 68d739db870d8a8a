"""What a wheel of crankfmu carries: every subpackage of src/crankfmu (a folder with an
``__init__.py``) is listed in pyproject.toml's packages, else an installation from the wheel lacks it
though the editable one that the tests run finds it by its path."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_subpackage_is_in_the_wheel():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    source = ROOT / "src"
    packages = {".".join(p.parent.relative_to(source).parts) for p in (source / "crankfmu").rglob("__init__.py")}
    assert packages, "no package found under src/"
    assert packages - listed == set(), f"pyproject.toml's packages lack {sorted(packages - listed)}"
