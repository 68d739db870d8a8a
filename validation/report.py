"""report.md: a summary table first (one row per FMU), the FMUs not validated with their reasons,
every published number with its verdict, then each FMU's details with PNG plots (every compared
output over its reference, small multiples, with its error and the tolerance line), and the
versions and commit it was made with."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import platform
import subprocess
import time
from pathlib import Path

import numpy as np

from crankfmu.atomic import save_figure, write_text
from crankfmu.pages.markup import markdown, page
from crankfmu.plots import pyplot

def plot_outputs(run, ref, names, tolerances: dict, path: Path, title: str) -> Path:
    """One small multiple per output: the FMU's value over the reference's (top), and below it the
    error relative to the output's scale on a log axis with the check's tolerance as a dashed line.
    The legend is the figure's title line, not a box over the data."""
    plt = pyplot()
    names = [n for n in names if n in run.values and n in ref.values]     # every compared output
    cols = min(4, max(1, len(names)))
    rows = max(1, math.ceil(len(names) / cols))
    head = 0.9                                      # inches for the two title lines
    fig = plt.figure(figsize=(3.6 * cols, 3.4 * rows + head))
    outer = fig.add_gridspec(rows, cols, hspace=0.42, wspace=0.38, top=1.0 - head / (3.4 * rows + head),
                             bottom=0.5 / (3.4 * rows + head), left=0.07, right=0.98)
    for k, name in enumerate(names):
        r, c = divmod(k, cols)
        cell = outer[r, c].subgridspec(2, 1, height_ratios=[2.0, 1.0], hspace=0.08)
        top = fig.add_subplot(cell[0])
        bottom = fig.add_subplot(cell[1], sharex=top)
        a, b = np.asarray(run[name], dtype=float), np.asarray(ref[name], dtype=float)
        unit = getattr(run, "units", {}).get(name)
        top.plot(ref.time, b, lw=2.6, color="0.75")
        top.plot(run.time, a, lw=0.9, color="C0")
        top.set_title(f"{name} [{unit or '1'}]", fontsize=8)
        top.tick_params(labelsize=7, labelbottom=False)
        top.grid(alpha=0.3)
        scale = float(np.max(np.abs(b))) or 1.0
        bottom.semilogy(run.time, np.maximum(np.abs(a - b) / scale, 1e-17), lw=0.7, color="C3")
        tol = tolerances.get(name)
        if tol:
            bottom.axhline(tol, color="k", ls="--", lw=0.8)
        bottom.set_ylim(1e-17, max(1.0, 10 * (tol or 0)))
        bottom.set_yticks([1e-15, 1e-10, 1e-5, 1.0])
        bottom.tick_params(labelsize=7)
        bottom.grid(alpha=0.3, which="major")
        if c == 0:
            bottom.set_ylabel("|error| / max|ref| [1]", fontsize=7)
        bottom.set_xlabel("time [s]", fontsize=7)
    fig.suptitle(f"{title}\ngrey: in-process reference; blue: FMU through fmpy; red: relative error; "
                 "dashed: the check's tolerance", fontsize=9, y=1.0 - 0.12 / (3.4 * rows + head))
    save_figure(fig, path, dpi=80)
    plt.close(fig)
    return path


def plot_work_precision(points, path: Path, title: str) -> Path:
    """Error against time, one line per method (its own colour and marker), the key outside the
    axes on the right, never over the data."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(12, 6.5))
    families = list(dict.fromkeys(p.family for p in points))
    markers = "osD^v<>ph*Xd"
    colours = plt.get_cmap("tab20").colors
    for i, fam in enumerate(families):
        pts = sorted((p for p in points if p.family == fam and math.isfinite(p.omega1_error)),
                     key=lambda p: p.time_s)
        if not pts:
            continue
        ax.loglog([p.time_s * 1e3 for p in pts], [max(p.omega1_error, 1e-16) for p in pts],
                  marker=markers[i % len(markers)], color=colours[(2 * i) % 20 + (i // 10) % 2], lw=1, ms=5,
                  label=fam)
    ax.set_xlabel("median wall time [ms]")
    ax.set_ylabel("max |omega1 error| on the output grid [rad/s]")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return path


def _g(x, digits=3):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{digits}g}" if isinstance(x, float) else str(x)


def worst_ratio(checks) -> tuple[float, object]:
    """The check closest to (or furthest past) its bar: |measured - expected| / tolerance."""
    worst, at = 0.0, None
    for c in checks:
        if c.ratio is not None and c.ratio >= worst:
            worst, at = c.ratio, c
    return worst, at


def versions() -> list[str]:
    """What the report was made with: the packages, Python, the machine and the commit."""
    from importlib.metadata import PackageNotFoundError, version

    out = []
    for name in ("crankfmu", "fmpy", "numpy", "scipy", "matplotlib", "pythonfmu"):
        try:
            out.append(f"{name} {version(name)}")
        except PackageNotFoundError:
            out.append(f"{name} (not installed)")
    out.append(f"Python {platform.python_version()}")
    try:
        here = Path(__file__).resolve().parent
        commit = subprocess.run(["git", "-C", str(here), "describe", "--always", "--dirty", "--abbrev=12"],
                                capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    out.append(f"commit {commit or 'unknown (not a git checkout)'}")
    return out


def write_report(out: Path, sections: list[dict], not_validated: list[tuple[str, str]], checks, quick: bool,
                 elapsed: float) -> Path:
    lines = [
        "# crankfmu validation report",
        "",
        f"{time.strftime('%Y-%m-%d %H:%M')} on {platform.node()} ({platform.machine()}, {os.cpu_count()} cores); "
        f"mode: {'--quick (CI subset)' if quick else 'full'}; {elapsed:.0f} s. " + "; ".join(versions()) + ".",
        "",
        f"**{checks.summary()}; {len(sections)} FMUs validated, {len(not_validated)} not validated.**",
        "",
        "## Summary",
        "",
        "| FMU | build | kind | interfaces | passed | failed | skipped | worst check against its tolerance | time [s] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for s in sections:
        items = s["checks"]
        passed = sum(c.passed for c in items)
        skipped = sum(c.skipped for c in items)
        ratio, at = worst_ratio(items)
        worst = f"{ratio:.2g} of the bar ({at.name.split('.', 2)[-1]})" if at is not None else "-"
        lines.append(f"| [{s['name']}.fmu](#{_anchor(s)}) | {s['build']} | {s['kind']} | {', '.join(s['interfaces'])} | "
                     f"{passed} | {len(items) - passed - skipped} | {skipped} | {worst} | {s['wall']:.1f} |")
    lines.append("")
    if not_validated:
        lines += ["## Not validated", "", "| FMU | why |", "|---|---|"]
        lines += [f"| {name} | {why} |" for name, why in not_validated]
        lines.append("")
    failed = [c for c in checks.items if not c.passed and not c.skipped]
    if failed:
        lines += ["## Failed checks", "", "| check | measured | expected | tolerance | note |", "|---|---|---|---|---|"]
        lines += [f"| {c.name} | {_g(c.measured, 6)} | {c.expected} | {c.tolerance} | {c.note} |" for c in failed]
        lines.append("")
    papers = [c for c in checks.items if c.verdict]
    if papers:
        lines += ["## The papers' numbers", "",
                  "Each published number with its verdict: agrees (within its tolerance), disagrees (the measured "
                  "value and the reason), not comparable (why). Checked on every FMU of the scenario; one row per "
                  "FMU.", "",
                  "| number | verdict | measured | published | tolerance | source and reason |", "|---|---|---|---|---|---|"]
        for c in papers:
            measured = "-" if c.skipped else f"{c.measured:.6g} {'' if c.unit in ('', '1') else c.unit}".strip()
            lines.append(f"| {c.name} | **{c.verdict}** | {measured} | {c.published} | {c.tolerance} | "
                         f"{c.note.replace('|', '/')} |")
        lines.append("")
    for s in sections:
        lines += _details(s)
    lines += ["## Every check", "", "```"] + [c.line() for c in checks.items] + ["```", ""]
    path = out / "report.md"
    text = "\n".join(lines)
    write_text(path, text)
    # the same report for a browser (the results page links it), and its checks for a program
    write_text(out / "report.html", page("crankfmu validation report", markdown(text)).decode())
    write_text(out / "checks.json", json.dumps(checks_record(sections, not_validated, checks, quick), indent=1,
                                               default=_json_number) + "\n")
    return path


def checks_record(sections: list[dict], not_validated, checks, quick: bool) -> dict:
    """What a program (the results page) reads of a harness run: each FMU validated (its name,
    build, kind, data file and counts) and every check with its fields."""
    fmus = []
    for s in sections:
        items = s["checks"]
        passed, skipped = sum(c.passed for c in items), sum(c.skipped for c in items)
        fmus.append({"name": s["name"], "build": s["build"], "kind": s["kind"], "data": str(s["data"]),
                     "interfaces": list(s["interfaces"]), "passed": passed, "skipped": skipped,
                     "failed": len(items) - passed - skipped})
    return {"summary": checks.summary(), "quick": quick, "versions": versions(), "fmus": fmus,
            "not_validated": [{"name": n, "why": w} for n, w in not_validated],
            "checks": [dataclasses.asdict(c) for c in checks.items]}


def _json_number(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {obj!r}")


def _anchor(s) -> str:
    return f"{s['name'].lower()}fmu-{s['build']}"


def _details(s) -> list[str]:
    lines = [f"## {s['name']}.fmu {s['build']}", "", f"{s['kind']}; data file `{s['data']}`; `{s['path']}`.", ""]
    for d in s.get("default", []):
        if "rows" not in d:
            continue
        lines += [f"### {d['interface']}: {d.get('what', 'the default experiment against the in-process reference')}",
                  "", f"{d['span']:g} s at {d['step']:g} s communication steps; FMU {d['fmu_wall']:.2f} s"
                  + (f", reference {d['ref_wall']:.2f} s" if d.get("ref_wall") else "") + ".", "",
                  "| output | max abs error | relative to max abs | tolerance |", "|---|---|---|---|"]
        lines += [f"| {r['output']} [{r['unit']}] | {r['abs']:.3g} | {r['rel']:.3g} | {r['tol']:g} |" for r in d["rows"]]
        lines += ["", f"![outputs]({d['plot']})", ""]
    if s.get("native_vs_python"):
        rows = s["native_vs_python"]["rows"]
        lines += ["### Native against Python (Co-Simulation, same scenario file)", "",
                  "| output | relative difference | tolerance |", "|---|---|---|"]
        lines += [f"| {r['output']} | {r['rel']:.3g} | {r['tol']:g} |" for r in rows]
        lines.append("")
    if "work_precision" in s:
        lines += _work_precision(s["work_precision"])
    if s.get("hard"):
        lines += ["### Hard cases", "",
                  "| case | interface | g [m/s2] | span [s] | step [s] | omega1 rel. error | phi1(end) error [rad] | "
                  "energy residual | FMU [s] | reference [s] | checks | notes |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in s["hard"]:
            passed = sum(c.passed for c in r["checks"])
            skipped = sum(c.skipped for c in r["checks"])
            lines.append(
                f"| {r['case']} | {r.get('interface', 'CoSimulation')} | {_g(r.get('g'))} | {_g(r.get('stop_time'))} | "
                f"{_g(r.get('step'))} | {_g(r.get('omega1_rel_error'))} | {_g(r.get('phi1_end_error'))} | "
                f"{_g(r.get('energy_residual'))} | {_g(r.get('fmu_wall'))} | {_g(r.get('ref_wall'))} | "
                f"{passed}/{len(r['checks']) - skipped}" + (f" ({skipped} skipped)" if skipped else "") +
                f" | {r.get('note', '').replace('|', '/')} |")
        lines += ["", "Expectations:", ""]
        seen = set()
        for r in s["hard"]:
            if r["case"] not in seen:
                seen.add(r["case"])
                lines.append(f"- **{r['case']}**: {r['expect']}")
        lines.append("")
        lines += [f"![{r['case']}]({r['plot']})" for r in s["hard"] if r.get("plot")]
        lines.append("")
    return lines


def _work_precision(wp) -> list[str]:
    lines = ["### Speed against error", "",
             f"Error: max |omega1 error| on the {wp['meta']['grid_s'] * 1e3:g} ms grid over {wp['meta']['span_s']:g} s "
             f"and |phi1 error| at the end, against {wp['meta']['truth']}. Time: median of up to "
             f"{wp['meta']['repeats']} runs (1 when a run takes over 1 s), all measured in this one run.", "",
             f"![work-precision]({wp['plot']})", "",
             "Fastest setting of each method reaching the error, and its time relative to the fastest method there:", ""]
    targets = wp["targets"]
    lines.append("| method | " + " | ".join(f"error <= {t:g} rad/s" for t in targets) + " |")
    lines.append("|---|" + "---|" * len(targets))
    for row in wp["ratios"]:
        cells = ["-" if row[t] is None else f"{row[t]['time_s'] * 1e3:.3g} ms ({row[t]['setting']}), x{row[t]['ratio']:.3g}"
                 for t in targets]
        lines.append(f"| {row['family']} | " + " | ".join(cells) + " |")
    lines += ["", *wp["verdict"], "", "All points:", "",
              "| method | setting | omega1 error [rad/s] | phi1(end) error [rad] | time [ms] | runs | note |",
              "|---|---|---|---|---|---|---|"]
    lines += [f"| {p.family} | {p.setting} | {_g(p.omega1_error)} | {_g(p.phi1_error)} | "
              f"{_g(p.time_s * 1e3 if math.isfinite(p.time_s) else float('nan'), 4)} | {p.repeats} | {p.note} |"
              for p in wp["points"]]
    lines.append("")
    return lines
