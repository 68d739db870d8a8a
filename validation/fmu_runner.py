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
from crankfmu.progress import ProgressBar


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

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]


def scenario_of(path) -> str | None:
    """The scenario a torque-causal crankfmu FMU names in its modelDescription, or None: Drive.fmu
    and DieCushion.fmu name their own files (``crankfmu hosts`` and the tests check them), and a
    speed-causal mechanism FMU (tests/test_causality.py, the SSP in ``crankfmu hosts``) has no
    motor line for the harness's cases."""
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    node = root.find("VendorAnnotations/Tool[@name='crankfmu']/Scenario")
    if node is None or not node.get("name") or node.get("causality") == "speed":
        return None
    return node.get("name")


class FmuUnderTest:
    def __init__(self, path):
        from fmpy import extract, read_model_description

        self.path = Path(path)
        if not self.path.is_file():
            raise CrankfmuError(f"no FMU at {self.path}: run `make fmu` (or give --fmu PATH)")
        self.model_description = read_model_description(str(self.path))
        self.name = self.model_description.coSimulation.modelIdentifier
        self.scenario_name = self._scenario_name()
        self.variables = {v.name: v for v in self.model_description.modelVariables}
        self.outputs = [v.name for v in self.model_description.modelVariables if v.causality == "output"]
        self.units = {v.name: (v.unit or (v.declaredType.unit if v.declaredType else None))
                      for v in self.model_description.modelVariables}
        self.unzipdir = extract(str(self.path))
        self.scenario_source = self._scenario_source()

    def _scenario_source(self) -> str:
        """What the in-process reference loads: the packaged scenario by name, or, for an FMU built
        from a user's scenario file, the copy the FMU carries (the same file the FMU runs)."""
        with zipfile.ZipFile(self.path) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
        node = root.find("VendorAnnotations/Tool[@name='crankfmu']/Scenario")
        inside = node.get("file") if node is not None else None
        if not inside:
            return self.scenario_name
        # the FMU carries its package as one archive (fmi.build.pack): its user/ files, unpacked
        package = Path(self.unzipdir) / "resources" / f"crankfmu_{self.name}"
        with zipfile.ZipFile(package.with_suffix(".zip")) as packed:
            names = packed.namelist()
            if inside not in names:
                raise CrankfmuError(f"{self.path.name} names its scenario file {inside} but does not carry it")
            packed.extractall(package, [n for n in names if n.startswith("user/")])
        return str(package / inside)

    def _scenario_name(self) -> str:
        name = scenario_of(self.path)
        if name is None:
            raise CrankfmuError(f"{self.path.name} does not name its crankfmu scenario "
                                "(VendorAnnotations/Tool[@name='crankfmu']/Scenario): not a crankfmu FMU?")
        return name

    def close(self):
        shutil.rmtree(self.unzipdir, ignore_errors=True)

    def run(self, stop_time: float, step: float, start_values: dict | None = None, label: str = "",
            output: list[str] | None = None, show_progress: bool = True) -> FmuRun:
        """Simulate from 0 to ``stop_time`` s with communication step ``step`` s."""
        from fmpy import simulate_fmu

        log: list[str] = []

        def logger(component, instance_name, status, category, message):
            log.append(message.decode(errors="replace") if isinstance(message, bytes) else str(message))

        start_values = dict(start_values or {})
        unknown = sorted(set(start_values) - set(self.variables))
        if unknown:
            raise CrankfmuError(f"{self.name} has no variable {', '.join(unknown)}")
        settings = {"stop_time": stop_time, "step": step, **start_values}
        bar = ProgressBar(stop_time, label=f"{self.name} {label or 'run'}",    # shows after 2 s
                          delay=2.0 if show_progress else math.inf)

        def step_finished(t, recorder):
            bar(t)
            return True

        started = time.perf_counter()
        try:
            result = simulate_fmu(self.unzipdir, model_description=self.model_description, validate=False,
                                  start_time=0.0, stop_time=stop_time, output_interval=step,
                                  start_values=start_values, output=output or self.outputs,
                                  debug_logging=True, logger=logger, step_finished=step_finished)
        except Exception as exc:      # fmpy raises on fmi2Error: that is an outcome to check, not a crash
            return FmuRun(label, np.empty(0), {}, time.perf_counter() - started, settings, log,
                          error=f"{type(exc).__name__}: {exc}")
        finally:
            bar.close()
        wall = time.perf_counter() - started
        values = {name: np.asarray(result[name], dtype=float) for name in result.dtype.names}
        t = values.pop("time")
        if not (t.size and math.isclose(t[-1], stop_time, rel_tol=1e-9, abs_tol=1e-12)):
            return FmuRun(label, t, values, wall, settings, log,
                          error=f"the run stopped at t = {t[-1] if t.size else 0:g} s before {stop_time:g} s")
        return FmuRun(label, t, values, wall, settings, log)
