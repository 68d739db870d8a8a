"""A page as a reader's browser shows it: headless Chromium (Debian's, which `make test` installs)
loads the file and returns its DOM after the load event, with the pages' own image check
(``crankfmu.pages.markup.IMAGE_CHECK``) written into ``<body>``."""

from __future__ import annotations

import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path


def chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    raise AssertionError("no headless Chromium on the PATH: make test installs Debian's chromium (apt-get, as root)")


def _chromium(page: Path, tmp_path: Path, *args: str, width: int = 1280, height: int = 2000) -> subprocess.CompletedProcess:
    run = subprocess.run([chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--allow-file-access-from-files",
                          f"--user-data-dir={tmp_path / 'chromium-profile'}", "--virtual-time-budget=20000",
                          f"--window-size={width},{height}", *args, page.resolve().as_uri()],
                         capture_output=True, text=True, timeout=180)
    assert run.returncode == 0, run.stderr[-2000:]
    return run


def loaded_dom(page: Path, tmp_path: Path, width: int = 1280) -> str:
    """The DOM of ``page`` once loaded (images included), from a fresh browser profile, in a
    window ``width`` px wide."""
    return _chromium(page, tmp_path, "--dump-dom", width=width).stdout


def page_width(page: Path, tmp_path: Path, width: int = 390) -> int:
    """``page``'s laid-out width in px in a viewport ``width`` px wide (a phone's: 390), as its own
    check writes it (``data-page-width``); wider than the viewport means the reader scrolls the
    whole page sideways. Headless Chromium's window is at least 500 px wide, so the page is loaded
    in an iframe of that width inside a wrapper page beside it."""
    wrapper = page.parent / f".width-{width}-{page.stem}.html"
    wrapper.write_text(
        f'<!DOCTYPE html><html><body style="margin:0"><iframe id="f" src="{page.name}" width="{width}" '
        'height="2000" style="border:0"></iframe><script>addEventListener("load", () => {'
        'const b = document.getElementById("f").contentDocument.body;'
        'document.body.dataset.inner = b.dataset.pageWidth || "";});</script></body></html>')
    try:
        dom = _chromium(wrapper, tmp_path, "--dump-dom", width=800).stdout
    finally:
        wrapper.unlink()
    found = re.search(r'data-inner="(\d+)"', dom)
    assert found, "the page's check did not run in the iframe (no data-page-width on its <body>)"
    return int(found.group(1))


def screenshot(page: Path, png: Path, tmp_path: Path, width: int = 1400, height: int = 2400) -> Path:
    """What a reader sees of ``page``'s top in a window ``width`` px wide."""
    _chromium(page, tmp_path, f"--screenshot={png}", "--hide-scrollbars", width=width, height=height)
    return png


def pdf_pages(page: Path, tmp_path: Path) -> int:
    """How many A4 pages ``page`` prints to in headless Chromium."""
    pdf = tmp_path / f"{page.stem}.pdf"
    _chromium(page, tmp_path, f"--print-to-pdf={pdf}", "--no-pdf-header-footer")
    return len(re.findall(rb"/Type\s*/Page(?![s\w])", pdf.read_bytes()))


def image_report(dom: str) -> tuple[int, list[str]]:
    """(images loaded, the src of each image the browser could not show), as the page's check wrote them."""
    body = re.search(r"<body([^>]*)>", dom)
    assert body, "no <body> in the loaded page"
    loaded = re.search(r'data-loaded-images="(\d+)"', body.group(1))
    assert loaded, "the page's image check did not run (no data-loaded-images on <body>)"
    broken = re.search(r'data-broken-images="([^"]*)"', body.group(1))
    return int(loaded.group(1)), [b for b in (broken.group(1) if broken else "").split() if b]


class Links(HTMLParser):
    """Every href and img src of a page, and every id (the targets of its #anchors)."""

    def __init__(self):
        super().__init__()
        self.hrefs, self.images, self.ids = [], [], set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "a" and "href" in a:
            self.hrefs.append(a["href"])
        if tag == "img" and "src" in a:
            self.images.append(a["src"])


def unresolved_links(page: Path) -> list[str]:
    """The links of ``page`` that lead nowhere: a relative file that does not exist, or an anchor
    (on this page or on a linked local page) with no element of that id. No link may leave the
    machine (the pages are self-contained)."""
    parser = Links()
    parser.feed(page.read_text())
    bad = []
    for href in parser.hrefs + parser.images:
        if re.match(r"[a-z]+://", href):
            bad.append(f"{href} (leaves the machine)")
            continue
        target, _, anchor = href.partition("#")
        path = (page.parent / target) if target else page
        if not path.is_file():
            bad.append(href)
            continue
        if anchor:
            other = parser if not target else Links()
            if target:
                other.feed(path.read_text())
            if anchor not in other.ids:
                bad.append(f"{href} (no id {anchor})")
    return bad
