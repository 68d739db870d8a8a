"""The native FMU's cost per 1 ms step in a plain C host (tests/c_host/fmu_driver.c), measured in
this run: the step loop's wall time as the driver reports it, the fastest of ``repeats``
processes (the machine is shared: compare the ratio against the C RK4 limit measured in the same
run, not the seconds)."""

from __future__ import annotations

import re
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def c_driver_per_step(fmu: Path, step: float, stop: float, repeats: int) -> dict:
    """{"us_per_step", "omega1"}: the fastest step loop of ``repeats`` driver processes running the
    FMU's linux64 binary from 0 to ``stop`` at ``step``, and omega1 at the end."""
    import fmpy
    from fmpy import extract, read_model_description

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    headers = Path(fmpy.__file__).parent / "c-code"
    with tempfile.TemporaryDirectory() as tmp:
        driver = Path(tmp) / "fmu_driver"
        subprocess.run(["gcc", "-O2", f"-I{headers}", "-o", str(driver), str(ROOT / "tests" / "c_host" / "fmu_driver.c"),
                        "-ldl"], check=True, capture_output=True)
        where = extract(str(fmu), str(Path(tmp) / "fmu"))
        steps = int(round(stop / step))
        best, omega = float("inf"), None
        for _ in range(repeats):
            done = subprocess.run(["env", "-i", "FMU_DRIVER_LOGGING=0", str(driver), where,
                                   md.coSimulation.modelIdentifier, md.guid, str(steps), repr(step), str(vr["omega1"])],
                                  capture_output=True, text=True, check=True)
            best = min(best, float(re.search(r"steps_seconds=(\S+)", done.stdout).group(1)))
            omega = float(re.search(r"result t=\S+ value=(\S+)", done.stdout).group(1))
    return {"us_per_step": 1e6 * best / steps, "omega1": omega}
