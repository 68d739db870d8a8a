"""The reference run of a native build runs in a forked process beside the build
(fmi/background.py): its text is the in-process run's, a child that fails leaves the parent to run
it and say why, and a build that fails first leaves no child behind."""

import multiprocessing
import os

import pytest

from crankfmu.errors import CrankfmuError
from crankfmu.fmi.background import reference_beside
from crankfmu.fmi.reference import reference_result
from crankfmu.scenario import load_scenario

pytestmark = pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="no fork here")


def test_the_text_is_the_in_process_runs_and_comes_from_another_process(tmp_path, monkeypatch):
    monkeypatch.setenv("CRANKFMU_CACHE", str(tmp_path))          # no cached reference: a real run
    scenario = load_scenario("seed002").with_params(J_flywheel=0.3)
    pids = []

    def run():
        pids.append(os.getpid())
        return reference_result(scenario)

    with reference_beside(run) as text:
        beside = text()
    assert pids == []                      # the run was not made here: the child's list is its own
    assert beside == reference_result(scenario)     # (from the cache the child wrote, or run again)
    assert beside.count("\n") == 1 + round(scenario.experiment.stop_time / scenario.experiment.output_interval) + 1


def test_a_child_that_fails_leaves_the_parent_to_run_it_and_say_why():
    calls = []

    def run():
        calls.append(os.getpid())
        raise CrankfmuError("the reference run refused the design")

    with reference_beside(run) as text:
        with pytest.raises(CrankfmuError, match="refused the design"):
            text()
    assert calls == [os.getpid()]          # once here, after the child's failure


def test_a_build_that_fails_first_stops_the_child():
    def run():
        import time
        time.sleep(60)
        return "never"

    with pytest.raises(RuntimeError):
        with reference_beside(run):
            children = multiprocessing.active_children()
            assert len(children) == 1
            raise RuntimeError("the tables were refused")
    assert not any(child.is_alive() for child in children)

