"""The results page (``crankfmu page``, the end of ``make demo``): one HTML file, beside the figures it links, that
shows every figure and animation a folder of results holds, grouped by the data file each comes
from (a paper's scenario, the pump jack, the well), each with its caption and the paper's figure it
reproduces, the key numbers beside the published ones, and the validation report.

Nothing is listed here by hand. A figure says what it is in its own file (``atomic.save_figure``
writes its title, caption and scenario into the PNG; an animation into the GIF's comment); the
paper's citation and figure titles come from the scenario file (``citation``, ``[paper_figures]``);
the published numbers from the harness's ``checks.json`` and from a study's ``summary.json``
(its ``reference`` table); the report is the harness's ``report.html``.
"""

from __future__ import annotations

import html
import json
import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..atomic import write_text
from ..errors import CrankfmuError
from .markup import page

#: the order of the groups: the papers' scenarios, the beam pumping unit and its well, the engines
ORDER = ("seed000", "seed001", "seed002", "seed003", "seed004", "pumpjack", "rp11l_guo", "engine1", "engine4",
         "jansen")
IMAGES = (".png", ".gif")


@dataclass
class Figure:
    path: Path            # relative to the page
    title: str
    caption: str
    scenario: str


@dataclass
class Group:
    name: str
    title: str = ""
    citation: str = ""
    paper_figures: dict = field(default_factory=dict)
    compared: set = field(default_factory=set)          # the paper's figures whose values are compared
    figures: list = field(default_factory=list)
    references: list = field(default_factory=list)      # (folder, the summary's reference table)
    claims: list = field(default_factory=list)          # (folder, a sweep's claims.json: the paper's claims checked)


def figure_info(path: Path) -> dict:
    """What a figure says of itself: title, caption, scenario (empty where it says nothing)."""
    from PIL import Image

    with Image.open(path) as image:
        if path.suffix.lower() == ".gif":
            try:
                about = json.loads((image.info.get("comment") or b"{}").decode())
            except (ValueError, UnicodeDecodeError):
                about = {}
            return {k: str(about.get(k, "")) for k in ("title", "caption", "scenario")}
        text = getattr(image, "text", {}) or {}
        return {"title": text.get("Title", ""), "caption": text.get("Description", ""),
                "scenario": text.get("Source", "")}


def _folder_scenario(folder: Path, root: Path) -> str:
    """A figure that names no scenario belongs to its folder's: the ``scenario`` of the nearest
    summary up to the page's folder, else the folder's name."""
    for d in (folder, *folder.parents):
        for name in ("summary.json", "flywheel.json"):
            f = d / name
            if f.is_file():
                try:
                    data = json.loads(f.read_text(encoding="utf-8"))
                except ValueError:
                    continue
                if isinstance(data, dict) and isinstance(data.get("scenario"), str):
                    return data["scenario"]
        if d == root:
            break
    return folder.name if folder != root else ""


def _describe(group: Group) -> None:
    """The group's title, citation and the paper's figures, from its data file."""
    from ..dynamics.well import load_well
    from ..scenario import load_scenario

    for load in (load_scenario, load_well):
        try:
            data = load(group.name)
        except Exception:  # noqa: BLE001 - not a packaged data file of this kind: try the next
            continue
        raw = getattr(data, "data", {}) or {}
        group.title = getattr(data, "title", "") or raw.get("title", "")
        group.citation = raw.get("citation", "")
        group.paper_figures = dict(raw.get("paper_figures", {}))
        group.compared = compared_figures(raw)
        return


_CITES = re.compile(r"Figs?\.\s*(\d+)[a-z]?(?:\s*-\s*(\d+))?")


def _figures_in(text: str) -> set[str]:
    """Every "Fig. N" a text cites ("Figs. 2-5" is four)."""
    found = set()
    for m in _CITES.finditer(str(text)):
        first, last = int(m.group(1)), int(m.group(2) or m.group(1))
        found.update(f"Fig. {n}" for n in range(first, min(last, first + 12) + 1))
    return found


def compared_figures(raw: dict) -> set[str]:
    """The paper's figures whose values the validation compares with crankfmu's: those the sources
    of the data file's [[paper]] numbers cite, those its sweep claims cite ([[kinematics.claims]]),
    and [kinematics] paper_figures (where its graphical values are read)."""
    found = set()
    for entry in raw.get("paper", []):
        found |= _figures_in(entry.get("source", ""))
    kinematics = raw.get("kinematics", {})
    for claim in kinematics.get("claims", []):
        found |= _figures_in(claim.get("text", ""))
    for fig in kinematics.get("paper_figures", []):
        found |= _figures_in(fig)
    return found


def reproduces(figure: Figure, paper_figures: dict, compared: set | None = None) -> list[tuple[str, bool]]:
    """The paper's figures this one cites in its title or caption ("Fig. 6", "Figs. 5-6"), each
    with the paper's title for it where the scenario file gives one, and whether values of that
    figure are compared (``compared``): only then does the page say the figure reproduces it."""
    out = []
    for key in sorted(_figures_in(f"{figure.title} {figure.caption}"), key=lambda k: int(k.split()[1])):
        if key in paper_figures:
            out.append((f"{key}: {paper_figures[key]}", key in (compared or set())))
    return out


def _json_files(root: Path, name: str, skip: set[Path]):
    """(folder, its parsed ``name``) for each such file under ``root`` outside ``skip``; a file that
    is not JSON is passed over (a study still writing it)."""
    for path in sorted(root.rglob(name)):
        if any(s in path.resolve().parents for s in skip):
            continue
        try:
            yield path.parent, json.loads(path.read_text(encoding="utf-8"))
        except ValueError:
            continue


def natural_key(path: Path) -> tuple:
    """A path's sort key with its numbers compared as numbers: Me_omega5, Me_omega7, Me_omega10,
    Me_omega15 (a string sort puts 10 and 15 before 5)."""
    return tuple((0, float(part), "") if part[:1].isdigit() else (1, 0.0, part)
                 for part in re.split(r"(\d+(?:\.\d+)?)", str(path)) if part)


def collect(root: Path, skip: set[Path]) -> dict[str, Group]:
    """The figures under ``root`` by data file, and the published-figure tables of the studies'
    summaries. A figure that names no data file belongs to the figures beside it that do, else to
    its folder's summary, else to its folder."""
    found = []
    for path in sorted((p for p in root.rglob("*") if p.suffix.lower() in IMAGES and p.is_file()), key=natural_key):
        if any(s in path.resolve().parents for s in skip) or path.name.startswith("."):
            continue
        found.append((path, figure_info(path)))
    by_folder = {}
    for path, info in found:
        if info["scenario"]:
            by_folder.setdefault(path.parent, info["scenario"])
    groups: dict[str, Group] = {}
    for path, info in found:
        scenario = (info["scenario"] or by_folder.get(path.parent) or _folder_scenario(path.parent, root)
                    or "other")
        group = groups.setdefault(scenario, Group(scenario))
        group.figures.append(Figure(path.relative_to(root), info["title"], info["caption"], scenario))
    def group_of_folder(folder: Path, data) -> Group:
        name = ((data.get("scenario") if isinstance(data, dict) else None) or by_folder.get(folder)
                or _folder_scenario(folder, root) or "other")
        return groups.setdefault(name, Group(name))

    for folder, data in _json_files(root, "summary.json", skip):
        if isinstance(data, dict) and isinstance(data.get("reference"), dict):
            group_of_folder(folder, data).references.append((folder.relative_to(root), data["reference"]))
    for folder, data in _json_files(root, "claims.json", skip):
        group_of_folder(folder, None).claims.append((folder.relative_to(root), data))
    for g in groups.values():
        _describe(g)
    return groups


def _paper_rows(checks: dict, group: str) -> list[dict]:
    """The published numbers the harness checked on the FMUs of ``group``'s data file, one row per
    number (the FMUs it was checked on named in the row)."""
    fmus = {f["name"]: Path(f["data"]).stem for f in checks.get("fmus", [])}
    rows: dict[str, dict] = {}
    for c in checks.get("checks", []):
        if not c.get("verdict"):
            continue
        fmu, build, _, number = (c["name"].split(".", 3) + ["", "", "", ""])[:4]
        if fmus.get(fmu) != group:
            continue
        row = rows.setdefault(number, {**c, "number": number, "builds": []})
        row["builds"].append(f"{fmu} {build}")
    return list(rows.values())


def paper_sources(name: str) -> dict[str, str]:
    """Each published number's ``source`` in the data file's [[paper]] (where the paper gives it),
    by the number's name; {} for a data file that is not a packaged scenario."""
    from ..scenario import load_scenario

    try:
        entries = load_scenario(name).data.get("paper", [])
    except CrankfmuError:
        return {}
    return {str(e.get("name")): str(e.get("source", "")) for e in entries if isinstance(e, dict)}


def _g(x) -> str:
    return f"{x:.6g}" if isinstance(x, (int, float)) else html.escape(str(x))


def _group_html(g: Group, checks: dict, unfolded: bool = False) -> str:
    """A data file's section: its numbers beside the paper's in the open, its figures folded (a
    summary a reader opens; ``unfolded`` for the first section), so the page reads at a glance."""
    parts = [f'<h2 id="{html.escape(g.name)}">{html.escape(g.title or g.name)}</h2>']
    if g.citation:
        parts.append(f'<p class="note">Source: {html.escape(g.citation)}. Data file: <code>{html.escape(g.name)}</code>.</p>')
    rows = _paper_rows(checks, g.name)
    if rows:
        parts.append("<h3>The paper's numbers beside ours</h3><table><tr><th>number</th><th>verdict</th>"
                     "<th>crankfmu</th><th>published</th><th>tolerance</th><th>where in the paper, and why</th>"
                     "<th>checked on</th></tr>")
        sources = paper_sources(g.name)
        for r in rows:
            unit = "" if r.get("unit") in ("", "1", None) else f" {r['unit']}"
            ours = "-" if r.get("skipped") else f"{_g(r['measured'])}{html.escape(unit)}"
            verdict = str(r["verdict"]).split()[0]
            # the tolerance in the number's unit ("1": a ratio), and where the paper gives it in words
            # beside the harness's note (a name such as settled_in_cycle_4 says little alone)
            tolerance = f"{r['tolerance']}{unit or (' (a ratio)' if r.get('unit') == '1' else '')}"
            where = "; ".join(t for t in (sources.get(r["number"], ""), r.get("note", "")) if t)
            parts.append(f'<tr><td>{html.escape(r["number"])}</td><td class="verdict-{html.escape(verdict)}">'
                         f'{html.escape(r["verdict"])}</td><td>{ours}</td><td>{html.escape(r["published"])}</td>'
                         f'<td>{html.escape(tolerance)}</td><td>{html.escape(where)}</td>'
                         f'<td>{html.escape(", ".join(r["builds"]))}</td></tr>')
        parts.append("</table>")
    for folder, table in g.references:
        parts.append(f"<h3>Published figures beside ours (<code>{html.escape(str(folder))}/summary.json</code>)</h3>"
                     "<table><tr><th>quantity</th><th>crankfmu</th><th>published</th><th>difference</th>"
                     "<th>tolerance</th><th>verdict</th></tr>")
        for name, r in table.items():
            tolerance = f"{100 * r['tolerance']:g} %" if isinstance(r.get("tolerance"), (int, float)) else "-"
            verdict = str(r.get("verdict", "not comparable"))
            why = f" ({html.escape(r['why'])})" if r.get("why") else ""
            parts.append(f"<tr><td>{html.escape(name)}</td><td>{_g(r.get('crankfmu'))}</td><td>{_g(r.get('published'))}</td>"
                         f"<td>{100 * r.get('relative', float('nan')):+.2f} %</td><td>{tolerance}</td>"
                         f'<td class="verdict-{html.escape(verdict.split()[0])}">{html.escape(verdict)}{why}</td></tr>')
        parts.append("</table>")
    for folder, claims in g.claims:
        parts.append(f"<h3>The paper's claims about its sweeps, checked (<code>{html.escape(str(folder))}/claims.json</code>)"
                     "</h3><table><tr><th>claim</th><th>quantity</th><th>the peak grows as claimed, in</th>"
                     "<th>share of the cycle where |quantity| grows as claimed (least, mean over the families)</th></tr>")
        for c in claims:
            parts.append(f"<tr><td>{html.escape(str(c.get('claim', '')))}</td><td>{html.escape(str(c.get('quantity', '')))}</td>"
                         f"<td>{c.get('peaks_hold_in')} of {c.get('families')} families</td>"
                         f"<td>{100 * c.get('share_of_cycle_min', float('nan')):.0f} %, "
                         f"{100 * c.get('share_of_cycle_mean', float('nan')):.0f} %</td></tr>")
        parts.append("</table>")
    if g.figures:
        shown = ", ".join(html.escape(f.title or f.path.name) for f in g.figures[:3]) + (", ..." if len(g.figures) > 3 else "")
        parts.append(f"<details{' open' if unfolded else ''}><summary>{len(g.figures)} figure"
                     f"{'s' if len(g.figures) > 1 else ''} (click to open): {shown}</summary>")
    for f in g.figures:
        src = html.escape(f.path.as_posix())
        alt = html.escape(f.title or f.path.name)
        cites = reproduces(f, g.paper_figures, g.compared)
        caption = html.escape(f.caption or f.title or f.path.name)
        more = "".join(f"<br>Reproduces the paper's {html.escape(c)} (its values are compared in the validation)."
                       if compared else f"<br>Drawn as the paper's {html.escape(c)} (no value of it is compared)."
                       for c, compared in cites)
        parts.append(f'<figure><a href="{src}"><img src="{src}" alt="{alt}"></a>'
                     f"<figcaption><code>{src}</code>: {caption}{more}</figcaption></figure>")
    if g.figures:
        parts.append("</details>")
    return "\n".join(parts)


def write_page(root, validation=None, out=None) -> Path:
    """Write ``root/index.html`` (or ``out``): every figure under ``root`` by data file, and the
    harness's report in ``validation`` (a folder with ``checks.json`` and ``report.html``)."""
    root = Path(root)
    if not root.is_dir():
        raise CrankfmuError(f"no results folder at {root}: run make demo (or a study with --out {root}) first")
    out = Path(out) if out is not None else root / "index.html"
    validation = Path(validation) if validation is not None else None
    checks: dict = {}
    if validation is not None:
        if not (validation / "checks.json").is_file():
            raise CrankfmuError(f"--validation {validation}: no checks.json there (crankfmu validate --out "
                                f"{validation} writes it)")
        checks = json.loads((validation / "checks.json").read_text(encoding="utf-8"))
    skip = {validation.resolve()} if validation is not None else set()     # the report's own plots
    groups = collect(root, skip)
    order = [n for n in ORDER if n in groups] + sorted(n for n in groups if n not in ORDER)
    count = sum(len(g.figures) for g in groups.values())
    body = ["<h1>crankfmu results</h1>",
            f'<p class="note">Written {time.strftime("%Y-%m-%d %H:%M")} from <code>{html.escape(str(root))}</code>: '
            f"{count} figures and animations from {len(groups)} data files. Each figure says what it shows and which "
            "of the paper's figures it reproduces; click one for its full size.</p>"]
    if checks:
        report = Path(os.path.relpath(validation / "report.html", out.parent)).as_posix()
        # which subset ran (validation.report.SUBSETS; a checks.json older than the name says quick or not)
        ran = checks.get("subset_name") or ("the --quick subset" if checks.get("quick") else "the full harness")
        body.append(f'<p><strong>Validation: {html.escape(checks.get("summary", ""))}</strong> on '
                    f'{len(checks.get("fmus", []))} FMUs, by {html.escape(ran)}. '
                    f'<a href="{html.escape(report)}">The validation report</a> shows every FMU against the in-process '
                    "reference, the closed forms and the papers.</p>")
    body.append("<nav><ul>" + "".join(f'<li><a href="#{html.escape(n)}">{html.escape(groups[n].title or n)}</a> '
                                        f"({len(groups[n].figures)})</li>" for n in order)
                + ('<li><a href="#validation">Validation</a></li>' if checks else "") + "</ul></nav>")
    body += [_group_html(groups[n], checks, unfolded=(i == 0)) for i, n in enumerate(order)]
    if checks:
        body.append('<h2 id="validation">Validation</h2><table><tr><th>FMU</th><th>build</th><th>kind</th>'
                    "<th>interfaces</th><th>data file</th><th>passed</th><th>failed</th><th>disagree</th><th>fitted</th>"
                    "<th>skipped</th></tr>")
        body += [f"<tr><td>{html.escape(f['name'])}.fmu</td><td>{html.escape(f['build'])}</td><td>{html.escape(f['kind'])}</td>"
                 f"<td>{html.escape(', '.join(f['interfaces']))}</td><td><code>{html.escape(f['data'])}</code></td>"
                 f"<td>{f['passed']}</td><td>{f['failed']}</td><td>{f.get('disagrees', 0)}</td><td>{f.get('fitted', 0)}</td>"
                 f"<td>{f['skipped']}</td></tr>" for f in checks["fmus"]]
        body.append(f'</table><p><a href="{html.escape(report)}">The whole validation report</a>; made with '
                    f'{html.escape("; ".join(checks.get("versions", [])))}.</p>')
    # every table scrolls sideways inside the page on a phone, rather than widening the page
    text = "\n".join(body).replace("<table>", '<div class="scroll"><table>').replace("</table>", "</table></div>")
    write_text(out, page("crankfmu results", text).decode())
    return out
