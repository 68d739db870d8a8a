"""Third-party co-simulation masters driving our FMUs and SSPs, each in a child process.

The masters, all installed from PyPI (with Debian's libtbb12 for ecos) by the Makefile:

- ``fmpy``: FMPy's ``simulate_fmu`` (Python, ctypes);
- ``ecos``: the ``ecos`` command of the ecospy wheel, a C++ process with no Python of its own
  (it loads our FMU's shim, which starts an interpreter itself);
- ``ecospy``: ecospy's in-process API (the same C++ engine, loaded by Python);
- ``libcosim``: libcosimpy, the Open Simulation Platform's libcosim (C++, FMI Library);
- ``ecco``: libcosim's ECCO algorithm (libcosimpy >= 0.0.6): variable communication steps chosen
  from the energy the coupling's power bonds (a torque and a speed each) fail to conserve
  (Sadjina and Pedersen 2020); ``ecco(...)`` runs FMUs coupled by connections and power bonds.

``run(master, path, ...)`` runs one master on an FMU or an SSP in a child process (a crash or a hang
of the master is a failed case, not a crash of the caller) and returns a ``MasterRun``: the
sampled time and the requested variables, the master's exit status and what it printed.
"""

from __future__ import annotations

import csv
import json
import os
import stat
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MASTERS = ("fmpy", "ecos", "ecospy", "libcosim")
TIME_LIMIT = 600


@dataclass
class MasterRun:
    master: str
    path: str
    time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    values: dict = field(default_factory=dict)       # "instance.variable" or "variable" -> array
    returncode: int = 0
    output: str = ""                                  # what the master printed (stdout + stderr)
    error: str | None = None                          # set when the run did not complete

    def __getitem__(self, name):
        return self.values[name]


def largest_difference(a: MasterRun, b: MasterRun, variable: str, step: float) -> float:
    """max |a - b| of ``variable`` at the communication points both runs report (libcosim from the
    first step on, ecos from t = 0)."""
    _, ia, ib = np.intersect1d(np.round(a.time / step), np.round(b.time / step), return_indices=True)
    return float(np.max(np.abs(a[variable][ia] - b[variable][ib])))


def version(master: str) -> str:
    from importlib.metadata import PackageNotFoundError, version as package_version

    package = {"fmpy": "fmpy", "ecos": "ecospy", "ecospy": "ecospy", "libcosim": "libcosimpy", "ecco": "libcosimpy",
               "cofmpy": "cofmupy"}[master]
    try:
        return f"{package} {package_version(package)}"
    except PackageNotFoundError:
        return f"{package} (not installed)"


def ecos_command() -> Path:
    """The ``ecos`` executable inside the ecospy wheel (the wheel ships it without its exec bit)."""
    import ecospy

    exe = Path(ecospy.__file__).parent / "binaries" / "ecos"
    if not os.access(exe, os.X_OK):
        try:
            exe.chmod(exe.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
        except OSError as exc:
            raise RuntimeError(f"{exe} is not executable and cannot be made so ({exc}): chmod +x it") from None
    return exe


def run(master: str, path, stop_time: float, step: float, variables: list[str],
        start_values: dict | None = None, parameter_set: str | None = None, instance: str = "fmu",
        env: dict | None = None) -> MasterRun:
    """Run ``master`` on the FMU or SSP at ``path`` from 0 to ``stop_time`` at communication step
    ``step``, recording ``variables`` (for an SSP: "instance.variable"). ``env``: the master
    process's whole environment (default: this process's), e.g. a bare one with an empty HOME."""
    path = str(Path(path).resolve())
    if master == "ecos":
        return _run_ecos_cli(path, stop_time, step, variables, parameter_set, env)
    job = {"master": master, "path": path, "stop_time": stop_time, "step": step, "variables": variables,
           "start_values": start_values or {}, "parameter_set": parameter_set, "instance": instance}
    return _in_child(job, path, env)


def _in_child(job: dict, path: str = "", env: dict | None = None) -> MasterRun:
    """The master ``job`` says, run by this module in a child process (a master that aborts takes
    only the child down), its RESULT line read back."""
    master = job["master"]
    cmd = [sys.executable, "-m", "crankfmu.validation.masters", json.dumps(job)]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=TIME_LIMIT, env=env)
    except subprocess.TimeoutExpired:
        return MasterRun(master, path, error=f"no answer within {TIME_LIMIT} s", returncode=-1)
    out = done.stdout + done.stderr
    lines = [line for line in done.stdout.splitlines() if line.startswith("RESULT ")]
    if done.returncode != 0 or not lines:
        return MasterRun(master, path, returncode=done.returncode, output=out,
                         error=f"exit status {done.returncode}" + ("" if lines else ", no result"))
    data = json.loads(lines[-1][7:])
    return MasterRun(master, path, np.asarray(data["time"]), {k: np.asarray(v) for k, v in data["values"].items()},
                     done.returncode, out, data.get("error"))


def ecco(fmus: dict, connections, bonds, parameters: dict, stop_time: float, record: list[str],
         step: float = 1e-3, min_step: float = 1e-4, max_step: float = 1e-2, tolerance: float = 1e-4) -> MasterRun:
    """libcosim's ECCO on the FMUs ``fmus`` ({instance: path}) coupled by ``connections`` ((from,
    output, to, input), ...), with a power bond on each of ``bonds`` ((instance, output, input,
    instance, output, input): the two sides' effort and flow), each instance's ``parameters`` set
    first; from ``step``, between ``min_step`` and ``max_step`` (s), to the absolute and relative
    ``tolerance`` of the bonds' energy residual. Records ``record`` ("instance.variable") at every
    communication point it chose, in a child process."""
    job = {"master": "ecco", "fmus": {k: str(Path(v).resolve()) for k, v in fmus.items()},
           "connections": [list(c) for c in connections], "bonds": [list(b) for b in bonds],
           "parameters": parameters, "stop_time": stop_time, "step": step, "min_step": min_step,
           "max_step": max_step, "tolerance": tolerance, "variables": list(record)}
    return _in_child(job)


def cofmpy(fmus: dict, connections, parameters: dict, stop_time: float, step: float, record: list[str],
           iterative: bool, bound: float = np.inf) -> MasterRun:
    """CoFMPy (PyPI cofmupy, pure Python on fmpy) on the FMUs ``fmus`` ({instance: path}) with plain
    ``connections`` ((from, output, to, input), ...), each instance's ``parameters`` set as its
    "initialization", Jacobi at the fixed ``step``: one pass per step, or ``iterative`` (each step
    repeated from the FMUs' saved states until the inputs used match the outputs at its end, its own
    tolerance and pass limit). Records ``record`` ("instance.variable") at every communication
    point; a run whose first recorded value passes ``bound`` in magnitude stops there (CoFMPy has
    no bound: a diverging coupling spins the FMUs ever faster). In a child process."""
    job = {"master": "cofmpy", "fmus": {k: str(Path(v).resolve()) for k, v in fmus.items()},
           "connections": [list(c) for c in connections], "parameters": parameters, "stop_time": stop_time,
           "step": step, "variables": list(record), "iterative": iterative,
           "bound": bound if np.isfinite(bound) else None}
    return _in_child(job)


def _run_ecos_cli(path, stop_time, step, variables, parameter_set, env=None) -> MasterRun:
    with tempfile.TemporaryDirectory() as tmp:
        # ecos passes an FMU's messages on at its debug level only
        cmd = [str(ecos_command()), "simulate", "--path", path, "--stopTime", repr(stop_time),
               "--stepSize", repr(step), "-l", "debug"]
        if parameter_set:
            cmd += ["--parameterSet", parameter_set]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=TIME_LIMIT, cwd=tmp, env=env)
        except subprocess.TimeoutExpired:
            return MasterRun("ecos", path, error=f"no answer within {TIME_LIMIT} s", returncode=-1)
        out = done.stdout + done.stderr
        files = sorted(Path(tmp).rglob("*.csv"))
        if done.returncode != 0 or not files:
            return MasterRun("ecos", path, returncode=done.returncode, output=out,
                             error=f"exit status {done.returncode}" + ("" if files else ", no CSV written"))
        columns: dict[str, list[float]] = {}
        for f in files:                       # one CSV per FMU instance: "<instance>.csv"
            with f.open() as handle:
                rows = list(csv.reader(handle, skipinitialspace=True))
            header = rows[0]
            for k, name in enumerate(header):
                key = name.split("[")[0].replace("::", ".")
                columns[key] = [float(r[k]) for r in rows[1:]]
        values = {}
        for v in variables:
            key = next((k for k in columns if k == v or k.endswith("." + v)), None)
            if key is not None:
                values[v] = np.asarray(columns[key])
        return MasterRun("ecos", path, np.asarray(columns["time"]), values, done.returncode, out)


# ------------------------------------------------------------------------------------ children
def _child(job: dict) -> dict:
    master = job["master"]
    n = int(round(job["stop_time"] / job["step"]))
    if master == "fmpy":
        return _child_fmpy(job)
    if master == "ecospy":
        return _child_ecospy(job, n)
    if master == "libcosim":
        return _child_libcosim(job, n)
    if master == "ecco":
        return _child_ecco(job)
    if master == "cofmpy":
        return _child_cofmpy(job)
    raise SystemExit(f"unknown master {master}")


def _child_fmpy(job):
    from fmpy import simulate_fmu

    messages = []

    def logger(component, instance, status, category, message):
        messages.append(message.decode(errors="replace"))

    try:
        r = simulate_fmu(job["path"], stop_time=job["stop_time"], output_interval=job["step"],
                         step_size=job["step"], start_values=job["start_values"], output=job["variables"],
                         logger=logger, debug_logging=False)
    except Exception as exc:                         # noqa: BLE001 - the refusal is the result
        print("\n".join(messages))
        return {"time": [], "values": {}, "error": f"{type(exc).__name__}: {exc}"}
    print("\n".join(messages))
    return {"time": r["time"].tolist(), "values": {v: r[v].tolist() for v in job["variables"]}}


def _child_ecospy(job, n):
    from ecospy import EcosSimulation, EcosSimulationStructure
    from ecospy.lib import EcosLib

    EcosLib.set_log_level("debug")       # ecos passes an FMU's messages on at its debug level only

    structure = EcosSimulationStructure()
    if job["path"].endswith(".ssp"):
        sim = EcosSimulation(ssp_path=job["path"], step_size=job["step"])
        names = job["variables"]
    else:
        structure.add_model(job["instance"], job["path"])
        if job["start_values"]:
            structure.add_parameter_set("given", {f"{job['instance']}::{k}": float(v)
                                                  for k, v in job["start_values"].items()})
        sim = EcosSimulation(structure=structure, step_size=job["step"])
        names = [f"{job['instance']}.{v}" for v in job["variables"]]
    try:
        sim.init(parameter_set=job["parameter_set"] or ("given" if job["start_values"] else None))
        times, rows = [0.0], [[sim.get_real(x.replace(".", "::", 1)) for x in names]]
        for _ in range(n):
            sim.step()
            times.append(sim.get_time())
            rows.append([sim.get_real(x.replace(".", "::", 1)) for x in names])
    except Exception as exc:                         # noqa: BLE001
        return {"time": [], "values": {}, "error": f"{type(exc).__name__}: {exc}"}
    finally:
        sim.terminate()
    columns = np.array(rows).T
    return {"time": times, "values": {v: c.tolist() for v, c in zip(job["variables"], columns)}}


def _child_libcosim(job, n):
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    step_ns = int(round(job["step"] * 1e9))
    if job["path"].endswith(".ssp"):
        execution = CosimExecution.from_ssp_file(job["path"], step_size=step_ns)
    else:
        execution = CosimExecution.from_step_size(step_ns)
        execution.add_local_slave(CosimLocalSlave(fmu_path=job["path"], instance_name=job["instance"]))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    names = job["variables"] if job["path"].endswith(".ssp") else [f"{job['instance']}.{v}" for v in job["variables"]]
    refs = []
    for name in names:
        instance, variable = name.split(".", 1)
        index = execution.slave_index_from_instance_name(instance)
        refs.append((index, _libcosim_reference(execution, index, variable)))
    for k, value in job["start_values"].items():
        index = execution.slave_index_from_instance_name(job["instance"])
        execution.real_initial_value(index, _libcosim_reference(execution, index, k), float(value))
    # libcosim initialises on the first step
    return _libcosim_record(execution, observer, refs, job["variables"], lambda times: len(times) < n, "libcosim")


def _libcosim_reference(execution, index: int, variable: str) -> int:
    """The value reference of ``variable`` in libcosim's slave ``index``."""
    return next(v.reference for v in execution.slave_variables(index) if v.name.decode() == variable)


def _libcosim_record(execution, observer, watched, names, more, master: str) -> dict:
    """Step libcosim's ``execution`` while ``more(times so far)``, recording the ``watched`` (slave
    index, value reference) as ``names`` at every communication point; a failed step ends the run
    with its error code."""
    times, rows = [], []
    while more(times):
        if not execution.step():
            return {"time": times, "values": {}, "error": f"{master}: the step after t = {times[-1] if times else 0:g} "
                                                          f"s failed (error code {execution.status().error_code})"}
        times.append(execution.status().current_time * 1e-9)
        rows.append([observer.last_real_values(i, [vr])[0] for i, vr in watched])
    columns = np.array(rows).T
    return {"time": times, "values": {v: c.tolist() for v, c in zip(names, columns)}}


def _child_ecco(job):
    from libcosimpy.CosimAlgorithm import CosimAlgorithm, EccoParams
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    algorithm = CosimAlgorithm.create_ecco_algorithm(EccoParams(
        step_size=job["step"], min_step_size=job["min_step"], max_step_size=job["max_step"],
        abs_tolerance=job["tolerance"], rel_tolerance=job["tolerance"]))
    execution = CosimExecution.from_algorithm(algorithm)
    index = {name: execution.add_local_slave(CosimLocalSlave(fmu_path=path, instance_name=name))
             for name, path in job["fmus"].items()}

    def ref(instance, variable):
        return _libcosim_reference(execution, index[instance], variable)

    for instance, values in job["parameters"].items():
        for name, value in values.items():
            execution.real_initial_value(index[instance], ref(instance, name), float(value))
    for a, output, b, input_ in job["connections"]:
        if execution.connect_real_variables(index[a], ref(a, output), index[b], ref(b, input_)) != 0:   # C status
            return {"time": [], "values": {}, "error": f"ecco: cannot connect {a}.{output} to {b}.{input_}"}
    for a, out_a, in_a, b, out_b, in_b in job["bonds"]:
        if algorithm.add_power_bond(index[a], ref(a, out_a), ref(a, in_a), index[b], ref(b, out_b), ref(b, in_b)) != 0:
            return {"time": [], "values": {}, "error": f"ecco: cannot bond {a} and {b}"}
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    watched = [(index[n.split(".", 1)[0]], ref(*n.split(".", 1))) for n in job["variables"]]
    return _libcosim_record(execution, observer, watched, job["variables"],
                            lambda times: not times or times[-1] < job["stop_time"] - 1e-12, "ecco")


def _cofmpy_reads_numbers():
    """cofmupy 1.0.0 was written against fmpy 0.3.20, whose model description gives the default
    experiment's values as numbers; later fmpy keeps them as text, and cofmupy's master fails taking
    the smallest step size of its FMUs (numpy's minimum of strings). Its FMU wrappers then read
    descriptions with the numbers restored."""
    import cofmupy.wrappers as wrappers

    read = wrappers.read_model_description

    def read_model_description(*args, **kwargs):
        description = read(*args, **kwargs)
        experiment = description.defaultExperiment
        for name in ("startTime", "stopTime", "tolerance", "stepSize"):
            value = getattr(experiment, name, None) if experiment is not None else None
            if isinstance(value, str):
                setattr(experiment, name, float(value))
        return description

    wrappers.read_model_description = read_model_description


def _child_cofmpy(job):
    import tempfile

    from cofmupy import Coordinator

    _cofmpy_reads_numbers()
    targets: dict = {}
    for a, output, b, input_ in job["connections"]:
        targets.setdefault((a, output), []).append({"id": b, "variable": input_})
    config = {"fmus": [{"id": name, "path": path, "initialization": job["parameters"].get(name, {})}
                       for name, path in job["fmus"].items()],
              "connections": [{"source": {"id": a, "variable": v}, "target": t} for (a, v), t in targets.items()],
              "cosim_method": "jacobi", "iterative": bool(job["iterative"])}
    n = int(round(job["stop_time"] / job["step"]))
    watched = [tuple(name.split(".", 1)) for name in job["variables"]]
    times, rows, error = [], [], None
    tempfile.tempdir = tempfile.mkdtemp(prefix="crankfmu-cofmpy-")      # fmpy's unpacked FMUs, left by CoFMPy
    coordinator = Coordinator()
    try:
        coordinator.start(config)
        master = coordinator.master
        for k in range(n):          # its run_simulation's "while t < end" may add a step on round-off
            coordinator.do_step(job["step"])
            times.append((k + 1) * job["step"])
            rows.append([float(master.get_variable(w)[0]) for w in watched])
            # only the first recorded variable is watched: the scenes record the speed they compare
            # first, and a diverging coupling shows there as soon as anywhere
            if job["bound"] is not None and not abs(rows[-1][0]) <= job["bound"]:
                error = f"{job['variables'][0]} = {rows[-1][0]:.6g} at t = {times[-1]:.6g} s, beyond {job['bound']:.6g}"
                break
    except Exception as exc:                         # noqa: BLE001
        error = f"{type(exc).__name__}: {exc}"
    finally:
        for handler in (coordinator.master.fmu_handlers.values() if coordinator.master else ()):
            for call in (handler.fmu.terminate, handler.fmu.freeInstance):     # CoFMPy frees nothing
                try:
                    call()
                except Exception:                    # noqa: BLE001
                    pass
        import shutil

        shutil.rmtree(tempfile.tempdir, ignore_errors=True)
    columns = np.array(rows).T if rows else np.zeros((len(watched), 0))
    return {"time": times, "values": {v: c.tolist() for v, c in zip(job["variables"], columns)}, "error": error}


if __name__ == "__main__":
    result = _child(json.loads(sys.argv[1]))
    print("RESULT " + json.dumps(result), flush=True)
