"""An FMU's reference result, as the Reference FMUs carry theirs: the default experiment's outputs
from an independent method (the in-process reference integrator; for speed causality the power
balance on the contour engine), in the FMU under the fmi-ls-ref layered standard and beside it as
the cross-check files ``<model>_ref.csv`` and ``<model>_ref.opt``.
"""

from __future__ import annotations

from pathlib import Path

#: the crankfmu package: its Python sources name a reference run in the cache
PACKAGE = Path(__file__).resolve().parents[1]


LS_REF = "extra/org.fmi-standard.fmi-ls-ref"
LS_REF_MANIFEST = """<?xml version="1.0" encoding="UTF-8"?>
<fmiReferences xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest"
    fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref" fmi-ls:fmi-ls-version="1.0.0-alpha.1"
    fmi-ls:fmi-ls-description="Layered Standard providing information on related files included in an FMU.">
  <Related type="text/csv" source="{name}_out.csv" role="result"
      description="Outputs of the default experiment, from crankfmu's in-process reference integrator (DOP853, rtol = atol = 1e-12)"/>
</fmiReferences>
"""


def reference_result(scenario) -> str:
    """The default experiment's outputs (CSV, quoted header) from the in-process reference: run once
    per design and code (``make fmu`` builds three FMUs of each scenario), then read from the
    per-user cache (or the installation's) under its design_digest and its grid."""
    import hashlib

    from crankfmu import COLUMNS

    from ..cache import kept

    def run() -> str:
        # the integrators and scipy only when the run is made: a build whose reference is kept (the
        # installation's prebuilt ones, make fmu's three builds of a scenario) reads it without them
        from crankfmu import simulate

        times = default_grid(scenario.experiment)
        result = simulate(scenario, t_end=scenario.experiment.stop_time, output_times=times)
        lines = [",".join(f'"{c}"' for c in COLUMNS)]
        lines += [",".join(f"{getattr(result, c)[i]:.17g}" for c in COLUMNS) for i in range(times.size)]
        return "\n".join(lines) + "\n"
    # under the design and the experiment's grid: a caller may change a loaded scenario's experiment
    # (the harness's tests shorten it), which its data no longer says
    exp = scenario.experiment
    grid = hashlib.sha256(repr((exp.start_time, exp.stop_time, exp.output_interval)).encode()).hexdigest()[:12]
    return kept("references", f"{design_digest(scenario)}-{grid}.csv", run, encoding="utf-8")


def default_grid(experiment):
    """The default experiment's output times (s): start, start + step, ..., stop, as fmpy reports a
    Co-Simulation run of it (the validation harness compares on them)."""
    import numpy as np

    n = int(round((experiment.stop_time - experiment.start_time) / experiment.output_interval))
    return experiment.start_time + experiment.output_interval * np.arange(n + 1)


def reference_values(scenario) -> dict:
    """reference_result's columns as arrays ({name: values}; the text holds each number to 17
    digits, so these are the integrator's own floats)."""
    import io

    import numpy as np

    from crankfmu import COLUMNS

    data = np.loadtxt(io.StringIO(reference_result(scenario)), delimiter=",", skiprows=1, ndmin=2)
    return {name: data[:, i] for i, name in enumerate(COLUMNS)}


def design_digest(scenario) -> str:
    """What a design's results are kept under in the cache (its reference run, its drawing): the hash
    of the scenario's data, its mechanism, its values and crankfmu's Python sources."""
    import hashlib

    return hashlib.sha256(repr((scenario.data, scenario.mechanism_definition(), sorted(scenario.values.items()),
                                code_digest())).encode()).hexdigest()[:24]


_CODE_DIGEST = []


def code_digest() -> str:
    """The hash of crankfmu's Python sources (what the reference run's numbers depend on), once per process."""
    import hashlib

    if not _CODE_DIGEST:
        digest = hashlib.sha256()
        for path in sorted(PACKAGE.rglob("*.py")):
            digest.update(path.relative_to(PACKAGE).as_posix().encode() + b"\0" + path.read_bytes())
        _CODE_DIGEST.append(digest.hexdigest())
    return _CODE_DIGEST[0]


def speed_reference(scenario) -> str:
    """The speed-causal FMU's default experiment (omega1 held at omega1_start) by another method:
    phi1 = phi1_start + omega1 t, and the drive torque as the equilibrium moment M_e of the power
    balance (dynamics.inverse, seed 001 eq. 1) on the contour engine, not the tables."""
    import numpy as np

    from ..dynamics.inverse import equilibrium_moment

    exp = scenario.experiment
    n = int(round((exp.stop_time - exp.start_time) / exp.output_interval))
    times = exp.start_time + exp.output_interval * np.arange(n + 1)
    values = scenario.values
    omega = values["omega1_start"]
    if omega == 0.0:
        return ""
    model = scenario.build()
    phi = values["phi1_start"] + omega * (times - exp.start_time)
    m = equilibrium_moment(model.reduced, phi, omega)
    J = model.reduced.coefficients(phi)[0]
    tau_drive = m.total
    if model.reduced.friction is not None:
        # with joint friction the drive also takes the frictions of the motion: Newton-Euler's drive
        # moment with them (the power balance alone does not know the reactions)
        from ..dynamics.reactions import joint_reactions
        tau_drive = joint_reactions(model.reduced, phi, omega, 0.0).driving_moment
    columns = {"time": times, "phi1": phi, "epsilon1": np.zeros_like(phi), "tau_drive": tau_drive,
               "M_load": -(m.weights + m.technological), "J_red": J, "E_kin": 0.5 * J * omega * omega}
    lines = [",".join(f'"{c}"' for c in columns)]
    lines += [",".join(f"{columns[c][i]:.17g}" for c in columns) for i in range(times.size)]
    return "\n".join(lines) + "\n"


def cross_check_options(source) -> str:
    """The cross-check file ``<model>_ref.opt``: the default experiment of ``source`` (fmi.source.Source)."""
    exp = source.experiment
    return (f"StartTime, {exp.start_time!r}\nStopTime, {exp.stop_time!r}\n"
            f"StepSize, {exp.output_interval!r}\nRelTol, {exp.tolerance!r}\n")
