"""report.md with its tables and PNG plots (reference and FMU overlaid, error over time,
work-precision)."""

from __future__ import annotations

import math
import os
import platform
import time
from pathlib import Path

import numpy as np

from crankfmu.plots import pyplot
from crankfmu.atomic import save_figure, write_text


def plot_overlay(fmu_run, ref, path: Path, title: str) -> Path:
    """omega1 of the FMU over the reference's (top) and |omega1 error| over time (bottom)."""
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    top.plot(ref.time, ref["omega1"], lw=2.5, color="0.7", label=f"in-process {ref.label}")
    top.plot(fmu_run.time, fmu_run["omega1"], lw=0.9, color="C0", label="FMU through fmpy")
    top.set_ylabel("omega1 [rad/s]")
    top.set_title(title)
    top.legend(loc="best")
    top.grid(True, alpha=0.3)
    err = np.abs(fmu_run["omega1"] - ref["omega1"])
    bottom.semilogy(fmu_run.time, np.maximum(err, 1e-16), lw=0.8, color="C3")
    bottom.set_ylabel("|omega1 error| [rad/s]")
    bottom.set_xlabel("time [s]")
    bottom.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def plot_work_precision(points, path: Path, title: str) -> Path:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 6))
    families = list(dict.fromkeys(p.family for p in points))
    markers = "osD^v<>ph*Xd"
    for i, fam in enumerate(families):
        pts = sorted((p for p in points if p.family == fam and math.isfinite(p.omega1_error)),
                     key=lambda p: p.time_s)
        if not pts:
            continue
        ax.loglog([p.time_s * 1e3 for p in pts], [max(p.omega1_error, 1e-16) for p in pts],
                  marker=markers[i % len(markers)], lw=1, label=fam)
    ax.set_xlabel("median wall time [ms]")
    ax.set_ylabel("max |omega1 error| on the 1 ms grid over 2 s [rad/s]")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def _g(x, digits=3):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{digits}g}" if isinstance(x, float) else str(x)


def write_report(out: Path, sections: list[dict], checks, quick: bool, elapsed: float) -> Path:
    lines = [
        "# crankfmu validation report",
        "",
        f"{time.strftime('%Y-%m-%d %H:%M')} on {platform.node()} ({platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}); mode: {'--quick (CI subset)' if quick else 'full'}; "
        f"{elapsed:.0f} s.",
        "",
        f"**{checks.summary()}.**",
        "",
    ]
    failed = [c for c in checks.items if not c.passed]
    if failed:
        lines += ["## Failed checks", "", "| check | measured | expected | tolerance | note |", "|---|---|---|---|---|"]
        lines += [f"| {c.name} | {_g(c.measured, 6)} | {c.expected} | {c.tolerance} | {c.note} |" for c in failed]
        lines.append("")
    for s in sections:
        lines += [f"## {s['name']}.fmu (scenario {s['scenario']})", ""]
        lines += s.get("intro", [])
        if "default" in s:
            d = s["default"]
            lines += ["### Default experiment: FMU (fmpy) against the in-process reference", "",
                      f"{d['span']:g} s at {d['step']:g} s communication steps; FMU {d['fmu_wall']:.2f} s, "
                      f"reference {d['ref_wall']:.2f} s.", "",
                      "| output | max abs error | relative to max abs | tolerance |", "|---|---|---|---|"]
            lines += [f"| {r['output']} [{r['unit']}] | {r['abs']:.3g} | {r['rel']:.3g} | {r['tol']:g} |"
                      for r in d["rows"]]
            lines += ["", f"![omega1, FMU over reference]({d['plot']})", ""]
        if s.get("paper"):
            lines += ["### The paper's numbers", "", "| check | measured | published | tolerance | source |",
                      "|---|---|---|---|---|"]
            lines += [f"| {c.name.split('.')[-1]} | {c.measured:.6g} {'' if c.unit == '1' else c.unit} | {c.expected} | {c.tolerance} | "
                      f"{c.note} |" for c in s["paper"]]
            lines.append("")
        if "work_precision" in s:
            wp = s["work_precision"]
            lines += ["### Speed against error", "",
                      f"Error: max |omega1 error| on the {wp['meta']['grid_s'] * 1e3:g} ms grid over "
                      f"{wp['meta']['span_s']:g} s and |phi1 error| at the end, against {wp['meta']['truth']}. "
                      f"Time: median of up to {wp['meta']['repeats']} runs (1 when a run takes over 1 s), "
                      "all measured in this one run.", "",
                      f"![work-precision]({wp['plot']})", "",
                      "Fastest setting of each method reaching the error, and its time relative to the fastest "
                      "method there:", ""]
            targets = wp["targets"]
            lines.append("| method | " + " | ".join(f"error <= {t:g} rad/s" for t in targets) + " |")
            lines.append("|---|" + "---|" * len(targets))
            for row in wp["ratios"]:
                cells = []
                for t in targets:
                    c = row[t]
                    cells.append("-" if c is None else f"{c['time_s'] * 1e3:.3g} ms ({c['setting']}), x{c['ratio']:.3g}")
                lines.append(f"| {row['family']} | " + " | ".join(cells) + " |")
            lines += ["", *wp["verdict"], "", "All points:", "",
                      "| method | setting | omega1 error [rad/s] | phi1(end) error [rad] | time [ms] | runs | note |",
                      "|---|---|---|---|---|---|---|"]
            lines += [f"| {p.family} | {p.setting} | {_g(p.omega1_error)} | {_g(p.phi1_error)} | "
                      f"{_g(p.time_s * 1e3 if math.isfinite(p.time_s) else float('nan'), 4)} | {p.repeats} | {p.note} |"
                      for p in wp["points"]]
            lines.append("")
        if s.get("hard"):
            lines += ["### Hard cases", "",
                      "| case | g [m/s2] | span [s] | step [s] | omega1 rel. error | phi1(end) error [rad] | "
                      "energy residual | FMU [s] | reference [s] | checks | notes |",
                      "|---|---|---|---|---|---|---|---|---|---|---|"]
            for r in s["hard"]:
                passed = sum(c.passed for c in r["checks"])
                lines.append(
                    f"| {r['case']} | {r['g']:g} | {r['stop_time']:g} | {r['step']:g} | "
                    f"{_g(r.get('omega1_rel_error'))} | {_g(r.get('phi1_end_error'))} | "
                    f"{_g(r.get('energy_residual'))} | {_g(r.get('fmu_wall'))} | {_g(r.get('ref_wall'))} | "
                    f"{passed}/{len(r['checks'])} | {r.get('note', '').replace('|', '/')} |")
            lines += ["", "Expectations:", ""]
            seen = set()
            for r in s["hard"]:
                if r["case"] not in seen:
                    seen.add(r["case"])
                    lines.append(f"- **{r['case']}**: {r['expect']}")
            lines.append("")
            for r in s["hard"]:
                if r.get("plot"):
                    lines.append(f"![{r['case']} g={r['g']:g}]({r['plot']})")
            lines.append("")
    lines += ["## Every check", "", "```"] + [c.line() for c in checks.items] + ["```", ""]
    path = out / "report.md"
    write_text(path, "\n".join(lines))
    return path
