"""Kinematic studies at constant crank speed, as the kinematics papers run them.

``values_at``  every velocity and acceleration of the scenario's ``[kinematics]`` points at one
               crank angle, the link's angular velocity and instant centre (seed 002).
``time_series``  the scenario's outputs over time at constant omega1, with the paper's
               approximate model beside them (seed 002 Figs. 6-9).
``cycle``      the outputs over one crank turn, the slider's stroke and the time ratio from the
               exact extremes (roots of the analytic transfer function), the arm's swing (seed 004).

Everything comes from the contour engine's analytic transfer functions; nothing here is specific
to one mechanism beyond what the scenario file names.
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics import extremes
from ..errors import CrankfmuError, ParameterError
from ..mechanisms.quantities import evaluate_all
from .paper_models import APPROXIMATIONS

TWO_PI = 2.0 * math.pi


def study_settings(scenario) -> dict:
    """The scenario's [kinematics] section (omega1, angles, the paper's values), or a clear error."""
    ks = scenario.kinematics_study
    if not ks:
        raise CrankfmuError(f"scenario {scenario.name} has no [kinematics] section: it is not a kinematic study")
    return ks


def crank_speed(scenario, omega1=None) -> float:
    w = float(study_settings(scenario).get("omega1", 0.0) if omega1 is None else omega1)
    if not (math.isfinite(w) and w > 0):
        raise ParameterError(f"omega1 must be a crank speed > 0 rad/s, got {w!r}", "omega1")
    return w


def values_at(scenario, at_deg: float, omega1: float | None = None) -> tuple[dict, dict]:
    """(values, detail) at crank angle ``at_deg`` (deg) and constant omega1 (rad/s).

    values: magnitudes in SI units, named v_P, a_P for each point P, Omega<k> and eps<k> for the
    study's link, v_PQ for each relative pair, I<k>_x, I<k>_y and I<k>P for the instant centre.
    detail: the signed vectors, the units and the instant centre's construction.
    """
    ks = study_settings(scenario)
    if not math.isfinite(at_deg):
        raise ParameterError(f"--at must be a crank angle in deg, got {at_deg!r}", "at")
    w = crank_speed(scenario, omega1)
    mechanism = scenario.assembled_mechanism()[0]
    definition = scenario.mechanism_definition()
    kin = mechanism.kinematics(np.array([math.radians(at_deg)]))
    pos, vel, acc = {}, {}, {}
    for p in ks["points"]:
        x, y, dx, dy, ddx, ddy = (float(a[0]) for a in kin.point(p))
        pos[p], vel[p], acc[p] = np.array([x, y]), np.array([dx, dy]) * w, np.array([ddx, ddy]) * w * w
    label = str(ks.get("link_label", ""))
    link = definition.links[ks["link"]]
    _, q, qq = (float(a[0]) for a in kin.link_angle(ks["link"]))
    Omega, eps = q * w, qq * w * w
    values, units = {}, {}
    for p in ks["points"]:
        values[f"v_{p}"], units[f"v_{p}"] = float(np.hypot(*vel[p])), "m/s"
    values[f"Omega{label}"], units[f"Omega{label}"] = abs(Omega), "rad/s"
    for a, b in ks.get("relative", []):
        values[f"v_{a}{b}"], units[f"v_{a}{b}"] = float(np.hypot(*(vel[a] - vel[b]))), "m/s"
    detail = {"at_deg": at_deg, "omega1": w, "link": ks["link"], "link_angle": link.angle,
              "Omega_signed": Omega, "eps_signed": eps,
              "positions": {p: pos[p].tolist() for p in pos}, "velocities": {p: vel[p].tolist() for p in vel},
              "accelerations": {p: acc[p].tolist() for p in acc}}
    if Omega != 0.0:
        # v_P = Omega k x (P - I)  =>  I = P + (k x v_P) / Omega, from the first point on the link
        p0 = ks["points"][0]
        centre = pos[p0] + np.array([-vel[p0][1], vel[p0][0]]) / Omega
        values[f"I{label}_x"], values[f"I{label}_y"] = float(centre[0]), float(centre[1])
        units[f"I{label}_x"] = units[f"I{label}_y"] = "m"
        for p in ks["points"]:
            values[f"I{label}{p}"], units[f"I{label}{p}"] = float(np.hypot(*(pos[p] - centre))), "m"
        detail["instant_centre_from"] = p0
    for p in ks["points"]:
        if p != ks["points"][0]:
            values[f"a_{p}"], units[f"a_{p}"] = float(np.hypot(*acc[p])), "m/s2"
    values[f"eps{label}"], units[f"eps{label}"] = abs(eps), "rad/s2"
    detail["units"] = units
    return values, detail


def compare_with_paper(scenario, values: dict) -> list[dict]:
    """Rows (name, exact, paper, relative difference) for the paper's published values."""
    paper = study_settings(scenario).get("paper", {})
    return [{"name": k, "exact": values[k], "paper": float(v), "rel_diff": (float(v) - values[k]) / values[k]}
            for k, v in paper.items() if k in values]


def time_series(scenario, omega1: float | None = None, span: float | None = None, n: int = 2001) -> dict:
    """The scenario's outputs over time at constant omega1, the path of the study's point and, when
    the scenario names one, the paper's approximation of the same quantities and its largest errors."""
    ks = study_settings(scenario)
    w = crank_speed(scenario, omega1)
    span = float(ks.get("span", TWO_PI / w) if span is None else span)
    t = np.linspace(0.0, span, n)
    phi = w * t
    mechanism = scenario.assembled_mechanism()[0]
    kin = mechanism.kinematics(phi)
    wanted = [q for q in scenario.quantities if q.name in ks.get("time_series", [])]
    exact = evaluate_all(wanted, kin, w)
    out = {"time": t, "phi1": phi, "exact": exact, "units": {q.name: q.unit(scenario.mechanism_definition())
                                                             for q in wanted}}
    if "path" in ks:
        x, y = kin.point(ks["path"])[:2]
        out["path"] = (x, y)
    out["figures"] = dict(ks.get("figures", {}))     # our figure -> the paper's that it reproduces
    approx_name = ks.get("approximation")
    if approx_name:
        approx = APPROXIMATIONS[approx_name](scenario.values, phi, w)
        out["approx"] = approx
        errors = {name: float(np.max(np.abs(approx[name] - exact[name]))) for name in exact if name in approx}
        if "path" in approx and "path" in out:
            errors["path"] = float(np.max(np.hypot(approx["path"][0] - out["path"][0],
                                                   approx["path"][1] - out["path"][1])))
        out["approx_errors"] = errors
        out["approx_name"] = approx_name
    return out


def cycle(scenario, quantities, omega1: float | None = None, n: int = 3600) -> dict:
    """Quantities over one crank turn at constant omega1, their peaks, and for the study's slider and
    arm: stroke, time ratio (slow stroke over quick return, in crank angle = in time) and swing."""
    ks = study_settings(scenario)
    w = crank_speed(scenario, omega1)
    mechanism = scenario.assembled_mechanism()[0]
    phi = np.linspace(0.0, TWO_PI, n, endpoint=False)
    kin = mechanism.kinematics(phi)
    wanted = [q for q in scenario.quantities if q.name in quantities]
    series = evaluate_all(wanted, kin, w)
    # the peaks located on the exact transfer functions, not read off the n samples
    if wanted:
        located = extremes(lambda p: np.vstack(list(evaluate_all(wanted, mechanism.kinematics(p), w).values())),
                           [0.0, TWO_PI])
        peaks = {f"max_abs_{q.name}": float(max(abs(lo), abs(hi)))
                 for q, lo, hi in zip(wanted, located["min"], located["max"])}
    else:
        peaks = {}
    out = {"phi1": phi, "series": series, "peaks": peaks}
    slider = ks.get("stroke_of")
    if slider:
        ext = [a for a, _ in mechanism.stationary_angles(lambda kin: kin.dq[slider])]
        if len(ext) != 2:
            raise CrankfmuError(f"{slider} has {len(ext)} extreme positions per turn, not 2: no stroke defined")
        values = mechanism.kinematics(np.array(ext)).q[slider]
        arc = (ext[1] - ext[0]) % TWO_PI
        out["stroke"] = float(abs(values[1] - values[0]))
        out["time_ratio"] = float(max(arc, TWO_PI - arc) / min(arc, TWO_PI - arc))
        out["slider_extremes_deg"] = [math.degrees(e) for e in ext]
    arm = ks.get("arm")
    if arm:
        ext = [a for a, _ in mechanism.stationary_angles(lambda kin: kin.dq[arm])]
        values = mechanism.kinematics(np.array(ext)).q[arm]
        out["arm_swing"] = float(abs(values[1] - values[0])) if len(ext) == 2 else float("nan")
    return out
