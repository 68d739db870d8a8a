"""Wall time per fmi2DoStep: FourBar.fmu against an FMU whose step does nothing, in one run.

    python benchmarks/fmu_step.py [--step 1e-3] [--stop 2.0] [--repeats 5]

Both FMUs are driven by fmpy in this process, the same way: instantiate, initialise, then
fmi2DoStep at a fixed communication step reading omega1 after each step, as a master would.
Prints the median microseconds per step of each, their ratio, and FourBar's max |omega1 error|
against the in-process reference over the run (speed is reported against error, never alone).
Also times the whole fmpy.simulate_fmu call of each. Timing is the median of --repeats runs;
the machine is shared, so compare the ratio, not the absolute figures.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def build_noop(dest: Path) -> Path:
    """Build NoOp.fmu in a fresh interpreter: once an FMU is loaded in this process, pythonfmu has
    put that FMU's resources (with a pythonfmu copy lacking the binaries) first on sys.path."""
    script = ROOT / "benchmarks" / "fmus" / "NoOp.py"
    code = ("import sys; sys.path.insert(0, sys.argv[1]); from pythonfmu import FmuBuilder; "
            "print(FmuBuilder.build_FMU(sys.argv[2], dest=sys.argv[3]))")
    done = subprocess.run([sys.executable, "-c", code, str(script.parent), str(script), str(dest)],
                          check=True, capture_output=True, text=True)
    return Path(done.stdout.strip().splitlines()[-1])


def initialised(fmu_path: Path, where: str | None = None):
    """(FMU2Slave instantiated and initialised at t = 0, value references by name), extracted to
    ``where`` (default: a new temporary directory)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_path))
    unzipped = extract(str(fmu_path), unzipdir=where)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="bench")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


def step_loop(fmu_path: Path, step: float, stop: float, speeds=None):
    """(seconds per step, the output after each step) of one run through FMU2Slave: omega1 of a
    torque-causal FMU; tau_drive of a speed-causal one, whose input omega1 is set to ``speeds[k]``
    before step k, as a drive's master would."""
    fmu, refs = initialised(fmu_path)
    vr = refs["omega1" if speeds is None else "tau_drive"]
    omega_in = refs["omega1"]
    n = int(round(stop / step))
    out = np.empty(n)
    t = 0.0
    started = time.perf_counter()
    for k in range(n):
        if speeds is not None:
            fmu.setReal([omega_in], [float(speeds[k])])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=step)
        t = (k + 1) * step
        out[k] = fmu.getReal([vr])[0]
    elapsed = time.perf_counter() - started
    fmu.terminate()
    fmu.freeInstance()
    return elapsed / n, out


def measure_speed_causal(fmus: dict, step: float, stop: float, repeats: int) -> dict:
    """Per-step wall times of speed-causal FMUs ({label: path}, interleaved runs, omega1 set to
    15 + 3 sin(4 t) rad/s before each step) and each one's tau_drive over the run ("tau_drive": by
    label)."""
    per_step = {label: [] for label in fmus}
    tau = {}
    speeds = 15.0 + 3.0 * np.sin(4.0 * step * np.arange(int(round(stop / step))))
    for _ in range(repeats):
        for label, path in fmus.items():
            seconds, tau[label] = step_loop(path, step, stop, speeds)
            per_step[label].append(seconds)
    return {"per_step": per_step, "tau_drive": tau}


def measure(fourbar: Path, step: float, stop: float, repeats: int, extra: dict | None = None) -> dict:
    """Per-step and whole-run wall times of FourBar.fmu, the do-nothing FMU and the ``extra`` FMUs
    ({label: path}, seed 000's too: the native FMU) (lists of seconds, interleaved runs), and the
    max |omega1 error| of each seed-000 FMU against the in-process reference ("error": FourBar's,
    "errors": by label)."""
    import fmpy

    import crankfmu

    with tempfile.TemporaryDirectory() as tmp:
        noop = build_noop(Path(tmp))
        fmus = {"FourBar.fmu": fourbar, "do-nothing FMU": noop, **(extra or {})}
        per_step = {label: [] for label in fmus}
        whole = {label: [] for label in fmus}
        omega = {}
        for _ in range(repeats):       # interleaved, so all see the same machine load
            for label, path in fmus.items():
                seconds, w = step_loop(path, step, stop)
                per_step[label].append(seconds)
                if path != noop:
                    omega[label] = w
                started = time.perf_counter()
                fmpy.simulate_fmu(str(path), stop_time=stop, output_interval=step, output=["omega1"])
                whole[label].append(time.perf_counter() - started)
    times = step * np.arange(1, omega["FourBar.fmu"].size + 1)
    reference = crankfmu.simulate("seed000", t_end=stop, output_times=times, rtol=1e-13).omega1
    errors = {label: float(np.max(np.abs(w - reference))) for label, w in omega.items()}
    return {"per_step": per_step, "whole": whole, "error": errors["FourBar.fmu"], "errors": errors}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fmu", default=str(ROOT / "build" / "fmus" / "FourBar.fmu"))
    parser.add_argument("--step", type=float, default=1e-3, help="communication step, s")
    parser.add_argument("--stop", type=float, default=2.0, help="end time, s")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    if not (args.step > 0 and args.stop > args.step and args.repeats >= 1):
        parser.error("need step > 0, stop > step and repeats >= 1")
    fourbar = Path(args.fmu)
    if not fourbar.exists():
        parser.error(f"{fourbar} not found: run `make fmu` first")

    m = measure(fourbar, args.step, args.stop, args.repeats)
    per_step, whole, error = m["per_step"], m["whole"], m["error"]
    fb, nop = statistics.median(per_step["FourBar.fmu"]), statistics.median(per_step["do-nothing FMU"])
    print(f"fmi2DoStep at {args.step:g} s steps over {args.stop:g} s, median of {args.repeats} runs:")
    print(f"  {'FMU':16} {'us/step':>10} {'simulate_fmu s':>15}")
    for label in per_step:
        print(f"  {label:16} {1e6 * statistics.median(per_step[label]):10.1f} "
              f"{statistics.median(whole[label]):15.3f}")
    print(f"  ratio FourBar / do-nothing: {fb / nop:.1f}")
    print(f"  FourBar max |omega1 error| against the reference: {error:.2e} rad/s "
          f"(rtol = FMU default)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
