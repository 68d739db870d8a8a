"""The pages a reader is sent to exist: every repository path that README.md and docs/*.md name
(in backticks or as a link) is in the repository, and none points outside it (shared/ is not
shipped)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: what a page may name that is made, not shipped: build outputs, a user's folders and files
MADE = ("build/", ".venv", "DIR", "OUT", "out/", "my", "press", "fmus/", "validation/report", "run/", "<")


#: the repository's top-level folders and files: a `code` span starting with one is a path into it
TOP = ("src/", "docs/", "tests/", "validation/", "benchmarks/", "fmu_build/", ".ci/", "README.md", "Makefile",
       "pyproject.toml", "setup.py", "shared/")


def named_paths(text: str):
    """Repository paths a page names: its links, and `code` spans that start at the repository's top."""
    for target in re.findall(r"\]\(([^)#\s]+)", text):
        if not re.match(r"[a-z]+:", target):
            yield target
    for code in re.findall(r"`([^`\s]+)`", text):
        if code.startswith(TOP):
            yield code


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_path_a_page_names_exists(page):
    missing = []
    for path in set(named_paths(page.read_text())):
        if path.startswith(MADE) or any(mark in path for mark in ("*", "NAME", "<", "NNN")):
            continue
        candidates = [page.parent / path, ROOT / path]
        if not any(c.exists() for c in candidates):
            missing.append(path)
    assert not missing, f"{page.name} names paths that are not in the repository: {sorted(missing)}"


def test_no_page_sends_the_reader_outside_the_repository():
    for page in PAGES:
        assert "shared/" not in page.read_text(), page.name
