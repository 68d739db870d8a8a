"""The harness tells the truth, both ways: a correct user FMU with a hard case passes in
Co-Simulation and in Model Exchange (CVode tightened only as far as the case needs), and its wrong
twins fail: a load off by 1e-6, an output declared in the wrong unit, a port of the wrong sign, a
carried data file that is not the binary's model. Skips come from the FMU's modelDescription, a
junk file is an error, and the JUnit output parses with a test case per check.

The hard case is tests/data/user/engine2s_scenario.toml: a single-cylinder engine whose gas force
peaks over about 3 degrees of each turn, 155 turns in 4 s, built as a native FMU."""

from __future__ import annotations

import dataclasses
import math
import re
import subprocess
import sys
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest

from crankfmu.scenario import load_scenario
from crankfmu.validation import CheckList, mechanism, model_exchange
from crankfmu.validation.fmu_runner import FmuUnderTest

ROOT = Path(__file__).resolve().parents[1]
ENGINE = ROOT / "tests" / "data" / "user" / "engine2s_scenario.toml"
CARRIED = "resources/crankfmu/user/engine2s_scenario.toml"


def crankfmu(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "crankfmu", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=900)


@pytest.fixture(scope="module")
def engine_fmu(tmp_path_factory):
    out = tmp_path_factory.mktemp("engine")
    run = crankfmu("fmu", str(ENGINE), "--native", "--out", str(out))
    assert run.returncode == 0, run.stderr
    return out / "Engine2S.fmu"


def twin(fmu: Path, folder: Path, name: str, edit_file=None, edit_description=None) -> Path:
    """A copy of ``fmu`` with its carried scenario file or its modelDescription.xml edited: the
    binary is the same, so the copy says one thing and does another."""
    path = folder / name / fmu.name
    path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == CARRIED and edit_file:
                data = edit_file(data.decode()).encode()
            if item.filename == "modelDescription.xml" and edit_description:
                data = edit_description(data.decode()).encode()
            target.writestr(item, data)
    return path


def replace_value(text: str, name: str, factor: float) -> str:
    """The scenario text with parameter ``name``'s value multiplied by ``factor``."""
    pattern = re.compile(rf"^({name} = {{ value = )([-0-9.e]+)", re.M)
    assert pattern.search(text), name
    return pattern.sub(lambda m: f"{m.group(1)}{float(m.group(2)) * factor!r}", text)


def wrong_unit(description: str) -> str:
    """M_load declared in J (a unit the FMU defines, of the same dimension as N.m: a host would
    read the number as an energy)."""
    edited, n = re.subn(r'(name="M_load".*?<Real unit=")N\.m(")', r"\1J\2", description, count=1, flags=re.S)
    assert n == 1
    return edited


def default_checks(path, tmp_path) -> CheckList:
    """The default experiment in Co-Simulation and the unit check, as `crankfmu validate` runs them,
    over the first 0.25 s (ten turns: a model error shows at the first output point; the whole 4 s
    reference would cost 26 s a twin)."""
    fmu = FmuUnderTest(path)
    try:
        scenario = load_scenario(fmu.scenario_source)
        scenario.experiment = dataclasses.replace(scenario.experiment, stop_time=0.25)
        checks = CheckList(echo=None)
        mechanism.check_units(fmu, scenario, checks, f"{fmu.name}.{fmu.kind.build}")
        mechanism.check_default(fmu, scenario, checks, tmp_path, "CoSimulation")
        return checks
    finally:
        fmu.close()


def failed(checks) -> set[str]:
    return {c.name.split(".", 4)[-1] for c in checks.items if c.status == "failed"}


# ---------------------------------------------------------------- the correct FMU passes, CS and ME
def test_a_correct_engine_fmu_passes_in_both_interfaces(engine_fmu, tmp_path):
    """`crankfmu validate --quick` on the engine: 0 failed, and Model Exchange needed CVode below
    1e-10 (the fixed 1e-10 of before failed this FMU): the rtol used is printed with the check. The
    JUnit file has one test case per check."""
    junit = tmp_path / "engine.xml"
    run = crankfmu("validate", "--fmu", str(engine_fmu), "--quick", "--out", str(tmp_path / "rep"),
                   "--junit", str(junit))
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    summary = run.stdout.strip().splitlines()[-2]
    passed = int(re.match(r"(\d+) passed, 0 failed$", summary).group(1))
    assert passed >= 60
    notes = (tmp_path / "rep" / "checks.json").read_text()
    used = {float(x) for x in re.findall(r"CVode rtol (\S+) \(tried", notes)}
    assert used and min(used) < model_exchange.START_RTOL, used
    root = ET.parse(junit).getroot()
    cases = root.findall("./testsuite/testcase")
    assert len(cases) == passed == int(root.get("tests")) and root.get("failures") == "0"


# ---------------------------------------------------------------- its wrong twins fail
@pytest.mark.parametrize("name, edit_file, edit_description, must_fail", [
    ("load_1e-6", lambda t: replace_value(t, "F_gas", 1 + 1e-6), None, {"M_load_at_own_states"}),
    ("piston_mass_1e-4", lambda t: replace_value(t, "m3", 1 + 1e-4), None, {"J_red_at_own_states"}),
    ("port_sign", lambda t: t.replace('point = "B"\naxis = "0"', 'point = "B"\naxis = "pi"'), None,
     {"piston_s_at_own_states", "piston_v_at_own_states"}),
    ("unit", None, lambda x: wrong_unit(x), {"output_units"}),
])
def test_a_wrong_twin_fails(engine_fmu, tmp_path, name, edit_file, edit_description, must_fail):
    path = twin(engine_fmu, tmp_path, name, edit_file, edit_description)
    checks = default_checks(path, tmp_path)
    found = failed(checks)
    assert {n.split(".")[-1] for n in found} >= must_fail, (name, sorted(found))


def test_the_unit_twin_declares_the_wrong_unit(engine_fmu, tmp_path):
    """The unit twin's modelDescription really says J for M_load, a unit it defines (so the failure
    above is the check reading the declaration, not an unreadable file)."""
    fmu = FmuUnderTest(twin(engine_fmu, tmp_path, "unit-only", None, wrong_unit))
    try:
        assert fmu.units["M_load"] == "J" and fmu.units["E_kin"] == "J"
    finally:
        fmu.close()


# ---------------------------------------------------------------- skips are facts of the FMU
def test_a_native_fmu_takes_every_value_it_declares(engine_fmu):
    """Geometry, masses, loads and gravity are parameters of the native FMU: nothing to skip. A
    variable it does not declare, or an output, cannot be set: that is a fact of its
    modelDescription, said with the declaration."""
    fmu = FmuUnderTest(engine_fmu)
    try:
        assert mechanism.unsettable_values(fmu, {"g": 9.81, "l2": 0.15, "m3": 0.5, "F_gas": 1e4}) == ""
        said = mechanism.unsettable_values(fmu, {"J_red": 1.0, "l9": 1.0})
        assert "J_red (declared causality output" in said and "l9 (it declares no such variable)" in said
    finally:
        fmu.close()


def test_the_native_fourbar_runs_the_cases_that_set_gravity_and_geometry(tmp_path):
    """The hard cases of seed 000 that set g = 9.81 and l3 run on its native FMU (FMI 2.0 and 3.0)
    and pass: none is skipped for a value the FMU accepts."""
    from crankfmu.validation import cases

    scenario = load_scenario("seed000")
    out = tmp_path / "fmus"
    for extra in ([], ["--fmi-version", "3"]):
        run = crankfmu("fmu", "seed000", "--native", *extra, "--out", str(out / (extra[-1] if extra else "2")))
        assert run.returncode == 0, run.stderr
    near = next(c for c in cases.load_cases("seed000").cases if "l3" in c.set and not c.refused_parameter)
    for path in sorted(out.rglob("FourBar.fmu")):
        fmu = FmuUnderTest(path)
        try:
            checks = CheckList(echo=None)
            assert mechanism.unsettable_values(fmu, {**near.set, "g": 9.81}) == ""
            row = cases.run_case(fmu, scenario, near, 9.81, True, checks)
            assert checks.failed == 0 and checks.skipped == 0 and checks.passed >= 3, \
                [c.line() for c in checks.items]
            assert row["omega1_rel_error"] < near.omega1_tolerance
        finally:
            fmu.close()


# ---------------------------------------------------------------- Model Exchange's rtol
class _Run:
    def __init__(self, rtol, error=None):
        self.rtol, self.error = rtol, error
        self.time = np.linspace(0.0, 1.0, 11)
        self.values = {"omega1": np.full(11, 10.0) + rtol * 1e4}

    def __getitem__(self, name):
        return self.values[name]


def test_model_exchange_is_tightened_only_as_far_as_needed():
    """An error that shrinks with rtol (CVode's) is followed down until under the bar; one that
    does not (the model's) still fails at the floor; an easy case runs once."""
    tried = []

    def run_at(rtol):
        tried.append(rtol)
        return _Run(rtol)

    shrinking = model_exchange.tightened_run(run_at, lambda run: run.rtol / 1.5e-11)
    assert shrinking.rtol == pytest.approx(1e-11) and tried == pytest.approx([1e-10, 1e-11])
    assert "tried 1e-10: 6.7 of the bar, 1e-11: 0.67 of the bar" in shrinking.note()
    assert shrinking.cvode_estimate == pytest.approx(9e-7 / (10 + 1e-7), rel=1e-6)
    tried.clear()
    wrong = model_exchange.tightened_run(run_at, lambda run: 40.0)
    assert wrong.rtol == pytest.approx(model_exchange.FLOOR_RTOL) and wrong.tries[-1][1] == 40.0
    assert len(tried) == round(math.log10(model_exchange.START_RTOL / model_exchange.FLOOR_RTOL)) + 1
    tried.clear()
    easy = model_exchange.tightened_run(run_at, lambda run: 0.1)
    assert tried == [model_exchange.START_RTOL] and easy.cvode_estimate is None
    refused = model_exchange.tightened_run(lambda r: _Run(r, error="fmi2Error"), lambda run: 0.0)
    assert refused.run.error == "fmi2Error" and not refused.tries


# ---------------------------------------------------------------- the CLI's exit codes and JUnit
def test_junit_marks_failures_skips_and_verdicts(tmp_path):
    from crankfmu.validation.junit import junit_xml

    checks = CheckList(echo=None)
    checks.close("A.python.cs.ok", 1.0, 1.0, 1e-6)
    checks.close("A.python.cs.bad", 2.0, 1.0, 1e-6)
    checks.skip("A.python.me.none", "no Model Exchange")
    disagreement = checks.close("A.python.paper.x", 34.98, 34.98, 0.01, note="the masses differ")
    disagreement.set_status("disagrees")
    root = ET.fromstring(junit_xml(checks.items, 1.5))
    suite = root.find("testsuite")
    assert suite.get("name") == "A.python" and (suite.get("tests"), suite.get("failures"), suite.get("skipped")) == \
        ("4", "1", "2")
    by_name = {c.get("name"): c for c in suite.findall("testcase")}
    assert by_name["cs.bad"].find("failure") is not None and by_name["cs.ok"].find("failure") is None
    assert by_name["paper.x"].find("skipped").get("type") == "disagrees"
    assert by_name["me.none"].find("skipped").get("type") == "skipped"


def test_validate_fails_when_nothing_passed(tmp_path, monkeypatch, capsys):
    """A run whose every check was skipped validated nothing: exit 1, said on stderr."""
    from crankfmu.validation import harness

    monkeypatch.setattr(harness, "readable_fmu", lambda path: None)

    def nothing(paths, out, quick, jobs=None, demo=False):
        checks = CheckList(echo=None)
        checks.skip("X.python.cs.all", "cannot")
        (out / "report.md").write_text("")
        return checks, out / "report.md"
    monkeypatch.setattr(harness, "validate", nothing)
    (tmp_path / "x.fmu").write_text("")
    args = harness.build_parser().parse_args(["--fmu", str(tmp_path / "x.fmu"), "--out", str(tmp_path / "o")])
    (tmp_path / "o").mkdir()
    assert harness.run_from_args(args) == 1
    assert "nothing was validated" in capsys.readouterr().err


def test_a_copy_of_the_engine_file_is_what_the_fmu_carries(engine_fmu, tmp_path):
    """The twins above edit the file the FMU carries: the harness's reference reads that copy, and
    the untouched copy passes the same checks the twins fail."""
    with zipfile.ZipFile(engine_fmu) as z:
        assert z.read(CARRIED).decode() == ENGINE.read_text()
    checks = default_checks(twin(engine_fmu, tmp_path, "same"), tmp_path)
    assert checks.failed == 0 and checks.passed > 40, [c.line() for c in checks.items if c.status == "failed"]
