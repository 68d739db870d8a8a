"""The validation harness itself: its checks pass on the real FMU and fail when something is wrong
(a wrong FMU parameter, a perturbed reference, a geometry off the paper, an unmet expectation)."""

import math

import numpy as np
import pytest

from crankfmu.validation import CheckList, cases, compare, harness, mechanism, paper, work_precision
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
    skipped = c.skip("h", "cannot be checked here")
    assert not skipped.passed and lines[-1] == "SKIP h: cannot be checked here"
    assert c.summary() == "3 passed, 4 failed, 1 skipped"


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


def test_turn_times_are_scipys_roots_of_the_hermite_interpolant():
    """The vectorised Newton on each turn's own interval against scipy's PPoly.solve (which searched
    every interval for each level: 110 of 125 s of the 1000 s case), on an uneven rotation."""
    from scipy.interpolate import CubicHermiteSpline

    t = np.linspace(0.0, 30.0, 3001)
    phi, w = 3 * t + 0.9 * np.sin(2 * t), 3 + 1.8 * np.cos(2 * t)
    levels = 2 * math.pi * np.arange(1, 14)
    exact = [CubicHermiteSpline(t, phi, w).solve(level, extrapolate=False)[0] for level in levels]
    assert np.max(np.abs(compare.turn_times(t, phi, w, levels) - exact)) < 1e-13


def test_ratio_table_and_fastest():
    P = work_precision.Point
    pts = [P("slow", "a", 1e-7, 0, 1.0, 1), P("fast", "b", 1e-7, 0, 0.1, 1), P("fast", "c", 1e-10, 0, 0.5, 1),
           P("broken", "d", float("nan"), float("nan"), float("nan"), 0, "failed")]
    rows = {r["family"]: r for r in work_precision.ratio_table(pts, targets=(1e-6, 1e-9))}
    assert rows["slow"][1e-6]["ratio"] == pytest.approx(10.0)
    assert rows["fast"][1e-9]["setting"] == "c" and rows["slow"][1e-9] is None and rows["broken"][1e-6] is None
    best, second = work_precision.fastest(pts, 1e-6)
    assert (best.setting, second.setting) == ("b", "a")


def test_a_fastest_method_is_named_only_beyond_the_spread():
    """Two methods whose runs overlap have no winner; one whose slowest run beats the other's
    fastest has. A run coarser than the output grid never wins, however fast."""
    P = work_precision.Point

    def point(family, median, low, high, on_grid=True):
        return P(family, "s", 1e-7, 0, median, 5, time_min=low, time_max=high, on_grid=on_grid)
    overlap = [point("Native FMU, rtol sweep", 0.010, 0.009, 0.013), point("Python FMU, rtol sweep", 0.012, 0.011, 0.014)]
    said = work_precision.verdict(overlap, 1e-6)
    assert "the fastest are **Native FMU and Python FMU**, whose runs overlap" in said and "next method" not in said
    apart = [point("Native FMU, rtol sweep", 0.010, 0.009, 0.011), point("Python FMU, rtol sweep", 0.030, 0.028, 0.033),
             point("Native FMU, step sweep", 0.001, 0.001, 0.001, on_grid=False)]
    said = work_precision.verdict(apart, 1e-6)
    assert said.startswith("At 1e-06 rad/s the fastest is **Native FMU**") and "takes 3 times as long" in said
    # the same FMU's other sweep is not "the next method"
    same = [point("Native FMU, rtol sweep", 0.010, 0.009, 0.011), point("Native FMU, step sweep", 0.02, 0.02, 0.02)]
    assert "only Native FMU" in work_precision.verdict(same, 1e-6)


def test_timed_points_are_medians_of_five_runs():
    calls = []
    out, times, outs = work_precision._timed(lambda: calls.append(1) or len(calls))
    assert len(times) == len(outs) == 5 == work_precision.REPEATS and out == 5


# ---------------------------------------------------------------- the FMU side
@pytest.fixture(scope="module")
def fmu(fmu_path):
    f = FmuUnderTest(fmu_path)
    yield f
    f.close()


def test_fmu_names_its_scenario(fmu):
    assert fmu.scenario_name == "seed000" and fmu.name == "FourBar"
    assert (fmu.kind.kind, fmu.kind.build, fmu.kind.causality) == ("scenario", "python", "torque")
    assert {"phi1", "omega1", "W_motor", "W_load", "W_ext"} <= set(fmu.outputs)


def test_default_checks_pass_on_the_real_fmu(fmu, scenario, tmp_path):
    checks = CheckList(echo=None)
    section = mechanism.check_default(fmu, scenario, checks, tmp_path, "CoSimulation")
    assert checks.failed == 0, [c.line() for c in checks.items if not c.passed]
    assert len(checks.items) >= 15 and (tmp_path / section["plot"]).is_file()
    # every output the FMU declares is compared: the joint reactions too
    compared = {r["output"] for r in section["rows"]}
    assert compared == set(fmu.outputs) and {"O_Fx", "C_Fy"} <= compared


def test_a_wrong_fmu_parameter_fails(fmu, scenario, tmp_path):
    """The FMU runs B = 20 while the reference is told 20.5: the harness must see it, in the states
    and in the motor's torque. (The joint reactions follow the FMU's own states correctly, so they
    pass at its states; against the reference their bar carries the states' difference.)"""
    checks = CheckList(echo=None)
    mechanism.check_default(fmu, scenario.with_params(B=20.5), checks, tmp_path, "CoSimulation")
    failed = {c.name for c in checks.items if not c.passed}
    assert {"FourBar.python.cs.default.omega1_rel_error", "FourBar.python.cs.default.cycle4_omega1_mean_error",
            "FourBar.python.cs.default.M_motor_rel_error"} <= failed
    assert "FourBar.python.cs.default.O_Fx_at_own_states" not in failed


def test_a_perturbed_reference_fails(fmu, scenario, tmp_path, monkeypatch):
    def perturbed(scenario, times, method="reference", model=None):      # cached_reference's signature
        ref = reference_run(scenario, times, method)
        ref.values["omega1"] = ref.values["omega1"] * (1 + 1e-5)   # 2e-4 rad/s: far above the FMU's error
        return ref
    monkeypatch.setattr(mechanism, "cached_reference", perturbed)
    checks = CheckList(echo=None)
    mechanism.check_default(fmu, scenario, checks, tmp_path, "CoSimulation")
    failed = {c.name for c in checks.items if not c.passed}
    assert {"FourBar.python.cs.default.omega1_rel_error", "FourBar.python.cs.default.cycle4_omega1_max_error"} <= failed
    assert "FourBar.python.cs.default.phi1_rel_error" not in failed       # only omega1 was perturbed


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
    assert {"FourBar.python.cs.hard.x.g0.refused_with_fmi2Error", "FourBar.python.cs.hard.y.g0.omega1_min",
            "FourBar.python.cs.hard.y.g0.badoiu-eq17_refuses", "FourBar.python.cs.hard.y.g0.lv-eq3_refuses"} <= failed
    # the runs themselves were fine: those checks pass
    assert "FourBar.python.cs.hard.y.g0.omega1_rel_error" not in failed


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
    import zipfile

    from crankfmu.cli import main
    assert main(["validate", "--fmu", str(tmp_path / "none.fmu"), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "no FMU at" in err and "none.fmu" in err and len(err.strip().splitlines()) == 1
    # a junk file, a zip without a modelDescription, another tool's FMU: each an error naming it, exit 2
    junk = tmp_path / "junk.fmu"
    junk.write_text("not a zip")
    empty = tmp_path / "empty.fmu"
    with zipfile.ZipFile(empty, "w") as z:
        z.writestr("readme.txt", "x")
    other = tmp_path / "other.fmu"
    with zipfile.ZipFile(other, "w") as z:
        z.writestr("modelDescription.xml", '<fmiModelDescription fmiVersion="2.0" modelName="O" guid="x"/>')
    for path, why in ((junk, "not a zip file"), (empty, "no modelDescription.xml"), (other, "not an FMU crankfmu built")):
        assert main(["validate", "--fmu", str(path), "--out", str(tmp_path / "r")]) == 2
        err = capsys.readouterr().err
        assert path.name in err and why in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "r").exists()           # refused before anything was written
    assert main(["validate", "--jobs", "0", "--out", str(tmp_path)]) == 2
    assert "--jobs must be >= 1" in capsys.readouterr().err


def test_an_fmu_crankfmu_did_not_build_is_listed_not_validated(tmp_path, capsys):
    """A third party's FMU (no crankfmu VendorAnnotation) is named in the report with the reason, and
    counted as skipped: nothing is left out silently."""
    import shutil
    import zipfile

    other = tmp_path / "Other.fmu"
    with zipfile.ZipFile(other, "w") as z:
        z.writestr("modelDescription.xml", '<?xml version="1.0"?><fmiModelDescription fmiVersion="2.0" '
                   'modelName="Other" guid="{x}"><CoSimulation modelIdentifier="Other"/></fmiModelDescription>')
    checks, report = harness.validate([other], tmp_path / "out", echo=None, jobs=1)
    assert checks.skipped == 1 and checks.failed == 0
    text = report.read_text()
    assert "## Not validated" in text and "Other.fmu" in text and "no crankfmu VendorAnnotation" in text
    shutil.rmtree(tmp_path / "out")


def test_every_kind_of_fmu_is_planned(tmp_path):
    """make fmu's FMUs, native ones included, each land in a group of its data file: the Python and
    the native FMUs (FMI 2.0 and 3.0) of one scenario together (they share reference runs), every
    kind recognised."""
    from pathlib import Path

    from crankfmu.validation.fmu_runner import kind_of

    fmus = harness.discover(Path("build/fmus"))
    if not fmus:
        pytest.skip("make fmu builds build/fmus/")
    groups, not_validated = harness.plan(fmus)
    assert not not_validated, not_validated
    kinds = {(kind_of(p).kind, kind_of(p).build, kind_of(p).causality) for g in groups for p in g}
    assert {("scenario", "python", "torque"), ("scenario", "native", "torque"), ("scenario", "python", "speed"),
            ("scenario", "native", "speed"), ("drive", "python", "torque"), ("drive", "python", "speed"),
            ("cushion", "python", "torque"), ("well", "python", "torque")} <= kinds
    fourbar = next(g for g in groups if any(p.endswith("native/FourBar.fmu") for p in g))
    fmi3 = Path("build/fmus/native3/FourBar.fmu").is_file()
    assert sorted(Path(p).parent.name for p in fourbar) == ["fmus", "native"] + (["native3"] if fmi3 else [])
    if fmi3:
        assert ("scenario", "native-fmi3", "torque") in kinds


def test_published_numbers_carry_their_verdict():
    """seed 003's Fig. 3: its minimum of J_e is fitted (the data set's J0 was chosen to give it: shown,
    never a pass); its maximum (38) disagrees for a stated reason (the paper gives no masses) and is
    checked against what this data set gives (34.98), so a change of it fails as "changed"; a number
    marked not comparable is listed with its reason. None of the three counts as passed, and the
    closing line counts each kind."""
    import copy

    from crankfmu.scenario import load_scenario

    scenario = load_scenario("seed003")
    entries = [e for e in scenario.data["paper"] if e["quantity"].startswith("reduced_inertia")]
    entries.append({"name": "table_2", "expected": 1.0, "unit": "s", "not_comparable": "no such run here",
                    "source": "Table 2"})
    shaped = copy.copy(scenario)
    shaped.data = {**scenario.data, "paper": entries}

    class Run:
        def __init__(self, low, high):
            self.values = {"J_red": np.array([low, high, 0.5 * (low + high)])}

        def __getitem__(self, name):
            return self.values[name]

    checks = CheckList(echo=None)
    paper.check_paper(shaped, None, Run(31.0, 34.98), checks, "S")
    verdicts = {c.name.split(".")[-1]: c.verdict for c in checks.items}
    assert verdicts == {"J_e_min": "fitted", "J_e_max": "disagrees", "table_2": "not comparable"}
    assert checks.failed == 0 and checks.passed == 0 and checks.skipped == 0
    assert checks.summary() == "0 passed, 0 failed, 1 disagree, 1 fitted, 1 not comparable"
    lines = [c.line() for c in checks.items]
    assert lines[0].startswith("FITTED S.paper.J_e_min 31 31 0.01 kg.m2")
    assert lines[1].startswith("DISAGREE S.paper.J_e_max 34.98 34.98 0.01 kg.m2 (published 38 kg.m2)")
    assert lines[2].startswith("NOTCOMP S.paper.table_2: not comparable: no such run here")
    disagreement = next(c for c in checks.items if c.name == "S.paper.J_e_max")
    assert "masses" in disagreement.note and "Fig. 3" in disagreement.note
    assert disagreement.published == "38 kg.m2" and disagreement.measured == pytest.approx(34.98)
    checks = CheckList(echo=None)
    paper.check_paper(shaped, None, Run(31.0, 36.0), checks, "S")
    assert {c.name.split(".")[-1]: c.verdict for c in checks.items}["J_e_max"] == "changed" and checks.failed == 1
    # a fitted number that moves is a failure too, and so is a disagreement that now agrees (a stale file)
    checks = CheckList(echo=None)
    paper.check_paper(shaped, None, Run(31.5, 38.0), checks, "S")
    verdicts = {c.name.split(".")[-1]: (c.verdict, c.status) for c in checks.items}
    assert verdicts["J_e_min"] == ("changed", "failed") and verdicts["J_e_max"] == ("changed", "failed")
    assert "stale" in next(c for c in checks.items if c.name == "S.paper.J_e_max").note


def test_the_papers_graphical_values_are_checked_with_their_verdict():
    """seed 002's [kinematics.paper] values at 30 deg (v_B, Omega2, ...) are published numbers too:
    each is a check with its verdict (a rewrite of check_paper once left them unreachable)."""
    from crankfmu.scenario import load_scenario

    scenario = load_scenario("seed002")
    checks = CheckList(echo=None)
    paper.check_paper(scenario, scenario.build(), None, checks, "S")
    graphical = [c for c in checks.items if c.name.endswith("_at_30deg")]
    assert len(graphical) >= 6 and all(c.verdict == "agrees" and c.published for c in graphical)


def test_the_demo_subset_proves_each_fmu_without_the_hard_cases(fmu_path, tmp_path):
    """make demo's subset (--demo): the FMU's own checks (fmpy's validation, units, the default
    experiment against the reference, the paper's numbers), none of the hard cases or the speed
    against error the --quick subset runs on seed000, and the report and checks.json say which
    subset ran."""
    import json

    assert [c for c in cases.load_cases("seed000").cases if c.quick], "seed000 has quick hard cases to leave out"
    assert cases.load_cases("seed000").work_precision
    checks, report = harness.validate([fmu_path], tmp_path, "demo", echo=None, jobs=1)
    assert checks.failed == 0, [c.line() for c in checks.items if not c.passed and not c.skipped]
    names = [c.name for c in checks.items]
    assert "FourBar.python.fmpy_validate" in names
    assert any(n.startswith("FourBar.python.cs.default.") for n in names)
    assert any(n.startswith("FourBar.python.paper.") for n in names)
    assert not [n for n in names if ".hard." in n or "work_precision" in n or n.startswith("coupled.")]
    assert "the --demo subset" in report.read_text()
    record = json.loads((tmp_path / "checks.json").read_text())
    assert record["subset"] == "demo" and record["quick"] and "--demo" in record["subset_name"]


def test_the_default_reference_is_the_one_the_build_made(tmp_path, monkeypatch):
    """The harness reads the reference run the FMU's build made of the default experiment (kept in
    the per-user cache) instead of integrating it again: the same numbers as its own run of it (the
    same integrator; the build ends at the experiment's stop time, the harness at the grid's last
    point, which may differ by an ulp), and the other outputs at its states alike. Another grid,
    and a mechanism with joint friction, are integrated in process."""
    from pathlib import Path

    from crankfmu.fmi.reference import default_grid
    from crankfmu.scenario import load_scenario
    from crankfmu.validation.reference import built_reference

    monkeypatch.setenv("CRANKFMU_CACHE", str(tmp_path))
    scenario = load_scenario("seed002")
    grid = default_grid(scenario.experiment)
    built = built_reference(scenario, grid)
    assert built is not None and built.result is None and built.model is not None
    assert list((tmp_path / "references").glob("*.csv")), "the run is kept where the build keeps it"
    own = reference_run(scenario, grid)
    assert set(own.values) == set(built.values) and len(own.values) > 10
    for name, values in own.values.items():
        scale = float(np.max(np.abs(values))) or 1.0
        assert np.max(np.abs(built[name] - values)) <= 1e-12 * scale, name
    assert built_reference(scenario, grid[:-1]) is None
    friction = load_scenario(str(Path(harness.__file__).parent / "data" / "slidercrank_friction_scenario.toml"))
    assert built_reference(friction, default_grid(friction.experiment)) is None


def test_an_output_figure_drawn_again_into_its_layout_is_the_figure_drawn_anew(tmp_path):
    """plot_outputs fills a layout it drew before (the FMUs of one data file share their panels):
    after a longer run with other values and bars, the picture is the one a new figure gives, pixel
    for pixel."""
    from types import SimpleNamespace

    import matplotlib.image as mpimg

    from crankfmu.validation import figures

    def runs(span, scale):
        t = np.linspace(0.0, span, 501)
        values = {"omega1": scale * np.sin(t), "phi1": scale * t, "E_kin": scale * t ** 2}
        fmu = SimpleNamespace(time=t, values=values, units={"omega1": "rad/s"})
        ref = SimpleNamespace(time=t, values={k: v * (1 + 1e-9) for k, v in values.items()})
        return fmu, ref

    class Run(SimpleNamespace):
        def __getitem__(self, name):
            return self.values[name]

    def wrap(pair):
        return tuple(Run(**vars(x)) for x in pair)

    names = ["omega1", "phi1", "E_kin"]
    short, long_ = wrap(runs(2.0, 1.0)), wrap(runs(9.0, 40.0))
    figures._LAYOUTS.clear()
    figures.plot_outputs(*short, names, {"omega1": 1e-8}, tmp_path / "new.png", "a run")
    figures.plot_outputs(*long_, names, {"phi1": 1e-3, "E_kin": 1e-5}, tmp_path / "other.png", "another run")
    assert len(figures._LAYOUTS) == 1
    (_, panels, _), = figures._LAYOUTS.values()
    for (top, bottom, *_), name in zip(panels, names):       # each panel's limits follow its data
        assert top.get_xlim() == pytest.approx((-0.45, 9.45)) and bottom.get_xlim() == top.get_xlim()
        low, high = top.get_ylim()
        assert low <= long_[0][name].min() and high >= long_[0][name].max() and high - low < 1.2 * np.ptp(
            long_[0][name]) + 1e-9
    figures.plot_outputs(*short, names, {"omega1": 1e-8}, tmp_path / "again.png", "a run")
    assert panels[0][0].get_xlim() == pytest.approx((-0.1, 2.1))
    new, other, again = (mpimg.imread(tmp_path / f"{n}.png") for n in ("new", "other", "again"))
    assert new.shape == again.shape and np.array_equal(new, again)
    assert not np.array_equal(new, other)
