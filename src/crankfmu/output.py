"""The reports: what each job writes from its result (CSV, JSON and the figures of ``plots``).

A run of ``crankfmu simulate``: timeseries.csv, summary.json, paper Figs. 3-4 and, where loads have
kinks, their contact figure; the equilibrium
study: summary.json, one CSV per speed, the moments and reactions; the flywheel study:
flywheel.json and its four figures. The studies compute and return dataclasses; writing is here.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .plots import plot_cycles, plot_moments, plot_reactions
from .contract import COLUMNS
from .dynamics.friction import friction_outputs
from .pictures.contact import plot_contacts
from .pictures.friction import plot_friction_power, plot_startup
from .pictures.flywheel_study import plot_flywheel_study
from .simulation import Result
from .atomic import replacing, write_text


def extra_columns(result: Result) -> dict[str, tuple[np.ndarray, str]]:
    """The scenario's [[outputs]] and its ports' inputs and s, v, a at the run's states, as the FMU
    outputs them: name -> (values, unit). Angles count whole turns (the contour engine's)."""
    from .mechanisms.quantities import evaluate_all

    scenario, model = result.scenario, result.model
    out = {}
    if scenario.quantities:
        definition = scenario.mechanism_definition()
        kin = model.mechanism.kinematics(np.asarray(result.phi1))
        values = evaluate_all(scenario.quantities, kin, np.asarray(result.omega1), np.asarray(result.epsilon1))
        out.update({q.name: (values[q.name], q.unit(definition)) for q in scenario.quantities})
    if result.W_friction is not None:
        values = {**result.friction, "W_friction": result.W_friction}
        out.update({name: (values[name], unit) for name, unit, _ in friction_outputs(model.reduced.friction.frictions)})
    for port in model.equation.ports:
        out[port.input_name] = (result.ports[port.input_name], port.input_unit)
        out.update({q.name: (result.ports[q.name], q.unit(model.mechanism.definition)) for q in port.quantities})
    return out


def write_timeseries(result: Result, path: Path) -> Path:
    """Plain CSV, one header line: the contract's columns, then the scenario's [[outputs]] and its
    ports'; the units are listed in summary.json ("columns")."""
    extra = extra_columns(result)
    data = np.column_stack([getattr(result, c) for c in COLUMNS] + [v for v, _ in extra.values()])
    with replacing(path) as partial:
        np.savetxt(partial, data, delimiter=",", header=",".join([*COLUMNS, *extra]), comments="", fmt="%.15g")
    return path


def write_summary(summary: dict, path: Path) -> Path:
    write_text(path, json.dumps(summary, indent=2, default=_json_default) + "\n")
    return path


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {obj!r}")


def write_run(result: Result, out_dir: str | Path) -> dict:
    """Everything `crankfmu simulate` writes; returns the summary."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    exp = result.scenario.experiment
    summary = result.summary()
    summary["columns"] = {**COLUMNS, **{name: unit for name, (_, unit) in extra_columns(result).items()}}
    write_timeseries(result, out / "timeseries.csv")
    figures = plot_cycles(result, out, exp.cycles, exp.summary_cycle) + plot_contacts(result, out)
    summary["figures"] = [p.name for p in figures]
    write_summary(summary, out / "summary.json")
    return summary


def write_equilibrium(scenario, results: list, out_dir, startup=None) -> dict:
    """summary.json (keyed by speed), equilibrium_<w>.csv and the figures; returns the summary.
    With joint friction, ``startup`` (equilibrium.StartupTorque) and the friction's figures."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = {r.key: r.summary() for r in results}
    summary["units"] = {"Me_*": "N.m", "inertia_ratio": "1", "omega1": "rad/s", "max_force_N": "N",
                        "max_couple_Nm": "N.m", "technological_work_per_cycle_J": "J"}
    summary["scenario"] = scenario.name
    summary["parameters"] = scenario.values
    written = []
    for r in results:
        m = r.moment
        columns = {"phi1_deg": np.degrees(m.phi1), "Me": m.total, "Me_static": m.static,
                   "Me_weights": m.weights, "Me_technological": m.technological, "Me_inertia": m.inertia}
        for joint in r.reactions.force:
            fx, fy = r.reactions.force[joint]
            columns[f"{joint}_Fx"], columns[f"{joint}_Fy"] = fx, fy
            if r.reactions.kind[joint] == "prismatic":
                columns[f"{joint}_couple"] = r.reactions.couple[joint]
        if r.with_friction is not None:
            columns["Me_with_friction"] = r.with_friction
            for joint, power in r.reactions.friction_power.items():
                columns[f"{joint}_friction"], columns[f"{joint}_Pf"] = r.reactions.friction[joint], power
        with replacing(out / f"equilibrium_{r.key}.csv") as partial:
            np.savetxt(partial, np.column_stack(list(columns.values())),
                       delimiter=",", header=",".join(columns), comments="", fmt="%.12g")
        written.append(out / f"equilibrium_{r.key}.csv")
    written += plot_moments(scenario, results, out)
    written.append(plot_reactions(scenario, results[0], out / f"reactions_{results[0].key}.png",
                                  [math.degrees(b) for b in results[0].switches]))
    if startup is not None:
        summary["startup"] = startup.summary()
        summary["units"]["startup_torque"] = "N.m"
        written.append(plot_friction_power(scenario, results[0], out / f"friction_{results[0].key}.png"))
        written.append(plot_startup(scenario, startup, out / "startup.png"))
    summary["files"] = [p.name for p in written]
    write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    return summary


def finite_or_null(value):
    """``value`` with every float that is not finite (inf, nan) replaced by None, at any depth."""
    if isinstance(value, dict):
        return {k: finite_or_null(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_null(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_flywheel(study, out_dir) -> list[Path]:
    """flywheel.json and the flywheel study's figures (J_e, the movement, the flywheel, eq. 3)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    plots = plot_flywheel_study(study, out)
    summary = {**study.summary(), "plots": [p.name for p in plots]}
    # strict JSON: a quantity that does not exist (no steady cycle, no linear estimate) is null
    write_text(out / "flywheel.json", json.dumps(finite_or_null(summary), indent=2, allow_nan=False) + "\n")
    return plots
