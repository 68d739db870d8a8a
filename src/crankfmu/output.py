"""Writing results: timeseries.csv, summary.json and the PNG plots (paper Figs. 3 and 4)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .simulation import COLUMNS, Result


def write_timeseries(result: Result, path: Path) -> Path:
    """Plain CSV, one header line; the units are listed in summary.json ("columns")."""
    data = np.column_stack([getattr(result, c) for c in COLUMNS])
    np.savetxt(path, data, delimiter=",", header=",".join(COLUMNS), comments="", fmt="%.15g")
    return path


def write_summary(summary: dict, path: Path) -> Path:
    path.write_text(json.dumps(summary, indent=2, default=_json_default) + "\n")
    return path


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {obj!r}")


def pyplot():
    """matplotlib.pyplot on the file-only Agg backend (no display on CI machines or in FMU hosts)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def turn_axis(ax, xlabel: str = "crank angle phi1 [deg]"):
    """An x axis over one crank turn, 0..360 deg in steps of 45, with a light grid."""
    ax.set_xlim(0, 360)
    ax.set_xticks(range(0, 361, 45))
    ax.set_xlabel(xlabel)
    ax.grid(alpha=0.3)


def plot_cycles(result: Result, out_dir: Path, cycles: int, summary_cycle: int) -> list[Path]:
    """Fig. 3 (omega1 over the first cycles) and Fig. 4 (omega1 over one settled cycle)."""
    plt = pyplot()

    paths = []
    phi0 = result.phi1[0]
    # Fig. 3: omega1 against the crank angle over `cycles` turns (or the whole run if shorter)
    end_angle = phi0 + 2 * math.pi * cycles
    sel = result.phi1 <= end_angle
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6.5), constrained_layout=True)
    ax1.plot(np.degrees(result.phi1[sel] - phi0), result.omega1[sel], lw=1.2)
    for k in range(1, cycles):
        ax1.axvline(360 * k, color="0.8", lw=0.8, zorder=0)
    ax1.set_xlabel("crank angle phi1 - phi1_start [deg]")
    ax1.set_ylabel("omega1 [rad/s]")
    ax1.set_title(f"{result.scenario.name}: crank speed over {cycles} kinematic cycles ({result.method})")
    ax1.grid(alpha=0.3)
    ax2.plot(result.time[sel], result.omega1[sel], lw=1.2, color="C1")
    ax2.set_xlabel("time t [s]")
    ax2.set_ylabel("omega1 [rad/s]")
    ax2.grid(alpha=0.3)
    p = out_dir / "omega1_cycles.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    paths.append(p)

    # Fig. 4: omega1 over cycle `summary_cycle`, against the crank angle within the turn
    stats = result.cycle_stats(summary_cycle)
    phis = phi0 + 2 * math.pi * (summary_cycle - 1) + np.linspace(0, 2 * math.pi, 1441)
    omega = result.omega_at_angle(phis)
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    ax.plot(np.degrees(phis - phis[0]), omega, lw=1.4)
    ax.axhline(stats["omega1_mean"], color="0.5", ls="--", lw=0.8,
               label=f"time mean {stats['omega1_mean']:.4f} rad/s")
    turn_axis(ax, f"crank angle within cycle {summary_cycle} [deg]")
    ax.set_ylabel("omega1 [rad/s]")
    ax.set_title(f"cycle {summary_cycle}: min {stats['omega1_min']:.4f}, max {stats['omega1_max']:.4f} rad/s, "
                 f"delta = {stats['delta']:.4f}")
    ax.legend(loc="best")
    p = out_dir / f"omega1_cycle{summary_cycle}.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    paths.append(p)
    return paths


def write_run(result: Result, out_dir: str | Path) -> dict:
    """Everything `crankfmu simulate` writes; returns the summary."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    exp = result.scenario.experiment
    summary = result.summary()
    summary["columns"] = dict(COLUMNS)
    write_timeseries(result, out / "timeseries.csv")
    write_summary(summary, out / "summary.json")
    plot_cycles(result, out, exp.cycles, exp.summary_cycle)
    return summary
