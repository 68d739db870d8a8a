"""The cost of reading every output at every step, as the ecos master does: FourBar.fmu (Python)
and the native FourBar.fmu, measured in one run.

    python benchmarks/all_outputs.py [--stop 10] [--step 1e-3]

- through fmpy in this process: microseconds per 1 ms step with every Real variable read after
  each step (the median of --repeats runs);
- in the ecos command (ecospy's C++ master, which writes every variable of every step to its
  CSV): the wall time of a --stop s run at --step, and its real-time factor (simulated time over
  wall time, process start included).

The Python FMU reads its [[outputs]] and joint reactions from the design's tables through the C
kernel (fmi.python.slave.lazy_outputs), as the native FMU does; before, each step's first read of a
reaction cost a Newton-Euler solve in Python.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def fmpy_per_step(fmu_path: Path, step: float, stop: float, repeats: int) -> float:
    """Median seconds per step through fmpy, every Real variable read after each step."""
    from fmpy import read_model_description

    from fmu_step import initialised

    reals = [v.valueReference for v in read_model_description(str(fmu_path)).modelVariables if v.type == "Real"]
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(repeats):
            fmu, _ = initialised(fmu_path, str(Path(tmp) / str(k)))
            n = int(round(stop / step))
            t = 0.0
            started = time.perf_counter()
            for _ in range(n):
                fmu.doStep(t, step)
                t += step
                fmu.getReal(reals)
            times.append((time.perf_counter() - started) / n)
            fmu.terminate()
            fmu.freeInstance()
    return statistics.median(times)


def ecos_wall(fmu_path: Path, step: float, stop: float) -> float:
    """Wall seconds of the ecos command simulating ``fmu_path`` for ``stop`` s at ``step`` (every
    variable of every step written to its CSV)."""
    sys.path.insert(0, str(ROOT))
    from validation.masters import ecos_command

    with tempfile.TemporaryDirectory() as tmp:
        started = time.perf_counter()
        done = subprocess.run([str(ecos_command()), "simulate", "--path", str(fmu_path), "--stopTime", repr(stop),
                               "--stepSize", repr(step)], capture_output=True, text=True, cwd=tmp, timeout=1200)
        wall = time.perf_counter() - started
        if done.returncode != 0 or not list(Path(tmp).rglob("*.csv")):
            raise RuntimeError(f"ecos failed on {fmu_path}: {done.stdout[-500:]} {done.stderr[-500:]}")
    return wall


def measure(fmus: dict[str, Path], step: float = 1e-3, stop: float = 10.0, repeats: int = 3) -> dict:
    """{label: {fmpy_us_per_step, ecos_wall_s, ecos_real_time_factor}} for each FMU."""
    out = {}
    for label, path in fmus.items():
        per_step = fmpy_per_step(path, step, min(stop, 2.0), repeats)
        wall = ecos_wall(path, step, stop)
        out[label] = {"fmpy_us_per_step": 1e6 * per_step, "ecos_wall_s": wall, "ecos_real_time_factor": stop / wall}
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--stop", type=float, default=10.0)
    parser.add_argument("--step", type=float, default=1e-3)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    fmus = {"FourBar.fmu (Python)": ROOT / "build" / "fmus" / "FourBar.fmu",
            "FourBar.fmu (native)": ROOT / "build" / "fmus" / "native" / "FourBar.fmu"}
    for label, m in measure(fmus, args.step, args.stop, args.repeats).items():
        print(f"{label}: {m['fmpy_us_per_step']:.1f} us per step through fmpy (every variable read); ecos "
              f"{args.stop:g} s at {args.step:g} s in {m['ecos_wall_s']:.2f} s, real-time factor "
              f"{m['ecos_real_time_factor']:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
