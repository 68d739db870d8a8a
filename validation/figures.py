"""The harness's figures: every compared output over its reference (one small multiple each),
and the speed-against-error study (one panel per family of methods, the peer on each)."""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
from matplotlib.ticker import MaxNLocator, NullLocator

from crankfmu.atomic import save_figure
from crankfmu.plots import pyplot


#: the figures of plot_outputs kept in this process, by their outputs' names (the Python and native
#: FMUs of one data file, in each interface, draw the same panels): building a figure's axes is
#: about 40 % of its time, so a layout drawn before is filled again. At most LAYOUTS_KEPT, the
#: oldest closed first.
_LAYOUTS: dict = {}
LAYOUTS_KEPT = 4


def plot_outputs(run, ref, names, tolerances: dict, path: Path, title: str) -> Path:
    """One small multiple per output: the FMU's value over the reference's (top), and below it the
    error relative to the output's scale on a log axis with the check's tolerance as a dashed line.
    The legend is the figure's title line, not a box over the data."""
    names = [n for n in names if n in run.values and n in ref.values]     # every compared output
    key = tuple(names)
    if key not in _LAYOUTS:
        if len(_LAYOUTS) >= LAYOUTS_KEPT:
            pyplot().close(_LAYOUTS.pop(next(iter(_LAYOUTS)))[0])
        _LAYOUTS[key] = _layout(names)
    fig, panels, heading = _LAYOUTS[key]
    units = getattr(run, "units", {})
    for name, (top, bottom, reference_line, fmu_line, label, error_line, bar_line) in zip(names, panels):
        a, b = np.asarray(run[name], dtype=float), np.asarray(ref[name], dtype=float)
        reference_line.set_data(ref.time, b)
        fmu_line.set_data(run.time, a)
        label.set_text(f"{name} [{units.get(name) or '1'}]")
        scale = float(np.max(np.abs(b))) or 1.0
        error_line.set_data(run.time, np.maximum(np.abs(a - b) / scale, 1e-17))
        tol = tolerances.get(name)
        bar_line.set_ydata([tol or 1.0, tol or 1.0])
        bar_line.set_visible(bool(tol))
        top.relim()
        bottom.relim()              # (the time axis is shared: both panels' data set its limits)
        top.autoscale_view()
        bottom.set_ylim(1e-17, max(1.0, 10 * (tol or 0)))
    heading.set_text(f"{title}\ngrey: in-process reference; blue: FMU through fmpy; red: relative error; "
                     "dashed: the check's bar")
    heading.set_fontsize(10)                 # (save_figure shrinks a title that runs past the edge)
    save_figure(fig, path, dpi=80)
    return path


def _layout(names):
    """(figure, per output (top and bottom axes, reference, FMU, name, error and bar artists), the
    figure's title) for plot_outputs, the artists empty."""
    plt = pyplot()
    # 3 columns of 4.8 in at 80 dpi: 1152 px, the report's width, so its text (9 pt and up: 10 px
    # and up) is shown at its own size
    cols = min(3, max(1, len(names)))
    rows = max(1, math.ceil(len(names) / cols))
    head = 0.9                                      # inches for the two title lines
    fig = plt.figure(figsize=(4.8 * cols, 3.4 * rows + head))
    outer = fig.add_gridspec(rows, cols, hspace=0.42, wspace=0.38, top=1.0 - head / (3.4 * rows + head),
                             bottom=0.5 / (3.4 * rows + head), left=0.07, right=0.98)
    panels = []
    for k, name in enumerate(names):
        r, c = divmod(k, cols)
        cell = outer[r, c].subgridspec(2, 1, height_ratios=[2.0, 1.0], hspace=0.08)
        top = fig.add_subplot(cell[0])
        bottom = fig.add_subplot(cell[1], sharex=top)
        reference_line, = top.plot([], [], lw=2.6, color="0.75")
        fmu_line, = top.plot([], [], lw=0.9, color="C0")
        # the panel's name as a plain text over it, not an axes title: matplotlib moves each title
        # clear of the axes' decorations at every draw, a quarter of a 36-output figure's time
        label = top.text(0.5, 1.03, "", fontsize=10, ha="center", va="bottom", transform=top.transAxes)
        top.tick_params(labelsize=9, labelbottom=False)
        # at most 5 ticks on each axis (the bottom panel shares the time axis): matplotlib makes each
        # tick as an object of its own, most of a 36-output figure's drawing time
        top.xaxis.set_major_locator(MaxNLocator(5, steps=[1, 2, 2.5, 5, 10]))
        top.yaxis.set_major_locator(MaxNLocator(5, steps=[1, 2, 2.5, 5, 10]))
        top.grid(alpha=0.3)
        error_line, = bottom.semilogy([], [], lw=0.7, color="C3")
        bar_line = bottom.axhline(1.0, color="k", ls="--", lw=0.8)
        # the decades as plain text: the log axis' own labels are mathtext (10 to a power), laid out
        # anew at every draw, 15 % of a 18-output figure's refill
        bottom.set_yticks([1e-15, 1e-10, 1e-5, 1.0], ["1e-15", "1e-10", "1e-5", "1"])
        # no minor ticks on the 17 decades: 136 tick marks per panel too small to read, and most of the
        # figure's drawing time (a 36-output figure took 5.3 s)
        bottom.yaxis.set_minor_locator(NullLocator())
        bottom.tick_params(labelsize=9)
        bottom.grid(alpha=0.3, which="major")
        if c == 0:
            bottom.set_ylabel("|error| / max|ref| [1]", fontsize=9)
        bottom.set_xlabel("time [s]", fontsize=9)
        panels.append((top, bottom, reference_line, fmu_line, label, error_line, bar_line))
    heading = fig.suptitle("", fontsize=10, y=1.0 - 0.12 / (3.4 * rows + head))
    return fig, panels, heading


#: the speed-against-error study's panels, each a family of methods (at most six series and the peer)
PANELS = (
    ("FMUs, rtol sweep at 1 ms steps (Co-Simulation)", lambda f: "FMU" in f and "rtol sweep" in f),
    ("FMUs, communication step sweep (Co-Simulation)", lambda f: "FMU" in f and "step sweep" in f),
    ("FMUs as Model Exchange (fmpy's CVode)", lambda f: "Model Exchange" in f),
    ("crankfmu in process and the papers' schemes", lambda f: f.startswith(("crankfmu", "paper"))),
    ("scipy solve_ivp on the same equation", lambda f: f.startswith("solve_ivp")),
)
PEER = "solve_ivp DOP853"


def plot_work_precision(points, path: Path, title: str) -> Path:
    """Small multiples, one panel per family of methods (PANELS), each with the peer (scipy's
    DOP853) drawn grey on it; a point is the median time with a bar from the fastest to the slowest
    run; a hollow marker is a run coarser than the output grid (not in the verdicts). Each panel's
    key is under it, outside the data."""
    plt = pyplot()
    panels = [(t, [f for f in dict.fromkeys(p.family for p in points) if keep(f)]) for t, keep in PANELS]
    panels = [(t, fams) for t, fams in panels if fams]
    cols = min(3, len(panels))
    rows = math.ceil(len(panels) / cols)
    # 3 panels of 3.8 in at 100 dpi: 1140 px, the report's width, so 9 pt text shows at 12 px
    fig, axes = plt.subplots(rows, cols, figsize=(3.8 * cols, 4.6 * rows), squeeze=False, sharex=True, sharey=True)
    finite = [p for p in points if math.isfinite(p.omega1_error) and math.isfinite(p.time_s)]
    peer = sorted((p for p in finite if p.family == PEER), key=lambda p: p.time_s)
    markers = "osD^v<>"
    for ax, (panel, families) in zip(axes.flat, panels):
        if peer and PEER not in families:
            ax.loglog([p.time_s * 1e3 for p in peer], [max(p.omega1_error, 1e-16) for p in peer], color="0.55",
                      lw=2.5, alpha=0.6, label=f"{PEER} (the peer)")
        for i, fam in enumerate(families):
            pts = sorted((p for p in finite if p.family == fam), key=lambda p: p.time_s)
            if not pts:
                continue
            colour = "0.35" if fam == PEER else f"C{i}"
            x = np.array([p.time_s * 1e3 for p in pts])
            y = np.array([max(p.omega1_error, 1e-16) for p in pts])
            spread = np.array([[p.time_s - p.time_min, p.time_max - p.time_s] for p in pts]).T * 1e3
            # a key's line wraps at 42 characters: the key stays under its own panel, inside the figure
            label = textwrap.fill(fam if fam != PEER else f"{PEER} (the peer)", 42)
            ax.errorbar(x, y, xerr=np.nan_to_num(spread), color=colour, lw=1, ms=6, marker=markers[i % len(markers)],
                        capsize=2, label=label, mfc=colour)
            hollow = [k for k, p in enumerate(pts) if not p.on_grid]
            if hollow:
                ax.plot(x[hollow], y[hollow], ls="none", marker=markers[i % len(markers)], ms=9, mfc="white",
                        color=colour)
            ax.set_xscale("log")
            ax.set_yscale("log")
        ax.set_title(textwrap.fill(panel, 40), fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.tick_params(labelsize=9, labelbottom=True, labelleft=True)
        ax.set_xlabel("median wall time [ms]", fontsize=9)
        ax.set_ylabel("max |omega1 error| [rad/s]", fontsize=9)
        ax.legend(fontsize=9, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=1, frameon=False)
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    fig.suptitle(f"{title}\nbars: fastest to slowest run; hollow: steps coarser than the output grid "
                 "(not in the verdicts)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return path


def plot_coupled(scene: str, rows: list[dict], path: Path) -> Path:
    """A coupled scene's error against the communication step, one line per master (a third-party
    master's dashed), each labelled in the right margin with a leader to its line's end, the labels
    in the order of the ends and none over another (no legend box); above it, a strip with a row per
    master and an x at each step where its run diverged."""
    plt = pyplot()
    masters = list(dict.fromkeys(r["master"] for r in rows))
    fig, (strip, ax) = plt.subplots(2, 1, figsize=(8.4, 5.4), sharex=True,
                                    gridspec_kw={"height_ratios": [0.9, 4.0], "hspace": 0.08})
    ends = []
    for k, master in enumerate(masters):
        mine = sorted((r["step"], r["error"]) for r in rows if r["master"] == master)
        color = f"C{k}"
        finite = [(h, e) for h, e in mine if math.isfinite(e) and e > 0]
        if finite:
            ax.loglog(*zip(*finite), marker="osD^v<>"[k % 7], ms=4, lw=1.2, color=color,
                      ls="--" if master.startswith("CoFMPy") else "-")
            ends.append((math.log10(finite[-1][1]), finite[-1][0], master, color))
        diverged = [h for h, e in mine if not math.isfinite(e)]
        strip.plot(diverged, [k] * len(diverged), "x", ms=7, color=color)
    strip.set_yticks(range(len(masters)), masters, fontsize=7)
    strip.set_ylim(len(masters) - 0.5, -0.5)
    strip.set_title(f"{scene}: coupled error against the step (top: the runs that diverged)", fontsize=10)
    strip.grid(True, axis="x", which="both", lw=0.3, color="0.85")
    ax.set_xscale("log")
    ax.set_xlabel("communication step H (s)")
    ax.set_ylabel("max |omega1 - reference| / max omega1 (1)")
    ax.grid(True, which="both", lw=0.3, color="0.85")
    steps = sorted({r["step"] for r in rows})
    ax.set_xlim(steps[0] / 1.5, steps[-1] * 1.5)
    if ends:
        low, high = (math.log10(v) for v in ax.get_ylim())
        placed = []
        for y, h, master, color in sorted(ends):
            fraction = (y - low) / (high - low)
            placed.append((max(fraction, placed[-1][0] + 0.06) if placed else fraction, y, h, master, color))
        shift = max(0.0, placed[-1][0] - 1.0)           # the top label stays inside the plot's height
        for fraction, y, h, master, color in placed:
            ax.annotate(master, (h, 10 ** y), xytext=(1.03, fraction - shift), textcoords="axes fraction", fontsize=8,
                        color=color, va="center", annotation_clip=False,
                        arrowprops={"arrowstyle": "-", "color": color, "lw": 0.5, "alpha": 0.6})
    fig.subplots_adjust(left=0.2, right=0.8, top=0.93, bottom=0.11)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
