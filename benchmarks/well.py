"""The pumping well's speed (issue 39), measured in one run:

    python benchmarks/well.py [--quick]

- RodString.fmu per 1 ms communication step, the native build against the Python one (the same C
  string steps: what the native one saves is the Python around them), through fmpy in this
  process (the polished rod stroking: s and v set before every step, F read after it) and in the
  plain C host (tests/c_host/fmu_driver.c, the string hanging);
- `crankfmu well rp11l_guo` end to end (five balancing runs, the steady run, the figures and the
  animation) against the code this issue started from (BASELINE, run from `git archive` of it
  with the same Python and packages: the coupled loop and the string's steps in Python) and
  against today's code with its Python reference loop pinned to one core (--reference-loop under
  taskset: one core, so the figures are drawn one after the other), with the RP 11L figures of
  each beside the others'.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: the commit issue 39 measured `crankfmu well rp11l_guo` on (10.2 s then)
BASELINE = "5ccf93f"
WELL = "rp11l_guo"
FIGURES = ("PPRL", "MPRL", "peak_torque")


def fmpy_per_step(fmu_path: Path, step: float, stop: float, repeats: int) -> float:
    """Median seconds per communication step through fmpy: s and v set (a 2 m stroke at 9.5
    strokes/min), a step, F read."""
    from fmu_step import initialised

    omega = 2 * math.pi * 9.5 / 60
    n = int(round(stop / step))
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(repeats):
            fmu, vr = initialised(fmu_path, str(Path(tmp) / str(k)))
            inputs, out = [vr["s"], vr["v"]], [vr["F"]]
            t = 0.0
            started = time.perf_counter()
            for i in range(n):
                fmu.setReal(inputs, [1.0 - math.cos(omega * t), omega * math.sin(omega * t)])
                fmu.doStep(t, step)
                t = (i + 1) * step
                fmu.getReal(out)
            times.append((time.perf_counter() - started) / n)
            fmu.terminate()
            fmu.freeInstance()
    return statistics.median(times)


def c_driver_per_step(fmu_path: Path, step: float, stop: float, repeats: int) -> float:
    """Fastest seconds per step of ``repeats`` runs of the C host's step loop (its own report)."""
    import fmpy
    from fmpy import extract, read_model_description

    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    steps = int(round(stop / step))
    with tempfile.TemporaryDirectory() as tmp:
        driver = Path(tmp) / "fmu_driver"
        subprocess.run(["gcc", "-O2", f"-I{Path(fmpy.__file__).parent / 'c-code'}", "-o", str(driver),
                        str(ROOT / "tests" / "c_host" / "fmu_driver.c"), "-ldl"], check=True, capture_output=True)
        where = extract(str(fmu_path), str(Path(tmp) / "fmu"))
        best = math.inf
        for _ in range(repeats):
            done = subprocess.run([str(driver), where, md.coSimulation.modelIdentifier, md.guid, str(steps), repr(step),
                                   str(vr["F"])], capture_output=True, text=True, check=True,
                                  env={**os.environ, "FMU_DRIVER_LOGGING": "0"})
            best = min(best, float(re.search(r"steps_seconds=(\S+)", done.stdout).group(1)))
    return best / steps


def _timed_run(command, cwd: Path, env: dict) -> tuple[float, dict]:
    started = time.perf_counter()
    subprocess.run(command, cwd=cwd, env=env, check=True, capture_output=True)
    seconds = time.perf_counter() - started
    summary = json.loads((cwd / "out" / "summary.json").read_text(encoding="utf-8"))
    return seconds, {k: summary[k] for k in FIGURES}


def well_end_to_end(repeats: int, baseline: bool = True) -> dict:
    """{label: {"s": median seconds, "figures": {...}}} for `crankfmu well rp11l_guo` now, with the
    reference loop on one core, and at BASELINE (``baseline``, when git can give its sources); each
    after a first run that warms the caches (the kernel compiled, files read), unless one repeat."""
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    runs = {"now": ([sys.executable, "-m", "crankfmu", "well", WELL, "--out", "out"], env)}
    if shutil.which("taskset"):
        runs["reference loop, one core"] = (["taskset", "-c", "0", sys.executable, "-m", "crankfmu", "well", WELL,
                                             "--out", "out", "--reference-loop"], env)
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "baseline"
        base.mkdir()
        archive = (subprocess.run(["git", "-C", str(ROOT), "archive", BASELINE, "src"], capture_output=True)
                   if baseline else None)
        if archive is not None and archive.returncode == 0:
            subprocess.run(["tar", "-x", "-C", str(base)], input=archive.stdout, check=True)
            runs[f"baseline {BASELINE}"] = ([sys.executable, "-m", "crankfmu", "well", WELL, "--out", "out"],
                                           {**env, "PYTHONPATH": str(base / "src")})
        for label, (command, run_env) in runs.items():
            cwd = Path(tmp) / re.sub(r"\W+", "_", label)
            cwd.mkdir()
            if repeats > 1:
                _timed_run(command, cwd, run_env)
            times, figures = [], None
            for _ in range(repeats):
                seconds, figures = _timed_run(command, cwd, run_env)
                times.append(seconds)
            results[label] = {"s": statistics.median(times), "figures": figures}
    return results


def measure(native: Path, python: Path, quick: bool = False) -> dict:
    stop = 2.0 if quick else 10.0
    repeats = 2 if quick else 3
    string = {}
    for label, path in (("native", native), ("python", python)):
        if path.is_file():
            string[label] = {"fmpy_us_per_step": 1e6 * fmpy_per_step(path, 1e-3, stop, repeats),
                             "c_driver_us_per_step": 1e6 * c_driver_per_step(path, 1e-3, stop, repeats)}
    # --quick (the test of this script): one run of each, and not the baseline's 14 s
    return {"rodstring": string, "well": well_end_to_end(1 if quick else 3, baseline=not quick)}


def targets(result: dict) -> list[tuple[str, str, bool | None]]:
    """(target, measured, met) for speed.md."""
    rows = []
    string = result["rodstring"]
    if "native" in string and "python" in string:
        n, p = string["native"], string["python"]
        rows.append(("native RodString.fmu per 1 ms step against the Python one (issue 39: reported)",
                     f"through fmpy {n['fmpy_us_per_step']:.1f} vs {p['fmpy_us_per_step']:.1f} us "
                     f"({p['fmpy_us_per_step'] / n['fmpy_us_per_step']:.1f}x); in the C host "
                     f"{n['c_driver_us_per_step']:.1f} vs {p['c_driver_us_per_step']:.1f} us "
                     f"({p['c_driver_us_per_step'] / n['c_driver_us_per_step']:.1f}x)", None))
    well = result["well"]
    now = well["now"]
    for label, other in well.items():
        if label == "now":
            continue
        worst = max(abs(now["figures"][k] - other["figures"][k]) / abs(other["figures"][k]) for k in FIGURES)
        ratio = other["s"] / now["s"]
        baseline = label.startswith("baseline")
        rows.append((f"`crankfmu well {WELL}` end to end, against {label}" + (" (issue 39: at least 5x)" if baseline
                                                                                 else " (reported)"),
                     f"{now['s']:.2f} s vs {other['s']:.2f} s: {ratio:.1f}x; PPRL, MPRL and peak torque agree to "
                     f"{worst:.1e}", (ratio >= 5.0 and worst <= 1e-6) if baseline else None))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--native", default=str(ROOT / "build" / "fmus" / "native" / "RodString.fmu"))
    parser.add_argument("--python", default=str(ROOT / "build" / "fmus" / "RodString.fmu"))
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT / "benchmarks"))
    result = measure(Path(args.native), Path(args.python), args.quick)
    for target, measured, met in targets(result):
        print(f"{target}: {measured}" + ("" if met is None else f" ({'MET' if met else 'NOT MET'})"))
    print(json.dumps(result, indent=2, default=lambda x: float(x) if isinstance(x, np.floating) else str(x)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
