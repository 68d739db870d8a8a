"""The mechanism drawn with matplotlib: links as bars (plates for links of three or more joints on no
line), revolute joints as pins, ground pins with the frame's hatching, slides as blocks on their
guides, mass centres with the centre-of-mass symbol, point labels that do not overlap; optional
overlays: velocities, the links' instant centres and the joint reactions, each with its scale.

``MechanismPicture`` makes the artists once and moves them per frame (``update``), so a static
drawing (``draw_figure``) and an animation (``pictures.animate``) are the same drawing.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass, field

import numpy as np

from .labels import label, obstacle_boxes, place_labels, renderer_of
from .sketch import Frames, Sketch, is_colinear
from ..atomic import save_figure
from ..units import engineering

TWO_PI = 2.0 * math.pi
PIN = dict(marker="o", ms=7, mfc="white", mec="black", mew=1.4, ls="none", zorder=6)
CENTRE = dict(marker="o", ms=8, mfc="none", mec="0.15", mew=1.0, ls="none", zorder=7)


def link_colour(number: int) -> str:
    return f"C{(number - 1) % 10}"


#: the overlays' arrows: the links take matplotlib's ten colours, so an arrow in one of them would
#: read as part of a link (bar 5's purple was the reactions' colour); black and a dark grey are free
VELOCITY_COLOUR, REACTION_COLOUR = "black", "0.35"


def nice(value: float) -> float:
    """1, 2 or 5 times a power of ten, at most ``value`` (scale bars and keys)."""
    if not value > 0:
        return 1.0
    p = 10.0 ** math.floor(math.log10(value))
    return max(m * p for m in (1.0, 2.0, 5.0) if m * p <= value)


def _hull_order(xy: np.ndarray) -> np.ndarray:
    c = xy.mean(axis=0)
    return np.argsort(np.arctan2(xy[:, 1] - c[1], xy[:, 0] - c[0]))


def _rectangle(centre, angle: float, length: float, height: float) -> np.ndarray:
    u = np.array([math.cos(angle), math.sin(angle)])
    n = np.array([-u[1], u[0]])
    h, w = 0.5 * length, 0.5 * height
    return np.array([centre + h * u + w * n, centre - h * u + w * n, centre - h * u - w * n, centre + h * u - w * n])


def _hatch(start, end, side, size: float, count: int) -> list:
    """Short diagonal strokes along the segment start-end on one side: the frame's symbol."""
    d = end - start
    n = side * np.array([-d[1], d[0]]) / (np.hypot(*d) or 1.0)
    u = d / (np.hypot(*d) or 1.0)
    return [[start + t * d, start + t * d + size * (n - u) * 0.7] for t in np.linspace(0.0, 1.0, count)]


@dataclass
class MechanismPicture:
    """The artists of one mechanism in one axes; ``update(i)`` moves them to frame i."""

    ax: object
    sketch: Sketch
    frames: Frames
    turn: Frames                 # one full turn: the guides' travel and the drawing's size
    trace: list = field(default_factory=list)
    grow_traces: bool = False
    labels: list = field(default_factory=list)

    def __post_init__(self):
        from matplotlib.collections import LineCollection
        from matplotlib.patches import Polygon

        ax, sk = self.ax, self.sketch
        definition = sk.mechanism.definition
        self.size = sk.extent(self.turn)
        self.block = (0.09 * self.size, 0.055 * self.size)
        self.bars, self.plates, self.blocks = {}, {}, {}
        for link, pts in sk.link_points.items():
            colour = link_colour(definition.links[link].number)
            xy = np.array([self.frames.xy[p][0] for p in pts])
            if is_colinear(xy, self.size):
                self.bars[link] = ax.plot([], [], "-", lw=6, color=colour, alpha=0.85, solid_capstyle="round",
                                          zorder=3, label=f"{definition.links[link].number}: {link}")[0]
            else:
                self.plates[link] = ax.add_patch(Polygon(np.zeros((len(pts), 2)), closed=True, fc=colour, alpha=0.4,
                                                          ec=colour, lw=3, zorder=3,
                                                          label=f"{definition.links[link].number}: {link}"))
        for s in sk.slides:
            colour = link_colour(definition.links[s.block].number)
            self.blocks[s.joint] = ax.add_patch(Polygon(np.zeros((4, 2)), closed=True, fc=colour, ec="black",
                                                        lw=1.2, alpha=0.9, zorder=4,
                                                        label=f"{definition.links[s.block].number}: {s.block}"))
        self.segments = [ax.plot([], [], "-", lw=3, color="0.3", zorder=3)[0] for _ in sk.segments]
        # the frame: pins on the ground and the fixed guides of slides, with hatching
        strokes, lines = [], []
        for p in sk.ground_pins:
            x, y = self.frames.xy[p][0]
            s = 0.035 * self.size
            tri = np.array([[x, y], [x - s, y - 1.6 * s], [x + s, y - 1.6 * s]])
            ax.add_patch(Polygon(tri, closed=True, fc="0.85", ec="black", lw=1.0, zorder=2))
            base = np.array([[x - 1.6 * s, y - 1.6 * s], [x + 1.6 * s, y - 1.6 * s]])
            lines.append(base)
            strokes += _hatch(base[0], base[1], -1, 0.6 * s, 6)
        for s in sk.slides:
            if s.guide != "ground":
                continue
            a = float(self.turn.angle[f"axis:{s.joint}"][0])
            u = np.array([math.cos(a), math.sin(a)])
            path = self.turn.xy[s.point]
            along = path @ u
            origin = path[0] - along[0] * u
            lo, hi = along.min() - self.block[0], along.max() + self.block[0]
            offset = np.array([-u[1], u[0]]) * 0.5 * self.block[1]
            start, end = origin + lo * u - offset, origin + hi * u - offset
            lines.append(np.array([start, end]))
            strokes += _hatch(start, end, -1, 0.03 * self.size, max(6, int(12 * (hi - lo) / self.size)))
        self.frame_lines = lines
        ax.add_collection(LineCollection(lines, colors="black", lw=1.4, zorder=2))
        ax.add_collection(LineCollection(strokes, colors="black", lw=0.8, zorder=2))
        self.ground_pin_points = list(sk.ground_pins)
        self.pins = ax.plot([], [], **PIN, label="revolute joint")[0]
        centres = sorted(set(sk.centres.values()))
        self.centre_points = centres
        self.centres = ax.plot([], [], **CENTRE, label="mass centre")[0]
        self.centre_cross = ax.plot([], [], marker="+", ms=8, mec="0.15", mew=1.0, ls="none", zorder=7)[0]
        joint_points = sk.joint_points
        self.other_points = [p for p in sk.points if p not in joint_points and p not in centres]
        self.others = ax.plot([], [], "o", ms=3.5, color="black", zorder=7)[0]
        self.traces = {p: ax.plot([], [], "--", lw=1.0, color="0.35", zorder=1, label=f"path of {p}")[0]
                       for p in self.trace}
        # labels: joints and named points in black, mass centres in grey (once per position); a point
        # that sits on a labelled one all the turn (a slider-crank's C at A where l_AC = 0) joins its
        # label, "A = C", rather than a second label over it
        self.label_points = []
        tiny = 1e-9 * max(self.size, 1e-300)
        for p in [*joint_points, *self.other_points]:
            same = next((k for k, q in enumerate(self.label_points)
                         if np.max(np.abs(self.turn.xy[p] - self.turn.xy[q])) <= tiny), None)
            if same is not None:
                self.labels[same].set_text(f"{self.labels[same].get_text()} = {p}")
                continue
            self.label_points.append(p)
            self.labels.append(label(ax, p, (0, 0), fontsize=10, fontweight="bold", zorder=9))
        for link, c in sk.centres.items():
            if c in self.label_points:
                continue
            self.label_points.append(c)
            self.labels.append(label(ax, c, (0, 0), fontsize=8, color="0.3", zorder=9))

    def update(self, i: int):
        f, sk = self.frames, self.sketch
        xy = {p: a[i] for p, a in f.xy.items()}
        for link, line in self.bars.items():
            pts = np.array([xy[p] for p in sk.link_points[link]])
            d = pts - pts[0]
            t = d @ (d[np.argmax(np.hypot(d[:, 0], d[:, 1]))])
            ends = pts[[np.argmin(t), np.argmax(t)]]
            line.set_data(ends[:, 0], ends[:, 1])
        for link, patch in self.plates.items():
            pts = np.array([xy[p] for p in sk.link_points[link]])
            patch.set_xy(pts[_hull_order(pts)])
        for s in sk.slides:
            self.blocks[s.joint].set_xy(_rectangle(xy[s.point], float(f.angle[f"axis:{s.joint}"][i]), *self.block))
        for line, (_, a, b) in zip(self.segments, sk.segments):
            line.set_data([xy[a][0], xy[b][0]], [xy[a][1], xy[b][1]])
        pins = np.array([xy[p] for p in [*sk.ground_pins, *sk.pins]] or np.zeros((0, 2)))
        self.pins.set_data(pins[:, 0], pins[:, 1])
        c = np.array([xy[p] for p in self.centre_points])
        self.centres.set_data(c[:, 0], c[:, 1])
        self.centre_cross.set_data(c[:, 0], c[:, 1])
        o = np.array([xy[p] for p in self.other_points] or np.zeros((0, 2)))
        self.others.set_data(o[:, 0], o[:, 1])
        for p, line in self.traces.items():
            path = f.xy[p][: i + 1] if self.grow_traces else self.turn.xy[p]
            line.set_data(path[:, 0], path[:, 1])
        for p, ann in zip(self.label_points, self.labels):
            ann.xy = tuple(xy[p])

    def artists(self) -> list:
        """The artists ``update`` moves (an animation redraws only these)."""
        return [*self.bars.values(), *self.plates.values(), *self.blocks.values(), *self.segments, self.pins,
                self.centres, self.centre_cross, self.others, *self.traces.values(), *self.labels]

    def obstacles(self, i: int) -> tuple[list, list]:
        """(points, polylines) in m that labels must not cover at frame i: every point, the links'
        bars and outlines, the blocks and the frame's lines."""
        xy = {p: a[i] for p, a in self.frames.xy.items()}
        paths = [np.column_stack(line.get_data()) for line in [*self.bars.values(), *self.segments]]
        paths += [np.vstack([patch.get_xy()]) for patch in [*self.plates.values(), *self.blocks.values()]]
        paths += [np.asarray(line) for line in self.frame_lines]
        paths += [self.frames.xy[p][: i + 1] if self.grow_traces else self.turn.xy[p] for p in self.traces]
        return list(xy.values()), paths

    def limits(self, extra=()) -> tuple:
        """Axis limits holding every point over the frames and the turn, and ``extra`` points."""
        pts = np.concatenate([*self.frames.xy.values(), *self.turn.xy.values(), *([np.array(extra)] if len(extra) else [])])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pad = 0.12 * max(hi - lo) + self.block[0]
        return (lo[0] - pad, hi[0] + pad), (lo[1] - pad, hi[1] + pad)


def drawing_section(scenario) -> dict:
    """The scenario's ``[drawing]`` section (angle, overlays, traced points, caption, speed)."""
    return dict(scenario.data.get("drawing", {}))


def drawing_speed(scenario, omega1: float | None = None) -> float:
    """The crank speed a drawing's velocities and reactions use (rad/s): the argument, else the
    scenario's [drawing], [kinematics] or [equilibrium] speed, else omega1_start."""
    from ..errors import ParameterError

    if omega1 is None:
        for section in ("drawing", "kinematics", "equilibrium"):
            w = scenario.data.get(section, {}).get("omega1")
            if w is not None:
                omega1 = float(w[0] if isinstance(w, list) else w)
                break
        else:
            omega1 = scenario["omega1_start"]
    if not (math.isfinite(omega1) and omega1 > 0):
        raise ParameterError(f"omega1 = {omega1!r} rad/s: a drawing's crank speed must be finite and > 0 "
                             "(give --omega)", "omega1")
    return float(omega1)


OVERLAYS = ("velocities", "instant_centres", "reactions")


def draw_figure(scenario, at_deg: float, show=(), omega1: float | None = None, trace=None, caption: str = ""):
    """The mechanism of ``scenario`` at crank angle ``at_deg`` (deg) as a matplotlib figure.

    ``show``: any of OVERLAYS; velocities and reactions at constant crank speed ``omega1`` (rad/s,
    default ``drawing_speed``). ``trace``: points whose path over a turn is drawn."""
    from ..errors import ParameterError
    from ..plots import pyplot

    unknown = set(show) - set(OVERLAYS)
    if unknown:
        raise ParameterError(f"unknown overlay(s) {', '.join(sorted(unknown))}; valid: {', '.join(OVERLAYS)}", "show")
    if not math.isfinite(at_deg):
        raise ParameterError(f"--at must be a crank angle in deg, got {at_deg!r}", "at")
    mechanism = scenario.assembled_mechanism()[0]
    sketch = Sketch.of(mechanism)
    trace = check_trace(sketch, trace or [])
    phi = math.radians(at_deg)
    frames = sketch.frames([phi])
    turn = sketch.frames(np.linspace(0.0, TWO_PI, 361))
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9.5, 7))
    picture = MechanismPicture(ax, sketch, frames, turn, trace=trace)
    picture.update(0)
    extra, labels, notes, keys = [], [], [], []
    points, paths = picture.obstacles(0)
    w = drawing_speed(scenario, omega1) if {"velocities", "reactions"} & set(show) else None
    if "instant_centres" in show:
        extra += _instant_centres(ax, sketch, frames, picture, labels, notes, paths)
    if "velocities" in show:
        extra += _velocities(ax, sketch, frames, picture, w, labels, paths, keys)
    if "reactions" in show:
        extra += _reactions(ax, scenario, sketch, frames, picture, w, phi, labels, paths, keys)
    (x0, x1), (y0, y1) = picture.limits(extra)
    y0 -= 0.07 * len(keys) * (y1 - y0)          # room for the vector keys below the mechanism
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    _keys(ax, keys)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.2)
    _scale_bar(ax, picture.size)
    definition = mechanism.definition
    speed = f", omega1 = {w:g} rad/s" if w is not None else ""
    ax.set_title(f"{scenario.title}\nphi1 = {at_deg:g} deg{speed}", fontsize=10)
    words = [caption, f"assembly branch: {definition.branch}", *notes]
    fig.text(0.02, 0.01, "\n".join(textwrap.fill(s, 120) for s in words if s), fontsize=7.5, va="bottom")
    handles, names = ax.get_legend_handles_labels()
    handles = [(h, picture.centre_cross) if h is picture.centres else h for h in handles]   # the symbol: o and +
    ax.legend(handles, names, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    renderer = renderer_of(fig)
    place_labels(fig, ax, picture.labels + labels, obstacle_boxes(ax, points + extra, paths), renderer=renderer)
    return fig


def check_trace(sketch, trace) -> list:
    from ..errors import ParameterError

    for p in trace:
        if p not in sketch.points:
            raise ParameterError(f"trace: {p!r} is not a point of mechanism {sketch.mechanism.definition.name} "
                                 f"(points: {', '.join(sketch.points)})", "trace")
    return list(trace)


def _scale_bar(ax, size: float):
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    length = nice(0.25 * size)
    ax.add_artist(AnchoredSizeBar(ax.transData, length, f"{length:g} m", "lower right", pad=0.6, sep=4,
                                  frameon=False, size_vertical=0.004 * size, fontproperties={"size": 8}))


def _instant_centres(ax, sketch, frames, picture, labels, notes, paths) -> list:
    """Each turning link's instant centre, with dotted lines to the link's joints (the graphical
    construction); one far beyond the drawing is named in the caption instead."""
    definition = sketch.mechanism.definition
    extra = []
    for link, ld in definition.links.items():
        if ld.angle == "phi1" or ld.angle not in sketch.mechanism.unknown_names:
            continue            # the crank turns about its pin; a constant angle: a translating link
        centre = sketch.instant_centre(frames, link)
        name = f"I{ld.number}"
        if centre is None:
            notes.append(f"{name}: link {link} translates at this angle (instant centre at infinity)")
            continue
        middle = np.mean([frames.xy[p][0] for p in sketch.link_points.get(link, [ld.centre])], axis=0)
        if np.hypot(*(centre - middle)) > 3.0 * picture.size:
            notes.append(f"{name} (link {link}) at ({centre[0]:.3g}, {centre[1]:.3g}) m, beyond the drawing")
            continue
        for p in sketch.link_points.get(link, [ld.centre]):
            q = frames.xy[p][0]
            ax.plot([centre[0], q[0]], [centre[1], q[1]], ":", lw=1.0, color=link_colour(ld.number), zorder=2)
            paths.append(np.array([centre, q]))
        ax.plot(*centre, marker="X", ms=9, color=link_colour(ld.number), mec="black", ls="none", zorder=8,
                label="instant centre" if not extra else None)
        labels.append(label(ax, name, tuple(centre), fontsize=10, fontweight="bold", color=link_colour(ld.number)))
        extra.append(centre)
    return extra


def _arrows(ax, origins, vectors, colour, unit: str, size: float, name: str, paths, keys):
    """Vectors drawn to one scale (the longest a quarter of the drawing); their key (a vector of a
    round magnitude) is drawn by ``_keys`` once the limits are known."""
    longest = max(float(np.max(np.hypot(vectors[:, 0], vectors[:, 1]))), 1e-300)
    scale = 0.25 * size / longest          # m of drawing per unit of the quantity
    style = dict(angles="xy", scale_units="xy", scale=1.0 / scale, color=colour, width=0.004, zorder=8)
    # a white rim: an arrow that lies along a link or over a slider's block stays visible on it
    ax.quiver(origins[:, 0], origins[:, 1], vectors[:, 0], vectors[:, 1], label=name, edgecolor="white",
              linewidth=0.8, **style)
    keys.append((nice(longest), unit, style))
    tips = origins + vectors * scale
    paths += [np.array([a, b]) for a, b in zip(origins, tips)]
    return list(tips)


def _beside(origin, tip):
    """Where an arrow's label is anchored: the middle of its shaft, so the label sits beside its own
    arrow (at the tip it could land nearer another point's arrow or joint, v_B beside C)."""
    return tuple(0.5 * (np.asarray(origin) + np.asarray(tip)))


def _keys(ax, keys):
    """Each vector scale as a key arrow in the lower left corner, labelled with its magnitude."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    for k, (value, unit, style) in enumerate(keys):
        x, y = x0 + 0.03 * (x1 - x0), y0 + (0.04 + 0.06 * k) * (y1 - y0)
        ax.quiver([x], [y], [value], [0.0], **style)
        ax.text(x + value / style["scale"] + 0.015 * (x1 - x0), y, engineering(value, unit), fontsize=8, va="center")


def _velocities(ax, sketch, frames, picture, w, labels, paths, keys) -> list:
    points = [p for p in sketch.moving_points if p not in set(sketch.centres.values()) or p in sketch.joint_points]
    origins = np.array([frames.xy[p][0] for p in points])
    v = np.array([frames.v[p][0] for p in points]) * w
    moving = np.hypot(v[:, 0], v[:, 1]) > 0
    tips = _arrows(ax, origins[moving], v[moving], VELOCITY_COLOUR, "m/s", picture.size, "velocity", paths, keys)
    for p, origin, tip, vec in zip(np.array(points)[moving], origins[moving], tips, v[moving]):
        labels.append(label(ax, f"v_{p} {engineering(np.hypot(*vec), 'm/s')}", _beside(origin, tip), fontsize=8,
                            color=VELOCITY_COLOUR))
    return tips


def _reactions(ax, scenario, sketch, frames, picture, w, phi, labels, paths, keys) -> list:
    """The joint reactions of ``crankfmu equilibrium`` (constant crank speed) at this angle: each
    joint's force of its first link on its second."""
    from ..dynamics.reactions import joint_reactions

    r = joint_reactions(scenario.build().reduced, np.array([phi]), w)
    names = list(r.force)
    joints = {j.name: j for j in sketch.mechanism.definition.joints}
    origins = np.array([frames.xy[joints[n].point][0] for n in names])
    forces = np.array([[r.force[n][0][0], r.force[n][1][0]] for n in names])
    tips = _arrows(ax, origins, forces, REACTION_COLOUR, "N", picture.size, "joint reaction", paths, keys)
    for n, origin, tip, f in zip(names, origins, tips, forces):
        labels.append(label(ax, f"F_{n} {engineering(np.hypot(*f), 'N')}", _beside(origin, tip), fontsize=8,
                            color=REACTION_COLOUR))
    return tips


def save(fig, path, scenario: str = "", caption: str = "") -> None:
    from pathlib import Path

    from ..plots import pyplot

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path, dpi=110, scenario=scenario, caption=caption)
    pyplot().close(fig)
