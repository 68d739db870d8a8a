"""Every figure and animation make demo draws, made by the Makefile's own recipes (so a command the
demo runs that stops working fails here), each saying what it shows, and all of them on one
contact sheet in the tests' output (build/test-output/contact_sheet.png) for a reviewer to look at."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from conftest import ROOT
from crankfmu.pages.contact import pictures_in, write_contact_sheet


@pytest.fixture(scope="module")
def demo_figures(tmp_path_factory) -> Path:
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    out = tmp_path_factory.mktemp("demo")
    # the recipes as make demo runs them, with this interpreter's crankfmu and no re-installation
    bin_dir = Path(sys.executable).parent
    done = subprocess.run(["make", "--no-print-directory", "-j2", "demo-papers", "demo-well", f"OUT={out}",
                           f"BIN={bin_dir}", "STAMP="], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return out


def test_the_demo_draws_every_figure_each_saying_what_it_shows(demo_figures):
    pictures = pictures_in(demo_figures)
    # the five papers' studies, the pump jack and the well: 47 today; fewer means a recipe lost one
    assert len(pictures) >= 45, [str(p.relative_to(demo_figures)) for p in pictures]
    for path in pictures:
        with Image.open(path) as image:
            width, height = image.size
            said = image.info.get("Title", "") if path.suffix == ".png" else image.info.get("comment", b"").decode()
            frames = getattr(image, "n_frames", 1)
        # readable at a page's width: 9 pt text is 12 px high at these sizes
        assert width >= 500 and height >= 300, (path, image.size)
        assert said.strip(), f"{path.name} carries no title or description"
        if path.suffix == ".gif":
            assert frames >= 30, (path, frames)


def test_a_contact_sheet_shows_every_demo_figure_at_once(demo_figures):
    out = ROOT / "build" / "test-output" / "contact_sheet.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    sheet = write_contact_sheet(demo_figures, out)
    with Image.open(sheet) as image:
        width, height = image.size
    rows = -(-len(pictures_in(demo_figures)) // 6)
    assert width >= 2000 and height >= 300 * rows, (width, height, rows)
