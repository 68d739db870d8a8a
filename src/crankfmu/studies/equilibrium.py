"""The equilibrium-moment study (seed 001 Figs. 2-5): M_e(phi1) over a cycle at constant crank
speeds, with and without the inertia forces and moments, the joint reactions, and the checks a
user can read back: the cycle mean of M_e is the technological work per machine cycle over the
cycle's angle (2 pi, or 2 pi cycle_turns: a four-stroke engine's 4 pi).

``equilibrium_study(scenario, [15, 10, 7, 5])`` returns one :class:`SpeedResult` per speed;
``output.write_equilibrium`` writes summary.json, one CSV per speed and the figures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..dynamics.inverse import EquilibriumMoment, equilibrium_moment
from ..dynamics.loads import TECHNOLOGICAL
from ..dynamics.reactions import JointReactions, joint_reactions
from ..errors import ParameterError
from ..numerics import extremes
from ..scenario import load_scenario

TWO_PI = 2.0 * math.pi


@dataclass
class SpeedResult:
    omega1: float                   # rad/s
    moment: EquilibriumMoment       # at the study's crank angles
    reactions: JointReactions       # with inertia
    reactions_static: JointReactions
    mean: float                     # N.m, exact cycle mean of M_e (piecewise Gauss-Legendre)
    tech_work: float                # J per machine cycle (negative: resisting)
    located: dict                   # the extremes located on the exact functions (located_extremes)
    switches: tuple = ()            # rad: where a switched load changes over the cycle (cycle_breaks' inner ones)
    cycle_angle: float = TWO_PI     # rad: the machine's cycle
    switched: str = ""              # the switched loads in words (their [[loads]] descriptions)
    #: with joint friction (dynamics.friction): M_e with it (N.m, Newton-Euler with the frictions,
    #: inertia included) at the study's angles, and its exact cycle mean; None without friction
    with_friction: np.ndarray | None = None
    mean_with_friction: float | None = None

    @property
    def key(self) -> str:
        """The speed as the study's files name it (equilibrium_<key>.csv, Me_omega<key>.png)."""
        return speed_key(self.omega1)

    def summary(self) -> dict:
        e = self.located
        return {
            "omega1": self.omega1,
            "Me_min": e["Me_min"],
            "Me_max": e["Me_max"],
            "Me_mean": self.mean,
            "Me_min_static": e["Me_min_static"],
            "Me_max_static": e["Me_max_static"],
            "inertia_ratio": e["inertia_ratio"],
            "Me_min_at_deg": e["Me_min_at_deg"],
            "Me_max_at_deg": e["Me_max_at_deg"],
            "technological_work_per_cycle_J": self.tech_work,
            "technological_work_over_cycle_angle": -self.tech_work / self.cycle_angle,
            "joint_reaction_peaks": e["joint_reaction_peaks"],
            "joint_reaction_peaks_static": e["joint_reaction_peaks_static"],
            **({} if self.with_friction is None else {
                "Me_min_with_friction": float(np.min(self.with_friction)),
                "Me_max_with_friction": float(np.max(self.with_friction)),
                "Me_mean_with_friction": self.mean_with_friction,
                # the drive's mean power that reaches the loads, where the drive gives work
                "efficiency": self.mean / self.mean_with_friction if self.mean_with_friction > 0.0 else None}),
        }


def located_extremes(model, omega1: float, breaks) -> dict:
    """M_e's extremes with and without inertia, the largest inertia share and the joint reactions'
    peaks at constant omega1, each located by ``numerics.extremes`` on the exact functions (its own
    scan, refined between samples, one-sided limits at the load switches): none depends on the
    study's output grid."""
    def moments(p):
        m = equilibrium_moment(model.reduced, p, omega1)
        return np.vstack([m.total, m.static, m.total - m.static])

    m = extremes(moments, breaks)
    largest_total = max(abs(m["min"][0]), abs(m["max"][0]))
    largest_inertia = max(abs(m["min"][2]), abs(m["max"][2]))
    out = {"Me_min": float(m["min"][0]), "Me_max": float(m["max"][0]),
           "Me_min_static": float(m["min"][1]), "Me_max_static": float(m["max"][1]),
           "inertia_ratio": float(largest_inertia / largest_total),
           "Me_min_at_deg": float(np.degrees(m["min_at"][0]) % (360.0 * model.reduced.cycle_turns)),
           "Me_max_at_deg": float(np.degrees(m["max_at"][0]) % (360.0 * model.reduced.cycle_turns))}
    if model.mechanism.definition.joints:
        for key, inertia in (("joint_reaction_peaks", True), ("joint_reaction_peaks_static", False)):
            kinds = joint_reactions(model.reduced, np.array([0.0]), omega1, inertia=inertia).kind

            def magnitudes(p, inertia=inertia):
                r = joint_reactions(model.reduced, p, omega1, inertia=inertia)
                return np.vstack([r.magnitude(j) for j in kinds]
                                 + [np.abs(r.couple[j]) for j in kinds if kinds[j] == "prismatic"])

            peaks = extremes(magnitudes, breaks)["max"]
            slides = iter(peaks[len(kinds):])
            out[key] = {j: {"kind": kind, "max_force_N": float(peaks[i]),
                            **({"max_couple_Nm": float(next(slides))} if kind == "prismatic" else {})}
                        for i, (j, kind) in enumerate(kinds.items())}
    return out


def parse_speeds(text) -> list[float]:
    """'15,10,7,5' (or a list) -> [15.0, 10.0, 7.0, 5.0]; each speed must be > 0 rad/s."""
    items = text.split(",") if isinstance(text, str) else list(text)
    speeds = []
    for item in items:
        try:
            w = float(item)
        except (TypeError, ValueError):
            raise ParameterError(f"omega1: {item!r} is not a speed in rad/s", "omega1") from None
        if not (math.isfinite(w) and w > 0):
            raise ParameterError(f"omega1 = {item!r}: each crank speed must be > 0 rad/s (the crank turning "
                                 "forward; eq. 1 divides by omega1)", "omega1")
        speeds.append(w)
    if not speeds:
        raise ParameterError("give at least one crank speed (rad/s)", "omega1")
    return speeds


def cycle_breaks(model) -> list[float]:
    """Crank angles (rad) where a load jumps at constant forward speed over the machine's cycle,
    with 0 and its end (2 pi cycle_turns). A switch is the kinematics' (a slider's reversal, a
    velocity's sign): it comes back every turn of the cycle."""
    period, turns = model.reduced.period, model.reduced.cycle_turns
    breaks = {0.0, period}
    angles = [angle for load in model.reduced.sliders       # every switched load: slider forces,
              for angle in load.switch_angles(model.mechanism)]  # direction-dependent loads
    if model.reduced.friction is not None:   # a joint's friction turns round where its joint reverses
        angles += model.reduced.friction.switch_angles()
    for angle in angles:
        breaks |= {angle % TWO_PI + TWO_PI * n for n in range(turns)}
    return sorted(breaks)


def technological_torque(model, phi1, omega1) -> np.ndarray:
    """The technological loads reduced to the crank (N.m) at crank angles phi1 and speed omega1."""
    kin = model.mechanism.kinematics(phi1)
    return sum((load.torque(kin, omega1) for load in model.reduced.loads if load.category == TECHNOLOGICAL),
               np.zeros_like(kin.phi1))


def cycle_mean(fn, breaks, max_width=math.radians(5.0), nodes=16) -> float:
    """The mean of fn(phi1 array) over the pieces between ``breaks`` (from 0 to the cycle's end),
    Gauss-Legendre on each smooth piece."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    total = 0.0
    for a, b in zip(breaks[:-1], breaks[1:]):
        if b <= a:
            continue
        pieces = max(1, int(math.ceil((b - a) / max_width)))
        edges = np.linspace(a, b, pieces + 1)
        mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
        phis = (mid[:, None] + half[:, None] * x[None, :]).ravel()
        total += float(np.sum(fn(phis).reshape(pieces, nodes) * (half[:, None] * w[None, :])))
    return total / (breaks[-1] - breaks[0])


def equilibrium_study(scenario, speeds=None, n_angles: int | None = None) -> list[SpeedResult]:
    """M_e with and without inertia and the joint reactions at each constant crank speed."""
    scenario = load_scenario(scenario)
    spec = scenario.data.get("equilibrium", {})
    speeds = parse_speeds(spec.get("omega1", []) if speeds is None else speeds)
    n_angles = int(spec.get("angles", 360) if n_angles is None else n_angles)
    if n_angles < 8:
        raise ParameterError(f"angles = {n_angles}: use at least 8 crank angles per cycle", "angles")
    model = scenario.build()
    period = model.reduced.period
    phi1 = np.linspace(0.0, period, n_angles * model.reduced.cycle_turns, endpoint=False)
    breaks = cycle_breaks(model)
    results = []
    for w in speeds:
        # the technological loads' work per machine cycle forward (negative: they take work), at this
        # speed (a viscous load's depends on it); a slider force's is also known in closed form (work_per_cycle)
        tech_work = period * cycle_mean(lambda p: technological_torque(model, p, w), breaks)
        moment = equilibrium_moment(model.reduced, phi1, w)
        mean = cycle_mean(lambda p: equilibrium_moment(model.reduced, p, w).total, breaks)
        reactions = joint_reactions(model.reduced, phi1, w)
        friction = {}
        if model.reduced.friction is not None:
            # the power balance (equilibrium_moment) is the papers' frictionless M_e; Newton-Euler
            # with the frictions gives the drive's moment with them
            friction = {"with_friction": reactions.driving_moment, "mean_with_friction": cycle_mean(
                lambda p: joint_reactions(model.reduced, p, w).driving_moment, breaks)}
        results.append(SpeedResult(
            omega1=w, moment=moment,
            reactions=reactions,
            reactions_static=joint_reactions(model.reduced, phi1, w, inertia=False),
            mean=mean, tech_work=tech_work, located=located_extremes(model, w, breaks),
            switches=tuple(breaks[1:-1]), cycle_angle=period,
            switched=scenario.describe_loads(model.reduced, [model.reduced.loads.index(s) for s in model.reduced.sliders]),
            **friction))
    return results


#: the crank speed of a start from rest (rad/s): the limit omega1 -> 0+, in which a slider force
#: has its forward value, a damper none, and the inertia forces vanish
START_SPEED = float(np.finfo(float).tiny)


@dataclass
class StartupTorque:
    """The drive torque that starts the crank forward from rest at each crank angle (N.m): the
    static M_e (omega1 -> 0+, no inertia) with the joints' static friction opposing the start,
    and without friction. Its largest value is what the drive must give at rest to start the
    machine from any angle."""

    phi1: np.ndarray            # rad
    with_friction: np.ndarray   # N.m
    without: np.ndarray         # N.m

    def summary(self) -> dict:
        i, j = int(np.argmax(self.with_friction)), int(np.argmax(self.without))
        return {"startup_torque": float(self.with_friction[i]), "at_deg": float(np.degrees(self.phi1[i])),
                "startup_torque_without_friction": float(self.without[j]),
                "without_friction_at_deg": float(np.degrees(self.phi1[j])),
                "grid_deg": float(np.degrees(self.phi1[1] - self.phi1[0]))}


def startup_torque(model, n_angles: int = 720) -> StartupTorque:
    """The start-up torque (StartupTorque) on ``n_angles`` crank angles per turn over the cycle."""
    phi1 = np.linspace(0.0, model.reduced.period, n_angles * model.reduced.cycle_turns, endpoint=False)
    with_friction = joint_reactions(model.reduced, phi1, START_SPEED, inertia=False).driving_moment
    return StartupTorque(phi1, with_friction, equilibrium_moment(model.reduced, phi1, START_SPEED).static)


def speed_key(w: float) -> str:
    return f"{w:g}"


