"""The velocity plan (seed 002's Fig. 5b): each point's velocity drawn from the pole to scale, the
relative velocities joining their heads, labelled where they cover nothing (``labels``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atomic import save_figure
from ..plots import pyplot
from .labels import label, obstacle_boxes, place_labels, renderer_of


def plot_velocity_plan(detail: dict, relative, path: Path, title: str, scenario: str = "") -> Path:
    """Pole p at the origin, each point's velocity drawn from it to scale, the relative velocities
    joining their heads (the paper's Fig. 5b, from the computed velocities). The frame is square
    around the polygon (pole included) with a margin for the labels, and the labels are placed
    where they cover no other text, arrow or point (labels)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    vel = {p: np.array(v) for p, v in detail["velocities"].items()}
    labels, paths = [], []
    for i, (p, v) in enumerate(vel.items()):
        ax.annotate("", xy=v, xytext=(0, 0), arrowprops=dict(arrowstyle="->", color=f"C{i}", lw=1.8))
        paths.append(np.array([[0.0, 0.0], v]))
        labels.append(label(ax, f"{p.lower()}: |v_{p}| = {np.hypot(*v):.3f} m/s", tuple(v), color=f"C{i}", fontsize=9))
    for a, b in relative:
        ax.annotate("", xy=vel[a], xytext=vel[b], arrowprops=dict(arrowstyle="->", color="0.4", ls="--"))
        paths.append(np.array([vel[b], vel[a]]))
        labels.append(label(ax, f"v_{a}{b} = {np.hypot(*(vel[a] - vel[b])):.3f} m/s", tuple(0.5 * (vel[a] + vel[b])),
                            color="0.3", fontsize=8))
    ax.plot(0, 0, "ko")
    labels.append(label(ax, "p (pole)", (0.0, 0.0), fontsize=9))
    corners = np.array([[0.0, 0.0], *vel.values()])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * max(hi - lo) * 1.45
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_aspect("equal")
    ax.set_xlabel("v_x [m/s]")
    ax.set_ylabel("v_y [m/s]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    renderer = renderer_of(fig)
    place_labels(fig, ax, labels, obstacle_boxes(ax, corners, paths), renderer=renderer)
    save_figure(fig, path, dpi=110, scenario=scenario,
                caption="The velocity plan (the paper's Fig. 5b) drawn from the computed velocities: each point's "
                        "velocity from the pole p, the relative velocities joining their heads.")
    plt.close(fig)
    return path
