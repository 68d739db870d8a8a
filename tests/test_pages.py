"""The pages a person reads in a browser: the results page (crankfmu page), the validation report's
HTML, each FMU's documentation, and what they are made of (the Markdown subset, MathML). Each page
is loaded by headless Chromium: every image must show and every link must lead somewhere."""

from __future__ import annotations

import html
import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from browser import image_report, loaded_dom, page_width, pdf_pages, screenshot, unresolved_links
from crankfmu.pages.markup import markdown, slug
from crankfmu.pages.mathml import math, symbol

ROOT = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "crankfmu"]


def run(*args, cwd=None):
    done = subprocess.run([*CLI, *args], capture_output=True, text=True, cwd=cwd, timeout=900)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
    return done.stdout


# ------------------------------------------------------------------------------------------------
# what pages are made of

def test_markdown_renders_the_reports_subset():
    html = markdown("# Title\n\nSome `code` and **bold** and [a link](#the-part).\n\n## The part\n\n"
                    "| a | b |\n|---|---|\n| 1 | x < y |\n\n- one\n- two\n\n```\nraw <b>\n```\n![plot](p.png)")
    assert '<h1 id="title">Title</h1>' in html
    assert '<h2 id="the-part">The part</h2>' in html and '<a href="#the-part">a link</a>' in html
    assert "<code>code</code>" in html and "<strong>bold</strong>" in html
    assert "<table><tr><th>a</th><th>b</th></tr>" in html and "<td>x &lt; y</td>" in html
    assert "<ul><li>one</li><li>two</li></ul>" in html
    assert "<pre>raw &lt;b&gt;</pre>" in html                  # code is shown, never interpreted
    assert '<img src="p.png" alt="plot">' in html


def test_slug_is_githubs_anchor_of_the_reports_headings():
    # report.md links its summary rows to "## FourBar.fmu native" as #fourbarfmu-native
    assert slug("FourBar.fmu native") == "fourbarfmu-native"


def test_mathml_names_become_symbols():
    assert symbol("phi1") == "<msub><mi>φ</mi><mn>1</mn></msub>"
    assert symbol("omega_switch") == "<msub><mi>ω</mi><mi>switch</mi></msub>"
    assert "<mo>′</mo>" in symbol("J_prime")
    m = math("J(phi1)*der(omega1) == M_motor - B*omega1/2")
    assert m.startswith('<math display="block">') and "<mfrac><mrow><mi>d</mi>" in m and "<mo>=</mo>" in m
    # a sum subtracted keeps its brackets: a - (b - c) is not a - b - c
    assert "<mo>(</mo>" in math("a - (b - c)") and "<mo>(</mo>" not in math("(a - b) - c")


def test_mathml_refuses_what_it_cannot_write():
    with pytest.raises(SyntaxError):
        math("a = = b")
    with pytest.raises(ValueError, match="no MathML"):
        math("[a, b]")


# ------------------------------------------------------------------------------------------------
# the results page, from real studies, in a real browser

@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """A small results folder made as make demo makes build/demo: a drawing, a kinematic study, an
    animation, an equilibrium study, and the harness on one FMU."""
    root = tmp_path_factory.mktemp("results")
    run("draw", "seed000", "--out", str(root / "mechanism_fig2.png"))
    run("kinematics", "seed002", "--at", "30", "--out", str(root / "seed002"))
    run("animate", "seed001", "--frames", "4", "--out", str(root / "seed001" / "mechanism.gif"))
    run("equilibrium", "seed001", "--omega", "15", "--out", str(root / "seed001"))
    run("sweep", "seed004", "--param", "e=0.31:0.45:2", "--param", "l1=0.15:0.29:2", "--out", str(root / "seed004"))
    fmu = ROOT / "build" / "fmus" / "SliderCrank.fmu"
    if not fmu.exists():
        run("fmu", "seed002", "--out", str(root.parent / "fmus"))
        fmu = root.parent / "fmus" / "SliderCrank.fmu"
    subprocess.run([*CLI, "validate", "--quick", "--fmu", str(fmu), "--out", str(root / "validation")],
                   capture_output=True, text=True, timeout=900)          # its verdict is the harness's tests' concern
    run("page", str(root), "--validation", str(root / "validation"))
    return root


def test_every_figure_is_on_the_page_with_its_caption(results):
    page = html.unescape((results / "index.html").read_text())
    figures = sorted(p.relative_to(results).as_posix() for p in results.rglob("*")
                     if p.suffix in (".png", ".gif") and "validation" not in p.parts)
    assert len(figures) == 17         # 1 drawing, 5 kinematics, 1 animation, 2 equilibrium, 8 sweep families
    for f in figures:
        assert f'<img src="{f}"' in page, f
    # each figure says what it is: the equilibrium figure's caption comes from its PNG
    assert "with the links' inertia forces and moments (curve 1)" in page
    # and which of the paper's figures it is drawn as, with the paper's title from the scenario file;
    # "reproduces" only where values of that figure are compared (seed 004's sweep claims cite Figs.
    # 8-9; seed 001's Fig. 2 and seed 002's Fig. 6 give no value the validation compares)
    assert "Reproduces the paper's Fig. 9: The acceleration a5 when l1 varies between 0.15 m and 0.3 m (its values" in page
    assert "Drawn as the paper's Fig. 2: The equilibrium moment over a kinematic cycle at omega1 = 15" in page
    assert "Reproduces the paper's Fig. 2: The equilibrium" not in page
    assert "Drawn as the paper's Fig. 6: Point B motion graph obtained in MathCad (no value of it is compared)" in page
    # the groups are cited by authors and title
    assert "Malcoci" in page and "Classical and Modern Kinematic Analysis" in page


def test_each_data_files_figures_are_folded_but_the_firsts(results):
    """The page reads at a glance: a section's numbers in the open, its figures behind a summary a
    reader opens (the first section's open), each summary naming how many and what they show."""
    import re

    page = (results / "index.html").read_text()
    folds = re.findall(r"<details( open)?><summary>(\d+) figures? \(click to open\): ([^<]+)</summary>", page)
    sections = page.count("<h2 id=")
    assert len(folds) >= sections - 1 >= 3, (len(folds), sections)       # the validation's section has no figures
    assert [bool(opened) for opened, _, _ in folds] == [True] + [False] * (len(folds) - 1)
    assert sum(int(n) for _, n, _ in folds) == 17


def test_the_papers_numbers_stand_beside_ours(results):
    checks = json.loads((results / "validation" / "checks.json").read_text())
    published = [c for c in checks["checks"] if c["verdict"]]
    assert published, "the harness checked no published number of seed002"
    page = html.unescape((results / "index.html").read_text())
    assert "The paper's numbers beside ours" in page
    for c in published:
        assert f"<td>{c['published']}</td>" in page


def test_the_papers_claims_stand_beside_the_sweep(results):
    claims = json.loads((results / "seed004" / "claims.json").read_text())
    assert claims
    page = html.unescape((results / "index.html").read_text())
    assert "The paper's claims about its sweeps, checked" in page
    for c in claims:
        assert f"<td>{c['claim']}</td><td>{c['quantity']}</td><td>{c['peaks_hold_in']} of {c['families']} families" in page


def test_results_page_loads_in_chromium_with_every_image_and_link(results, tmp_path):
    page = results / "index.html"
    loaded, broken = image_report(loaded_dom(page, tmp_path))
    assert broken == []
    assert loaded == page.read_text().count("<img ")
    assert unresolved_links(page) == []


def test_validation_report_html_loads_in_chromium(results, tmp_path):
    report = results / "validation" / "report.html"
    loaded, broken = image_report(loaded_dom(report, tmp_path))
    assert broken == [] and loaded >= 1
    assert unresolved_links(report) == []


def test_validation_report_reads_at_a_glance(results, tmp_path):
    """The report a person reads: the verdict counts and the summary table first, the data file's
    section after, plots folded; no wider than a phone's screen at 390 px (its tables scroll
    inside the page); a short print; and a screenshot at 1400 px that shows it (kept beside the
    test's output for a reviewer)."""
    report = results / "validation" / "report.html"
    text = report.read_text()
    assert text.index("<h2 id=\"summary\">") < text.index("<h2 id=\"seed002\">")
    assert "<details>" in text and "<summary>" in text and '<div class="scroll">' in text
    assert page_width(report, tmp_path, 390) <= 390
    pages = pdf_pages(report, tmp_path)
    assert 1 <= pages <= 8, pages               # one FMU's report; make validate's (every FMU) is about 30
    png = screenshot(report, tmp_path / "report_1400.png", tmp_path)
    from PIL import Image
    with Image.open(png) as image:
        assert image.size == (1400, 2400)
        # the top of the report is not blank: the summary is in view
        assert np.unique(np.asarray(image.convert("L").crop((0, 0, 1400, 600)))).size > 20


def test_results_page_fits_a_phone(results, tmp_path):
    page = results / "index.html"
    assert page_width(page, tmp_path, 390) <= 390


def test_a_missing_figure_is_shown_as_missing(results, tmp_path):
    """The check the two tests above rely on can fail: a page whose image is gone says so."""
    copy = tmp_path / "copy"
    copy.mkdir()
    (copy / "a.png").write_bytes((results / "mechanism_fig2.png").read_bytes())
    run("page", str(copy))
    (copy / "a.png").unlink()
    loaded, broken = image_report(loaded_dom(copy / "index.html", tmp_path))
    assert (loaded, broken) == (0, ["a.png"])
    assert unresolved_links(copy / "index.html") == ["a.png", "a.png"]


def test_a_figure_reproduces_a_papers_figure_only_where_its_values_are_compared():
    from crankfmu.pages.results import Figure, compared_figures, reproduces
    from crankfmu.scenario import load_scenario

    assert compared_figures(load_scenario("seed000").data) == {"Fig. 4"}          # settled_in_cycle_4
    assert compared_figures(load_scenario("seed002").data) == {"Fig. 2", "Fig. 5"}
    assert compared_figures(load_scenario("seed003").data) == {"Fig. 3", "Fig. 6", "Fig. 7"}
    assert compared_figures(load_scenario("pumpjack").data) == set()               # there is no paper
    figure = Figure(Path("a.png"), "omega1", "as the paper's Figs. 3-4 draw it", "seed000")
    titles = load_scenario("seed000").data["paper_figures"]
    assert [c for _, c in reproduces(figure, titles, {"Fig. 4"})] == [False, True]


def test_a_runs_caption_says_what_its_data_shows(tmp_path):
    """seed 000 starts at 0.1 rad/s, not from rest, and settles; a run too short to settle says so."""
    import crankfmu
    from crankfmu.plots import run_story, settled_story

    settled = crankfmu.simulate(crankfmu.load_scenario("seed000"), method="fast")
    said = run_story(settled, 5)
    assert said.startswith("From omega1 = 0.1 rad/s, the crank settles into a periodic cycle") and "rest" not in said
    assert settled_story(settled, 4).startswith("The motion has settled")
    rest = crankfmu.simulate(crankfmu.load_scenario("seed000").with_params(omega1_start=0.0), t_end=0.3,
                             method="fast")
    said = run_story(rest, 2)
    assert said.startswith("From rest") and ("not settled" in said or "ends before" in said)


def test_page_refuses_a_folder_that_is_not_there(tmp_path):
    done = subprocess.run([*CLI, "page", str(tmp_path / "nothing")], capture_output=True, text=True)
    assert done.returncode != 0
    assert done.stderr.strip().count("\n") == 0 and "no results folder" in done.stderr
    done = subprocess.run([*CLI, "page", str(tmp_path), "--validation", str(tmp_path / "nothing")],
                          capture_output=True, text=True)
    assert done.returncode != 0 and "no checks.json" in done.stderr
    assert not (tmp_path / "index.html").exists()             # nothing half-written


# ------------------------------------------------------------------------------------------------
# each FMU's documentation, as the FMU carries it

def _documentation(fmu: Path, into: Path) -> Path:
    with zipfile.ZipFile(fmu) as z:
        for name in z.namelist():
            if name.startswith("documentation/"):
                z.extract(name, into)
    return into / "documentation" / "index.html"


@pytest.mark.parametrize("which", ["FourBar.fmu", "native/FourBar.fmu", "RodString.fmu"])
def test_fmu_documentation_loads_in_chromium(which, tmp_path):
    fmu = ROOT / "build" / "fmus" / which
    assert fmu.exists(), f"{fmu}: make test builds it (make fmu)"
    index = _documentation(fmu, tmp_path / "fmu")
    text = index.read_text()
    loaded, broken = image_report(loaded_dom(index, tmp_path))
    assert broken == [] and loaded == text.count("<img ")
    assert unresolved_links(index) == []
    # equations as MathML, written for the FMU's user (no docstring markup, no integrator it lacks)
    assert text.count("<math") >= 3
    assert ":class:" not in text and "``" not in text and "radau" not in text
    assert "9.999999999999999e-12" not in text


def test_mechanism_documentation_says_what_the_fmu_is_and_groups_its_parameters(tmp_path):
    python = _documentation(ROOT / "build" / "fmus" / "FourBar.fmu", tmp_path / "python").read_text()
    native = _documentation(ROOT / "build" / "fmus" / "native" / "FourBar.fmu", tmp_path / "native").read_text()
    for text in (python, native):
        for group in ("Geometry", "Masses and inertias", "Loads", "Motor", "Start", "Solver"):
            assert f"<h3>{group}</h3>" in text
        assert "tunable: between communication steps" in text
        assert "Bădoiu" in text                              # the paper, by author and title
    assert "Python: pythonfmu" in python and "Co-Simulation" in python and "Model Exchange" not in python
    assert "native: C" in native and "Co-Simulation and Model Exchange" in native
    # the native FMU's tables: built when it initialises, their checked bound at the file's values
    assert "largest relative error" in native and "when the FMU initialises" in native
    row = native[native.index("<td>l1</td>"):].split("</tr>")[0]
    assert "before initialisation" in row and "(0, inf) m" in row
    row = python[python.index("<td>l1</td>"):].split("</tr>")[0]
    assert "before initialisation" in row and "(0, inf) m" in row
