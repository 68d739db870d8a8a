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
    joining their heads (the paper's Fig. 5b, from the computed velocities)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 6))
    vel = {p: np.array(v) for p, v in detail["velocities"].items()}
    for i, (p, v) in enumerate(vel.items()):
        ax.annotate("", xy=v, xytext=(0, 0), arrowprops=dict(arrowstyle="->", color=f"C{i}", lw=1.8))
        ax.text(*(v * 1.04), f"{p.lower()}  (|v_{p}| = {np.hypot(*v):.3f} m/s)", color=f"C{i}")
    for a, b in relative:
        ax.annotate("", xy=vel[a], xytext=vel[b], arrowprops=dict(arrowstyle="->", color="0.4", ls="--"))
        mid = 0.5 * (vel[a] + vel[b])
        ax.text(*mid, f" v_{a}{b} = {np.hypot(*(vel[a] - vel[b])):.3f}", color="0.3", fontsize=8)
    ax.plot(0, 0, "ko")
    ax.text(0, 0, "  p (pole)")
    lim = 1.2 * max(np.hypot(*v) for v in vel.values())
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    ax.set_xlabel("v_x [m/s]")
    ax.set_ylabel("v_y [m/s]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
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
