"""fmpy's logging proxy in a long-lived process (a test worker, the harness): fmpy 0.3.32 routes
every FMI 2.0 FMU's messages through one process-wide pointer, which ``simulate_fmu(logger=...)``
leaves pointing at a callback freed when it returns. An FMU that logs afterwards through fmpy's
default callbacks then calls freed memory: a pytest worker died in FourBar.fmu's fmi2DoStep when
a diverging coupling made it refuse a step, after another test had run simulate_fmu with a
logger. ``validation.fmu_runner.simulate_logged`` sets the pointer back to a logger of the
process's life; every in-process run with a logger goes through it."""

from __future__ import annotations

import subprocess
import sys

from crankfmu.cli import main

SCRIPT = """
import sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from crankfmu.validation.fmu_runner import simulate_logged

path = sys.argv[1]
seen = []
simulate_logged(path, stop_time=0.01, logger=lambda *a: seen.append(a[-1]), debug_logging=False)
md = read_model_description(path)
fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier)
fmu.instantiate()                        # fmpy's default callbacks: its logging proxy
fmu.setupExperiment(startTime=0.0)
fmu.enterInitializationMode()
fmu.exitInitializationMode()
try:
    fmu.doStep(currentCommunicationPoint=5.0, communicationStepSize=0.01)     # refused, and logged
except Exception:
    print("refused", flush=True)
"""


def test_an_fmu_logs_through_fmpys_default_callbacks_after_a_run_with_a_logger(tmp_path):
    """In a fresh process (a crash must not take the test runner down): a run with a logger, then
    an FMU on fmpy's default callbacks refuses a step. Its message is printed and the process ends
    normally; with fmpy's simulate_fmu in place of simulate_logged it dies with SIGSEGV."""
    assert main(["fmu", "seed000", "--native", "--out", str(tmp_path)]) == 0
    done = subprocess.run([sys.executable, "-c", SCRIPT, str(tmp_path / "FourBar.fmu")], capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, (done.returncode, done.stdout[-2000:], done.stderr[-2000:])
    assert "fmi2DoStep at t = 5.0 s, but this instance is at t = 0.0 s" in done.stdout
    assert done.stdout.rstrip().endswith("refused")
