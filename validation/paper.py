"""The numbers each paper publishes, checked against what crankfmu computes.

A scenario file lists them as ``[[paper]]`` entries (name, quantity, expected, tolerance, unit,
source, and the quantity's own keys); this module computes each named quantity. Where a number
can be read from the FMU's outputs it is (``settled_change``); geometric facts come from the
FMU's scenario built in process.
"""

from __future__ import annotations

import math

from crankfmu.dynamics.loads import DeadPointMoment
from crankfmu.errors import DefinitionError

from .compare import cycles


def rocker_extreme_deg(entry, model, fmu_run):
    """Crank angle (deg) of the rocker's extreme ``index`` (0: phi1d, 1: phi1a of seed 000 eq. 18)."""
    loads = [l for l in model.reduced.loads if isinstance(l, DeadPointMoment)]
    if not loads:
        raise DefinitionError("rocker_extreme_deg needs a dead_point_moment load in the scenario")
    return math.degrees((loads[0].phi1d, loads[0].phi1a)[int(entry["index"])])


def settled_change(entry, model, fmu_run):
    """Relative change of the cycle-mean crank speed from cycle ``cycle`` to the next, from the
    FMU's outputs: the paper's "already stabilised" in that cycle, as a number."""
    k = int(entry["cycle"])
    found = cycles(fmu_run.time, fmu_run["phi1"], fmu_run["omega1"])
    if len(found) < k + 1:
        return float("nan")
    a, b = found[k - 1]["omega1_mean"], found[k]["omega1_mean"]
    return abs(b - a) / b


def kinematic_cycle(entry, model, fmu_run):
    """``key`` (stroke, time_ratio, arm_swing) of the kinematic study's cycle at constant omega1."""
    from crankfmu.studies.kinematics import cycle
    return cycle(model.scenario, [])[entry["key"]]


def inertia_ratio(entry, model, fmu_run):
    """max|M_e - M_e,static| / max|M_e| at the constant crank speed ``omega1`` (seed 001 eq. 1)."""
    from crankfmu.studies.equilibrium import equilibrium_study
    return equilibrium_study(model.scenario, [float(entry["omega1"])])[0].summary()["inertia_ratio"]


def reduced_inertia_min(entry, model, fmu_run):
    """The smallest reduced inertia J_red over the turn (kg.m2), from the FMU's own output over its run."""
    return float(min(fmu_run["J_red"]))


QUANTITIES = {f.__name__: f for f in (rocker_extreme_deg, settled_change, kinematic_cycle, inertia_ratio,
                                      reduced_inertia_min)}


def check_paper(scenario, model, fmu_run, checks, prefix: str):
    """One check per ``[[paper]]`` entry of the scenario file."""
    for entry in scenario.data.get("paper", []):
        quantity = QUANTITIES.get(entry.get("quantity"))
        if quantity is None:
            raise DefinitionError(f"{scenario.where}: [[paper]] {entry.get('name')!r}: unknown quantity "
                                  f"{entry.get('quantity')!r} (known: {', '.join(QUANTITIES)})")
        value = quantity(entry, model, fmu_run)
        checks.close(f"{prefix}.paper.{entry['name']}", value, entry["expected"], entry["tolerance"],
                     entry.get("unit", ""), note=entry.get("source", ""))
    study = scenario.kinematics_study
    if study.get("paper"):
        # the paper's graphical values at its check position ([kinematics.paper]), within
        # [kinematics] paper_tolerance (relative): a drawing at 0.01 m/mm is read to about 1 mm
        from crankfmu.studies.kinematics import values_at
        exact, detail = values_at(model.scenario, float(study["at_deg"]))
        rel = float(study.get("paper_tolerance", 0.015))
        for name, published in study["paper"].items():
            checks.close(f"{prefix}.paper.{name}_at_{study['at_deg']:g}deg", exact[name], published,
                         rel * abs(published), detail["units"][name],
                         note=f"graphical value, {100 * rel:g} % tolerance")
