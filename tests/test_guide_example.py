"""The worked example of docs/mechanism-files.md, copied out of the guide as a user would: it
passes the check, the fast path agrees with the reference integrator and closes the energy balance,
its drawing renders, and its FMU (built by `crankfmu fmu`) passes the harness with no failure."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from crankfmu.check import check_scenario
from crankfmu.cli import main
from conftest import assert_two_integrators_agree_and_energy_closes

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "mechanism-files.md"
ENGINE = Path(__file__).resolve().parent / "data" / "user" / "engine4s_scenario.toml"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The guide's ```toml blocks that start with '# file: NAME', written to a fresh folder."""
    folder = tmp_path_factory.mktemp("guide")
    written = []
    for block in re.findall(r"```toml\n(.*?)```", GUIDE.read_text(), re.S):
        m = re.match(r"# file: (\S+)", block)
        if m:
            (folder / m.group(1)).write_text(block)
            written.append(m.group(1))
    assert sorted(written) == ["engine4s_scenario.toml", "press.toml", "press_scenario.toml"]
    return folder


def test_the_guides_machine_cycle_example_is_the_file_the_tests_run(files):
    """The guide's four-stroke engine (cycle_turns) is tests/data/user/engine4s_scenario.toml, which
    tests/test_machine_cycle.py checks against a hand-written reference: the two are one text."""
    guide = (files / "engine4s_scenario.toml").read_text()
    assert guide.removeprefix("# file: engine4s_scenario.toml\n") == ENGINE.read_text()


def test_the_guides_example_passes_the_check(files):
    report = check_scenario(str(files / "press_scenario.toml"))
    assert report.status == 0, report.text()


def test_the_guides_example_simulates_alike_with_two_integrators_and_closes_its_energy(files):
    """fast (compiled Dormand-Prince on the tabulated model) against reference (DOP853 on the contour
    engine, rtol 1e-12): both at their default tolerances reach about 1e-8 rad/s on the other
    examples; 1e-6 relative leaves room for this one's slider-force switches."""
    assert_two_integrators_agree_and_energy_closes(files / "press_scenario.toml")


def test_the_guides_example_becomes_a_validated_fmu(files, tmp_path, capsys, fmu_path):
    # an FMU already run in this process (as in a notebook or a pytest worker) puts pythonfmu's
    # binary-less copy from that FMU's resources first on sys.path: the build must not depend on it
    import fmpy

    fmpy.simulate_fmu(fmu_path, stop_time=0.01)
    assert main(["draw", str(files / "press_scenario.toml"), "--out", str(tmp_path / "press.png")]) == 0
    assert main(["fmu", str(files / "press_scenario.toml"), "--out", str(tmp_path / "fmus")]) == 0
    fmu = tmp_path / "fmus" / "Press.fmu"
    assert fmu.is_file()
    status = main(["validate", "--fmu", str(fmu), "--out", str(tmp_path / "validation")])
    out = capsys.readouterr().out
    assert status == 0, out
    assert re.search(r"\d+ passed, 0 failed", out)


def test_check_gives_the_bound_of_a_length_the_file_sets_too_short(files, tmp_path):
    """The guide promises the parameter's bound: with l = 0.1 m written into the press file (not
    given with --set), check names where assembly fails and the bound l must respect."""
    edited = tmp_path / "press_scenario.toml"
    text = (files / "press_scenario.toml").read_text()
    edited.write_text(text.replace('l = { value = 0.35,', 'l = { value = 0.1,'))
    (tmp_path / "press.toml").write_text((files / "press.toml").read_text())
    report = check_scenario(str(edited))
    said = report.text()
    assert report.status == 1
    bound = re.search(r"the crank turns fully only for .*\bl > ([0-9.]+) m \(the file gives 0.1\)", said)
    assert bound, said
    # the bound is where assembly starts: just above it the press turns fully, just below it does not
    from crankfmu.scenario import load_scenario

    value = float(bound.group(1))
    load_scenario(str(edited)).with_params(l=value * 1.001).assembled_mechanism()
    with pytest.raises(Exception, match="cannot be assembled"):
        load_scenario(str(edited)).with_params(l=value * 0.999).assembled_mechanism()
