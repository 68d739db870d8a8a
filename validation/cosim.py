"""A fixed-step Jacobi master on fmpy: an instrument of the harness, small on purpose, that couples
FMI 2.0 Co-Simulation FMUs the way the common masters do, to measure what the FMUs' coupling
features buy (docs/coupling.md).

At each communication point t_n it reads every connected output, then sets every connected input
to the value read and steps every FMU from t_n to t_n + H (Jacobi: all FMUs step on the values of
t_n). Two ways to pass an input over the step:

- ``hold``: the value at t_n is held over the step (a zero-order hold: what ecos and libcosim
  do), an O(H) error in the coupled solution;
- ``extrapolate``: the value and its slope, from the source FMU's first output derivative
  (fmi2GetRealOutputDerivatives), given to the receiving FMU as the input and its derivative
  (fmi2SetRealInputDerivatives): the input is a line over the step, an O(H^2) error. What PyFMI's
  Master does with extrapolation_order = 1 and OMSimulator with --inputExtrapolation.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

MODES = ("hold", "extrapolate")


@dataclass
class Coupled:
    """The outputs recorded at each communication point (``record``: "FMU.variable" names)."""

    time: np.ndarray
    values: dict

    def __getitem__(self, name):
        return self.values[name]


def jacobi(fmus: dict, connections, parameters: dict, stop_time: float, step: float, mode: str = "hold",
           record=(), folder: Path | None = None) -> Coupled:
    """Run the FMUs ``fmus`` ({name: path}) coupled by ``connections`` ((from FMU, output, to FMU,
    input), ...) from 0 to ``stop_time`` at the communication step ``step`` (s), each FMU's
    ``parameters`` ({name: {variable: value}}) set before initialisation."""
    import tempfile

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    work = Path(folder or tempfile.mkdtemp(prefix="crankfmu-cosim-"))
    instances, refs = {}, {}
    for name, path in fmus.items():
        md = read_model_description(str(path))
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), str(work / name)),
                        modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0, stopTime=stop_time)
        refs[name] = {v.name: v.valueReference for v in md.modelVariables}
        values = parameters.get(name, {})
        if values:
            fmu.setReal([refs[name][n] for n in values], list(values.values()))
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        instances[name] = fmu

    def vr(qualified):
        fmu, variable = qualified.split(".", 1)
        return fmu, refs[fmu][variable]

    n_steps = int(round(stop_time / step))
    times = np.arange(n_steps + 1) * step
    recorded = {name: np.empty(n_steps + 1) for name in record}
    try:
        for n in range(n_steps + 1):
            read = {}
            for source, output, _, _ in connections:
                read[source, output] = instances[source].getReal([refs[source][output]])[0]
            for name in record:
                fmu, ref = vr(name)
                recorded[name][n] = instances[fmu].getReal([ref])[0]
            if n == n_steps:
                break
            slopes = {}
            if mode == "extrapolate":
                for source, output, _, _ in connections:
                    slopes[source, output] = instances[source].getRealOutputDerivatives([refs[source][output]], [1])[0]
            for source, output, target, input_ in connections:
                instances[target].setReal([refs[target][input_]], [read[source, output]])
                if mode == "extrapolate":
                    instances[target].setRealInputDerivatives([refs[target][input_]], [1], [slopes[source, output]])
            for fmu in instances.values():
                fmu.doStep(currentCommunicationPoint=times[n], communicationStepSize=step)
    finally:
        for fmu in instances.values():
            fmu.terminate()
            fmu.freeInstance()
    return Coupled(times, recorded)


def observed_order(steps, errors) -> float:
    """The slope of log(error) against log(step) between the two smallest steps."""
    (h1, e1), (h2, e2) = sorted(zip(steps, errors))[:2]
    return float(np.log(e2 / e1) / np.log(h2 / h1))
