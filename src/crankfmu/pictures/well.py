"""The pumping well's pictures (``crankfmu well``): the surface and pump dynamometer cards, the
gearbox torque over the crank angle with its parts, and the unit moving while its card is drawn."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..atomic import replacing, save_figure
from ..plots import legend_outside, pyplot

KN = 1e-3


def _positions(stroke):
    """(surface, pump) positions above the bottom of their strokes (m)."""
    return -(stroke["s"] - stroke["s"].max()), -(stroke["u_pump"] - stroke["u_pump"].max())


def cards_png(stroke, design, out: Path, title: str, scenario: str = "") -> Path:
    plt = pyplot()
    surface, pump = _positions(stroke)
    fig, ax = plt.subplots(figsize=(8, 5.5))
    ax.plot(surface, stroke["F"] * KN, color="C0", label="surface card (polished rod)")
    ax.plot(pump, stroke["F_pump"] * KN, color="C1", label="pump card (rods at the pump)")
    wrf, fo = design.buoyant_weight * KN, design.fluid_load * KN
    ax.axhline(wrf, color="0.5", ls=":", lw=1)
    ax.axhline(wrf + fo, color="0.5", ls=":", lw=1)
    ax.text(0.0, wrf, " Wrf", va="bottom", color="0.4", fontsize=8)
    ax.text(0.0, wrf + fo, " Wrf + Fo", va="bottom", color="0.4", fontsize=8)
    ax.axhline(fo, color="C1", ls=":", lw=1)
    ax.text(0.0, fo, " Fo (fluid load on the plunger)", va="bottom", color="C1", fontsize=8)
    ax.set_xlabel("position above the bottom of stroke [m]")
    ax.set_ylabel("load [kN]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=8)
    path = Path(out) / "cards.png"
    save_figure(fig, path, dpi=120, bbox_inches="tight", scenario=scenario,
                caption="The dynamometer cards of the steady stroke: the polished rod's load against its position "
                        "(surface card) and the rods' load at the pump against the plunger's position (pump card), "
                        "with the buoyant rod weight Wrf and the fluid load Fo.")
    plt.close(fig)
    return path


def torque_png(stroke, parts: dict, api_rod, out: Path, title: str, scenario: str = "") -> Path:
    plt = pyplot()
    angle = np.degrees(stroke["phi1"] - stroke["phi1"][0])
    fig, ax = plt.subplots(figsize=(9, 5.5))
    ax.plot(angle, parts["net"] * KN, color="k", lw=2, label="net gearbox torque (M_motor - J_flywheel eps1)")
    ax.plot(angle, parts["rod"] * KN, color="C0", label="rod load part (-F s')")
    ax.plot(angle, api_rod * KN, color="C9", ls="--", lw=1, label="API 11E: TF F on the card")
    ax.plot(angle, parts["weights"] * KN, color="C2", label="counterweights and unit weights")
    ax.plot(angle, parts["inertia"] * KN, color="C3", label="unit inertia ((J - J_flywheel) eps1 + J'/2 omega1^2)")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("crank angle from the bottom of stroke [deg]")
    ax.set_ylabel("torque at the crank shaft [kN.m]")
    ax.set_xlim(0, 360)
    ax.set_xticks(range(0, 361, 45))
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=8)
    path = Path(out) / "torque.png"
    save_figure(fig, path, dpi=120, bbox_inches="tight", scenario=scenario,
                caption="The net gearbox torque over the steady stroke and its parts (rod load, counterweights and "
                        "unit weights, unit inertia), with API 11E's torque factor times the card's load beside it.")
    plt.close(fig)
    return path


def animation_gif(cw, stroke, out: Path, frames: int = 60, fps: int = 15, progress=None, scenario: str = "") -> Path:
    """The unit's links (crank, pitman, beam, horsehead, rod) and its surface card being drawn."""
    plt = pyplot()
    from .animate import write_gif

    definition_points = ("O", "W", "E", "S", "H")
    index = np.linspace(0, len(stroke["t"]) - 1, frames).astype(int)
    phi = np.mod(stroke["phi1"][index], 2 * math.pi)
    kin = cw.model.mechanism.kinematics(phi)
    xy = {p: (kin.point(p)[0], kin.point(p)[1]) for p in definition_points}
    v = cw.scenario.values
    surface, _ = _positions(stroke)
    fig, (ax, card) = plt.subplots(1, 2, figsize=(10, 5.2), dpi=96, gridspec_kw={"width_ratios": [1.2, 1]})
    # the horsehead's arc (0.35 rad either side of the beam's line, radius arm_A about S) at every
    # frame, within the limits: it reaches above the beam's points (it was clipped at the top)
    theta = np.arctan2(xy["H"][1] - xy["S"][1], xy["H"][0] - xy["S"][0])
    arcs = theta[:, None] + np.linspace(-0.35, 0.35, 20)[None, :]
    xs = np.concatenate([*(xy[p][0] for p in definition_points), (xy["S"][0][:, None] + v["arm_A"] * np.cos(arcs)).ravel()])
    ys = np.concatenate([*(xy[p][1] for p in definition_points), (xy["S"][1][:, None] + v["arm_A"] * np.sin(arcs)).ravel()])
    rod_x = v["I_dist"] + v["arm_A"]
    ax.set_xlim(min(xs.min(), -v["crank_R"]) - 0.5, max(xs.max(), rod_x) + 0.8)
    ax.set_ylim(-v["G_crank"] - 0.3, ys.max() + 0.3)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.plot([ax.get_xlim()[0], ax.get_xlim()[1]], [-v["G_crank"]] * 2, color="0.4", lw=2)
    crank, = ax.plot([], [], "o-", color="C0", lw=3, label="crank")
    pitman, = ax.plot([], [], "o-", color="C1", lw=2, label="pitman")
    beam, = ax.plot([], [], "o-", color="C2", lw=3, label="walking beam and horsehead")
    head, = ax.plot([], [], color="C2", lw=3)
    rod, = ax.plot([], [], color="0.2", lw=1.5, label="polished rod")
    readout = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=9, family="monospace")
    card.plot(surface, stroke["F"] * KN, color="0.85", lw=1, label="the whole stroke")
    drawn, = card.plot([], [], color="C0", lw=2, label="drawn so far")
    dot, = card.plot([], [], "o", color="C3", label="now")
    card.set_xlabel("polished rod position above the bottom [m]")
    card.set_ylabel("polished rod load [kN]")
    card.set_title("surface dynamometer card", fontsize=10)
    card.grid(alpha=0.3)
    ax.set_title("the unit (grey line: the ground)", fontsize=10)
    period = float(stroke["t"][-1] - stroke["t"][0])
    fig.suptitle(f"{cw.scenario.title}: one steady stroke of {period:.2f} s", fontsize=11)
    # the keys below the axes, so neither covers the unit nor the card
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, fontsize=8, frameon=False)
    card.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3, fontsize=8, frameon=False)
    fig.tight_layout()
    path = Path(out) / "well.gif"
    for artist in (crank, pitman, beam, head, rod, drawn, dot, readout):
        artist.set_animated(True)
    start = stroke["phi1"][0]

    def frame(k):
        O, W, E, S, H = ((xy[p][0][k], xy[p][1][k]) for p in definition_points)
        crank.set_data([O[0], W[0]], [O[1], W[1]])
        pitman.set_data([W[0], E[0]], [W[1], E[1]])
        beam.set_data([E[0], S[0], H[0]], [E[1], S[1], H[1]])
        theta = math.atan2(H[1] - S[1], H[0] - S[0])
        arc = np.linspace(theta - 0.35, theta + 0.35, 20)
        head.set_data(S[0] + v["arm_A"] * np.cos(arc), S[1] + v["arm_A"] * np.sin(arc))
        rod.set_data([rod_x, rod_x], [S[1] + v["arm_A"] * math.sin(theta) - 0.05, -v["G_crank"]])
        upto = index[k] + 1
        drawn.set_data(surface[:upto], stroke["F"][:upto] * KN)
        dot.set_data([surface[upto - 1]], [stroke["F"][upto - 1] * KN])
        readout.set_text(f"t = {stroke['t'][index[k]] - stroke['t'][0]:5.2f} s\n"
                         f"crank {math.degrees(stroke['phi1'][index[k]] - start):5.1f} deg from the bottom")

    about = {"title": f"{cw.scenario.title}: one steady stroke", "scenario": scenario,
             "caption": "The pumping unit through one steady stroke, its surface card drawn as the polished rod moves."}
    with replacing(path) as partial:
        write_gif(fig, frame, frames, partial, fps, progress, json.dumps(about))
    plt.close(fig)
    return path
