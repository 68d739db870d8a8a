"""The benchmark scripts run and report (no timing is asserted: the machines are shared)."""

import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))


def test_fmu_step_benchmark_reports_both_fmus_their_ratio_and_the_error(fmu_path, capsys):
    import fmu_step

    assert fmu_step.main(["--fmu", fmu_path, "--stop", "0.2", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"FourBar.fmu\s+\d+\.\d", out) and re.search(r"do-nothing FMU\s+\d+\.\d", out)
    assert re.search(r"ratio FourBar / do-nothing: \d", out)
    error = float(re.search(r"max \|omega1 error\| against the reference: (\S+)", out).group(1))
    assert error < 1e-6


def test_speed_benchmark_prints_the_table_and_every_target_with_its_measure(fmu_path, tmp_path, capsys):
    import speed

    from pathlib import Path

    from crankfmu.cli import main

    native = Path(fmu_path).parent / "native" / "FourBar.fmu"
    if not native.exists():
        assert main(["fmu", "seed000", "--native", "--out", str(tmp_path / "native")]) == 0
        native = tmp_path / "native" / "FourBar.fmu"
    assert speed.main(["--quick", "--designs", "400", "--fmu", fmu_path, "--native", str(native),
                       "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    for family in ("crankfmu fast", "solve_ivp RK45", "solve_ivp DOP853", "solve_ivp LSODA", "paper eq. 17",
                   "crankfmu reference", "FourBar.fmu via fmpy", "native FourBar.fmu via fmpy"):
        assert f"| {family}" in out
    assert out.count("| yes |") + out.count("| NO |") == 4           # the four targets, each judged
    assert "## Targets (issue 39)" in out and "native RodString.fmu per 1 ms step" in out
    assert "## Targets (issue 40)" in out
    assert re.search(r"`crankfmu well rp11l_guo` end to end, against reference loop, one core \(reported\) \| "
                     r"\d+\.\d+ s vs \d+\.\d+ s", out)
    # issue 17: where simulate()'s time goes, and its five targets (the first runs on a fresh machine
    # are not measured with --quick, and say so); issue 27: the native FMU in the C driver against
    # the C RK4 limit, and through fmpy against the do-nothing FMU
    for name in ("seed000", "seed001", "seed003"):
        assert re.search(rf"\| {name} \| [\d.]+ \| [\d.]+ \| [\d.]+ \| [\d.]+ \| [\d.]+ \| [\d.]+ \|", out)
    # issue 28, where `make fmu` built both speed-causal FourBar FMUs: the native one beside the
    # Python one, the same kernel step, so the same tau_drive to the bit
    speed_fmus = (Path(fmu_path).parent / "FourBarSpeed.fmu").exists() and (native.parent / "FourBarSpeed.fmu").exists()
    # issue 38: FourBar.fmu, Python and native, with every variable read at every step (fmpy, ecos)
    # issue 40, where `make fmu` built the FMI 3.0 FourBar.fmu: its step against FMI 2.0's, judged
    fmi3 = (native.parent.parent / "native3" / "FourBar.fmu").exists()
    judged = out.count("| MET |") + out.count("| NOT MET |")
    # issues 58 and 68: the four-stroke engine's FMU step with its brake as a couple of omega1, as a
    # fan and as a general law against the motor line's, native and Python, each judged
    assert "## Targets (issues 58 and 68: loads of the speed)" in out
    assert "brake as a couple of omega1 (affine) <= 1.3x" in out
    assert "brake as a fan, -c omega1 |omega1| (degree 2) <= 1.3x" in out
    assert "brake as a general law, tanh(omega1/240) <= 3x" in out
    # issue 69: the fast path's step with joint friction against its frictionless step, judged
    # (the Python FMU's ratio beside it, reported)
    assert "## Targets (issue 69: joint friction)" in out and "with friction in its 4 joints <= 1.5x" in out
    assert judged == 5 + speed_fmus + 2 + fmi3 + 6 + 1 and out.count("| not measured |") == 2
    if fmi3:
        assert re.search(r"FMI 3.0 against FMI 2.0 \(issue 40: at most 1.1x\) \| [\d.]+ vs [\d.]+ us/step, ratio [\d.]+ \|",
                         out)
    assert re.search(r"FourBar.fmu \(Python\) in the ecos master, 10 s with every variable read at every 1 ms step: "
                     r"real-time factor >= 10 .* \| [\d.]+ \([\d.]+ s wall\); through fmpy [\d.]+ us/step \|", out)
    data = json.loads((tmp_path / "speed.json").read_text())
    assert {"python", "native"} <= data["every_output"].keys()
    if speed_fmus:
        assert re.search(r"native FourBarSpeed.fmu per 1 ms step .* ratio [\d.]+; tau_drive differs by 0.0e\+00 N.m \| MET",
                         out)
    assert re.search(r"native FourBar.fmu per 1 ms step in the C driver .* ratio [\d.]+ \|", out)
    assert "hand-written right-hand side" in out
    limit = re.search(r"the C RK4 limit: ([\d.]+) ms at (\S+) rad/s", out)      # measured, at the target error
    assert limit and float(limit.group(2)) <= 1e-8
    fast = [r for r in data["rows"] if r["family"].startswith("crankfmu fast") and r["setting"] == "rtol 1e-11"]
    # the C kernel at its default tolerance: within the 1e-8 rad/s target
    assert len(fast) == 1
    assert fast[0]["omega1_error"] <= 1e-8
