"""Every FMU (the five mechanisms, Drive, the pumping unit, and the native FourBar in FMI 2.0 and 3.0)
fails loudly and safely whatever the host's logging setting (tests/fuzz_host.py).

Each case is a child process (fmpy's FMU2Slave, or FMU3Slave, driving the FMU through raw FMI calls) with a time
limit, so a crash or a hang is that case's failure. The children run two at a time (the machine's
two cores) when the module starts; each test then reads its own report.

Groups, each for every FMU with loggingOn false and true:
- parameters: every parameter set to NaN, +inf, -inf, -1e300, 1e300, 0 and -1;
- designs: 20 random designs within +-60 % of the defaults (g = 0 or 9.81, omega1_start = 0, 0.1,
  5 or 20), refused or stepped 2 s at 10 ms with finite outputs and the energy balance
  |E_kin - E_kin(0) - W_motor - W_load - W_ext| <= 1e-6 (|W_motor| + |W_load| + 1 J): the FMU's
  work integrals ride in its state, so only the integrator's error (rtol 1e-11) remains;
- calls: bad fmi2DoStep arguments and calls out of order;
- cycles: 200 instantiate/step/free cycles in one process, identical results, memory growth
  under 100 MB;
- instances: three interleaved instances equal one alone; state get/set and
  serialize/deserialize continue bit for bit; a corrupted state is refused.
"""

from __future__ import annotations

import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FMUS = ("FourBar", "ThreeLoop", "SliderCrank", "Shaper", "QuickReturn", "Drive", "PumpJack", "native/FourBar",
        "native3/FourBar")
GROUPS = ("parameters", "designs", "calls", "cycles", "instances")
TIME_LIMIT = 600     # s per child: a hang fails the case
CASES = [(fmu, group, logging) for fmu in FMUS for group in GROUPS for logging in (False, True)]


def run_case(fmu: str, group: str, logging: bool) -> dict:
    path = ROOT / "build" / "fmus" / f"{fmu}.fmu"
    cmd = [sys.executable, str(ROOT / "tests" / "fuzz_host.py"), str(path), group, "1" if logging else "0",
           str(FMUS.index(fmu))]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=TIME_LIMIT)
    except subprocess.TimeoutExpired:
        return {"crash": f"no answer within {TIME_LIMIT} s (a hang)"}
    if done.returncode != 0:
        return {"crash": f"exit status {done.returncode}", "stderr": done.stderr[-3000:]}
    try:
        return json.loads(done.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return {"crash": "no report", "stdout": done.stdout[-3000:], "stderr": done.stderr[-3000:]}


@pytest.fixture(scope="module")
def reports(fmu_path):
    """All cases, two children at a time (fmu_path builds the FMUs when pytest runs alone)."""
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = {case: pool.submit(run_case, *case) for case in CASES}
        return {case: f.result() for case, f in futures.items()}


@pytest.mark.parametrize("fmu,group,logging", CASES,
                         ids=[f"{f}-{g}-logging{'On' if l else 'Off'}" for f, g, l in CASES])
def test_fmu_fails_loudly_and_safely(reports, fmu, group, logging):
    report = reports[(fmu, group, logging)]
    assert "crash" not in report, report
    assert report["problems"] == [], "\n".join(report["problems"][:20])
    counts = report["counts"]
    print(fmu, group, "loggingOn" if logging else "loggingOff", counts)
    # the case exercised what it claims (a case that checks nothing cannot pass)
    if group == "parameters":
        assert counts["refused at fmi2SetReal"] > 0 and counts.get("accepted", 0) > 0
    elif group == "designs":
        assert counts.get("designs stepped for 2 s", 0) >= 5
        if fmu != "Drive":                      # a mechanism: its energy balance on every run
            assert counts["energy balances"] == counts["designs stepped for 2 s"]
    elif group == "calls":
        assert counts["refusals"] >= 15
    elif group == "cycles":
        assert counts["cycles"] == 200 and counts["rss growth MB"] < 100
    elif group == "instances":
        assert counts["state checks"] == 4 and counts["refusals"] == 1
