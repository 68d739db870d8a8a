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


def reduced_inertia_max(entry, model, fmu_run):
    """The largest reduced inertia J_red over the turn (kg.m2), from the FMU's own output over its run."""
    return float(max(fmu_run["J_red"]))


#: flywheel designs made in this process, by scenario (file and values) and delta: the Python and the
#: native FMU of one scenario share one (a design takes about 10 s)
_FLYWHEELS: dict = {}


def flywheel(entry, model, fmu_run):
    """``key`` of ``crankfmu flywheel``'s design for the coefficient of speed fluctuation ``delta``
    (studies.flywheel.FlywheelDesign: e.g. omega_peak_reduction, epsilon_peak_reduction)."""
    from crankfmu.studies.flywheel import design_flywheel

    scenario, delta = model.scenario, float(entry["delta"])
    key = (str(scenario.where), tuple(sorted(scenario.values.items())), delta)
    if key not in _FLYWHEELS:
        _FLYWHEELS[key] = design_flywheel(scenario, delta)
    return float(getattr(_FLYWHEELS[key], entry["key"]))


QUANTITIES = {f.__name__: f for f in (rocker_extreme_deg, settled_change, kinematic_cycle, inertia_ratio,
                                      reduced_inertia_min, reduced_inertia_max, flywheel)}

#: a [[paper]] entry's verdict (checks.py has what each counts as): it agrees (independent evidence
#: within its tolerance); it disagrees (the file says why, ``disagrees``, and what this data set gives
#: instead, ``ours``, checked to ``tolerance`` so a change shows); it is fitted (``fitted``: the data
#: set was chosen to give it, so it is shown and checked but is no evidence); or it cannot be compared
#: (``not_comparable``, the reason)
VERDICTS = ("agrees", "disagrees", "fitted", "not comparable")


def check_paper(scenario, model, fmu_run, checks, prefix: str):
    """One check per ``[[paper]]`` entry of the scenario file, each with its verdict (``Check.verdict``)
    and the status that verdict counts as (``Check.status``)."""
    for entry in scenario.data.get("paper", []):
        name = f"{prefix}.paper.{entry['name']}"
        source = entry.get("source", "")
        if "not_comparable" in entry:
            check = checks.skip(name, f"not comparable: {entry['not_comparable']} ({source})")
            check.expected, check.verdict = _published(entry), "not comparable"
            check.published = _published(entry)
            check.set_status("not comparable")
            continue
        quantity = QUANTITIES.get(entry.get("quantity"))
        if quantity is None:
            raise DefinitionError(f"{scenario.where}: [[paper]] {entry.get('name')!r}: unknown quantity "
                                  f"{entry.get('quantity')!r} (known: {', '.join(QUANTITIES)})")
        value = quantity(entry, model, fmu_run)
        published, tol = float(entry["expected"]), float(entry["tolerance"])
        agrees = abs(value - published) <= tol
        if "disagrees" in entry:
            if "ours" not in entry:
                raise DefinitionError(f"{scenario.where}: [[paper]] {entry['name']!r}: a disagreement needs "
                                      "ours = the value this data set gives")
            check = checks.close(name, value, float(entry["ours"]), tol, entry.get("unit", ""),
                                 note=f"{entry['disagrees']} ({source})")
            if agrees:       # the file says it disagrees and it no longer does: the file is out of date
                check.note = f"now agrees with the published {published:g}: the file's disagreement is stale ({source})"
                check.verdict, status = "changed", "failed"
            elif check.passed:
                check.verdict, status = "disagrees", "disagrees"
            else:
                check.verdict, status = "changed", "failed"
        elif "fitted" in entry:
            check = checks.close(name, value, published, tol, entry.get("unit", ""),
                                 note=f"fitted: {entry['fitted']} ({source})")
            check.verdict, status = ("fitted", "fitted") if check.passed else ("changed", "failed")
        else:
            check = checks.close(name, value, published, tol, entry.get("unit", ""), note=source)
            check.verdict, status = ("agrees", "passed") if check.passed else ("disagrees, unexplained", "failed")
        check.published = _published(entry)
        check.set_status(status)
    study = scenario.kinematics_study
    if study.get("paper"):
        # the paper's graphical values at its check position ([kinematics.paper]), within
        # [kinematics] paper_tolerance (relative): a drawing at 0.01 m/mm is read to about 1 mm
        from crankfmu.studies.kinematics import values_at
        exact, detail = values_at(model.scenario, float(study["at_deg"]))
        rel = float(study.get("paper_tolerance", 0.015))
        for name, published in study["paper"].items():
            check = checks.close(f"{prefix}.paper.{name}_at_{study['at_deg']:g}deg", exact[name], published,
                                 rel * abs(published), detail["units"][name],
                                 note=f"graphical value, {100 * rel:g} % tolerance")
            check.verdict = "agrees" if check.passed else "disagrees, unexplained"
            check.published = f"{published:g} {detail['units'][name]}"


def _published(entry) -> str:
    """The published value as the report shows it: the file's ``published`` wording where the paper
    states no number (``negligible``), else the number with its unit."""
    if "published" in entry:
        return str(entry["published"])
    unit = entry.get("unit", "")
    return f"{entry['expected']:g} {'' if unit == '1' else unit}".strip()
