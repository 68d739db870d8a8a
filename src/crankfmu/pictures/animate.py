"""The mechanism moving: one crank turn at constant speed, or a simulated run (``timeseries.csv`` of
``crankfmu simulate``), with the paths of chosen points growing as they are traced, a time and
angle readout and, beside it, omega1 over time with a moving cursor.

GIF goes through Pillow (no external program); MP4 through matplotlib's FFMpegWriter, which needs
ffmpeg on the PATH. The artists are made once and moved per frame (draw.MechanismPicture), and the
labels are placed again in every frame so they never overlap. For a GIF the still parts (axes,
ticks, the omega1 curve, the frame) are rendered once and each frame redraws only the moving
artists over them (blitting): a frame costs a few ms instead of a full redraw.
"""

from __future__ import annotations

import csv
import json
import math
import shutil
import textwrap
from pathlib import Path

import numpy as np

from ..atomic import replacing
from ..errors import CrankfmuError, ParameterError
from .draw import MechanismPicture, TWO_PI, check_trace, drawing_speed
from .labels import obstacle_boxes, place_labels
from .sketch import Sketch


def read_run(result_dir) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(time s, phi1 rad, omega1 rad/s) of a run written by ``crankfmu simulate``."""
    path = Path(result_dir) / "timeseries.csv"
    if not path.is_file():
        raise CrankfmuError(f"--result {result_dir}: no timeseries.csv there (write one with crankfmu simulate)")
    with path.open() as f:
        reader = csv.reader(f)
        header = [h.strip().strip('"') for h in next(reader)]
        missing = {"time", "phi1", "omega1"} - set(header)
        if missing:
            raise CrankfmuError(f"{path}: columns {', '.join(sorted(missing))} missing (found {', '.join(header)})")
        cols = [header.index(n) for n in ("time", "phi1", "omega1")]
        rows = np.array([[float(r[c]) for c in cols] for r in reader if r])
    if rows.shape[0] < 2:
        raise CrankfmuError(f"{path}: fewer than two rows")
    return rows[:, 0], rows[:, 1], rows[:, 2]


def run_words(result_dir) -> str:
    """A run in words, its start, length and method (summary.json's, where it names one): "a run
    from omega1 = 6 rad/s over 4 s (fast)", never its folder's path."""
    import json

    t, _, omega = read_run(result_dir)
    try:
        method = json.loads((Path(result_dir) / "summary.json").read_text(encoding="utf-8")).get("method")
    except (OSError, ValueError, AttributeError):
        method = None
    how = f" ({method})" if isinstance(method, str) and method else ""
    return f"a run from omega1 = {omega[0]:.4g} rad/s over {t[-1] - t[0]:.4g} s{how}"


def animate(scenario, out, result_dir=None, trace=None, frames: int = 120, fps: int = 20,
            omega1: float | None = None, progress=None) -> Path:
    """Write the animation to ``out`` (.gif or .mp4) and return its path."""
    from ..plots import pyplot

    out = Path(out)
    if out.suffix.lower() not in (".gif", ".mp4"):
        raise ParameterError(f"--out {out}: the animation is written as .gif or .mp4", "out")
    if out.suffix.lower() == ".mp4" and shutil.which("ffmpeg") is None:
        raise CrankfmuError(f"--out {out}: MP4 needs ffmpeg on the PATH (not found); write a .gif instead")
    if not (isinstance(fps, int) and 1 <= fps <= 60):
        raise ParameterError(f"--fps must be an integer in [1, 60], got {fps!r}", "fps")
    fig, frame, count = animation_figure(scenario, result_dir, trace, frames, omega1)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        with replacing(out) as partial:
            if out.suffix.lower() == ".gif":
                # what the animation shows, in the GIF's comment (a page's caption: crankfmu page)
                about = {"title": f"{scenario.title}: " + (run_words(result_dir) if result_dir
                                                            else "one crank turn at constant speed"),
                         "caption": f"{scenario.title}, moving" + (f" as {run_words(result_dir)} turns it" if result_dir
                                                                   else " at constant crank speed")
                                    + ".", "scenario": scenario.name}
                write_gif(fig, frame, count, partial, fps, progress, json.dumps(about))
            else:
                from matplotlib.animation import FFMpegWriter, FuncAnimation

                for artist in fig.findobj(lambda a: a.get_animated()):
                    artist.set_animated(False)
                callback = (lambda k, n: progress(k + 1)) if progress is not None else None
                FuncAnimation(fig, frame, frames=count).save(partial, writer=FFMpegWriter(fps=fps),
                                                             progress_callback=callback)
    finally:
        pyplot().close(fig)
    return out


def write_gif(fig, frame, count, out: Path, fps: int, progress, comment: str = ""):
    """``count`` frames of ``fig`` (``frame(i)`` moves its animated artists to frame i) as a GIF at
    ``out``, with ``comment`` (what it shows, for a page's caption) in the file: each frame is
    blitted over the still background and the frames written with Pillow."""
    from PIL import Image

    canvas = fig.canvas
    moving = fig.findobj(lambda a: a.get_animated())
    canvas.draw()                                   # the still parts only (animated artists are skipped)
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for i in range(count):
        frame(i)
        canvas.restore_region(background)
        for artist in moving:
            fig.draw_artist(artist)
        images.append(Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy()))
        if progress is not None:
            progress(i + 1)
    # one palette for every frame, without dithering: the still parts are the same pixels in every
    # frame, so each frame after the first stores only the moving links (a tenth of the bytes)
    palette = images[0].quantize(colors=96, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    frames = [image.quantize(palette=palette, dither=Image.Dither.NONE) for image in images]
    frames[0].save(out, format="GIF", save_all=True, append_images=frames[1:], duration=int(round(1000 / fps)),
                   loop=0, optimize=True, disposal=1, comment=comment.encode())


def animation_figure(scenario, result_dir=None, trace=None, frames: int = 120, omega1: float | None = None):
    """(figure, frame(i) that moves it to frame i, number of frames): the animation before writing."""
    from ..plots import pyplot

    if not (isinstance(frames, int) and 2 <= frames <= 2000):
        raise ParameterError(f"--frames must be an integer in [2, 2000], got {frames!r}", "frames")
    section = dict(scenario.data.get("drawing", {}))
    mechanism = scenario.assembled_mechanism()[0]
    sketch = Sketch.of(mechanism)
    trace = check_trace(sketch, trace if trace is not None else section.get("trace", []))
    if result_dir is None:
        w = drawing_speed(scenario, omega1)
        t_all = np.linspace(0.0, TWO_PI / w, 361)
        phi_all, omega_all = w * t_all, np.full(t_all.shape, w)
        what = f"one crank turn at constant omega1 = {w:g} rad/s"
    else:
        t_all, phi_all, omega_all = read_run(result_dir)
        what = run_words(result_dir)
    index = np.unique(np.linspace(0, t_all.size - 1, frames).round().astype(int))
    t, phi = t_all[index], phi_all[index]
    movie = sketch.frames(np.mod(phi, TWO_PI))
    turn = sketch.frames(np.linspace(0.0, TWO_PI, 361))

    plt = pyplot()
    # 960 x 442 pixels: text at 9 pt is 12 px high, readable in a page or a slide. A run's speed
    # gets a panel beside the mechanism; at constant speed that panel would be a flat line, so the
    # mechanism takes the whole width and the readout gives the speed
    constant = result_dir is None
    if constant:
        fig, ax = plt.subplots(figsize=(10, 4.6), dpi=96)
    else:
        fig, (ax, ax_w) = plt.subplots(1, 2, figsize=(10, 4.6), dpi=96, gridspec_kw={"width_ratios": [1.25, 1]})
    picture = MechanismPicture(ax, sketch, movie, turn, trace=trace, grow_traces=True)
    (x0, x1), (y0, y1) = picture.limits()
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    if constant:           # as wide as the mechanism needs at this height, no empty margins
        fig.set_size_inches(min(10.0, max(6.0, 3.8 * (x1 - x0) / (y1 - y0) + 1.3)), 4.6)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.2)
    ax.set_title(textwrap.fill(scenario.title + (f": {what}" if constant else ""), 80 if constant else 58),
                 fontsize=9)
    moving = []
    if not constant:
        ax_w.plot(t_all, omega_all, lw=1.2, color="C0")
        cursor = ax_w.axvline(t[0], color="C3", lw=1.0)
        dot = ax_w.plot([t[0]], [omega_all[index[0]]], "o", color="C3")[0]
        moving = [cursor, dot]
        ax_w.set_xlabel("time [s]")
        ax_w.set_ylabel("omega1 [rad/s]")
        ax_w.set_title(textwrap.fill(f"crank speed: {what}", 48), fontsize=9)
        ax_w.grid(True, alpha=0.3)
        lo, hi = float(np.min(omega_all)), float(np.max(omega_all))
        pad = 0.05 * (hi - lo) if hi > lo else 0.05 * max(abs(hi), 1.0)
        ax_w.set_ylim(lo - pad, hi + pad)
    readout = fig.text(0.01, 0.015, "", fontsize=9, family="monospace")
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()

    def frame(i):
        picture.update(i)
        readout.set_text(f"t = {t[i]:8.4f} s   phi1 = {math.degrees(phi[i]) % 360:6.1f} deg   "
                         f"omega1 = {omega_all[index[i]]:8.4f} rad/s")
        if moving:
            cursor.set_xdata([t[i], t[i]])
            dot.set_data([t[i]], [omega_all[index[i]]])
        points, paths = picture.obstacles(i)
        place_labels(fig, ax, picture.labels, obstacle_boxes(ax, points, paths), renderer=renderer)
        return []

    for artist in [*picture.artists(), *moving, readout]:
        artist.set_animated(True)
    frame(0)
    return fig, frame, len(index)
