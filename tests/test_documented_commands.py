"""Every command the docs print works: each `crankfmu ...` line of README.md and docs/*.md is read
by crankfmu's real parser (a wrong option or command fails here), and each `fmpy ...` line that
the docs and the FMUs' own pages (documentation/index.html) show is run on the FMU it names, as a
reader would paste it (an FMU page once printed `--fmi-type`, which fmpy does not know)."""

from __future__ import annotations

import html
import importlib
import os
import re
import shlex
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FMUS = ROOT / "build" / "fmus"
#: a synopsis line (`crankfmu fmu SCENARIO --out DIR [--name NAME]`) shows a command's shape, not a
#: command to paste: its placeholders are upper case and its options in brackets
PLACEHOLDER = re.compile(r"\[|\||\b[A-Z][A-Z_]{2,}\b|<\w+>|\.\.\.")


def shell_lines(text: str) -> list[str]:
    """The command lines of a page's ```sh blocks, continuations joined, comments dropped."""
    lines = []
    for block in re.findall(r"```(?:sh|bash|console)\n(.*?)```", text, re.S):
        joined = re.sub(r"\\\n\s*", " ", block)
        for line in joined.splitlines():
            line = line.split(" #", 1)[0].strip()
            if line.startswith("$ "):
                line = line[2:]
            if line:
                lines.append(line)
    return lines


def documented(program: str, inline: bool = False) -> list[tuple[str, str]]:
    """(page, line) of each ``program`` command the pages show in their ```sh blocks (and, with
    ``inline``, in their `code` spans), synopsis lines left out."""
    found = []
    for page in PAGES:
        text = page.read_text()
        # an inline span is a command to paste when it names the FMU it runs ("`fmpy validate`" is a name)
        spans = [s for s in re.findall(r"`([^`\n]+)`", text) if ".fmu" in s] if inline else []
        for line in shell_lines(text) + spans:
            if line.startswith(program + " ") and not PLACEHOLDER.search(line[len(program):]):
                found.append((page.name, line))
    return found


CRANKFMU_LINES = documented("crankfmu")


def parse(argv: list[str]):
    """crankfmu's parser on ``argv``, the delegated commands' (validate, hosts) by their own parser."""
    from crankfmu.cli import build_parser

    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    delegate = getattr(args, "delegate", None)
    if delegate:
        return importlib.import_module(delegate).build_parser().parse_args(rest)
    if rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    return args


def test_the_docs_show_commands_to_check():
    assert len(CRANKFMU_LINES) >= 25, CRANKFMU_LINES
    assert {page for page, _ in CRANKFMU_LINES} >= {"README.md", "mechanism-files.md", "your-mechanism.md"}


@pytest.mark.parametrize("page, line", CRANKFMU_LINES, ids=[f"{p}:{l[:60]}" for p, l in CRANKFMU_LINES])
def test_every_documented_crankfmu_command_parses(page, line):
    try:
        parse(shlex.split(line)[1:])
    except SystemExit as exc:
        pytest.fail(f"{page}: `{line}` is refused by crankfmu's parser (exit {exc.code})")


def test_a_wrong_option_is_caught():
    """The check above can fail: the option the FMU pages once printed, on crankfmu."""
    with pytest.raises(SystemExit):
        parse(["simulate", "seed000", "--out", "x", "--fmi-type", "ModelExchange"])


# ---------------------------------------------------------------- fmpy, as the pages print it
def fmu_page_commands(fmu: Path) -> list[str]:
    with zipfile.ZipFile(fmu) as z:
        page = z.read("documentation/index.html").decode()
    return [html.unescape(line.strip()) for pre in re.findall(r"<pre>(.*?)</pre>", page, re.S)
            for line in pre.splitlines() if line.strip().startswith("fmpy ")]


def run_fmpy(line: str, folder: Path):
    env = {**os.environ, "MPLBACKEND": "Agg"}         # --show-plot draws, and shows nothing, headless
    args = shlex.split(line)
    fmpy = Path(sys.executable).with_name("fmpy")     # the command fmpy installs, as a reader types it
    return subprocess.run([str(fmpy), *args[1:]], cwd=folder, env=env, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The Python and the native FourBar.fmu, make fmu's (built here when pytest runs alone)."""
    out = {}
    for build, folder, extra in (("python", FMUS, []), ("native", FMUS / "native", ["--native"])):
        path = folder / "FourBar.fmu"
        if not path.is_file():
            folder = tmp_path_factory.mktemp(build)
            assert subprocess.run([sys.executable, "-m", "crankfmu", "fmu", "seed000", *extra, "--out", str(folder)],
                                  capture_output=True).returncode == 0
            path = folder / "FourBar.fmu"
        out[build] = path
    return out


@pytest.mark.parametrize("build", ["python", "native"])
def test_every_fmpy_command_of_an_fmu_page_runs(built, build, tmp_path):
    fmu = built[build]
    (tmp_path / fmu.name).write_bytes(fmu.read_bytes())
    lines = fmu_page_commands(fmu)
    assert lines and all(fmu.name in line for line in lines)
    if build == "native":           # the native FMU has Model Exchange: its page shows how to run it
        assert any("--interface-type ModelExchange" in line for line in lines), lines
    for line in lines:
        run = run_fmpy(line, tmp_path)
        assert run.returncode == 0, f"`{line}`: {run.stderr[-1500:]}"


def test_every_fmpy_command_of_the_docs_runs(built, tmp_path):
    """The docs' fmpy lines, on FourBar.fmu (the FMU they name); a line that shows a refusal
    (`--start-values J_flywheel -1`) must be refused with the message the docs describe."""
    lines = documented("fmpy", inline=True)
    assert lines
    (tmp_path / "FourBar.fmu").write_bytes(built["python"].read_bytes())
    for page, line in lines:
        assert "FourBar.fmu" in line, (page, line)
        run = run_fmpy(line, tmp_path)
        if "J_flywheel -1" in line:
            assert "J_flywheel" in run.stdout + run.stderr, (page, line, run.stderr[-800:])
        else:
            assert run.returncode == 0, (page, line, run.stderr[-1500:])


# ---------------------------------------------------------------- what docs/fmus.md says a host sees
def quoted_refusals() -> list[tuple[str, float, str]]:
    """(parameter, value, the message's start as quoted) of docs/fmus.md's table of bad input, for
    its rows that set one start value (fmi2SetReal, or caught at fmi2ExitInitializationMode)."""
    text = (ROOT / "docs" / "fmus.md").read_text()
    rows = re.findall(r"^\| `(\w+)` = (\S+) \((?:fmi2SetReal|fmi2ExitInitializationMode)\) \| `(.+?)` \|$", text, re.M)
    return [(name, float(value), message) for name, value, message in rows]


@pytest.mark.parametrize("build", ["python", "native"])
def test_the_refusals_docs_fmus_quotes_are_what_the_fmu_says(built, build):
    """One wording for both builds: the native FMU's C refusals say what the Python FMU says."""
    from crankfmu.validation.fmu_runner import simulate_logged

    rows = quoted_refusals()
    assert len(rows) >= 4, rows
    for name, value, quoted in rows:
        log = []
        with pytest.raises(Exception):
            simulate_logged(str(built[build]), stop_time=0.01, start_values={name: value}, debug_logging=False,
                            logger=lambda *args: log.append(args[-1].decode() if isinstance(args[-1], bytes)
                                                            else args[-1]))
        start = quoted.split("...")[0].strip()
        assert any(line.startswith(start) for line in log), (name, value, quoted, log[-3:])
