"""make demo's lanes (crankfmu.cli.lanes): each lane runs its target's commands in order with its
output in its log, a log gets one line per finished command, and a failure stops its lane, shows
the log's end and exits 1 while the other lane finishes."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest

MAKEFILE = """\
a:
\techo one
\t# a comment make -n prints, not a command
\techo two
b:
\techo three
\tfalse
\techo never
"""


@pytest.fixture
def project(tmp_path):
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    (tmp_path / "Makefile").write_text(MAKEFILE)
    return tmp_path


def lanes(project, *specs):
    return subprocess.run([sys.executable, "-m", "crankfmu.cli.lanes", "--logs", "logs", *specs], cwd=project,
                          capture_output=True, text=True, timeout=60)


def test_each_lane_runs_its_commands_with_one_line_each_in_a_log(project):
    done = lanes(project, "first:a")
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    assert [line.split("]")[0] for line in lines] == ["first [ 1/2", "first [ 2/2"], lines
    assert (project / "logs" / "first.log").read_text().splitlines() == ["$ echo one", "one", "$ echo two", "two"]


def test_a_failed_command_stops_its_lane_and_says_where_while_the_other_finishes(project):
    done = lanes(project, "first:a", "second:b")
    assert done.returncode == 1
    assert "second: false failed" in done.stdout and "three" in done.stdout, done.stdout
    assert "never" not in (project / "logs" / "second.log").read_text()
    assert (project / "logs" / "first.log").read_text().endswith("two\n")
