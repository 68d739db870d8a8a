"""The flywheel study's figures (``crankfmu flywheel``): the mechanism's reduced inertia J_e, the
movement from the start, the steady cycle before and after the flywheel, the turning moment and
the eq. 3 step-size study.

Every word comes from the study's own data: the scenario's name, its flywheel (none, or the
file's where the design starts from it), its loads (each [[loads]] entry's ``description``, else
its kind), its motor, and the paper's figure numbers only where the scenario's ``[paper_figures]``
lists them (seed003's Figs. 3, 5-7); no figure borrows another machine's words.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..atomic import save_figure
from ..plots import legend_outside, pyplot, turn_axis
from ..units import engineering

TWO_PI = 2.0 * math.pi


# --------------------------------------------------------------------------------------------
# words from the study's data

def paper_figures(scenario, *numbers: int) -> str:
    """" (Fig. 3)", " (Figs. 5-6)": the paper's figures the plot reproduces, only where the
    scenario's [paper_figures] lists every one of them; "" otherwise."""
    listed = scenario.data.get("paper_figures", {})
    if not numbers or not all(f"Fig. {n}" in listed for n in numbers):
        return ""
    if len(numbers) == 1:
        return f" (Fig. {numbers[0]})"
    return f" (Figs. {numbers[0]}-{numbers[-1]})"


def flywheel_words(J: float, file_J: float | None = None) -> str:
    """"without a flywheel", "with the file's flywheel J_F = 0.02 kg.m2", "with J_F = 0.5 kg.m2"."""
    if J == 0.0:
        return "without a flywheel"
    whose = "the file's flywheel " if file_J is not None and J == file_J else ""
    return f"with {whose}J_F = {J:.4g} kg.m2"


def angle_label(offset: float, what: str = "crank angle") -> str:
    """The x axis's words: phi1 itself, or the paper's phi, counted from ``offset`` (rad)."""
    if offset == 0.0:
        return f"{what} phi1 [deg]"
    return f"{what} phi = phi1 - {math.degrees(offset):g} deg [deg] (the paper's zero)"


def paper_deg(phi, offset):
    return np.degrees(np.asarray(phi) - offset)


def acting(model, omega1: float) -> list[int]:
    """The loads (indices into model.reduced.loads) with a torque on the crank somewhere over the
    cycle at ``omega1``: the weights of a machine without gravity (g = 0) are not named."""
    grid = np.linspace(0.0, model.reduced.period, 721)
    kin = model.mechanism.kinematics(grid)
    speed = np.full_like(grid, omega1)
    return [i for i, load in enumerate(model.reduced.loads) if np.any(np.asarray(load.torque(kin, speed)))]


# --------------------------------------------------------------------------------------------
# the figures

def plot_inertia(study, path: Path) -> Path:
    """J_e(phi): the mechanism's own reduced inertia over a turn, the flywheel not included (it
    only shifts the curve), with the paper's tabulation step marked where the file gives it."""
    plt = pyplot()
    scenario, offset, model = study.scenario, study.angle_offset, study.model
    phi = offset + np.linspace(0.0, TWO_PI, 721)
    J_e = model.reduced.coefficients(phi)[0] - model.reduced.J_flywheel
    d = study.design
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    ax.plot(paper_deg(phi, offset), J_e, lw=1.5)
    step = scenario.data.get("flywheel", {}).get("paper_step_deg")
    if step:
        every = max(1, int(round(step / 0.5)))
        ax.plot(paper_deg(phi[::every], offset), J_e[::every], "o", ms=4, label=f"every {step:g} deg (the paper's step)")
        legend_outside(ax)
    turn_axis(ax, angle_label(offset))
    ax.set_ylabel("reduced inertia of the mechanism J_e [kg.m2]")
    ax.set_title(f"{scenario.name}: J_e over a turn{paper_figures(scenario, 3)}\n{engineering(d.J_e_min, 'kg.m2')} "
                 f"at {d.J_e_min_at_deg:.1f} deg to {engineering(d.J_e_max, 'kg.m2')} at {d.J_e_max_at_deg:.1f} deg")
    flywheel = model.reduced.J_flywheel
    save_figure(fig, path, dpi=120, scenario=scenario.name,
                caption="The mechanism's own reduced moment of inertia at the crank over one turn (its links' "
                        "kinetic energy per omega1^2 / 2), mean " + engineering(d.J_e_mean, "kg.m2")
                        + (f"; the flywheel's {flywheel:.4g} kg.m2 adds to it and is not drawn." if flywheel
                           else "; the run has no flywheel."))
    plt.close(fig)
    return path


def plot_movement(study, path: Path) -> Path:
    """The run from the file's start speed with the design's starting flywheel: omega1 by the
    reference and by eq. 3 at 1 deg, epsilon1, and the torques on the crank."""
    plt = pyplot()
    reference, eq3, offset, scenario = study.reference, study.eq3, study.angle_offset, study.scenario
    model = reference.model
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(8, 8.5), constrained_layout=True, sharex=True)
    deg = paper_deg(reference.phi1, offset)
    a1.plot(deg, reference.omega1, lw=1.5, label="reference (DOP853, time domain)")
    if eq3 is not None:               # (none with joint friction, which the scheme does not take)
        a1.plot(paper_deg(eq3.trajectory.y[0], offset), eq3.trajectory.y[1], lw=1, ls="--",
                label="eq. 3 (the crank-angle scheme\nof seed 003's paper), 1 deg")
    a1.set_ylabel("omega1 [rad/s]")
    a2.plot(deg, reference.epsilon1, lw=1.2)
    a2.set_ylabel("epsilon1 [rad/s2]")
    a3.plot(deg, reference.M_motor + reference.M_load, lw=1.2, label="M_motor + M_load")
    a3.plot(deg, reference.M_load, lw=0.8,
            label=f"M_load: {scenario.describe_loads(model.reduced, acting(model, study.design.omega_m))}")
    if reference.friction:
        a3.plot(deg, reference.friction["M_friction"], lw=0.8, label="M_friction: the joints' friction")
    a3.set_ylabel("torque on the crank [N.m]")
    a3.set_xlabel(angle_label(offset))
    for ax in (a1, a2, a3):
        ax.grid(alpha=0.3)
    for ax in (a1, a3):
        legend_outside(ax, fontsize=8)
    J = float(scenario["J_flywheel"])
    start = f"from omega1 = {reference.omega1[0]:g} rad/s {flywheel_words(J, study.design.baseline_J_flywheel)}"
    # over the figure, not the first panel: the panels are narrowed by their legends outside, and a
    # title centred on one ran off the figure's left edge
    fig.suptitle(f"{scenario.name}: {start}{paper_figures(scenario, 5, 6)}")
    settled = study.movement.get("settled_within_1e-3_at_deg")
    save_figure(fig, path, dpi=120, scenario=scenario.name,
                caption=f"The run {start} (the flywheel the design starts from): crank speed by the reference"
                        + (" and by the crank-angle scheme of eq. 3" if eq3 is not None else "")
                        + ", acceleration, and the torques on the crank. "
                        + (f"It settles on the steady cycle within 1e-3 rad/s after {settled:.0f} deg."
                           if settled is not None else "It has not settled on the steady cycle by the end."))
    plt.close(fig)
    return path


def plot_flywheel(study, path: Path) -> Path:
    """The steady cycle the design starts from and the one with the flywheel it found."""
    plt = pyplot()
    design, offset, scenario = study.design, study.angle_offset, study.scenario
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6.5), constrained_layout=True, sharex=True)
    base = flywheel_words(design.baseline_J_flywheel, design.baseline_J_flywheel)
    sized = f"with J_F = {design.J_F_simulated:.4g} kg.m2 (sized)"
    for c, label in ((design.without, base), (design.with_flywheel, sized)):
        a1.plot(paper_deg(c.phi1, offset), c.omega1, label=f"{label}: delta {c.delta:.4f}")
        a2.plot(paper_deg(c.phi1, offset), c.epsilon1, label=label)
    a1.set_ylabel("omega1 [rad/s]")
    a2.set_ylabel("epsilon1 [rad/s2]")
    turn_axis(a2, angle_label(offset) + " (steady cycle)", design.without.angle)
    fig.suptitle(f"{scenario.name}: the steady cycle {base}\nand {sized}{paper_figures(scenario, 7)}: peaks of omega1 "
                 f"-{100 * design.omega_peak_reduction:.2f} %, of |epsilon1| -{100 * design.epsilon_peak_reduction:.1f} %")
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
        legend_outside(ax, fontsize=8)
    save_figure(fig, path, dpi=120, scenario=scenario.name,
                caption=f"The steady cycle {base} (where the design starts) and with the flywheel whose simulated steady "
                        f"cycle has the target delta = {design.delta_target:g} ({design.J_F_simulated:.4g} kg.m2; eq. 17 "
                        f"gives {design.J_F_eq17:.4g} kg.m2).")
    plt.close(fig)
    return path


def plot_turning_moment(study, path: Path) -> Path:
    """The turning moment diagram over the machine's cycle at the steady cycle's mean speed: the
    loads that do work on the crank (driving) against those that take it (resisting), the motor's
    mean share added to the driving side where it works, the areas between them (the energy the
    flywheel stores and gives back) and the energy's swing, whose range is eq. 17's dW_max."""
    plt = pyplot()
    design, scenario, model = study.design, study.scenario, study.model
    omega = design.omega_m
    dW, (grid, swing) = design.dW_max, design.swing
    kin = model.mechanism.kinematics(grid)
    speed = np.full_like(grid, omega)
    torques = [np.broadcast_to(np.asarray(load.torque(kin, speed), dtype=float), grid.shape)
               for load in model.reduced.loads]
    span = grid[-1] - grid[0]
    works = [float(np.trapezoid(t, grid)) for t in torques]
    scale = max([abs(w) for w in works] + [1e-300])
    takers = [i for i, w in enumerate(works) if w < -1e-9 * scale]
    givers = [i for i in range(len(torques)) if i not in takers]
    resisting = -sum((torques[i] for i in takers), np.zeros_like(grid))
    driving = sum((torques[i] for i in givers), np.zeros_like(grid))
    # the joints' friction resists, at the mean speed as eq. 17's swing counts it
    friction = study.friction_torque(grid)
    if friction is not None:
        resisting = resisting - friction
    # what a drive supplies on average: the mean the loads leave over the cycle (the motor's share of
    # a machine driven by its motor, a small balance for an engine whose gas drives its generator)
    share = float(np.trapezoid(resisting - driving, grid) / span)
    driving = driving + share
    deg = np.degrees(grid)
    giving = scenario.describe_loads(model.reduced, [i for i in givers if np.any(torques[i])])
    motor = model.motor
    has_motor = any(getattr(motor, k) != 0.0 for k in ("A", "B", "A_low", "B_low"))
    significant = abs(share) > 1e-3 * max(float(np.max(np.abs(resisting))), 1e-300)
    what_drives = ([giving] if giving != "none" else [])
    if has_motor and significant:
        what_drives.insert(0, f"the motor (its mean over the cycle, {engineering(share, 'N.m')})")
    elif significant:                 # no motor: the loads' small imbalance at the mean speed, levelled
        what_drives.append(f"a level {engineering(share, 'N.m')} (the loads' imbalance at omega_m)")
    resisting_words = scenario.describe_loads(model.reduced, takers)
    if friction is not None:
        resisting_words = (f"{resisting_words} and " if takers else "") + "the joints' friction"
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6.5), constrained_layout=True, sharex=True)
    a1.plot(deg, driving, color="black", lw=1.2, label="driving: " + "\nand ".join(what_drives or ["none"]))
    a1.plot(deg, resisting, color="tab:blue", lw=1.2, ls="--",
            label=f"resisting: {resisting_words}\n(mean {engineering(float(np.mean(resisting)), 'N.m')})")
    a1.fill_between(deg, driving, resisting, where=driving >= resisting, color="tab:green", alpha=0.35,
                    interpolate=True, label="energy to the flywheel")
    a1.fill_between(deg, driving, resisting, where=driving < resisting, color="tab:red", alpha=0.35,
                    interpolate=True, label="energy from it")
    a1.set_ylabel("torque on the crank [N.m]")
    fig.suptitle(f"{scenario.name}: turning moment at omega_m = {omega:.4g} rad/s")
    a2.plot(deg, swing, color="black", lw=1.2, label="the energy stored:\nthe driving less the\nresisting work")
    lo, hi = int(np.argmin(swing)), int(np.argmax(swing))
    a2.plot([deg[lo], deg[hi]], [swing[lo], swing[hi]], "o", color="tab:blue", ms=5,
            label=f"dW_max = {engineering(dW, 'J')} (eq. 17)")
    a2.set_ylabel("energy swing dW [J]")
    turn_axis(a2, "crank angle phi1 [deg]", span)
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
        legend_outside(ax, fontsize=8)
    save_figure(fig, path, dpi=120, scenario=scenario.name,
                caption=f"The torques on the crank over the machine's cycle at its mean speed: driving "
                        f"({' and '.join(what_drives or ['none'])}) against resisting "
                        f"({resisting_words}). The green areas store energy in the flywheel, "
                        f"the red give it back; the largest swing, dW_max = {engineering(dW, 'J')}, is what the "
                        "flywheel is sized from (eq. 17).")
    plt.close(fig)
    return path


def plot_stability(study, path: Path) -> Path:
    plt = pyplot()
    stability, scenario = study.stability, study.scenario
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    ok = [r for r in stability.rows if r["stable"]]
    bad = [r for r in stability.rows if not r["stable"]]
    ax.loglog([r["step_deg"] for r in ok], [r["error"] for r in ok], "o-", label="stable: last-turn error")
    for k, r in enumerate(bad):
        ax.axvline(r["step_deg"], color="C3", lw=0.8, alpha=0.6, label="a step tried: unstable" if k == 0 else None)
    estimate = stability.linear_estimate_deg
    if math.isfinite(estimate):
        ax.axvline(estimate, color="k", ls="--", lw=1, label=f"estimate 2 J omega1 / B = {estimate:.2f} deg")
    if stability.limit:
        # the measured limit lies between two tried steps a fraction of a degree apart: a span that
        # narrow shows no width, so the stable side is a line and the unstable side a shaded region
        stable, unstable = stability.limit["largest_stable_deg"], stability.limit["smallest_unstable_deg"]
        ax.axvline(stable, color="C2", lw=1.6, label=f"largest stable step {stable:.2f} deg")
        ax.axvspan(unstable, ax.get_xlim()[1], color="C3", alpha=0.12, lw=0,
                   label=f"unstable from {unstable:.2f} deg")
    ax.set_xlabel("angle step of eq. 3 [deg]")
    ax.set_ylabel("max |omega1 error| over the last turn [rad/s]")
    ax.set_title(f"{scenario.name}: eq. 3 step-size study ({stability.turns} turns from the start, "
                 f"{flywheel_words(stability.J_flywheel)})")
    ax.grid(alpha=0.3, which="both")
    legend_outside(ax, fontsize=8)
    why = ("against the linear estimate 2 J omega1 / B (B the motor line's slope)" if math.isfinite(estimate)
           else "; no linear estimate: the motor line has no slope (B = 0) to make the scheme stiff")
    save_figure(fig, path, dpi=120, scenario=scenario.name,
                caption="How large an angle step the crank-angle scheme of eq. 3 takes before it turns unstable"
                        + (", " if math.isfinite(estimate) else "") + why + ".")
    plt.close(fig)
    return path


def plot_flywheel_study(study, out: Path) -> list[Path]:
    """Every figure of the study, in the order flywheel.json lists them."""
    out = Path(out)
    plots = [plot_inertia(study, out / "J_e.png"), plot_movement(study, out / "movement.png"),
             plot_flywheel(study, out / "flywheel.png"), plot_turning_moment(study, out / "turning_moment.png")]
    if not study.stability.skipped:
        plots.append(plot_stability(study, out / "eq3_stability.png"))
    return plots
