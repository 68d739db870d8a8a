"""The validation harness itself: its checks pass on the real FMU and fail when something is wrong
(a wrong FMU parameter, a perturbed reference, a geometry off the paper, an unmet expectation)."""

import math

import numpy as np
import pytest

from crankfmu.validation import CheckList, cases, compare, harness, paper, work_precision
from crankfmu.validation.fmu_runner import FmuUnderTest
from crankfmu.validation.reference import periodic_reference, reference_run


# ---------------------------------------------------------------- checks
def test_check_lines_and_outcomes():
    lines = []
    c = CheckList(echo=lines.append)
    assert c.close("a", 1.0005, 1.0, 1e-3).passed
    assert not c.close("b", 1.01, 1.0, 1e-3).passed
    assert not c.at_most("c", float("nan"), 1.0).passed          # NaN never passes
    assert c.at_most("d", -1e-9, 1e-8).passed                    # an error counts by magnitude
    assert c.below("e", -2.9, 0.0, "rad/s").passed and not c.below("f", 0.0, 0.0).passed
    assert not c.holds("g", False).passed
    assert lines[0] == "PASS a 1.0005 1 0.001"
    assert lines[1].startswith("FAIL b 1.01 1 0.001")
    assert lines[4] == "PASS e -2.9 <0 0 rad/s"
    assert c.summary() == "3 passed, 4 failed"


# ---------------------------------------------------------------- comparisons on known functions
def test_phi_quadrature_is_fourth_order_on_a_smooth_motion():
    for h, limit in ((1e-2, 2e-11), (1e-3, 2e-15)):
        t = np.arange(0.0, 2.0 + h / 2, h)
        phi, w, e = 3 * t + np.sin(5 * t), 3 + 5 * np.cos(5 * t), -25 * np.sin(5 * t)
        # h^4/720 * max|omega''''| * T bounds the composite Hermite rule's error
        assert compare.phi_quadrature_residual(t, phi, w, e) <= h ** 4 / 720 * 5 ** 5 * 2.0 + limit
    # an inconsistent phi1 (a 1e-6 rad slip) is seen
    t = np.arange(0.0, 2.0, 1e-3)
    slip = np.where(t > 1.0, 1e-6, 0.0)
    assert compare.phi_quadrature_residual(t, 3 * t + slip, 3 + 0 * t, 0 * t) == pytest.approx(1e-6)


def test_energy_residual_and_cycles_on_a_uniform_rotation():
    t = np.linspace(0.0, 3.0, 3001)
    w = np.full_like(t, 2 * math.pi)            # one turn per second
    values = {"E_kin": 0.5 * 2.0 * w ** 2, "W_motor": 10 * t, "W_load": -10 * t, "W_ext": 0 * t}
    assert compare.energy_residual(values) < 1e-15
    values["W_load"] = -9.99 * t                # 0.1 % of the motor work goes missing
    assert compare.energy_residual(values) == pytest.approx(0.03 / (30 + 29.97), rel=1e-9)
    turns = compare.cycles(t, w * t, w)
    assert len(turns) == 3
    assert turns[1]["t_start"] == pytest.approx(1.0, abs=1e-12)
    assert turns[1]["omega1_mean"] == pytest.approx(2 * math.pi, rel=1e-12) and turns[1]["delta"] == 0


def test_ratio_table_and_fastest():
    P = work_precision.Point
    pts = [P("slow", "a", 1e-7, 0, 1.0, 1), P("fast", "b", 1e-7, 0, 0.1, 1), P("fast", "c", 1e-10, 0, 0.5, 1),
           P("broken", "d", float("nan"), float("nan"), float("nan"), 0, "failed")]
    rows = {r["family"]: r for r in work_precision.ratio_table(pts, targets=(1e-6, 1e-9))}
    assert rows["slow"][1e-6]["ratio"] == pytest.approx(10.0)
    assert rows["fast"][1e-9]["setting"] == "c" and rows["slow"][1e-9] is None and rows["broken"][1e-6] is None
    best, second = work_precision.fastest(pts, 1e-6)
    assert (best.setting, second.setting) == ("b", "a")


# ---------------------------------------------------------------- the FMU side
@pytest.fixture(scope="module")
def fmu(fmu_path):
    f = FmuUnderTest(fmu_path)
    yield f
    f.close()


def test_fmu_names_its_scenario(fmu):
    assert fmu.scenario_name == "seed000" and fmu.name == "FourBar"
    assert {"phi1", "omega1", "W_motor", "W_load", "W_ext"} <= set(fmu.outputs)


def test_default_checks_pass_on_the_real_fmu(fmu, scenario, tmp_path):
    checks = CheckList(echo=None)
    section = harness.check_default(fmu, scenario, checks, tmp_path)
    assert checks.failed == 0, [c.line() for c in checks.items if not c.passed]
    assert len(checks.items) >= 15 and (tmp_path / section["default"]["plot"]).is_file()


def test_a_wrong_fmu_parameter_fails(fmu, scenario, tmp_path):
    """The FMU runs B = 20 while the reference is told 20.5: the harness must see it."""
    checks = CheckList(echo=None)
    harness.check_default(fmu, scenario.with_params(B=20.5), checks, tmp_path)
    failed = {c.name for c in checks.items if not c.passed}
    assert "FourBar.default.omega1_rel_error" in failed and "FourBar.default.cycle4_omega1_mean_error" in failed


def test_a_perturbed_reference_fails(fmu, scenario, tmp_path, monkeypatch):
    def perturbed(*args, **kwargs):
        ref = reference_run(*args, **kwargs)
        ref.values["omega1"] = ref.values["omega1"] * (1 + 1e-5)   # 2e-4 rad/s: far above the FMU's error
        return ref
    monkeypatch.setattr(harness, "reference_run", perturbed)
    checks = CheckList(echo=None)
    harness.check_default(fmu, scenario, checks, tmp_path)
    failed = {c.name for c in checks.items if not c.passed}
    assert {"FourBar.default.omega1_rel_error", "FourBar.default.cycle4_omega1_max_error"} <= failed
    assert "FourBar.default.phi1_rel_error" not in failed       # only omega1 was perturbed


def test_a_geometry_off_the_paper_fails_the_paper_numbers(scenario):
    model = scenario.with_params(l1=0.201).build()
    checks = CheckList(echo=None)
    paper.check_paper(scenario, model, _FakeRun(), checks, "X")
    failed = {c.name for c in checks.items if not c.passed}
    assert failed == {"X.paper.phi1d_deg", "X.paper.phi1a_deg"}


class _FakeRun:
    """Eight turns at exactly 3 rad/s: settled, so settled_in_cycle_4 passes."""
    time = np.linspace(0.0, 8 * 2 * math.pi / 3, 4001)
    values = {"phi1": 3 * time, "omega1": np.full(4001, 3.0)}

    def __getitem__(self, name):
        return self.values[name]


def test_unmet_expectations_fail(fmu, scenario):
    """A refusal expected of a valid geometry, and a reversal expected of the default motor."""
    checks = CheckList(echo=None)
    not_refused = cases.HardCase(name="x", expect="", set={"l3": 0.46}, stop_time=0.05, step=1e-3,
                                 refused_parameter="l3")
    cases.run_case(fmu, scenario, not_refused, 0.0, False, checks)
    no_reversal = cases.HardCase(name="y", expect="", set={}, stop_time=0.2, step=1e-3, omega1_below=0.0,
                                 schemes_refuse=True)
    cases.run_case(fmu, scenario, no_reversal, 0.0, False, checks)
    failed = {c.name for c in checks.items if not c.passed}
    assert {"FourBar.hard.x.g0.refused_with_fmi2Error", "FourBar.hard.y.g0.omega1_min",
            "FourBar.hard.y.g0.badoiu-eq17_refuses", "FourBar.hard.y.g0.lv-eq3_refuses"} <= failed
    # the runs themselves were fine: those checks pass
    assert "FourBar.hard.y.g0.omega1_rel_error" not in failed


def test_bad_case_files_are_named(tmp_path):
    with pytest.raises(Exception, match="unknown key"):
        cases.HardCase.from_dict({"name": "z", "expect": "", "set": {}, "stop_time": 1, "step": 1e-3,
                                  "tolerance": 1}, "cases/z.toml")
    with pytest.raises(Exception, match="step must be > 0"):
        cases.HardCase.from_dict({"name": "z", "expect": "", "set": {}, "stop_time": 1, "step": 0}, "z.toml")


def test_periodic_reference_matches_a_direct_run(scenario):
    """The settled-cycle extension against a direct reference run to 14 s."""
    times = np.linspace(0.0, 14.0, 1401)
    direct = reference_run(scenario, times)
    extended = periodic_reference(scenario, times, settle_time=6.0)
    assert extended.settings["cycles_extended"] > 20
    assert np.max(np.abs(extended["omega1"] - direct["omega1"])) < 1e-8
    assert np.max(np.abs(extended["phi1"] - direct["phi1"])) < 1e-8
    assert np.max(np.abs(extended["W_motor"] - direct["W_motor"])) < 1e-6 * np.max(np.abs(direct["W_motor"]))


def test_validate_command_errors(tmp_path, capsys):
    from crankfmu.cli import main
    assert main(["validate", "--fmu", str(tmp_path / "none.fmu"), "--out", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "FAIL none.loads" in out and "0 passed, 1 failed" in out
