"""What a drawing of a mechanism consists of, read from the mechanism file alone (no matplotlib).

The ``[[joints]]`` say which points each link carries: a link is drawn through its joint points
(a bar when they lie on one line, a plate otherwise), a link whose joints all sit at one point
of a slide is the slide's block, and the other link of a prismatic joint is its guide (a line on
the ground, or the moving link's own bar). Ground pins are the revolute joints on ``ground``.
A file without joints is drawn from its point definitions: each point is joined to the point it
is defined from.

``Sketch.frames(phi1)`` gives every point's position (and velocity per unit crank speed) at an
array of crank angles, with the link angles, from the contour engine's exact kinematics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..mechanisms.contour import Mechanism


@dataclass
class Slide:
    joint: str
    point: str
    axis: str                 # a constant angle expression or an angle unknown (rad)
    guide: str                # a link name or "ground"
    block: str


@dataclass
class Frames:
    """Positions at N crank angles: ``xy[p]`` (N, 2) in m, ``v[p]`` (N, 2) in m/rad (times omega1
    for m/s), ``angle[link]`` and ``rate[link]`` (rad, rad/rad) for every link."""

    phi1: np.ndarray
    xy: dict[str, np.ndarray]
    v: dict[str, np.ndarray]
    angle: dict[str, np.ndarray]
    rate: dict[str, np.ndarray]

    def at(self, i: int) -> "Frames":
        return Frames(self.phi1[i:i + 1], {k: a[i:i + 1] for k, a in self.xy.items()},
                      {k: a[i:i + 1] for k, a in self.v.items()},
                      {k: a[i:i + 1] for k, a in self.angle.items()}, {k: a[i:i + 1] for k, a in self.rate.items()})


@dataclass
class Sketch:
    """The drawing's topology: which points each link joins, the pins, slides and mass centres."""

    mechanism: Mechanism
    link_points: dict[str, list[str]] = field(default_factory=dict)   # link -> points joined by it
    ground_pins: list[str] = field(default_factory=list)
    pins: list[str] = field(default_factory=list)                     # moving revolute joints
    slides: list[Slide] = field(default_factory=list)
    centres: dict[str, str] = field(default_factory=dict)             # link -> mass centre point
    segments: list[tuple[str, str, str]] = field(default_factory=list)  # (link or "", p, q) without joints

    @classmethod
    def of(cls, mechanism: Mechanism) -> "Sketch":
        definition = mechanism.definition
        sketch = cls(mechanism)
        sketch.centres = {name: link.centre for name, link in definition.links.items()}
        joints = definition.joints
        if not joints:
            sketch._from_points()
            return sketch
        points_of: dict[str, list[str]] = {name: [] for name in definition.links}
        for j in joints:
            for link in j.links:
                if link != "ground" and j.point not in points_of[link]:
                    points_of[link].append(j.point)
        for j in joints:
            if j.kind == "revolute":
                target = sketch.ground_pins if "ground" in j.links else sketch.pins
                if j.point not in target:
                    target.append(j.point)
            else:
                first, second = j.links
                # the block is the link that carries nothing but this point
                single = [l for l in (second, first) if l != "ground" and points_of[l] == [j.point]]
                block = single[0] if single else second
                guide = first if block == second else second
                sketch.slides.append(Slide(j.name, j.point, j.axis, guide, block))
        blocks = {s.block for s in sketch.slides}
        # points carried by a link besides its joints (a horsehead, a coupler point, a crank arm's
        # counterweight): defined from one of the link's points by terms turning with its angle
        for p, (base, angles) in _point_terms(definition).items():
            for link, pts in points_of.items():
                angle = definition.links[link].angle
                if p not in pts and base in pts and angles and angles <= {angle}:
                    pts.append(p)
        sketch.link_points = {l: pts for l, pts in points_of.items() if l not in blocks and len(pts) >= 2}
        return sketch

    def _from_points(self):
        """Without joints: each point joined to the point its definition starts from, except the
        mass centres of turning links (inside their bars; a translating link's centre is its point)."""
        definition = self.mechanism.definition
        inside = {ld.centre for ld in definition.links.values() if ld.angle in definition.variables}
        for name, (base, _) in _point_terms(definition).items():
            if name not in inside and base is not None:
                self.segments.append(("", base, name))

    @property
    def points(self) -> list[str]:
        return list(self.mechanism.point_names)

    @property
    def moving_points(self) -> list[str]:
        fixed = set(self.mechanism.definition.fixed_points)
        return [p for p in self.points if p not in fixed]

    @property
    def joint_points(self) -> list[str]:
        """Points where joints sit (labelled first in a drawing), in file order."""
        out = []
        for p in [*self.ground_pins, *self.pins, *(s.point for s in self.slides)]:
            if p not in out:
                out.append(p)
        for _, a, b in self.segments:
            for p in (a, b):
                if p not in out:
                    out.append(p)
        return out

    def frames(self, phi1) -> Frames:
        phi1 = np.atleast_1d(np.asarray(phi1, dtype=float))
        kin = self.mechanism.kinematics(phi1)
        motion = {p: kin.point(p) for p in self.points}
        xy = {p: np.column_stack((m.x, m.y)) for p, m in motion.items()}
        v = {p: np.column_stack((m.dx, m.dy)) for p, m in motion.items()}
        angle = {l: kin.link_angle(l)[0] for l in self.mechanism.definition.links}
        rate = {l: kin.link_angle(l)[1] for l in self.mechanism.definition.links}
        for s in self.slides:           # a slide's axis may turn with a link (a guide on a lever)
            angle[f"axis:{s.joint}"] = self.mechanism.angle_of(s.axis, kin)
        return Frames(phi1, xy, v, angle, rate)

    def instant_centre(self, frames: Frames, link: str, i: int = 0):
        """The instant centre of ``link`` at frame ``i`` (m), or None for a link that translates there.

        v_P = w k x (P - I) for the link's mass centre P gives I = P + (k x v_P) / w, with velocities
        and w per unit crank speed (omega1 cancels)."""
        w = float(frames.rate[link][i])
        if abs(w) < 1e-12:
            return None
        p = frames.xy[self.centres[link]][i]
        vx, vy = frames.v[self.centres[link]][i]
        return np.array([p[0] - vy / w, p[1] + vx / w])

    def extent(self, frames: Frames) -> float:
        """The size of the drawing (m): the largest span of the points over the frames."""
        allxy = np.concatenate(list(frames.xy.values()))
        span = np.ptp(allxy, axis=0)
        return float(max(span.max(), 1e-9))


def _point_terms(definition) -> dict[str, tuple[str | None, set[str]]]:
    """Each point's base point and the angle variables of its own terms, from the [points] text."""
    import ast

    variables = set(definition.variables)
    out = {}
    for name, text in definition.point_sources.items():
        tree = ast.parse(text, mode="eval")
        bases = [n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and n.id in definition.points]
        angles = {n.id for call in ast.walk(tree) if isinstance(call, ast.Call) and getattr(call.func, "id", "") == "u"
                  for n in ast.walk(call) if isinstance(n, ast.Name) and n.id in variables}
        out[name] = (bases[0] if bases else None, angles)
    return out


def is_colinear(xy: np.ndarray, scale: float) -> bool:
    """Whether points (n, 2) lie on one line, within 1e-6 of the drawing's size."""
    if len(xy) < 3:
        return True
    d = xy - xy[0]
    far = d[np.argmax(np.hypot(d[:, 0], d[:, 1]))]
    norm = math.hypot(*far)
    if norm == 0.0:
        return True
    cross = np.abs(d[:, 0] * far[1] - d[:, 1] * far[0]) / norm
    return bool(np.max(cross) <= 1e-6 * scale)
