"""PNG plots of the kinematic studies: time series beside the paper's approximation (seed 002
Figs. 6-9), the velocity plan, and the sweep families (seed 004 Figs. 2-9)."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from .output import pyplot


def plot_time_series(ts: dict, out: Path, title: str) -> list[Path]:
    plt = pyplot()
    paths = []
    approx = ts.get("approx", {})
    for name, values in ts["exact"].items():
        fig, ax = plt.subplots(figsize=(8, 4))
        ax.plot(ts["time"], values, lw=1.6, label="exact (contour engine)")
        if name in approx:
            ax.plot(ts["time"], approx[name], "--", lw=1.0,
                    label=f"paper's approximation, max error {ts['approx_errors'][name]:.3g} {ts['units'][name]}")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"{name} [{ts['units'][name]}]")
        ax.set_title(f"{title}: {name}")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
        fig.tight_layout()
        paths.append(out / f"{name}.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    if "path" in ts:
        fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(*ts["path"], lw=1.6, label="exact")
        if "path" in approx:
            ax.plot(*approx["path"], "--", lw=1.0,
                    label=f"paper's approximation, max distance {ts['approx_errors']['path']:.3g} m")
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(f"{title}: path of the rod's point")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        paths.append(out / "path.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    return paths


def plot_velocity_plan(detail: dict, relative, path: Path, title: str) -> Path:
    """Pole p at the origin, each point's velocity drawn from it to scale, the relative velocities
    joining their heads (the paper's Fig. 5b, from the computed velocities). The frame is square
    around the polygon (pole included) with a margin for the labels, and the labels are placed
    where they cover no other text, arrow or point (pictures.labels)."""
    from .pictures.labels import label, obstacle_boxes, place_labels, renderer_of

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
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_families(result, scenario, units: dict, out: Path) -> list[Path]:
    """One PNG per quantity and swept parameter: a curve over the cycle for each of its values,
    the other parameters at the grid value nearest the scenario's own."""
    plt = pyplot()
    from .sweep import _key
    paths = []
    names = [a.name for a in result.axes]
    base = {a.name: min(a.values, key=lambda v: abs(v - scenario[a.name])) for a in result.axes}
    quantities = next(iter(result.series.values())).keys() if result.series else []
    deg = np.degrees(result.phi1) if result.phi1 is not None else None
    for axis, quantity in itertools.product(result.axes, quantities):
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for i, v in enumerate(axis.values):
            key = _key(tuple({**base, axis.name: v}[n] for n in names))
            if key in result.series:
                ax.plot(deg, result.series[key][quantity], lw=1.2, label=f"{axis.name} = {v:g}")
            else:
                ax.plot([], [], lw=0, label=f"{axis.name} = {v:g}: cannot be assembled")
        fixed = ", ".join(f"{k} = {v:g}" for k, v in base.items() if k != axis.name)
        ax.set_title(f"{quantity} over a cycle, {axis.name} swept ({fixed})")
        ax.set_xlabel("crank angle phi1 [deg]")
        ax.set_ylabel(f"{quantity} [{units.get(quantity, '')}]")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        paths.append(out / f"{quantity}_vs_{axis.name}.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    return paths
