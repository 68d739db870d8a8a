"""Flywheel sizing (seed 003 section 8, eqs. 16-17) and the eq. 3 step-size study.

* The steady cycle (studies/steady_cycle.py): the periodic solution omega1(phi1) of the movement
  equation in the crank angle, and delta = (omega_max - omega_min) / omega_m.
* Eq. 17: J_F = dW_max / (omega_m^2 [delta]) with dW_max = E_max - E_min, the largest swing of
  the work of the loads against a constant driving torque equal to their mean (the paper's
  assumption in eq. 15), omega_m from the steady cycle without flywheel. Eq. 16 subtracts the
  mechanism's own J_e (its cycle mean).
* The simulated flywheel: the J_F whose steady cycle has delta = [delta], by Brent's method on
  delta(J_F). The motor line's slope regulates the speed too, which eqs. 16-17 ignore. delta(J_F)
  comes from ``batch.SteadyBatch`` (the fast kernel, many flywheels in one call: a ladder of J_F
  brackets the root in one call, then each Brent step is one design); the crank-angle solution
  above is computed for no flywheel and for the one found, for the figures and peaks, and its
  delta is reported beside the batch's as an independent check.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.optimize import brentq

from .batch import SteadyBatch
from .equilibrium import cycle_breaks
from .steady_cycle import SteadyCycle, steady_cycle
from ..errors import CrankfmuError, ParameterError, SchemeError
from ..numerics import extremes
from ..scenario import load_scenario

TWO_PI = 2.0 * math.pi
@dataclass
class FlywheelDesign:
    """The flywheel for a target coefficient of speed fluctuation (what flywheel.json holds)."""

    scenario: str
    delta_target: float
    J_e_min: float                  # kg.m2, the mechanism's own reduced inertia over the turn
    J_e_max: float
    J_e_mean: float
    J_e_min_at_deg: float           # deg (paper's phi)
    J_e_max_at_deg: float
    dW_max: float                   # J, the largest swing of the loads' work (eq. 17)
    omega_m: float                  # rad/s, the steady cycle's time mean without flywheel
    J_F_eq17: float                 # kg.m2
    J_F_simulated: float            # the J_F whose simulated steady cycle has delta_target
    delta_achieved: float           # by the fast kernel's steady cycle (batch)
    delta_without_flywheel: float   # with J_F = 0: inf (null in flywheel.json) where the machine stalls
    delta_baseline: float           # with the flywheel the design starts from (0, or the file's)
    delta_with_J_F_eq17: float
    steady_cycle_solves: int
    without: SteadyCycle = field(repr=False)     # the steady cycles in the crank angle (engine)
    with_flywheel: SteadyCycle = field(repr=False)
    #: kg.m2: the flywheel of the cycle "without": 0, or the file's own where the machine has no
    #: steady cycle without one (an engine stalls in its compression stroke)
    baseline_J_flywheel: float = 0.0
    #: why the design starts from the file's flywheel ("" when it starts from none)
    baseline_reason: str = ""
    #: what in this machine eq. 17 leaves out (it takes J constant and the torques independent of
    #: the speed): why its flywheel differs from the simulated one
    eq17_departures: list = field(default_factory=list)
    #: (phi1 rad, dW J) over the machine's cycle at omega_m: energy_swing's curve, whose range is
    #: dW_max (the turning moment diagram draws it)
    swing: tuple = field(default=None, repr=False)

    UNITS = {"J_*": "kg.m2", "dW_max": "J", "omega_*": "rad/s", "epsilon_*": "rad/s2", "delta*": "1",
             "steady_cycle_solves": "batch calls of the fast kernel (one or many flywheels each)",
             "*_reduction": "1 (fraction of the value without flywheel)", "*_at_deg": "deg (paper's phi)"}
    #: flywheel.json's keys, in order (fields and the figures derived from the two cycles)
    SUMMARY = ("scenario", "delta_target", "baseline_J_flywheel", "baseline_reason", "eq17_departures", "J_e_min", "J_e_max", "J_e_mean", "J_e_min_at_deg",
               "J_e_max_at_deg", "dW_max", "omega_m", "J_F_eq17", "J_F_eq16", "J_F_simulated", "delta_achieved",
               "delta_achieved_crank_angle", "delta_without_flywheel", "delta_baseline", "delta_baseline_crank_angle",
               "delta_with_J_F_eq17", "steady_cycle_solves", "omega_peak_without", "omega_peak_with",
               "omega_peak_reduction", "epsilon_peak_without", "epsilon_peak_with", "epsilon_peak_reduction")

    @property
    def J_F_eq16(self) -> float:
        """Eq. 16: eq. 17's flywheel less the mechanism's own mean reduced inertia (kg.m2)."""
        return self.J_F_eq17 - self.J_e_mean

    @property
    def delta_achieved_crank_angle(self) -> float:
        """delta of the crank-angle steady cycle with the flywheel found: the independent check."""
        return self.with_flywheel.delta

    @property
    def delta_baseline_crank_angle(self) -> float:
        """delta of the crank-angle steady cycle the design starts from: delta_baseline's check."""
        return self.without.delta

    @property
    def omega_peak_without(self) -> float:
        return float(self.without.omega1.max())

    @property
    def omega_peak_with(self) -> float:
        return float(self.with_flywheel.omega1.max())

    @property
    def omega_peak_reduction(self) -> float:
        return float(1.0 - self.with_flywheel.omega1.max() / self.without.omega1.max())

    @property
    def epsilon_peak_without(self) -> float:
        return float(np.max(np.abs(self.without.epsilon1)))

    @property
    def epsilon_peak_with(self) -> float:
        return float(np.max(np.abs(self.with_flywheel.epsilon1)))

    @property
    def epsilon_peak_reduction(self) -> float:
        return float(1.0 - np.max(np.abs(self.with_flywheel.epsilon1)) / np.max(np.abs(self.without.epsilon1)))

    def summary(self) -> dict:
        """The numbers (not the cycles) with their units, as flywheel.json writes them (a delta
        with no steady cycle, which is infinite, as null)."""
        values = {name: getattr(self, name) for name in self.SUMMARY}
        return {**{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in values.items()},
                "units": self.UNITS}


@dataclass
class Eq3Stability:
    """Where the angle step of the paper's eq. 3 stops being stable."""

    turns: int
    rows: list[dict]                # per step tried: step_deg, stable, error (rad/s), reason
    limit: dict | None              # largest_stable_deg, smallest_unstable_deg (bisected)
    linear_estimate_deg: float      # 2 J omega1 / B at the cycle's worst point
    J_flywheel: float               # kg.m2
    #: why the study was not run ("" where it was): the scheme does not take the machine (joint friction)
    skipped: str = ""


@dataclass
class FlywheelStudy:
    """Everything ``crankfmu flywheel`` computes: the flywheel, the eq. 3 study and the movement from
    the start without flywheel (the reference and eq. 3 at 1 deg, for Fig. 6)."""

    design: FlywheelDesign
    stability: Eq3Stability
    movement: dict                  # settled angle (deg), eq. 3's largest error at 1 deg (rad/s)
    scenario: object = field(repr=False)       # the scenario without flywheel
    angle_offset: float = 0.0                  # rad, the paper's phi = 0
    reference: object = field(default=None, repr=False)
    eq3: object = field(default=None, repr=False)
    _model: object = field(default=None, repr=False, compare=False)

    @property
    def model(self):
        """The scenario's model (without flywheel), built once for every figure that reads it: an
        engine's build tabulates its loads."""
        if self._model is None:
            self._model = self.scenario.build()
        return self._model

    def friction_torque(self, phi1) -> np.ndarray | None:
        """The joints' friction on the crank (N.m) at the crank angles ``phi1`` turning steadily at
        the design's omega_m, as eq. 17's swing counts it (friction_torque); None without friction."""
        return friction_torque(self.model, phi1, self.design.omega_m)

    def summary(self) -> dict:
        """What flywheel.json holds."""
        return {**self.design.summary(), "eq3_stability": asdict(self.stability), "movement": self.movement}


def friction_torque(model, phi1, omega1: float) -> np.ndarray | None:
    """The joints' friction reduced to the crank (N.m, <= 0) at the crank angles ``phi1`` (rad) of a
    crank turning at the constant ``omega1`` (rad/s, > 0): eq. 17's machine at its mean speed, epsilon1
    0, each friction the one that motion's reactions give (dynamics.reactions.joint_reactions, the
    motion given); None without joint friction."""
    if model.reduced.friction is None:
        return None
    from ..dynamics.reactions import joint_reactions

    found = joint_reactions(model.reduced, np.asarray(phi1, dtype=float), omega1, 0.0)
    return sum(found.friction_power.values()) / omega1


def energy_swing(model, n: int = 20001, omega1: float = 1.0) -> tuple[float, np.ndarray, np.ndarray]:
    """dW_max (J) of eqs. 16-17 and the curve dW(phi1) over the machine's cycle: the loads' work
    against their mean. The loads of the speed at ``omega1`` (rad/s: the cycle's mean speed; a
    slider force reads only its sign), and the joints' friction there (friction_torque)."""
    breaks = cycle_breaks(model)
    cycle, turns = model.reduced.period, model.reduced.cycle_turns
    x, wts = np.polynomial.legendre.leggauss(8)
    grid = np.unique(np.concatenate([np.linspace(0.0, cycle, (n - 1) * turns + 1), breaks]))
    lo, hi = grid[:-1], grid[1:]
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    nodes = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    J, half_dJ, Q, kin = model.reduced.coefficients(nodes)
    if model.reduced.velocity_dependent:
        Q = Q + model.reduced.velocity_load(kin, np.full_like(nodes, omega1))   # forward, at the mean speed
    friction = friction_torque(model, nodes, omega1)
    if friction is not None:
        Q = Q + friction
    work = np.sum(Q.reshape(-1, x.size) * wts[None, :], axis=1) * half
    cumulative = np.concatenate([[0.0], np.cumsum(work)])
    swing = cumulative - cumulative[-1] / cycle * grid
    return float(swing.max() - swing.min()), grid, swing


def design_flywheel(scenario, delta: float, phi0: float | None = None, rtol: float = 1e-11,
                    progress=None) -> FlywheelDesign:
    """The flywheel for a target coefficient of speed fluctuation ``delta``.

    ``progress`` is called with 1, 2, 3 as the cycle without flywheel, the search and the cycle
    with the flywheel found are done."""
    scenario = load_scenario(scenario)
    try:
        delta = float(delta)
    except (TypeError, ValueError):
        raise ParameterError(f"delta must be a number, got {delta!r}", "delta") from None
    if not (math.isfinite(delta) and 0.0 < delta < 1.0):
        raise ParameterError(f"delta = {delta!r}: the target coefficient of speed fluctuation must lie in "
                             "(0, 1), e.g. 0.05", "delta")
    spec = scenario.data.get("flywheel", {})
    phi0 = float(spec.get("angle_offset", 0.0) if phi0 is None else phi0)
    base, free, reason = baseline(scenario, phi0, rtol)
    model = base.build()
    grid = np.linspace(0.0, TWO_PI, 3601)
    J_e = model.reduced.coefficients(grid)[0] - model.reduced.J_flywheel
    # the reduced inertia's extremes located on the exact function (the mean is the grid's: the
    # trapezoid rule on a periodic smooth function is exact to rounding)
    J_e_ext = extremes(lambda p: model.reduced.coefficients(p)[0] - model.reduced.J_flywheel, [0.0, TWO_PI])
    if progress is not None:
        progress(1)
    omega_m = free.omega_mean
    dW, swing_grid, swing = energy_swing(model, omega1=omega_m)
    J_eq17 = dW / (omega_m ** 2 * delta)

    # delta(J_F) of many flywheels at once on the fast kernel, the table built once
    batch = SteadyBatch(base, rtol=rtol, shoot_tol=1e-12)
    calls = [0]

    def deltas(J_values) -> np.ndarray:
        """delta of each flywheel; infinite where the machine stalls with it (too small a flywheel
        for an engine's compression stroke), so the search brackets past it"""
        calls[0] += 1
        found = batch.run([{"J_flywheel": float(J)} for J in J_values])
        if len(found.failed) == len(J_values) and not found.rows:
            bad = found.failed[0]
            raise CrankfmuError(f"no steady cycle with J_flywheel = {bad['J_flywheel']:g} kg.m2: {bad['reason']}")
        delta_of = {row["J_flywheel"]: row["delta"] for row in found.rows}
        return np.array([delta_of.get(float(J), math.inf) for J in J_values])

    # one call brackets the root: no flywheel, eq. 17's and a ladder of factors of 2 around it
    scale = J_eq17 if math.isfinite(J_eq17) and J_eq17 > 0.0 else 1.0
    J_base = float(base["J_flywheel"])
    ladder = np.concatenate([[0.0, J_eq17 if math.isfinite(J_eq17) else 0.0, J_base],
                             scale * 2.0 ** np.arange(-10, 4)])
    ladder_deltas = deltas(ladder)
    delta_free, delta_eq17, delta_base = (float(d) for d in ladder_deltas[:3])
    if delta_free <= delta:
        J_sim = 0.0
    else:
        order = np.argsort(ladder)
        J_sorted, d_sorted = ladder[order], ladder_deltas[order]
        below = np.nonzero(d_sorted <= delta)[0]
        if below.size:
            lo, hi = float(J_sorted[below[0] - 1]), float(J_sorted[below[0]])
        else:
            lo, hi = float(J_sorted[-1]), float(J_sorted[-1])
            while deltas([hi])[0] > delta:
                lo, hi = hi, 2.0 * hi
                if hi > 1e9:
                    raise CrankfmuError(f"no flywheel up to 1e9 kg.m2 reaches delta = {delta:g}")
        J_sim = brentq(lambda J_F: deltas([J_F])[0] - delta, lo, hi, xtol=1e-10, rtol=1e-12)
    delta_achieved = float(deltas([J_sim])[0])
    if progress is not None:
        progress(2)
    # the periodic solutions themselves (plots, peaks), by the crank-angle form on the engine: an
    # independent check of the fast kernel's delta
    fitted = free if J_sim == 0.0 else steady_cycle(base.with_params(J_flywheel=J_sim).build(), phi0, rtol,
                                                     omega_guess=free.omega1[0])
    if progress is not None:
        progress(3)
    return FlywheelDesign(
        scenario=scenario.name,
        delta_target=delta,
        J_e_min=float(J_e_ext["min"][0]),
        J_e_max=float(J_e_ext["max"][0]),
        J_e_mean=float(J_e[:-1].mean()),
        J_e_min_at_deg=float(np.degrees(J_e_ext["min_at"][0] - phi0) % 360),
        J_e_max_at_deg=float(np.degrees(J_e_ext["max_at"][0] - phi0) % 360),
        dW_max=dW,
        omega_m=omega_m,
        J_F_eq17=J_eq17,
        J_F_simulated=float(J_sim),
        delta_achieved=delta_achieved,
        delta_without_flywheel=delta_free,
        delta_baseline=delta_base,
        delta_with_J_F_eq17=delta_eq17,
        steady_cycle_solves=calls[0],
        without=free,
        with_flywheel=fitted,
        baseline_J_flywheel=J_base,
        baseline_reason=reason,
        eq17_departures=eq17_departures(base, model, J_e, J_sim, omega_m),
        swing=(swing_grid, swing),
    )


def eq17_departures(scenario, model, J_e, J_F: float, omega_m: float) -> list[str]:
    """What of this machine eq. 17 (J_F = dW_max / (omega_m^2 delta)) does not hold, in words from
    its data: eq. 17 takes the reduced inertia as constant and the driving and resisting torques
    as independent of the speed, so a varying J (its inertia torque 0.5 J' omega1^2 moves energy
    too), a motor line with a slope and loads of the speed (both damp the fluctuation) each move
    the flywheel the simulation finds away from eq. 17's."""
    out = []
    total = J_F + float(np.mean(J_e[:-1]))
    swing = float(np.max(J_e) - np.min(J_e))
    if total > 0 and swing > 0.01 * total:
        out.append(f"the reduced inertia varies by {100 * swing / total:.0f} % over the turn with the flywheel found "
                   "(its inertia torque 0.5 J' omega1^2 moves energy too)")
    B = float(model.motor.B)
    if B > 0.0:
        out.append(f"the motor line's torque falls with the speed (B = {B:g} N.m.s/rad), which damps the fluctuation")
    if model.reduced.friction is not None:
        out.append("the joints' friction follows the reactions, which the speed's fluctuation and the acceleration "
                   "change; eq. 17 counts it at omega_m with epsilon1 = 0")
    grid = np.linspace(0.0, model.reduced.period, 73)
    kin = model.mechanism.kinematics(grid)
    words = scenario.load_words()
    for load, entry in zip(model.reduced.loads, model.reduced.load_entries):
        if load.position_only:
            continue
        at = [np.asarray(load.torque(kin, np.full_like(grid, w)), dtype=float) for w in (omega_m, 1.1 * omega_m)]
        if np.max(np.abs(at[1] - at[0])) > 1e-9 * max(float(np.max(np.abs(at[0]))), 1e-300):
            out.append(f"{words[entry]} depends on the speed, which damps the fluctuation")
    return out


def baseline(scenario, phi0: float, rtol: float):
    """(scenario, steady cycle, why not without a flywheel) the flywheel is sized from: without a flywheel (the papers'
    machines), or with the file's own where there is no steady cycle without one (a single-cylinder
    engine stalls in its compression stroke: its crank speed falls to 0)."""
    base = scenario.with_params(J_flywheel=0.0)
    try:
        return base, steady_cycle(base.build(), phi0, rtol), ""
    except (SchemeError, CrankfmuError) as exc:
        J_own = float(scenario["J_flywheel"])
        if not J_own > 0.0:
            raise SchemeError(f"no steady cycle without a flywheel ({exc}); give the file a flywheel "
                              "(J_flywheel > 0) to start the design from") from None
        base = scenario.with_params(J_flywheel=J_own)
        why = str(exc).split("; ")[0].removeprefix("steady cycle: ").rstrip(".")
        reason = (f"with J_flywheel = 0 the search for a steady cycle fails ({why}): the design starts from the "
                  f"file's {J_own:g} kg.m2")
        return base, steady_cycle(base.build(), phi0, rtol), reason


# ---------------------------------------------------------------------------------------------
# the paper's eq. 3 scheme: where its angle step stops being stable

def eq3_stability(scenario, steps_deg, turns: int = 20, steady: SteadyCycle | None = None,
                  resolution_deg: float = 0.01, progress=None) -> Eq3Stability:
    """Run eq. 3 (``lv-eq3``) from the scenario's start for ``turns`` crank turns at each angle step.

    A step is *stable* when the run completes and its last turn stays within 10 % of omega_m of
    the steady cycle; an explicit scheme past its limit instead grows an oscillation that flips
    sign every step until omega1 <= 0 (SchemeError). The limit is then bisected to
    ``resolution_deg``. Linearising eq. 3 about the steady cycle gives the estimate
    dphi < 2 J omega1 / B (the motor line's slope B = -dM/domega1 is the stiff term).
    """
    from ..simulation import simulate

    scenario = load_scenario(scenario)
    model = scenario.build()
    phi0 = float(model.y0[0])
    if steady is None:
        steady = steady_cycle(model, phi0)
    J = model.reduced.coefficients(steady.phi1)[0]
    slope = model.motor.B if steady.omega1.min() > model.motor.omega_switch else model.motor.B_low
    estimate = float(np.degrees(np.min(2.0 * J * steady.omega1 / slope))) if slope > 0 else math.inf
    # the turns and a machine cycle more (a second more made an engine at 3600 rpm run 30 cycles more)
    t_end = (turns * 1.05 + 1.0) * steady.period
    calls = [0]

    def run(step):
        calls[0] += 1
        if progress is not None:
            progress(calls[0])
        try:
            r = simulate(scenario, method="lv-eq3", angle_step=math.radians(step), t_end=t_end)
        except SchemeError as exc:
            return {"step_deg": step, "stable": False, "error": None, "reason": str(exc).split(". ")[0]}
        phi, omega = r.trajectory.y[0], r.trajectory.y[1]
        last = phi >= phi[-1] - steady.angle
        ref = np.interp((phi[last] - phi0) % steady.angle + phi0, steady.phi1, steady.omega1)
        error = float(np.max(np.abs(omega[last] - ref)))
        stable = bool(np.all(np.isfinite(omega)) and error < 0.1 * steady.omega_mean)
        return {"step_deg": step, "stable": stable, "error": error,
                "reason": "" if stable else f"last-turn error {error:.3g} rad/s > 10 % of omega_m"}

    rows = [run(float(s)) for s in steps_deg]
    stable = [r["step_deg"] for r in rows if r["stable"]]
    unstable = [r["step_deg"] for r in rows if not r["stable"] and r["step_deg"] > max(stable, default=0.0)]
    limit = None
    if stable and unstable:
        lo, hi = max(stable), min(unstable)
        while hi - lo > resolution_deg:
            mid = 0.5 * (lo + hi)
            if run(mid)["stable"]:
                lo = mid
            else:
                hi = mid
        limit = {"largest_stable_deg": lo, "smallest_unstable_deg": hi}
    return Eq3Stability(turns, rows, limit, estimate, scenario["J_flywheel"])


# ---------------------------------------------------------------------------------------------
# the study behind `crankfmu flywheel`: figures and flywheel.json

#: what ``flywheel_study`` reports to ``progress``: 1..3 the flywheel (design_flywheel), 4 the eq. 3
#: study, 5 the movement from the start (the caller's 6: the figures)
STUDY_STAGES = 6


def flywheel_study(scenario, delta: float, steps_deg=None, progress=None) -> FlywheelStudy:
    """J_e, the equivalent torque and the movement from the start (Figs. 3, 5, 6), the flywheel
    (eqs. 16-17 and simulated, Fig. 7) and the eq. 3 stability study (output.write_flywheel writes
    flywheel.json and the figures)."""
    from ..simulation import simulate

    scenario = load_scenario(scenario)
    spec = scenario.data.get("flywheel", {})
    offset = float(spec.get("angle_offset", 0.0))
    design = design_flywheel(scenario, delta, phi0=offset, progress=progress)
    base = scenario.with_params(J_flywheel=design.baseline_J_flywheel)
    steps = list(spec.get("eq3_steps_deg", [1, 2, 5, 10, 20])) if steps_deg is None else list(steps_deg)
    # the paper's crank-angle scheme (eq. 3) takes the loads of the file alone: with joint friction
    # its study and its run from the start are left out, with the reason
    friction = base.build().reduced.friction is not None
    if friction:
        stability = Eq3Stability(0, [], None, math.nan, float(base["J_flywheel"]), skipped=(
            "the paper's crank-angle scheme (eq. 3) takes no joint friction, whose moment follows the "
            "reactions and so the acceleration it steps"))
    else:
        # eq. 3 starts at phi1_start: the design's steady cycle is that one where it was taken from there
        same_start = abs(base["phi1_start"] - offset) < 1e-15
        stability = eq3_stability(base, steps, steady=design.without if same_start else None)
    if progress is not None:
        progress(4)
    # the movement from the start (Fig. 6): the reference and eq. 3 at 1 deg, three turns
    t_end = 3.2 * design.without.period
    # output every half degree of crank or finer at the fastest the run turns, the steady cycle's peak
    # or the start (an engine turns 21.6 deg in the file's 1 ms output step: its epsilon1 peaks would
    # be sampled, not drawn); 10 % above it, as the start-up may overshoot the steady peak
    fastest = 1.1 * max(float(design.without.omega1.max()), abs(float(base["omega1_start"])))
    samples = int(math.ceil(t_end * fastest / math.radians(0.5))) + 1
    reference = simulate(base, t_end=t_end, output_times=np.linspace(base.experiment.start_time, t_end, samples))
    eq3 = None if friction else simulate(base, t_end=t_end, method="lv-eq3", angle_step=math.radians(1.0))
    if progress is not None:
        progress(5)
    settled = _settled_angle(reference, design.without, offset)
    movement = {"omega1_start": base["omega1_start"], "settled_within_1e-3_at_deg": settled,
                "eq3_1deg_max_error_first_3_turns": None}
    if eq3 is not None:
        eq3_phi, eq3_omega = eq3.trajectory.y[0], eq3.trajectory.y[1]
        both = eq3_phi <= reference.phi1[-1]
        movement["eq3_1deg_max_error_first_3_turns"] = float(np.max(np.abs(
            eq3_omega[both] - reference.omega_at_angle(eq3_phi[both]))))
    return FlywheelStudy(design, stability, movement, base, offset, reference, eq3)


def _settled_angle(result, steady: SteadyCycle, offset: float) -> float | None:
    """Paper's angle (deg, from the start) after which omega1 stays within 1e-3 rad/s of the steady cycle."""
    phi = result.phi1
    ref = np.interp((phi - offset) % steady.angle + offset, steady.phi1, steady.omega1)
    off = np.nonzero(np.abs(result.omega1 - ref) > 1e-3)[0]
    if off.size == 0:
        return 0.0
    if off[-1] == phi.size - 1:
        return None
    return float(np.degrees(phi[off[-1] + 1] - phi[0]))


