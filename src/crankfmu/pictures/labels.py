"""Text labels that do not overlap: placement beside their anchor points, and the check the tests
and the drawings use (matplotlib's rendered text extents, in display pixels).

A label is an annotation at a data point with an offset in typographic points. ``place_labels``
tries offsets around the anchor, nearest first, and keeps the first whose rendered box meets no
box already placed (other labels, titles, axis labels, legends) and stays inside the axes; the
figure's layout must be final before it is called (a later layout change moves the anchors).
"""

from __future__ import annotations

import math

import numpy as np

#: directions tried around an anchor, in order: right, upper right, up, ... (deg)
DIRECTIONS = (0, 45, 90, 135, 180, 225, 270, 315, 22.5, 67.5, 112.5, 157.5, 202.5, 247.5, 292.5, 337.5)
#: distances tried from the anchor, in points
RADII = (7, 13, 20, 30, 42, 56, 72, 90)


def renderer_of(fig):
    """The figure's renderer, after a draw (so aspect-equal axes have their final box)."""
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _tick_labels(fig) -> set:
    """Tick labels: matplotlib lays them out itself outside the axes (and keeps hidden ones for ticks
    beyond the limits, with stale positions), so they are left out of the checks; every label placed
    here stays inside its axes."""
    out = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                out |= {tick.label1, tick.label2}
    return out


def _text_box(t, renderer):
    """The rendered box of the text itself (an annotation's own extent also holds its leader line)."""
    from matplotlib.text import Text

    return Text.get_window_extent(t, renderer)


def _texts(fig, renderer, exclude=()) -> list:
    """(text, rendered box) of every visible non-empty text of the figure but tick labels."""
    from matplotlib.text import Text

    skip = _tick_labels(fig) | set(exclude)
    items = []
    for t in fig.findobj(Text):
        if t in skip or not t.get_visible() or not t.get_text().strip():
            continue
        box = _text_box(t, renderer)
        if box.width > 0 and box.height > 0:
            items.append((t.get_text(), box))
    return items


def _overlap(a, b, pad: float = 1.0) -> bool:
    return a.x0 < b.x1 + pad and b.x0 < a.x1 + pad and a.y0 < b.y1 + pad and b.y0 < a.y1 + pad


def label(ax, text: str, xy, **style):
    """An annotation at ``xy`` (data coordinates), placed later by ``place_labels``; a thin leader
    line joins it to its point when it had to move away (hidden under the text when near). A
    white box behind the text keeps it readable over a line it crosses (a guide, a grid)."""
    leader = dict(arrowstyle="-", lw=0.5, color="0.55", shrinkA=0, shrinkB=2, patchA=None)
    style.setdefault("bbox", dict(boxstyle="square,pad=0.1", fc="white", ec="none", alpha=0.8))
    return ax.annotate(text, xy=xy, xytext=(RADII[0], 0), textcoords="offset points",
                       ha="center", va="center", annotation_clip=False, arrowprops=leader, **style)


def _as_array(boxes) -> np.ndarray:
    return np.array([[b.x0, b.y0, b.x1, b.y1] for b in boxes], dtype=float).reshape(-1, 4)


def _hits(box: np.ndarray, others: np.ndarray, pad: float = 1.0) -> int:
    """How many of ``others`` (M, 4: x0, y0, x1, y1) the box (4,) meets."""
    if not len(others):
        return 0
    return int(np.count_nonzero((box[0] < others[:, 2] + pad) & (others[:, 0] < box[2] + pad)
                                & (box[1] < others[:, 3] + pad) & (others[:, 1] < box[3] + pad)))


def place_labels(fig, ax, labels, obstacles=None, renderer=None):
    """Move each annotation of ``labels`` to the nearest free offset around its anchor.

    ``obstacles``: display boxes to avoid besides the figure's other texts (e.g. markers).
    Returns the number of labels that found no free place (kept at their least crowded place).
    The label's box is measured once, centred on its anchor, and shifted per candidate offset
    (the labels are centred on their offset point).
    """
    renderer = renderer or renderer_of(fig)
    fixed = _as_array([box for _, box in _texts(fig, renderer, exclude=labels)] + list(obstacles or []))
    inside = ax.get_window_extent(renderer)
    px = fig.dpi / 72.0
    crowded = 0
    placed = np.zeros((0, 4))
    for ann in labels:
        ann.xyann = (0.0, 0.0)
        b = _text_box(ann, renderer)
        centred = np.array([b.x0, b.y0, b.x1, b.y1])
        best, best_count = (RADII[0], 0.0), None
        for r in RADII:
            for d in DIRECTIONS:
                offset = (r * math.cos(math.radians(d)), r * math.sin(math.radians(d)))
                box = centred + px * np.array([offset[0], offset[1], offset[0], offset[1]])
                outside = not (inside.x0 <= box[0] and box[2] <= inside.x1 and inside.y0 <= box[1] and box[3] <= inside.y1)
                count = _hits(box, placed) + _hits(box, fixed) + (2 if outside else 0)
                if best_count is None or count < best_count:
                    best, best_count, best_box = offset, count, box
                if count == 0:
                    break
            if best_count == 0:
                break
        ann.xyann = best
        crowded += best_count > 0
        placed = np.vstack([placed, best_box])
    return crowded


def obstacle_boxes(ax, points=(), paths=(), marker_px: float = 12.0, step_px: float = 5.0) -> list:
    """Display boxes a label must not cover: a square of ``marker_px`` around each point (data
    coordinates, e.g. joints and markers) and small squares every ``step_px`` along each polyline
    (bars, arrows, guides)."""
    from matplotlib.transforms import Bbox

    to_display = ax.transData.transform
    centres, sizes = [to_display(np.asarray(points, dtype=float).reshape(-1, 2))], [np.full(len(points), 0.5 * marker_px)]
    for path in paths:
        xy = to_display(np.asarray(path, dtype=float).reshape(-1, 2))
        for a, b in zip(xy[:-1], xy[1:]):
            t = np.linspace(0.0, 1.0, max(2, int(np.hypot(*(b - a)) / step_px) + 1))[:, None]
            centres.append(a + t * (b - a))
            sizes.append(np.full(t.shape[0], 2.0))
    c, h = np.concatenate(centres), np.concatenate(sizes)
    return [Bbox([[x - r, y - r], [x + r, y + r]]) for (x, y), r in zip(c, h)]


def overlapping_texts(fig) -> list[tuple[str, str]]:
    """Pairs of visible texts of the figure whose rendered boxes overlap (tick labels aside)."""
    items = _texts(fig, renderer_of(fig))
    return [(a, b) for i, (a, ba) in enumerate(items) for b, bb in items[i + 1:] if _overlap(ba, bb, pad=0.0)]
