"""Files written whole or not at all: every artifact crankfmu writes (an FMU, an SSP, a report's
CSV, JSON or figure) goes to a temporary name beside its final one and is moved into place only
when complete, so a command that fails leaves no half-written file behind, and a reader never sees
one (``os.replace`` is atomic within a folder)."""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def replacing(path):
    """Yields a temporary path beside ``path`` (same suffix, so writers that infer a format from it
    still do); on leaving without an error the file there replaces ``path``, on an error it is
    removed and ``path`` is left as it was."""
    path = Path(path)
    temporary = path.with_name(f".{path.stem}.part-{os.getpid()}{path.suffix}")
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def write_text(path, text: str) -> Path:
    with replacing(path) as temporary:
        Path(temporary).write_text(text, encoding="utf-8")
    return Path(path)


def figure_title(fig) -> str:
    """The figure's own title: its suptitle, else its axes' titles joined (what a caption starts from)."""
    sup = getattr(fig, "_suptitle", None)
    if sup is not None and sup.get_text().strip():
        return " ".join(sup.get_text().split())
    return "; ".join(" ".join(ax.get_title().split()) for ax in fig.axes if ax.get_title().strip())


def save_figure(fig, path, caption: str = "", scenario: str = "", **savefig) -> Path:
    """``fig.savefig(path, **savefig)``, whole or not at all (the format from the suffix). A PNG
    carries what it shows in its text chunks: its title (the figure's own), ``caption`` (what to
    look at) and ``scenario`` (the data file it comes from), so a page that shows it (``crankfmu
    page``) needs no list of figures of its own."""
    path = Path(path)
    if path.suffix.lower() == ".png":
        savefig["metadata"] = {**savefig.get("metadata", {}), "Title": figure_title(fig),
                               "Description": caption, "Source": scenario}
    with replacing(path) as temporary:
        fig.savefig(temporary, format=path.suffix.lstrip(".") or None, **savefig)
        # a title wider than the figure (a long one over a panel narrowed by its legend) runs off
        # its edge: drawn again smaller until it fits, where the first drawing shows it does not
        for _ in range(0 if savefig.get("bbox_inches") == "tight" else 8):    # (tight: the page grows)
            if not _shrink_titles_off_the_figure(fig):
                break
            fig.savefig(temporary, format=path.suffix.lstrip(".") or None, **savefig)
    return path


def _shrink_titles_off_the_figure(fig) -> bool:
    """Make each title that the last drawing put partly outside the figure 10 % smaller; whether
    there was one."""
    renderer = fig.canvas.get_renderer()
    width = fig.bbox.width
    titles = [fig._suptitle] if fig._suptitle is not None else []
    titles += [t for ax in fig.axes for t in (ax.title, ax._left_title, ax._right_title)]
    shrunk = False
    for text in titles:
        if not text.get_text() or not text.get_visible():
            continue
        box = text.get_window_extent(renderer)
        if box.x0 < -0.5 or box.x1 > width + 0.5:
            text.set_fontsize(text.get_fontsize() * 0.9)
            shrunk = True
    return shrunk
