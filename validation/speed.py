"""A mechanism FMU in speed causality (Python or native): the drive imposes omega1 and the FMU
answers with tau_drive, the torque that takes.

Three checks, each by another method than the FMU's own step:

* at constant omega1 every output against the engine's inverse dynamics: tau_drive against the
  equilibrium moment M_e of the power balance (dynamics.inverse, ``crankfmu equilibrium``), J_red,
  M_load and E_kin from the contour engine, the works by the energy balance, the [[outputs]] and
  the joint reactions (Newton-Euler) at the imposed motion;
* the torque-causal reference run of the same file played back: its omega1(t) imposed, tau_drive
  must be its motor torque;
* the energy balance with a varying omega1.
"""

from __future__ import annotations

import numpy as np

from crankfmu.dynamics.inverse import equilibrium_moment
from crankfmu.errors import CrankfmuError

from .compare import max_abs_error, relative_error
from .fmu_runner import input_signal
from .mechanism import OUTPUT_TOLERANCE
from .reference import ReferenceRun, with_outputs, cached_reference
from .figures import plot_outputs

#: the tables are checked to 1e-11; tau_drive sums J epsilon1, 0.5 J' omega1^2 and Q: 1e-8 of its scale
TAU_TOLERANCE = 1e-8
#: played back at 0.1 ms: without the host's derivative the FMU takes omega1's slope from its last
#: step, so epsilon1 lags by 1.5 steps and tau_drive by J times that (0.3 N.m on seed 001's 95 N.m)
PLAYBACK_STEP = 1e-4
PLAYBACK_SPAN = 0.3
PLAYBACK_TOLERANCE = 1e-2


def constant_speed_reference(scenario, times, omega1: float) -> ReferenceRun:
    """Every speed-causal output at phi1 = phi1_start + omega1 t, omega1 constant, from the engine."""
    model = scenario.build()
    phi1 = float(scenario["phi1_start"]) + omega1 * np.asarray(times)
    J, _, _, _ = model.reduced.coefficients(phi1)
    me = equilibrium_moment(model.reduced, phi1, omega1)
    values = {"phi1": phi1, "omega1": np.full_like(phi1, omega1), "epsilon1": np.zeros_like(phi1),
              "tau_drive": me.total, "M_load": -(me.weights + me.technological), "J_red": J,
              "E_kin": 0.5 * J * omega1 ** 2}
    return with_outputs(ReferenceRun("inverse dynamics at constant omega1", np.asarray(times), values, 0.0,
                                     model=model), scenario)


def check_speed_fmu(fmu, scenario, checks, out, quick: bool) -> dict:
    from fmpy.validation import validate_fmu

    prefix = f"{fmu.name}.{fmu.kind.build}"
    problems = validate_fmu(str(fmu.path))
    checks.holds(f"{prefix}.fmpy_validate", not problems, note="; ".join(map(str, problems))[:300])
    section = {"default": [], "hard": []}
    exp = scenario.experiment
    omega = float(fmu.variables["omega1"].start or scenario["omega1_start"])
    if not omega > 0:
        omega = 10.0
    span = min(exp.stop_time, 1.0) if quick else exp.stop_time
    run = fmu.run(span, exp.output_interval, {"omega1": omega}, label="constant omega1")
    if run.error:
        checks.holds(f"{prefix}.constant_omega1.ran", False, note=run.error)
        return section
    ref = constant_speed_reference(scenario, run.time, omega)
    rows = []
    for name in fmu.outputs:
        if name in ("W_drive", "W_load", "W_ext"):
            continue                   # integrals: the energy balance below checks them
        if name not in ref.values:
            checks.holds(f"{prefix}.constant_omega1.{name}_compared", False, note="the reference has no such output")
            continue
        tol = TAU_TOLERANCE if name == "tau_drive" else OUTPUT_TOLERANCE
        r = relative_error(run[name], ref[name])
        checks.at_most(f"{prefix}.constant_omega1.{name}_rel_error", r, tol)
        rows.append({"output": name, "unit": fmu.units.get(name) or "1", "abs": max_abs_error(run[name], ref[name]),
                     "rel": r, "tol": tol})
    balance = run["W_drive"] + run["W_load"] + run["W_ext"] - (run["E_kin"] - run["E_kin"][0])
    scale = float(np.max(np.abs(run["W_drive"]) + np.abs(run["W_load"]))) or 1.0
    checks.at_most(f"{prefix}.constant_omega1.energy_residual", float(np.max(np.abs(balance))) / scale, 1e-8)
    plot = plot_outputs(run, ref, [r["output"] for r in rows], {r["output"]: r["tol"] for r in rows},
                        out / f"{fmu.name}_{fmu.kind.build}_constant_omega1.png",
                        f"{fmu.title}: omega1 = {omega:g} rad/s held, against inverse dynamics")
    section["default"].append({"interface": "CoSimulation", "span": span, "step": exp.output_interval,
                               "fmu_wall": run.wall, "ref_wall": 0.0, "rows": rows, "plot": plot.name,
                               "what": f"omega1 = {omega:g} rad/s held: every output against the engine's "
                                       "inverse dynamics (tau_drive against crankfmu equilibrium's M_e)",
                               "run": run})
    section["hard"].append(_played_back(fmu, scenario, checks, prefix))
    section["hard"].append(_varying(fmu, checks, prefix, omega))
    return section


def _played_back(fmu, scenario, checks, prefix) -> dict:
    """The torque-causal reference of the same file, its omega1(t) imposed every PLAYBACK_STEP:
    tau_drive is its motor torque (from the third point on: the backward difference needs a step)."""
    row = {"case": "played_back", "stop_time": PLAYBACK_SPAN, "step": PLAYBACK_STEP, "g": scenario["g"],
           "expect": "the torque-causal reference run of the same file played back through the FMU: tau_drive "
                     f"is its motor torque, to {PLAYBACK_TOLERANCE:g} of max |M_motor| (omega1's slope is a "
                     "backward difference over the last step)"}
    n_before = len(checks.items)
    times = np.arange(0.0, PLAYBACK_SPAN + PLAYBACK_STEP / 2, PLAYBACK_STEP)
    try:
        ref = cached_reference(scenario, times)
    except CrankfmuError as exc:
        checks.skip(f"{prefix}.played_back", f"the file has no torque-causal run to play back: {exc}")
        row["checks"] = checks.items[n_before:]
        return row
    run = fmu.run(PLAYBACK_SPAN, PLAYBACK_STEP, {"omega1": float(ref["omega1"][0])}, label="played back",
                  inputs=input_signal(times, omega1=ref["omega1"]))
    if run.error:
        checks.holds(f"{prefix}.played_back.ran", False, note=run.error)
    else:
        error = float(np.max(np.abs(run["tau_drive"][3:] - ref["M_motor"][3:])))
        scale = float(np.max(np.abs(ref["M_motor"])))
        checks.at_most(f"{prefix}.played_back.tau_drive_vs_M_motor", error / scale, PLAYBACK_TOLERANCE)
        row.update(fmu_wall=run.wall, ref_wall=ref.wall)
    row["checks"] = checks.items[n_before:]
    return row


def _varying(fmu, checks, prefix, omega) -> dict:
    """omega1 = omega (1 + 0.3 sin 3t) over 2 s at 1 ms: the works by Gauss-Legendre close the
    energy balance to 1e-8 of the work done."""
    row = {"case": "varying_omega1", "stop_time": 2.0, "step": 1e-3, "g": float("nan"),
           "expect": "omega1 varying by 30 % at 3 rad/s: W_drive + W_load + W_ext = E_kin(t) - E_kin(0) to 1e-8"}
    n_before = len(checks.items)
    times = np.arange(0.0, 2.0 + 5e-4, 1e-3)
    run = fmu.run(2.0, 1e-3, {"omega1": omega}, label="varying omega1",
                  inputs=input_signal(times, omega1=omega * (1.0 + 0.3 * np.sin(3.0 * times))))
    if run.error:
        checks.holds(f"{prefix}.varying_omega1.ran", False, note=run.error)
    else:
        balance = run["W_drive"] + run["W_load"] + run["W_ext"] - (run["E_kin"] - run["E_kin"][0])
        scale = float(np.max(np.abs(run["W_drive"]) + np.abs(run["W_load"]))) or 1.0
        residual = float(np.max(np.abs(balance))) / scale
        checks.at_most(f"{prefix}.varying_omega1.energy_residual", residual, 1e-8)
        row.update(fmu_wall=run.wall, energy_residual=residual)
    row["checks"] = checks.items[n_before:]
    return row
