"""An FMU under test, driven through fmpy exactly as a host would drive it.

The FMU names the scenario file it implements in its modelDescription
(``VendorAnnotations/Tool[@name="crankfmu"]/Scenario``); the harness runs that same file in
process. Runs go through ``fmpy.simulate_fmu`` on the extracted FMU (extracted once, so the
timings measure simulation, not unzipping). A refused parameter does not raise: the run comes
back with ``error`` set and the FMU's log, which the checks read.
"""

from __future__ import annotations

import math
import shutil
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from crankfmu.errors import CrankfmuError
from crankfmu.fmi.source import crankfmu_annotation
from crankfmu.progress import ProgressBar


#: fmpy's printer and the callbacks that carry it, kept for the process's life (simulate_logged)
_PROCESS_LOGGER: dict = {}


def simulate_logged(*args, logger, **kwargs):
    """fmpy.simulate_fmu with the FMU's messages passed to ``logger``, in this process. fmpy (0.3.32)
    routes every FMI 2.0 FMU's messages through one process-wide pointer in its logging proxy, which
    simulate_fmu points at a callback it frees when it returns: any FMU that logs later through
    fmpy's default callbacks (an FMU2Slave instantiated without its own) then calls freed memory, and
    the process dies in that FMU's fmi2DoStep (a segfault seen in a test worker when a diverging
    coupling made FourBar.fmu refuse a step). The pointer is set back here to a logger of the
    process's life, fmpy's own printer."""
    from ctypes import byref

    from fmpy import simulate_fmu
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, printLogMessage
    from fmpy.logging import addLoggerProxy

    try:
        return simulate_fmu(*args, logger=logger, **kwargs)
    finally:
        if not _PROCESS_LOGGER:
            _PROCESS_LOGGER.update(printer=fmi2CallbackLoggerTYPE(printLogMessage), callbacks=fmi2CallbackFunctions())
        # addLoggerProxy points fmpy's pointer at callbacks.logger (and puts its proxy in that field)
        _PROCESS_LOGGER["callbacks"].logger = _PROCESS_LOGGER["printer"]
        addLoggerProxy(byref(_PROCESS_LOGGER["callbacks"]))


@dataclass
class FmuRun:
    """Outputs of one fmpy run at its communication points (``time`` s, others in their units)."""

    label: str
    time: np.ndarray
    values: dict[str, np.ndarray]
    wall: float                        # s for the whole simulate_fmu call
    settings: dict
    log: list[str] = field(default_factory=list)
    error: str | None = None           # set when the FMU refused (fmi2Error) or the run failed
    units: dict = field(default_factory=dict)   # each output's unit, as the FMU declares it
    init_wall: float = math.nan        # s from the call to the first communication point: load,
                                       # instantiate, initialise, and the first step
    per_step: float = math.nan         # s per communication step after the first (median-free mean)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]


@dataclass(frozen=True)
class FmuKind:
    """What a crankfmu FMU is, from its modelDescription: the data file it implements (``kind``:
    scenario, drive, cushion, shaft or well; ``data``: its name), the causality at its shaft, its build
    (python or native), its interfaces, and where it carries a user's file (``file``)."""

    kind: str
    data: str
    causality: str
    build: str
    interfaces: tuple[str, ...]
    file: str | None = None

    @property
    def label(self) -> str:
        """The kind in a report's words: "mechanism", "mechanism, speed causality", "drive", ..."""
        what = "mechanism" if self.kind == "scenario" else {"cushion": "die cushion", "shaft": "elastic shaft",
                                                              "well": "rod string"}.get(
            self.kind, self.kind)
        return what + (", speed causality" if self.causality == "speed" else "")


#: where a run reports how far it is: (what runs, fraction done); the harness's workers set it to
#: tell the parent, which draws one bar for all of them (None: each run draws its own bar)
PROGRESS = None


def report_progress(label: str, fraction: float):
    if PROGRESS is not None:
        PROGRESS(label, fraction)


def kind_of(path) -> FmuKind | None:
    """The FMU's kind, or None for an FMU crankfmu did not build (no crankfmu VendorAnnotation)."""
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    tool = crankfmu_annotation(root)
    if tool is None or not len(tool):
        return None
    node = tool[0]
    interfaces = tuple(tag for tag in ("CoSimulation", "ModelExchange") if root.find(tag) is not None)
    native = node.get("build") == "native" or "native" in (root.get("generationTool") or "")
    # a native FMI 3.0 FMU is a build of its own beside the FMI 2.0 one: its checks are named apart
    build = ("native-fmi3" if root.get("fmiVersion", "").startswith("3") else "native") if native else "python"
    return FmuKind(node.tag.lower(), node.get("name") or "", node.get("causality") or "torque", build, interfaces,
                   node.get("file"))


def scenario_of(path) -> str | None:
    """The scenario a crankfmu mechanism FMU (either causality) implements, or None."""
    kind = kind_of(path)
    return kind.data if kind is not None and kind.kind == "scenario" else None


def input_signal(times, **columns) -> np.ndarray:
    """Inputs as fmpy takes them: a structured array of ``time`` and one column per input."""
    signal = np.zeros(np.size(times), dtype=[("time", float), *((name, float) for name in columns)])
    signal["time"] = times
    for name, value in columns.items():
        signal[name] = value
    return signal


class FmuUnderTest:
    def __init__(self, path):
        from fmpy import extract, read_model_description

        self.path = Path(path)
        if not self.path.is_file():
            raise CrankfmuError(f"no FMU at {self.path}: run `make fmu` (or give --fmu PATH)")
        self.kind = kind_of(self.path)
        if self.kind is None:
            raise CrankfmuError(f"{self.path.name} carries no crankfmu VendorAnnotation (Tool name=\"crankfmu\"): "
                                "not an FMU crankfmu built, so there is no data file to check it against")
        self.model_description = read_model_description(str(self.path))
        md = self.model_description
        self.name = (md.coSimulation or md.modelExchange).modelIdentifier
        self.scenario_name = self.kind.data
        self.variables = {v.name: v for v in md.modelVariables}
        self.outputs = [v.name for v in md.modelVariables if v.causality == "output"]
        self.units = {v.name: (v.unit or (v.declaredType.unit if v.declaredType else None))
                      for v in md.modelVariables}
        self.unzipdir = extract(str(self.path))
        self.scenario_source = self._scenario_source()

    @property
    def native(self) -> bool:
        return self.kind.build.startswith("native")

    @property
    def title(self) -> str:
        """How the report names it: the file and its build (native FMUs share the Python ones' names)."""
        return f"{self.name}.fmu ({self.kind.build})"

    def _scenario_source(self) -> str:
        """What the in-process model loads: the packaged data file by name, or, for an FMU built
        from a user's scenario file, the copy the FMU carries (the same file the FMU runs)."""
        inside = self.kind.file
        if not inside:
            return self.scenario_name
        if self.native:           # carried as plain files (fmi.source.NATIVE_USER_FILES)
            from crankfmu.fmi.source import NATIVE_USER_FILES

            path = Path(self.unzipdir) / NATIVE_USER_FILES / inside
            if not path.is_file():
                raise CrankfmuError(f"{self.path.name} names its scenario file {inside} but does not carry it")
            return str(path)
        # a pythonfmu FMU carries its package as one archive (fmi.python.build.pack): its user/ files, unpacked
        package = Path(self.unzipdir) / "resources" / f"crankfmu_{self.name}"
        with zipfile.ZipFile(package.with_suffix(".zip")) as packed:
            names = packed.namelist()
            if inside not in names:
                raise CrankfmuError(f"{self.path.name} names its scenario file {inside} but does not carry it")
            packed.extractall(package, [n for n in names if n.startswith("user/")])
        return str(package / inside)

    def close(self):
        shutil.rmtree(self.unzipdir, ignore_errors=True)

    def run(self, stop_time: float, step: float, start_values: dict | None = None, label: str = "",
            output: list[str] | None = None, show_progress: bool = True, interface: str = "CoSimulation",
            rtol: float | None = None, inputs=None) -> FmuRun:
        """Simulate from 0 to ``stop_time`` s with communication (output) step ``step`` s, as
        Co-Simulation or as Model Exchange through fmpy's CVode at relative tolerance ``rtol``;
        ``inputs``: a structured array (time and input columns), as fmpy takes it."""

        log: list[str] = []

        def logger(*args):
            # FMI 2.0's logger (component, instance, status, category, message) or FMI 3.0's
            # logMessage (environment, status, category, message): the message is last in both
            message = args[-1]
            log.append(message.decode(errors="replace") if isinstance(message, bytes) else str(message))

        start_values = dict(start_values or {})
        unknown = sorted(set(start_values) - set(self.variables))
        if unknown:
            raise CrankfmuError(f"{self.name} has no variable {', '.join(unknown)}")
        settings = {"stop_time": stop_time, "step": step, **start_values}
        what = f"{self.name} ({self.kind.build}) {label or 'run'}"
        bar = ProgressBar(stop_time, label=what,    # shows after 2 s
                          delay=2.0 if show_progress and PROGRESS is None else math.inf)
        report_progress(what, 0.0)

        stamps = []

        def step_finished(t, recorder):
            stamps.append(time.perf_counter())
            bar(t)
            report_progress(what, t / stop_time if stop_time > 0 else 1.0)
            return True

        # fmpy's CVode takes at most 500 steps between two outputs: Model Exchange records at
        # least every 10 ms (the rows on the asked grid are kept below)
        interval = min(step, 1e-2) if interface == "ModelExchange" else step
        if interface == "ModelExchange" and abs(step / interval - round(step / interval)) > 1e-9:
            interval = step / math.ceil(step / interval)
        started = time.perf_counter()
        try:
            result = simulate_logged(self.unzipdir, model_description=self.model_description, validate=False,
                                  start_time=0.0, stop_time=stop_time, output_interval=interval,
                                  start_values=start_values, output=output or self.outputs,
                                  debug_logging=True, logger=logger, step_finished=step_finished,
                                  fmi_type=interface, relative_tolerance=rtol, input=inputs)
        except Exception as exc:      # fmpy raises on fmi2Error: that is an outcome to check, not a crash
            return FmuRun(label, np.empty(0), {}, time.perf_counter() - started, settings, log,
                          error=f"{type(exc).__name__}: {exc}")
        finally:
            bar.close()
        wall = time.perf_counter() - started
        values = {name: np.asarray(result[name], dtype=float) for name in result.dtype.names}
        t = values.pop("time")
        if interface == "ModelExchange":
            # fmpy records events (before and after each) as extra rows: keep the last row at each
            # output time, the grid a Co-Simulation run and the reference share
            grid = np.round(t / step) * step
            on = np.nonzero(np.isclose(t, grid, rtol=0.0, atol=1e-9 * max(step, 1.0)))[0]
            keep = on[np.append(grid[on][1:] != grid[on][:-1], True)]
            t, values = grid[keep], {k: v[keep] for k, v in values.items()}
        if not (t.size and math.isclose(t[-1], stop_time, rel_tol=1e-9, abs_tol=1e-12)):
            return FmuRun(label, t, values, wall, settings, log,
                          error=f"the run stopped at t = {t[-1] if t.size else 0:g} s before {stop_time:g} s")
        init_wall = stamps[0] - started if stamps else math.nan
        per_step = (stamps[-1] - stamps[0]) / (len(stamps) - 1) if len(stamps) > 1 else math.nan
        return FmuRun(label, t, values, wall, settings, log, units=self.units, init_wall=init_wall,
                      per_step=per_step)
