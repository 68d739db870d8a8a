"""The benchmark scripts run and report (no timing is asserted: the machines are shared)."""

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
