"""report.md (and report.html): what a person reads of a harness run.

First the verdict counts and a summary (one row per FMU build: its counts and its worst check
against its bar), the failed checks and the FMUs not validated; then one section per data file,
its builds side by side: each published number once with every build's value, the default
experiment's errors (a column per build and interface), the native builds against the Python one,
speed against error, and the hard cases. Plots, every point and every check are folded
(``<details>``: closed on screen and left out of a print), so the report prints short."""

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

from crankfmu.atomic import write_text
from crankfmu.pages.markup import markdown, page

from .checks import STATUSES, count, summary_of

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


#: the verdict counts' columns, as the summary table heads them
COUNT_HEADS = {"passed": "passed", "failed": "failed", "disagrees": "disagree", "fitted": "fitted",
               "not comparable": "not comparable", "skipped": "skipped"}
SHORT = {"CoSimulation": "CS", "ModelExchange": "ME"}


#: what each subset of the harness is called in the report and the results page
SUBSETS = {"full": "the full harness",
           "quick": "the --quick subset, make test's: shorter hard cases and fewer speed-against-error points",
           "demo": "the --demo subset, make demo's: no hard cases, no speed against error and no coupled scenes, "
                   "which make validate runs"}


def shortened(subset: str) -> bool:
    """Whether ``subset`` (SUBSETS) runs the hard cases over their quick spans, fewer
    speed-against-error points and the coupled scenes' barred steps only: quick's and demo's way."""
    return subset != "full"


def write_report(out: Path, sections: list[dict], not_validated: list[tuple[str, str]], checks, subset: str,
                 elapsed: float) -> Path:
    counts = count(checks.items)
    shown = [st for st in STATUSES if st in ("passed", "failed") or counts[st]]
    lines = [
        "# crankfmu validation report",
        "",
        f"**{checks.summary()}**: {len(sections)} FMU{'s' if len(sections) != 1 else ''} validated (each build of "
        f"each data file apart), {len(not_validated)} not validated, in {elapsed:.0f} s "
        f"({time.strftime('%Y-%m-%d %H:%M')} on {platform.node()}, {platform.machine()}, {os.cpu_count()} cores). "
        f"This run is {SUBSETS[subset]}.",
        "",
        "A run fails (exit status 1) on any failed check, and when nothing passed. A published number that "
        "**disagrees** for a reason stated in its data file, or was **fitted** (the data set was chosen to give it), "
        "is counted apart and does not fail the run; if its value changes, it fails. docs/validation.md says what "
        "each verdict, bar and skip means.",
        "",
        "## Summary",
        "",
        "| FMU | build | kind | interfaces | " + " | ".join(COUNT_HEADS[st] for st in shown)
        + " | worst check against its bar | time [s] |",
        "|---|---|---|---|" + "---|" * len(shown) + "---|---|",
    ]
    for sec in sections:
        c = count(sec["checks"])
        ratio, at = worst_ratio(sec["checks"])
        worst = f"{ratio:.2g} of the bar ({at.name.split('.', 2)[-1]})" if at is not None else "-"
        shown_name = sec["name"] if "coupled" in sec else f"{sec['name']}.fmu"
        lines.append(f"| [{shown_name}](#{_group_anchor(sec['data'])}) | {sec['build']} | {sec['kind']} | "
                     f"{', '.join(SHORT.get(i, i) for i in sec['interfaces'])} | "
                     + " | ".join(str(c[st]) for st in shown) + f" | {worst} | {sec['wall']:.1f} |")
    lines.append("")
    failed = [c for c in checks.items if c.status == "failed"]
    if failed:
        lines += ["## Failed checks", "", "| check | measured | expected | bar | note |", "|---|---|---|---|---|"]
        lines += [f"| {c.name} | {_g(c.measured, 6)} | {c.expected} | {c.tolerance} | {_cell(c.note)} |" for c in failed]
        lines.append("")
    if not_validated:
        lines += ["## Not validated", "", "| FMU | why |", "|---|---|"]
        lines += [f"| {name} | {_cell(why)} |" for name, why in not_validated]
        lines.append("")
    groups: dict[str, list[dict]] = {}
    for sec in sections:
        groups.setdefault(str(sec["data"]), []).append(sec)
    for data, secs in groups.items():
        lines += _group(data, secs)
    lines += ["## Every check", "", "<details>", f"<summary>{len(checks.items)} checks, one line each</summary>", "",
              "```"] + [c.line() for c in checks.items] + ["```", "", "</details>", "",
              "## Made with", "", "; ".join(versions()) + ".", ""]
    path = out / "report.md"
    text = "\n".join(lines)
    write_text(path, text)
    # the same report for a browser (the results page links it), and its checks for a program
    write_text(out / "report.html", page("crankfmu validation report", markdown(text)).decode())
    write_text(out / "checks.json", json.dumps(checks_record(sections, not_validated, checks, subset), indent=1,
                                               default=_json_number) + "\n")
    return path


def _cell(text) -> str:
    """Text for a table cell: no pipe, no line break."""
    return " ".join(str(text).replace("|", "/").split())


def _group_anchor(data) -> str:
    from crankfmu.pages.markup import slug
    return slug(f"{Path(str(data)).stem}")


def _label(sec) -> str:
    return f"{sec['name']} {sec['build']}"


def _group(data: str, secs: list[dict]) -> list[str]:
    """One data file's section: its builds side by side (the coupled scenes: their own section)."""
    if all("coupled" in s for s in secs):
        return _coupled(secs[0]["coupled"])
    lines = [f"## {Path(data).stem}", "",
             "Builds: " + "; ".join(f"`{s['name']}.fmu` {s['build']} ({s['kind']}, "
                                    f"{', '.join(SHORT.get(i, i) for i in s['interfaces'])}: "
                                    f"{summary_of(count(s['checks']))})" for s in secs) + ".", ""]
    lines += _papers(secs)
    lines += _defaults(secs)
    lines += _native_vs_python(secs)
    for s in secs:
        if "work_precision" in s:
            lines += _work_precision(s["work_precision"])
    lines += _hard(secs)
    return lines


def _papers(secs) -> list[str]:
    """Each published number once, with each build's value."""
    numbers: dict[str, dict] = {}
    for s in secs:
        for c in s["checks"]:
            if c.verdict and ".paper." in c.name:
                number = c.name.split(".paper.", 1)[1]
                numbers.setdefault(number, {"check": c, "values": {}})["values"][_label(s)] = c
    if not numbers:
        return []
    builds = list(dict.fromkeys(b for n in numbers.values() for b in n["values"]))
    lines = ["### The paper's numbers", "",
             "| number | verdict | published | bar | " + " | ".join(builds) + " | source and reason |",
             "|---|---|---|---|" + "---|" * len(builds) + "---|"]
    for number, n in numbers.items():
        c = n["check"]
        verdicts = sorted({v.verdict for v in n["values"].values()})
        unit = "" if c.unit in ("", "1") else f" {c.unit}"
        cells = []
        for b in builds:
            v = n["values"].get(b)
            cells.append("" if v is None else "-" if not math.isfinite(v.measured) else f"{v.measured:.6g}{unit}")
        lines.append(f"| {number} | **{', '.join(verdicts)}** | {c.published or c.expected} | {c.tolerance} | "
                     + " | ".join(cells) + f" | {_cell(c.note)} |")
    return lines + [""]


def _defaults(secs) -> list[str]:
    """The default experiment's largest relative error of every output, a column per build and
    interface; the plots folded."""
    lines = []
    by_name: dict[str, list] = {}
    for s in secs:
        for d in s.get("default", []):
            if "rows" in d:
                by_name.setdefault(s["name"], []).append((f"{s['build']} {SHORT.get(d['interface'], d['interface'])}",
                                                          s, d))
    for name, runs in by_name.items():
        what = runs[0][2].get("what", "the default experiment against the in-process reference")
        d0 = runs[0][2]
        lines += [f"### {name}.fmu: {what}", "",
                  f"{d0['span']:g} s at {d0['step']:g} s communication steps. Each cell: the largest error relative to "
                  "the output's largest value, against the bar in the last column.", ""]
        outputs = list(dict.fromkeys(r["output"] for _, _, d in runs for r in d["rows"]))
        lines += ["| output | " + " | ".join(label for label, _, _ in runs) + " | bar |",
                  "|---|" + "---|" * len(runs) + "---|"]
        for out_name in outputs:
            found = [next((r for r in d["rows"] if r["output"] == out_name), None) for _, _, d in runs]
            unit = next((r["unit"] for r in found if r is not None), "")
            bars = {f"{r['tol']:g}" for r in found if r is not None}
            # one bar for the row, or where the runs' bars differ (Model Exchange's CVode against
            # Co-Simulation, say) each cell's own, beside its error: no list of bars left unexplained
            cells = ["" if r is None else f"{r['rel']:.2g}" + (f" (bar {r['tol']:g})" if len(bars) > 1 else "")
                     for r in found]
            bar = bars.pop() if len(bars) == 1 else "each cell's own"
            lines.append(f"| {out_name} [{unit}] | " + " | ".join(cells) + f" | {bar} |")
        walls = "; ".join(f"{label} {d['fmu_wall']:.2f} s" for label, _, d in runs)
        lines += ["", f"Wall time of each run through fmpy: {walls}.", "",
                  "<details>", "<summary>Plots: every output over the reference, and its error against the bar</summary>",
                  ""] + [f"![{label}]({d['plot']})" for label, _, d in runs] + ["", "</details>", ""]
    return lines


def _native_vs_python(secs) -> list[str]:
    natives = [s for s in secs if s.get("native_vs_python")]
    if not natives:
        return []
    outputs = list(dict.fromkeys(r["output"] for s in natives for r in s["native_vs_python"]["rows"]))
    lines = ["### Native builds against the Python FMU (Co-Simulation, the same data file)", "",
             "| output | " + " | ".join(_label(s) for s in natives) + " | bar |", "|---|" + "---|" * len(natives) + "---|"]
    for name in outputs:
        rows = [next((r for r in s["native_vs_python"]["rows"] if r["output"] == name), None) for s in natives]
        bar = next((f"{r['tol']:g}" for r in rows if r), "")
        lines.append(f"| {name} | " + " | ".join("" if r is None else f"{r['rel']:.2g}" for r in rows) + f" | {bar} |")
    return lines + [""]


def _hard(secs) -> list[str]:
    """The hard cases: a row per case and gravity, a column per build and interface (omega1's
    relative error, or why it did not run), the expectations listed, the plots folded."""
    columns, cells, rows_order, expects, plots = [], {}, [], {}, []
    for s in secs:
        for r in s.get("hard", []):
            col = f"{s['build']} {SHORT.get(r.get('interface', 'CoSimulation'), '')}"
            if col not in columns:
                columns.append(col)
            key = (r["case"], r.get("g"))
            if key not in rows_order:
                rows_order.append(key)
            expects.setdefault(r["case"], r["expect"])
            c = count(r["checks"])
            if c["skipped"] and not c["passed"]:
                text = "skipped"
            elif c["failed"]:
                text = f"**FAIL** ({c['failed']})"
            elif r.get("omega1_rel_error") is not None:
                text = f"{r['omega1_rel_error']:.1g}" + (f" at rtol {r['rtol']:.0e}" if r.get("rtol") else "")
            else:
                text = f"{c['passed']} passed"
            cells[(key, col)] = text
            if r.get("plot"):
                plots.append((f"{_label(s)} {r.get('interface', '')} {r['case']} g = {_g(r.get('g'))}", r["plot"]))
    if not rows_order:
        return []
    lines = ["### Hard cases", "",
             "Each cell: omega1's largest error relative to its largest value (the Model Exchange rtol used where "
             "CVode was tightened), or the case's outcome; every check of a case is in the list at the end.", "",
             "| case | g [m/s2] | " + " | ".join(columns) + " |", "|---|---|" + "---|" * len(columns)]
    for key in rows_order:
        lines.append(f"| {key[0]} | {_g(key[1])} | " + " | ".join(cells.get((key, c), "") for c in columns) + " |")
    lines += ["", "Expectations:", ""] + [f"- **{k}**: {v}" for k, v in expects.items()]
    if plots:
        lines += ["", "<details>", f"<summary>{len(plots)} plots of the hard cases</summary>", ""]
        lines += [f"![{label}]({plot})" for label, plot in plots] + ["", "</details>"]
    return lines + [""]


def checks_record(sections: list[dict], not_validated, checks, subset: str) -> dict:
    """What a program (the results page) reads of a harness run: each FMU validated (its name,
    build, kind, data file and counts) and every check with its fields."""
    fmus = []
    for s in sections:
        items = s["checks"]
        c = count(items)
        fmus.append({"name": s["name"], "build": s["build"], "kind": s["kind"], "data": str(s["data"]),
                     "interfaces": list(s["interfaces"]), "passed": c["passed"], "skipped": c["skipped"],
                     "failed": c["failed"], "disagrees": c["disagrees"], "fitted": c["fitted"],
                     "not_comparable": c["not comparable"]})
    return {"summary": checks.summary(), "counts": checks.counts(), "quick": subset != "full", "subset": subset,
            "subset_name": SUBSETS[subset], "versions": versions(), "fmus": fmus,
            "not_validated": [{"name": n, "why": w} for n, w in not_validated],
            "checks": [dataclasses.asdict(c) for c in checks.items]}


def _json_number(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {obj!r}")


def _coupled(section) -> list[str]:
    """The coupled scenes: per scene its figure, the error of each master at each step, the observed
    order and the largest stable step."""
    steps = section["steps"]
    lines = ["## coupled scenes", "",
             "The scenes of `validation/scenes.py` coupled by the masters of `validation/cosim.py` on the native FMI "
             "2.0 FMUs, against each scene's one-model reference (DOP853): max |omega1 - reference| / max omega1 at "
             "the communication points; a run that passes ten times the reference's largest crank speed, or that an "
             "FMU refuses, has diverged. docs/coupling.md says which master to pick for which scene.", ""]
    for scene in section["scenes"]:
        steps = scene.get("steps", section["steps"])
        lines += [f"### {scene['scene']}", "", f"![{scene['scene']}: error against step]({scene['plot']})", "",
                  "| master | " + " | ".join(f"H = {h * 1e3:g} ms" for h in steps)
                  + " | observed order | largest stable step |", "|---|" + "---|" * (len(steps) + 2)]
        for summary in scene["summary"]:
            master = summary["master"]
            cells = []
            for h in steps:
                row = next(r for r in scene["rows"] if r["master"] == master and r["step"] == h)
                cells.append(_g(row["error"]) if math.isfinite(row["error"]) else "diverged")
            order = "-" if not math.isfinite(summary["order"]) else f"{summary['order']:.2f}"
            stable = "none" if not math.isfinite(summary["largest_stable"]) else \
                f"{summary['largest_stable'] * 1e3:g} ms"
            lines.append(f"| {master} | " + " | ".join(cells) + f" | {order} | {stable} |")
        lines.append("")
        ecco = scene.get("ecco")
        if ecco and math.isfinite(ecco["error"]):
            lines += [f"libcosim's ECCO on the scene's power bonds (energy-based step control, 0.1 to 10 ms, "
                      f"tolerance 1e-4): error {_g(ecco['error'])} in {ecco['steps']} steps; the fixed-step master "
                      f"at as many steps ({ecco['step'] * 1e3:.3g} ms): inputs held {_g(ecco['hold'])}, extrapolated "
                      f"{_g(ecco['extrapolate'])}.", ""]
        elif ecco:
            lines += [f"libcosim's ECCO did not run the scene: {ecco['failure'][:300]}", ""]
    return lines


def _work_precision(wp) -> list[str]:
    meta = wp["meta"]
    fewest = meta.get("fewest_runs", meta["repeats"])
    lines = ["### Speed against error", "",
             f"Error: max |omega1 error| on the {meta['grid_s'] * 1e3:g} ms output grid over {meta['span_s']:g} s, "
             f"against {meta['truth']}. Time: the median of {meta['repeats']} runs of the whole call (fewer only for a "
             f"run over 1 s: the fewest here {fewest}), with the fastest and slowest run; all measured in this one run "
             "on this machine. Only runs that deliver the output grid enter the verdicts.", "",
             *wp["verdict"], "", f"![speed against error]({wp['plot']})", "",
             "Fastest setting of each method reaching the error on the output grid, and its time relative to the "
             "fastest method there:", ""]
    targets = wp["targets"]
    lines.append("| method | " + " | ".join(f"error <= {t:g} rad/s" for t in targets) + " |")
    lines.append("|---|" + "---|" * len(targets))
    for row in wp["ratios"]:
        cells = ["-" if row[t] is None else f"{row[t]['time_s'] * 1e3:.3g} ms ({row[t]['setting']}), x{row[t]['ratio']:.3g}"
                 for t in targets]
        lines.append(f"| {row['family']} | " + " | ".join(cells) + " |")
    lines += ["", "<details>", f"<summary>All {len(wp['points'])} points (an FMU's initialisation and cost per "
              "communication step apart)</summary>", "",
              "| method | setting | omega1 error [rad/s] | phi1(end) error [rad] | median [ms] | fastest-slowest [ms] | "
              "runs | FMU init [ms] | per step [us] | note |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for p in wp["points"]:
        spread = (f"{p.time_min * 1e3:.3g}-{p.time_max * 1e3:.3g}" if math.isfinite(p.time_min) else "-")
        note = p.note + ("" if p.on_grid else (" " if p.note else "") + "coarser than the output grid")
        lines.append(f"| {p.family} | {p.setting} | {_g(p.omega1_error)} | {_g(p.phi1_error)} | "
                     f"{_g(p.time_s * 1e3 if math.isfinite(p.time_s) else float('nan'), 4)} | {spread} | {p.repeats} | "
                     f"{_g(p.init_s * 1e3)} | {_g(p.per_step_s * 1e6)} | {_cell(note)} |")
    lines += ["", "</details>", ""]
    return lines
