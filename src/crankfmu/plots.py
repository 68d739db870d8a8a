"""Every figure crankfmu draws from numbers, in one module (the mechanism drawings and animations
and the velocity plan are ``pictures``): a run's crank speed (paper Figs. 3 and 4), the kinematic
studies (seed 002 Figs. 6-9, seed 004's families and delta map), the equilibrium moments and joint
reactions (seed 001 Figs. 2-5) and the scheme study's start-up (the flywheel study's are in
``pictures.flywheel_study``). Each takes a study's result and a path and returns the
path(s) written; axes carry their units. matplotlib is imported only when a figure is drawn.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np

from .dynamics.equation import OMEGA
from .atomic import save_figure
from .units import engineering

TWO_PI = 2.0 * math.pi
#: the speed fluctuations drawn as contour lines on the steady-sweep map (typical design targets:
#: 0.01-0.02 for generators and fine machines, 0.05 for machine tools, 0.1 for pumps and presses)
DELTA_TARGETS = (0.01, 0.02, 0.05, 0.1)


# --------------------------------------------------------------------------------------------
# matplotlib and a crank-turn axis

def pyplot():
    """matplotlib.pyplot on the file-only Agg backend (no display on CI machines or in FMU hosts)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def legend_outside(ax, **kwargs):
    """The legend to the right of the axes, never over the data."""
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False,
                     **{"fontsize": 8, **kwargs})


def turn_axis(ax, xlabel: str = "crank angle phi1 [deg]", cycle: float = TWO_PI):
    """An x axis over one crank turn, 0..360 deg in steps of 45, or over a machine cycle of several
    (``cycle`` rad: 0..720 deg in steps of 90 for a four-stroke engine), with a light grid."""
    end = int(round(math.degrees(cycle)))
    ax.set_xlim(0, end)
    ax.set_xticks(range(0, end + 1, 45 * max(1, end // 360)))
    ax.set_xlabel(xlabel)
    ax.grid(alpha=0.3)


# --------------------------------------------------------------------------------------------
# a run (crankfmu simulate) and the scheme study

#: a cycle has settled when its mean speed differs from the next one's by less than this (relative)
SETTLED = 1e-3


def _cycle_change(result, k: int) -> float:
    """|mean speed of turn k+1 - of turn k| / of turn k+1, NaN where the run has no turn k+1."""
    try:
        a, b = result.cycle_stats(k)["omega1_mean"], result.cycle_stats(k + 1)["omega1_mean"]
    except Exception:  # noqa: BLE001 - the run ends before turn k+1: no statement can be made
        return math.nan
    return abs(b - a) / abs(b)


def run_story(result, cycles: int) -> str:
    """What the run does, read from its own data: where it starts (from rest or at a speed) and
    whether it has settled by the end of the cycles drawn (SETTLED)."""
    w0 = float(result.omega1[0])
    start = "From rest" if w0 == 0.0 else f"From omega1 = {w0:.4g} rad/s"
    change = _cycle_change(result, cycles - 1) if cycles > 1 else math.nan
    if not math.isfinite(change):
        return f"{start}; the run ends before its cycles can be compared."
    if change < SETTLED:
        return (f"{start}, the crank settles into a periodic cycle: cycle {cycles}'s mean speed is within "
                f"{100 * change:.2g} % of cycle {cycles - 1}'s.")
    return (f"{start}; the crank has not settled by cycle {cycles}: its mean speed still changes by "
            f"{100 * change:.2g} % from cycle {cycles - 1}.")


def settled_story(result, k: int) -> str:
    """Whether cycle ``k`` (a turn, or a machine cycle of several) is settled, from the run: its mean
    speed against cycle k+1's."""
    change = _cycle_change(result, k)
    if not math.isfinite(change):
        return f"Whether cycle {k} is settled cannot be told: the run ends before cycle {k + 1}."
    if change < SETTLED:
        return f"The motion has settled: cycle {k + 1}'s mean speed is within {100 * change:.2g} % of this one's."
    return f"The motion has not settled: cycle {k + 1}'s mean speed differs by {100 * change:.2g} %."


def plot_cycles(result, out_dir: Path, cycles: int, summary_cycle: int) -> list[Path]:
    """Fig. 3 (omega1 over the first cycles) and Fig. 4 (omega1 over one settled cycle)."""
    plt = pyplot()

    paths = []
    phi0 = result.phi1[0]
    # a machine cycle: one crank turn, or the scenario's cycle_turns (a four-stroke engine's two)
    cycle, turns = result.scenario.cycle_angle, result.scenario.cycle_turns
    kind = "kinematic cycles" if turns == 1 else f"machine cycles of {turns} turns"
    # Fig. 3: omega1 against the crank angle over `cycles` cycles (or the whole run if shorter)
    end_angle = phi0 + cycle * cycles
    sel = result.phi1 <= end_angle
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6.5), constrained_layout=True)
    ax1.plot(np.degrees(result.phi1[sel] - phi0), result.omega1[sel], lw=1.2)
    for k in range(1, cycles):
        ax1.axvline(360 * turns * k, color="0.8", lw=0.8, zorder=0)
    ax1.set_xlabel("crank angle phi1 - phi1_start [deg]")
    ax1.set_ylabel("omega1 [rad/s]")
    ax1.set_title(f"{result.scenario.name}: crank speed over {cycles} {kind} ({result.method})")
    ax1.grid(alpha=0.3)
    ax2.plot(result.time[sel], result.omega1[sel], lw=1.2, color="C1")
    ax2.set_xlabel("time t [s]")
    ax2.set_ylabel("omega1 [rad/s]")
    ax2.grid(alpha=0.3)
    p = out_dir / "omega1_cycles.png"
    figures = dict(result.scenario.data.get("run_figures", {}))
    as_paper = f", as the paper's {figures['cycles']} draws it" if figures.get("cycles") else ""
    save_figure(fig, p, dpi=120, scenario=result.scenario.name,
                caption=f"The crank speed omega1 from the start over {cycles} {kind}, against the crank angle (top"
                        f"{as_paper}) and against time (bottom). {run_story(result, cycles)}")
    plt.close(fig)
    paths.append(p)

    # Fig. 4: omega1 over cycle `summary_cycle`, against the crank angle within the cycle
    stats = result.cycle_stats(summary_cycle)
    phis = phi0 + cycle * (summary_cycle - 1) + np.linspace(0, cycle, 1440 * turns + 1)
    omega = result.omega_at_angle(phis)
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    ax.plot(np.degrees(phis - phis[0]), omega, lw=1.4)
    ax.axhline(stats["omega1_mean"], color="0.5", ls="--", lw=0.8,
               label=f"time mean {stats['omega1_mean']:.4f} rad/s")
    turn_axis(ax, f"crank angle within cycle {summary_cycle} [deg]", cycle)
    ax.set_ylabel("omega1 [rad/s]")
    ax.set_title(f"cycle {summary_cycle}: min {stats['omega1_min']:.4f}, max {stats['omega1_max']:.4f} rad/s, "
                 f"delta = {stats['delta']:.4f}")
    legend_outside(ax)
    p = out_dir / f"omega1_cycle{summary_cycle}.png"
    save_figure(fig, p, dpi=120, scenario=result.scenario.name,
                caption=f"The crank speed over {'turn' if turns == 1 else 'machine cycle'} {summary_cycle}"
                        + (f" (the paper's {figures['settled']})" if figures.get("settled") else "")
                        + f": its extremes and the coefficient of speed fluctuation delta = (max - min) / mean. "
                          f"{settled_story(result, summary_cycle)}")
    plt.close(fig)
    paths.append(p)
    return paths


def plot_startup(reference, runs: dict, out: Path, method="badoiu-eq17") -> Path:
    """omega1 over the first turn: the reference and the study's runs of ``method``."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    t_end = reference.cycle_bounds(1)[1] * 1.2
    sel = reference.time <= t_end
    ax.plot(reference.time[sel], reference.omega1[sel], "k", lw=2, label="reference (DOP853, time domain)")
    for (m, deg), r in runs.items():
        if m != method:
            continue
        keep = r.trajectory.t <= t_end
        ax.plot(r.trajectory.t[keep], r.trajectory.y[OMEGA][keep], lw=1, label=f"{method}, {deg:g} deg")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("omega1 [rad/s]")
    ax.set_title(f"{reference.scenario.name}: start-up, first crank turn")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    legend_outside(ax)
    save_figure(fig, out, dpi=120, scenario=reference.scenario.name,
                caption=f"The start-up over the first crank turn: {method} at several angle steps against the "
                        "time-domain reference.")
    plt.close(fig)
    return out


# --------------------------------------------------------------------------------------------
# kinematic studies and sweeps

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
        cite = ts.get("figures", {}).get(name)
        ax.set_title(f"{title}: {name}" + (f" (the paper's {cite})" if cite else ""))
        ax.grid(True, alpha=0.3)
        legend_outside(ax, fontsize=8)
        paths.append(out / f"{name}.png")
        save_figure(fig, paths[-1], dpi=110, bbox_inches="tight", scenario=title,
                    caption=f"{name} over time at the paper's constant crank speed: the exact value from the contour "
                            "engine" + (", and the paper's approximate formula with its largest error." if name in approx
                                        else "."))
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
        cite = ts.get("figures", {}).get("path")
        ax.set_title(f"{title}: path of the rod's point" + (f" (the paper's {cite})" if cite else ""))
        ax.grid(True, alpha=0.3)
        legend_outside(ax, fontsize=8)
        paths.append(out / "path.png")
        save_figure(fig, paths[-1], dpi=110, bbox_inches="tight", scenario=title,
                    caption="The path of the point the paper traces over one crank turn, exact and by the paper's "
                            "formulas.")
        plt.close(fig)
    return paths


def plot_families(result, scenario, units: dict, out: Path) -> list[Path]:
    """One PNG per quantity and swept parameter: a curve over the cycle for each of its values,
    the other parameters at the grid value nearest the scenario's own."""
    plt = pyplot()
    paths = []
    base = {a.name: min(a.values, key=lambda v: abs(v - scenario[a.name])) for a in result.axes}
    quantities = next(iter(result.series.values())).keys() if result.series else []
    deg = np.degrees(result.phi1) if result.phi1 is not None else None
    def unit_of(name):
        unit = scenario.parameters[name].unit if name in scenario.parameters else "1"
        return "" if unit == "1" else f" {unit}"

    for axis, quantity in itertools.product(result.axes, quantities):
        fig, ax = plt.subplots(figsize=(9.5, 4.5), constrained_layout=True)
        for i, v in enumerate(axis.values):
            series = result.series_at({**base, axis.name: v})
            if series is not None:
                ax.plot(deg, series[quantity], lw=1.2, label=f"{axis.name} = {v:g}{unit_of(axis.name)}")
            else:
                ax.plot([], [], lw=0, label=f"{axis.name} = {v:g}{unit_of(axis.name)}: cannot be assembled")
        fixed = ", ".join(f"{k} = {v:g}{unit_of(k)}" for k, v in base.items() if k != axis.name)
        cite = scenario.data.get("kinematics", {}).get("figures", {}).get(f"{quantity}_vs_{axis.name}")
        ax.set_title(f"{quantity} over a cycle, {axis.name} swept" + (f" ({fixed})" if fixed else "")
                     + (f" (the paper's {cite})" if cite else ""))
        turn_axis(ax)              # ticks every 45 deg, as every other figure over a turn
        ax.set_ylabel(f"{quantity} [{units.get(quantity, '')}]")
        legend_outside(ax)
        paths.append(out / f"{quantity}_vs_{axis.name}.png")
        save_figure(fig, paths[-1], dpi=110, scenario=scenario.name,
                    caption=f"{quantity} over one crank turn for each value of {axis.name}, the other swept "
                            f"parameters held ({fixed or 'none'}).")
        plt.close(fig)
    return paths


def _contour_label_places(lines, ys) -> list[tuple[float, float]]:
    """One place per drawn piece of each contour line, well inside the map: the vertex nearest a
    height of its own (the levels' heights staggered from 25 % to 75 % of the y range), so no label
    is clipped at an edge and two levels' labels do not meet."""
    low, high = float(np.min(ys)), float(np.max(ys))
    places = []
    n = len(lines.allsegs)
    for i, pieces in enumerate(lines.allsegs):
        target = low + (high - low) * (0.25 + 0.5 * (i + 0.5) / n)
        for piece in pieces:
            if len(piece) >= 2:
                places.append(tuple(piece[int(np.argmin(np.abs(piece[:, 1] - target)))]))
    return places


def plot_steady(result, out: Path, units: dict | None = None, scenario: str = "") -> list[Path]:
    """delta over the grid: a map for two swept parameters, curves for one (the first two axes;
    the others at their first value)."""
    if not result.rows:
        return []
    plt = pyplot()
    units = units or {}
    axes = result.axes
    fixed = {a.name: a.values[0] for a in axes[2:]}
    fig, ax = plt.subplots(figsize=(7.5, 5))
    if len(axes) == 1:
        xs = axes[0].values
        ys = [(result.row_at({axes[0].name: x}) or {"delta": np.nan})["delta"] for x in xs]
        ax.plot(xs, ys, "o-", ms=3)
        ax.set_xlabel(f"{axes[0].name}  [{units.get(axes[0].name, '?')}]")
        ax.set_ylabel("delta = (omega1 max - min) / mean  [1]")
    else:
        a0, a1 = axes[0], axes[1]
        grid = np.full((len(a1.values), len(a0.values)), np.nan)
        for i, v1 in enumerate(a1.values):
            for j, v0 in enumerate(a0.values):
                row = result.row_at({**fixed, a0.name: v0, a1.name: v1})
                if row is not None:
                    grid[i, j] = row["delta"]
        # delta spans decades over a design grid (a light flywheel to a heavy one): a logarithmic
        # colour scale, and the design targets as labelled contour lines
        from matplotlib.colors import LogNorm

        positive = grid[np.isfinite(grid) & (grid > 0)]
        norm = LogNorm(vmin=positive.min(), vmax=positive.max()) if positive.size and positive.max() > positive.min() else None
        mesh = ax.pcolormesh(a0.values, a1.values, np.where(grid > 0, grid, np.nan), shading="nearest",
                             cmap="viridis", norm=norm)
        fig.colorbar(mesh, ax=ax, label="delta = (omega1 max - min) / mean  [1], log scale")
        levels = [d for d in DELTA_TARGETS if positive.size and positive.min() < d < positive.max()]
        if levels and min(len(a0.values), len(a1.values)) >= 2:
            lines = ax.contour(a0.values, a1.values, grid, levels=levels, colors="white", linewidths=1.2)
            ax.clabel(lines, fmt=lambda d: f"delta = {d:g}", fontsize=8, inline=True,
                      manual=_contour_label_places(lines, a1.values))
        ax.set_xlabel(f"{a0.name}  [{units.get(a0.name, '?')}]")
        ax.set_ylabel(f"{a1.name}  [{units.get(a1.name, '?')}]")
    ax.set_title("steady-cycle speed fluctuation" + (f" ({', '.join(f'{k} = {v:g}' for k, v in fixed.items())})"
                                                      if fixed else ""))
    path = out / "delta.png"
    fig.tight_layout()
    save_figure(fig, path, dpi=120, scenario=scenario,
                caption="The steady cycle's coefficient of speed fluctuation delta over the design grid; the white "
                        "lines are the usual design targets.")
    plt.close(fig)
    return [path]


# --------------------------------------------------------------------------------------------
# equilibrium moments and joint reactions

def plot_moments(scenario, results: list, out: Path) -> list[Path]:
    """One figure per speed, as the paper's Figs. 2-5: curve 1 with inertia, curve 2 without. The
    scenario's [equilibrium] section names what the moment is (``moment``: seed 001's equilibrium
    moment, a pumping unit's net gearbox torque), the paper's figure of each of its speeds
    (``figures``, in the order of its omega1; none where the paper has none) and a ``rating`` (N.m)
    drawn at plus and minus its value (a reducer's rated torque)."""
    plt = pyplot()
    paths = []
    spec = scenario.data.get("equilibrium", {})
    label = spec.get("moment", "equilibrium moment M_e")
    figures = dict(zip((float(w) for w in spec.get("omega1", [])), spec.get("figures", [])))
    changed = ", ".join(f"{k} = {v:g}" for k, v in sorted(scenario.overrides.items()))
    for r in results:
        m = r.moment
        deg = np.append(np.degrees(m.phi1), math.degrees(r.cycle_angle))
        close = lambda a: np.append(a, a[0])  # noqa: E731
        fig, ax = plt.subplots(figsize=(9.5, 4.5), constrained_layout=True)
        ax.plot(deg, close(m.total), lw=1.6, label="1: with inertia forces\nand moments [N.m]")
        ax.plot(deg, close(m.static), lw=1.2, ls="--", label="2: inertia neglected [N.m]")
        if r.with_friction is not None:
            ax.plot(deg, close(r.with_friction), lw=1.2, color="C3",
                    label=f"3: with inertia and joint\nfriction [N.m] (mean {r.mean_with_friction:.2f})")
        ax.axhline(r.mean, color="0.5", lw=0.8, ls=":", label=f"cycle mean {r.mean:.2f} N.m")
        if "rating" in spec:
            rating = float(spec["rating"])
            for sign in (1.0, -1.0):
                ax.axhline(sign * rating, color="C3", lw=1.0, ls="-.",
                           label=f"rating +/-{rating:.0f} N.m" if sign > 0 else None)
        turn_axis(ax, cycle=r.cycle_angle)
        ax.set_ylabel(f"{label} [N.m]")
        s = r.summary()
        cite = f" ({figures[r.omega1]})" if r.omega1 in figures else ""
        friction = "" if r.with_friction is None else " (3: with joint friction)"
        ax.set_title(f"{scenario.name}{f' with {changed}' if changed else ''}{friction}: {label} at omega1 = {r.omega1:g} "
                     f"rad/s{cite}; inertia ratio {s['inertia_ratio']:.3f}", fontsize=10)
        legend_outside(ax)
        p = out / f"Me_omega{r.key}.png"
        save_figure(fig, p, dpi=120, scenario=scenario.name,
                    caption=f"The {label} over one crank turn at the constant crank speed {r.omega1:g} rad/s: with the "
                            "links' inertia forces and moments (curve 1) and without them (curve 2)"
                            + ("; curve 3 adds the joints' friction (Newton-Euler)." if r.with_friction is not None
                               else "."))
        plt.close(fig)
        paths.append(p)
    return paths


def plot_reactions(scenario, r, path: Path, switches_deg=()) -> Path:
    """One panel per joint (ten curves on one axis tangle), each reaction's magnitude over the
    turn; dotted lines at ``switches_deg``, the angles where a switched load changes (a slider's
    force reversing with its velocity), which is where the reactions jump."""
    plt = pyplot()
    joints = list(r.reactions.force)
    columns = 2 if len(joints) > 3 else 1
    rows = -(-len(joints) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(10, 1.25 + 1.45 * rows), sharex=True, squeeze=False,
                             constrained_layout=True)
    deg = np.degrees(r.reactions.phi1)
    for k, (ax, joint) in enumerate(zip(axes.T.flat, joints)):
        magnitude = r.reactions.magnitude(joint)
        ax.plot(deg, magnitude, lw=1.2, color="C0")
        for s in switches_deg:
            ax.axvline(s, color="0.4", lw=0.8, ls=":")
        turn_axis(ax, "crank angle phi1 [deg]" if k % rows == rows - 1 else "", r.cycle_angle)
        ax.set_ylim(0.0, 1.12 * max(float(np.max(magnitude)), 1e-12))
        ax.set_title(f"{joint} ({r.reactions.kind[joint]}): peak {engineering(float(np.max(magnitude)), 'N')}",
                     fontsize=9, loc="left")
        ax.set_ylabel("|F| [N]", fontsize=8)
    for ax in list(axes.T.flat)[len(joints):]:
        ax.set_axis_off()
    switches = ", ".join(f"{s:.1f}" for s in switches_deg)
    fig.suptitle(f"{scenario.name}: joint reactions at omega1 = {r.omega1:g} rad/s"
                 + (f" (dotted: a switched load changes, at {switches} deg)" if switches else ""), fontsize=10)
    save_figure(fig, path, dpi=110, scenario=scenario.name,
                caption=f"The magnitude of every joint's reaction force over one crank turn at {r.omega1:g} rad/s "
                        "(Newton-Euler, inertia included), a panel per joint."
                        + (f" The jumps are at the angles where a switched load changes ({switches} deg): "
                           f"{r.switched or 'a load switched by its direction'}." if switches else ""))
    plt.close(fig)
    return path
