"""pictures.together.both: two drawings at once on two cores (the well's figures beside its
animation), one after the other on one; a failure on either side is raised here, the forked
side's as one CrankfmuError line naming it; neither leaves a half-written file."""

from __future__ import annotations

import os

import pytest

from crankfmu.atomic import replacing
from crankfmu.errors import CrankfmuError
from crankfmu.pictures import together


def writer(path, text):
    def write():
        with replacing(path) as partial:
            partial.write_text(text, encoding="utf-8")
    return write


@pytest.mark.parametrize("cores", [1, 2])
def test_both_sides_write_their_files(tmp_path, monkeypatch, cores):
    monkeypatch.setattr(together, "_cores", lambda: cores)
    pids = []
    result = together.both(writer(tmp_path / "a.txt", "first"),
                           lambda: (writer(tmp_path / "b.txt", "second")(), pids.append(os.getpid()), 7)[-1])
    assert result == 7 and pids == [os.getpid()]
    assert (tmp_path / "a.txt").read_text(encoding="utf-8") == "first"
    assert (tmp_path / "b.txt").read_text(encoding="utf-8") == "second"


@pytest.mark.parametrize("cores", [1, 2])
def test_a_failure_in_the_first_is_raised_with_its_message(tmp_path, monkeypatch, cores):
    monkeypatch.setattr(together, "_cores", lambda: cores)

    def fails():
        with replacing(tmp_path / "a.txt") as partial:
            partial.write_text("half", encoding="utf-8")
            raise ValueError("no room for the legend")

    with pytest.raises((CrankfmuError, ValueError), match="no room for the legend"):
        together.both(fails, writer(tmp_path / "b.txt", "second"))
    assert not (tmp_path / "a.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == (["b.txt"] if cores == 2 else [])


def test_the_cores_are_the_ones_this_process_may_use():
    """taskset or a container's limit, not the machine's count: a process pinned to one core draws
    one thing at a time."""
    assert 1 <= together._cores() <= (os.cpu_count() or 1)
    if hasattr(os, "sched_getaffinity"):
        assert together._cores() == len(os.sched_getaffinity(0))
