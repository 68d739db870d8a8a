"""The command line writes what the issue promises and fails cleanly on bad input."""

import csv
import json

import pytest

import crankfmu
from crankfmu.cli import main


def test_simulate_writes_csv_summary_and_plots(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["simulate", "seed000", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "cycle 4" in printed and "omega1 min" in printed and "residual" in printed
    with open(out / "timeseries.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["time", "phi1", "omega1", "epsilon1", "M_motor", "M_load", "J_red", "E_kin",
                       "W_motor", "W_load", "W_ext"]
    assert len(rows) == 2002        # header + 0..2 s every 1 ms
    summary = json.loads((out / "summary.json").read_text())
    for key in ("omega1_min", "omega1_max", "omega1_mean", "delta", "J_red_min", "J_red_max",
                "energy_residual"):
        assert isinstance(summary[key], float)
    assert summary["omega1_min"] < summary["omega1_mean"] < summary["omega1_max"]
    assert abs(summary["energy_residual"]) < 1e-8
    assert summary["columns"]["omega1"] == "rad/s"
    for png in ("omega1_cycles.png", "omega1_cycle4.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_simulate_with_the_paper_scheme_and_a_set(tmp_path):
    out = tmp_path / "eq17"
    assert main(["simulate", "seed000", "--out", str(out), "--method", "badoiu-eq17",
                 "--set", "J_flywheel=2", "--angle-step-deg", "0.5"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["parameters"]["J_flywheel"] == 2.0
    assert summary["settings"]["angle_step_deg"] == pytest.approx(0.5)


@pytest.mark.parametrize("args, message", [
    (["simulate", "seed999"], "unknown scenario 'seed999'"),
    (["simulate", "seed000", "--set", "nope=1"], "unknown parameter 'nope'"),
    (["simulate", "seed000", "--set", "l11=1"], "unknown parameter 'l11' for scenario seed000 (did you mean l1?)"),
    (["simulate", "seed000", "--set", "l1=-1"], "l1 = -1.0 is out of range"),
    (["simulate", "seed000", "--set", "l1"], "--set expects NAME=VALUE"),
    (["simulate", "seed000", "--t-end", "0"], "duration must be > 0"),
    (["simulate", "seed000", "--set", "omega1_start=0", "--method", "lv-eq3"], "lv-eq3 cannot run this case"),
])
def test_bad_input_exits_1_with_one_line(tmp_path, capsys, args, message):
    assert main(args + ["--out", str(tmp_path / "x")]) == 1
    assert message in capsys.readouterr().err


def test_scenario_by_path(tmp_path):
    src = crankfmu.load_scenario("seed000").path
    copy = tmp_path / "mine.toml"
    copy.write_text(open(src).read().replace("value = 1.0, unit = \"kg.m2\"", "value = 3.0, unit = \"kg.m2\""))
    assert crankfmu.load_scenario(copy)["J_flywheel"] == 3.0


def test_schemes_study_prints_orders(tmp_path, capsys):
    out = tmp_path / "schemes"
    assert main(["schemes", "seed000", "--out", str(out), "--steps-deg", "0.4,0.2"]) == 0
    printed = capsys.readouterr().out
    assert "badoiu-eq17" in printed and "lv-eq3" in printed
    rows = json.loads((out / "schemes.json").read_text())
    orders = [r["order"] for r in rows if r["order"] is not None]
    assert len(orders) == 2 and all(0.8 < o < 1.2 for o in orders)
    assert (out / "startup.png").exists()


def test_progress_bar_in_a_log_file_writes_a_line_every_10_percent():
    import io

    from crankfmu.progress import ProgressBar
    bar = ProgressBar(2.0, "run", delay=0.0, stream=io.StringIO())
    for i in range(1001):
        bar(i * 0.002)
    bar.close()
    lines = bar.stream.getvalue().splitlines()
    assert 10 <= len(lines) <= 11 and "\r" not in bar.stream.getvalue() and lines[-1].startswith("run [####")


def test_validate_and_hosts_parse_their_own_options_and_load_only_when_run(capsys):
    """Every other subcommand starts without importing the harnesses (0.4 s of cases and
    references); validate and hosts still refuse an unknown option with their own usage."""
    import subprocess
    import sys

    code = ("import sys, crankfmu.cli; crankfmu.cli.build_parser(); "
            "print(sorted(m for m in sys.modules if m.startswith('crankfmu.validation')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"
    for command in ("validate", "hosts"):
        with pytest.raises(SystemExit) as info:
            main([command, "--no-such-option"])
        assert info.value.code == 2
        assert f"crankfmu {command}: error: unrecognized arguments: --no-such-option" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["validate", "--help"])
    assert "--quick" in capsys.readouterr().out


# ---------------------------------------------------------------- first contact: version, help, paths
def test_version_and_help_name_their_defaults(capsys):
    """--version answers; the top-level help is plain text (no reST markup) and does not point at
    itself; every option of simulate shows its default, --method its choices explained."""
    from importlib.metadata import version

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out.strip() == f"crankfmu {version('crankfmu')}"
    with pytest.raises(SystemExit):
        main(["--help"])
    top = capsys.readouterr().out
    assert "``" not in top and ":class:" not in top and "(``crankfmu --help``)" not in top and "FMU" in top
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: reference)" in text and "fast: the C kernel" in text and "(default: None)" not in text
    assert "--rtol RTOL relative (and absolute) tolerance" in text and "reference 1e-12" in text


@pytest.mark.parametrize("command", [
    ["simulate", "seed000", "--t-end", "0.01", "--out"],
    ["equilibrium", "seed001", "--omega", "15", "--out"],
    ["draw", "seed000", "--out"],
    ["validate", "--fmu", "build/fmus/FourBar.fmu", "--out"],
])
def test_an_output_path_that_cannot_be_written_is_refused_before_any_work(command, tmp_path, capsys, monkeypatch):
    """A file where the output folder would go: one line naming it, exit status != 0, before any
    model is built or any FMU run (both made to fail the test here), nothing written (it used to
    fail after the computation with NotADirectoryError)."""
    from crankfmu.scenario import Scenario
    from crankfmu.validation import harness

    def computed(*args, **kwargs):
        raise AssertionError("the computation started before the output path was checked")
    monkeypatch.setattr(Scenario, "build", computed)
    monkeypatch.setattr(harness, "validate", computed)
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    target = blocker / "out" / ("x.png" if command[0] == "draw" else "")
    code = main([*command, str(target)])
    err = capsys.readouterr().err.strip()
    assert code != 0 and len(err.splitlines()) == 1, err
    assert "is a file, not a folder" in err and "a_file" in err
    assert blocker.read_text() == "not a folder" and sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


@pytest.mark.parametrize("command", [
    ["simulate", "seed000", "--out"],
    ["sweep", "seed004", "--param", "e=0.3:0.45:2", "--out"],
    ["validate", "--fmu", "build/fmus/FourBar.fmu", "--out"],
])
def test_an_output_folder_the_system_refuses_is_refused_before_any_work(command, capsys, monkeypatch):
    """/proc/x: access() tells root it may write in /proc, but nothing can be made there; a file
    made and removed in the nearest existing folder finds that out before any model is built (the
    simulation used to run for 2.5 s and then fail with FileNotFoundError)."""
    from crankfmu.scenario import Scenario
    from crankfmu.validation import harness

    def computed(*args, **kwargs):
        raise AssertionError("the computation started before the output path was checked")
    monkeypatch.setattr(Scenario, "build", computed)
    monkeypatch.setattr(harness, "validate", computed)
    code = main([*command, "/proc/crankfmu-test/x"])
    err = capsys.readouterr().err.strip()
    assert code != 0 and len(err.splitlines()) == 1, err
    assert "--out /proc/crankfmu-test/x: cannot write in /proc" in err


def test_simulate_prints_no_python_objects(tmp_path, capsys):
    """The run's settings in words (the method, its solver, rtol, the table), not a raw dict."""
    assert main(["simulate", "seed000", "--method", "fast", "--out", str(tmp_path)]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert "{" not in first and "'" not in first, first
    assert first.startswith("seed000 (fast: Dormand-Prince 5(4) on the tabulated model (C kernel), rtol ")


def test_a_sweep_writes_its_rows_in_grid_order_and_leaves_no_stale_figures(tmp_path):
    """The rows come back from the workers in the order they finish; peaks.csv lists them in the
    grid's order. A second sweep of another parameter into the same folder leaves none of the
    first one's figures behind."""
    import csv

    assert main(["sweep", "seed004", "--param", "e=0.30:0.45:4", "--param", "l1=0.15:0.30:2",
                 "--out", str(tmp_path)]) == 0
    with (tmp_path / "peaks.csv").open() as f:
        rows = [(float(r["e"]), float(r["l1"])) for r in csv.DictReader(f)]
    assert rows == sorted(rows) and len(rows) == 7         # e = l1 = 0.3 cannot be assembled: failed.csv
    assert (tmp_path / "omega3_vs_e.png").is_file()
    assert main(["sweep", "seed004", "--param", "l1=0.15:0.30:3", "--out", str(tmp_path), "--restart"]) == 0
    assert not list(tmp_path.glob("*_vs_e.png")) and (tmp_path / "omega3_vs_l1.png").is_file()


def test_a_progress_bar_says_it_finished_once():
    """A sweep tells its bar 1.0 for its last chunk and again at its end: a log gets one 100 % line."""
    import io

    from crankfmu.progress import ProgressBar

    log = io.StringIO()
    bar = ProgressBar(1.0, label="x", delay=0.0, stream=log)
    for value in (0.05, 0.5, 1.0, 1.0, 1.0):
        bar(value)
    bar.close()
    lines = log.getvalue().splitlines()
    assert sum("100.0%" in line for line in lines) == 1 and len(lines) == 3, lines
