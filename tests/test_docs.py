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


# --------------------------------------------------------------------------------------------
# docs/cli.md against the real command line

CLI_PAGE = ROOT / "docs" / "cli.md"


def cli_parsers():
    """(name, parser) of every `crankfmu` subcommand as the program builds it. validate and hosts
    parse their own options (the subcommand only names the module that does): their parsers are
    built from those modules."""
    import argparse
    import importlib

    from crankfmu.cli import build_parser

    parser = build_parser()
    yield "", parser
    subparsers = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    assert len(subparsers) == 1, "crankfmu has one level of subcommands"
    for name, sub in subparsers[0].choices.items():
        delegate = sub.get_default("delegate")
        if delegate:
            sub = importlib.import_module(delegate).build_parser()
        yield name, sub


def long_flags(parser):
    return sorted(s for a in parser._actions for s in a.option_strings if s.startswith("--") and s != "--help")


def cli_sections(text: str) -> dict[str, str]:
    """docs/cli.md's sections: `## crankfmu NAME` -> the text up to the next `## ` heading; the
    page's text before the first command's section is the section of `crankfmu` itself ("")."""
    parts = re.split(r"^## +crankfmu +(\S+) *$", text, flags=re.M)
    sections = {"": parts[0]}
    for name, body in zip(parts[1::2], parts[2::2]):
        sections[name] = body.split("\n## ", 1)[0]
    return sections


def missing_from_cli_page(text: str) -> list[str]:
    """What the real parser has that ``text`` (docs/cli.md) does not document: a subcommand
    without its `## crankfmu NAME` section, or a long option not named in its command's section."""
    sections = cli_sections(text)
    missing = []
    for name, parser in cli_parsers():
        if name not in sections:
            missing.append(f"crankfmu {name}")
            continue
        for flag in long_flags(parser):
            if not re.search(rf"(?<![\w-]){re.escape(flag)}(?![\w-])", sections[name] if name else text):
                missing.append(f"crankfmu {name} {flag}".replace("  ", " "))
    return missing


def test_cli_page_documents_every_command_and_option():
    missing = missing_from_cli_page(CLI_PAGE.read_text())
    assert not missing, f"docs/cli.md does not document: {missing}"


def test_the_cli_page_check_fails_on_a_missing_option_or_command():
    text = CLI_PAGE.read_text()
    # an option gone from its command's section (it is still named elsewhere on the page)
    assert "crankfmu sweep --chunk" in missing_from_cli_page(text.replace("--chunk", "--chunks"))
    # a command's section gone
    without = re.sub(r"^## crankfmu well\n.*?(?=^## )", "", text, flags=re.M | re.S)
    assert "crankfmu well" in missing_from_cli_page(without)


def option_rows(section: str) -> dict[str, tuple[str, str]]:
    """A cli.md section's option table: ``--flag`` -> (meaning, default), the cells as written."""
    rows = {}
    for line in section.splitlines():
        m = re.match(r"^\| `(--[\w-]+)[^`]*` \|", line)
        if m:
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
            rows[m.group(1)] = (cells[1], cells[2]) if len(cells) >= 3 else (cells[-1], "")
    return rows


def help_disagreements(text: str) -> list[str]:
    """Where ``crankfmu COMMAND --help`` and docs/cli.md say different things: a command whose
    description opens with a leaked usage line (``crankfmu ...``), an option without help text, an
    option of the page's tables that the command does not have, a required option the page does not
    call required (or the reverse), a default the page's table does not state."""
    import argparse

    sections = cli_sections(text)
    found = []
    for name, parser in cli_parsers():
        if not name:
            continue
        if (parser.description or "").lstrip().startswith("``"):
            found.append(f"crankfmu {name} --help: its description opens with a usage line")
        actions = {s: a for a in parser._actions for s in a.option_strings if s.startswith("--") and s != "--help"}
        for flag, action in actions.items():
            if not (action.help or "").strip():
                found.append(f"crankfmu {name} {flag}: no help text")
        rows = option_rows(sections.get(name, ""))
        for flag, (_, default) in rows.items():
            action = actions.get(flag)
            if action is None:
                found.append(f"crankfmu {name} {flag}: in docs/cli.md's table, not in the command")
                continue
            if action.required != (default == "required"):
                found.append(f"crankfmu {name} {flag}: required {action.required}, docs/cli.md says {default!r}")
            value = action.default
            if isinstance(value, (int, float, str)) and not isinstance(value, bool) and value != argparse.SUPPRESS:
                if str(value) not in default:
                    found.append(f"crankfmu {name} {flag}: default {value!r}, docs/cli.md says {default!r}")
    return found


def test_every_help_agrees_with_the_cli_page():
    found = help_disagreements(CLI_PAGE.read_text())
    assert not found, "\n".join(found)


def test_the_help_check_fails_on_a_changed_default_or_a_documented_option_the_command_lacks():
    text = CLI_PAGE.read_text()
    changed = text.replace("| `--frames N` | frames, spread evenly over the motion | 120 |",
                           "| `--frames N` | frames, spread evenly over the motion | 100 |")
    assert "crankfmu animate --frames: default 120, docs/cli.md says '100'" in help_disagreements(changed)
    extra = text.replace("| `--fps N` |", "| `--fps N` | x | 20 |\n| `--speed X` |")
    assert "crankfmu animate --speed: in docs/cli.md's table, not in the command" in help_disagreements(extra)
