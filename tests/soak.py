"""Many short host processes per FMU, counting abnormal exits (``make soak``; a short version runs
in ``make test`` through tests/test_fmu_soak.py).

    python tests/soak.py [--per-fmu 300] [--fmus build/fmus ...] [--jobs 2]

Each process loads one FMU, instantiates it, initialises it, takes three 10 ms steps and exits.
The hosts alternate: fmpy (a Python host) and the C driver of tests/c_host (dlopen(RTLD_LOCAL),
no Python in the process, an empty environment), each for the FMU's FMI version (2.0 or 3.0). The cases cycle through: logging on, logging off,
a refused parameter (-1 for one whose minimum is 0: the host sees fmi2Error) and a host that exits without
freeing the instance. An exit is abnormal when the process dies by a signal, hangs, exits with a
status the case does not expect, or prints a C library heap error (``corrupted``, ``double free``).
pythonfmu's library destructor used to abort about one fmpy process in two hundred at exit.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HEAP_ERRORS = ("corrupted", "double free", "free(): invalid", "malloc(): ", "Segmentation fault", "Aborted")
CASES = ("logging", "quiet", "refused", "no-free")
TIME_LIMIT = 120

FMPY_HOST_TEMPLATE = r"""
import sys
from fmpy import read_model_description, simulate_fmu
from fmpy.{module} import {slave}
from fmpy.fmi1 import FMICallException
where, case, refusable = sys.argv[1], sys.argv[2], sys.argv[3]
for other in sys.argv[4:]:       # another vendor's FMU first, in the same process
    simulate_fmu(other, stop_time=0.03, output_interval=0.01)
md = read_model_description(where)
vr = {{v.name: v.valueReference for v in md.modelVariables}}
fmu = {slave}(guid=md.guid, unzipDirectory=where, modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName="soak")
fmu.instantiate(loggingOn=(case == "logging"))
{setup}fmu.enterInitializationMode()
try:
    if case == "refused":
        fmu.{set_real}([vr[refusable]], [-1.0])
    fmu.exitInitializationMode()
    t = 0.0
    for _ in range(3):
        fmu.doStep(t, 0.01)
        t += 0.01
    print("output", fmu.{get_real}([next(v.valueReference for v in md.modelVariables if v.causality == "output")])[0])
except FMICallException as exc:
    print("refused:", exc)
    if case != "refused":
        sys.exit(1)
if case == "no-free":
    sys.exit(0)      # the instance is alive at exit
fmu.terminate()
fmu.freeInstance()
"""
#: the host for each FMI version: FMU2Slave (setupExperiment, Real) or FMU3Slave (Float64)
FMPY_HOSTS = {"2": FMPY_HOST_TEMPLATE.format(module="fmi2", slave="FMU2Slave", setup="fmu.setupExperiment(startTime=0.0)\n",
                                             set_real="setReal", get_real="getReal"),
              "3": FMPY_HOST_TEMPLATE.format(module="fmi3", slave="FMU3Slave", setup="", set_real="setFloat64",
                                             get_real="getFloat64")}

def build_driver(where: Path) -> dict[str, Path]:
    """The C hosts by FMI version: tests/c_host/fmu_driver.c (2) and fmu3_driver.c (3)."""
    import fmpy

    headers = Path(fmpy.__file__).parent / "c-code"
    drivers = {}
    for version, source in (("2", "fmu_driver.c"), ("3", "fmu3_driver.c")):
        drivers[version] = where / source.removesuffix(".c")
        subprocess.run(["gcc", "-std=c99" if version == "3" else "-std=gnu99", "-O1", "-Wall", "-Werror",
                        f"-I{headers}", "-o", str(drivers[version]), str(ROOT / "tests" / "c_host" / source), "-ldl"],
                       check=True)
    return drivers


def command(host: str, case: str, unzipped: str, md, drivers: dict, stock: Path | None = None
            ) -> tuple[list[str], set[int]]:
    """The command of one process and the exit statuses that are normal for it (host "fmpy+stock":
    fmpy that runs the stock pythonfmu FMU ``stock`` first)."""
    # a parameter whose declared minimum makes -1 a refusal (J_flywheel in the mechanisms)
    refusable = next(v.name for v in md.modelVariables
                     if v.causality == "parameter" and v.min is not None and float(v.min) >= 0)
    version = md.fmiVersion[0]
    if host.startswith("fmpy"):
        others = [str(stock)] if host == "fmpy+stock" else []
        # a fresh process with a fresh environment, as the C driver's (env -i): a host does not
        # inherit what the test worker's earlier tests left in its environment. Stock pythonfmu
        # 0.7 frees its interpreter state twice at exit (tests/test_fmu_mixed_hosts.py); whether
        # that aborts a process depends on its heap's shape, which an inherited environment
        # changed: 8 to 11 of 100 fmpy+stock processes aborted in full-suite runs, 0 of 1,200
        # outside them, with our FMU's part of the run finished ("output ..." printed)
        env = ["env", "-i", f"PATH={os.environ.get('PATH', '/usr/bin:/bin')}", f"HOME={tempfile.gettempdir()}",
               "LANG=C.UTF-8"]
        return env + [sys.executable, "-c", FMPY_HOSTS[version], unzipped, case, refusable, *others], {0}
    driver = drivers[version]
    vr = {v.name: v.valueReference for v in md.modelVariables}
    env = ["env", "-i", f"FMU_DRIVER_LOGGING={'0' if case == 'quiet' else '1'}",
           f"FMU_DRIVER_NO_FREE={'1' if case == 'no-free' else '0'}"]
    first_output = next(v.valueReference for v in md.modelVariables if v.causality == "output")
    args = [str(driver), unzipped, md.coSimulation.modelIdentifier, md.guid, "3", "0.01", str(first_output)]
    if case == "refused":
        return env + args + [f"{vr[refusable]}=-1"], {1}
    return env + args, {0}


def run_one(cmd: list[str], normal: set[int]) -> str | None:
    """None for a normal exit, else what was abnormal."""
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=TIME_LIMIT)
    except subprocess.TimeoutExpired:
        return f"no exit within {TIME_LIMIT} s"
    text = done.stdout + done.stderr
    heap = [e for e in HEAP_ERRORS if e in text]
    if done.returncode < 0:
        return f"killed by signal {-done.returncode} {heap}: {text[-500:]}"
    if heap:
        return f"heap error {heap}: {text[-500:]}"
    if done.returncode not in normal:
        return f"exit status {done.returncode} (expected {sorted(normal)}): {text[-500:]}"
    return None


def soak(fmus: list[Path], per_fmu: int, jobs: int = 2, progress=None, stock: Path | None = None) -> dict:
    """{(fmu, host): {"processes": n, "abnormal": [reasons], "cases": {case names}}}. With ``stock``
    (a stock pythonfmu FMU) every third process is an fmpy host that runs it first."""
    hosts = ("fmpy", "c-driver", "fmpy+stock") if stock else ("fmpy", "c-driver")
    from fmpy import extract, read_model_description

    results: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        drivers = build_driver(Path(tmp))
        plan = []
        for k, fmu in enumerate(fmus):
            md = read_model_description(str(fmu))
            unzipped = extract(str(fmu), unzipdir=str(Path(tmp) / fmu.stem))
            for i in range(per_fmu):
                host = hosts[i % len(hosts)]
                case = CASES[(i // len(hosts) + k) % len(CASES)]   # offset per FMU: a short soak sees every case
                label = fmu.stem + (" (FMI 3.0)" if md.fmiVersion.startswith("3") else "")
                plan.append(((label, host), case, *command(host, case, unzipped, md, drivers, stock)))
        done = 0
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            futures = [(key, case, pool.submit(run_one, cmd, normal)) for key, case, cmd, normal in plan]
            for key, case, future in futures:
                entry = results.setdefault(key, {"processes": 0, "abnormal": [], "cases": set()})
                entry["processes"] += 1
                entry["cases"].add(case)
                outcome = future.result()
                if outcome is not None:
                    entry["abnormal"].append(outcome)
                done += 1
                if progress is not None:
                    progress(done)
    return results


def main(argv=None) -> int:
    sys.path.insert(0, str(ROOT / "src"))
    from crankfmu.progress import ProgressBar

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--per-fmu", type=int, default=300, help="processes per FMU (half fmpy, half C driver)")
    parser.add_argument("--fmus", action="append", default=None,
                        help="a folder of FMUs, repeatable (default: build/fmus, the Python FMUs)")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    folders = args.fmus or [str(ROOT / "build" / "fmus")]
    fmus = sorted(p for folder in folders for p in Path(folder).glob("*.fmu"))
    if not fmus:
        print(f"no FMU in {', '.join(folders)}: run make fmu", file=sys.stderr)
        return 2
    if shutil.which("gcc") is None:
        print("gcc is needed to build the C driver", file=sys.stderr)
        return 2
    bar = ProgressBar(len(fmus) * args.per_fmu, "soak")
    results = soak(fmus, args.per_fmu, args.jobs, bar)
    bar.close()
    total = sum(r["processes"] for r in results.values())
    abnormal = sum(len(r["abnormal"]) for r in results.values())
    for (fmu, host), r in sorted(results.items()):
        print(f"{'PASS' if not r['abnormal'] else 'FAIL'} {fmu:12s} {host:9s} {r['processes']:5d} processes, "
              f"{len(r['abnormal'])} abnormal exits")
        for reason in r["abnormal"][:3]:
            print(f"    {reason}")
    print(f"soak: {total} processes, {abnormal} abnormal exits")
    return 1 if abnormal else 0


if __name__ == "__main__":
    sys.exit(main())
