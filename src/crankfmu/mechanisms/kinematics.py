"""What the contour engine gives at an array of crank angles: each unknown's position and first and
second transfer functions, each point's motion (eq. 11's t, p, tt, pp for mass centres) and each
link's angle (mechanisms/contour.py computes them)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, NamedTuple

import numpy as np


class PointMotion(NamedTuple):
    """A point's position (m) and its first and second derivatives by phi1 (m/rad, m/rad^2) at each
    crank angle: eq. 11's t, p, tt, pp for a mass centre are dx, dy, ddx, ddy."""

    x: np.ndarray
    y: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    ddx: np.ndarray
    ddy: np.ndarray

    def along(self, axis: int) -> np.ndarray:
        """The position along axis 0 (x) or 1 (y), m."""
        return self[axis]

    def ratio(self, axis: int) -> np.ndarray:
        """The velocity ratio d(position)/dphi1 along axis 0 (x) or 1 (y), m/rad."""
        return self[2 + axis]


class OnDemand(Mapping):
    """A mapping computed on first use: the points' motions, which a search on a link's transfer
    function (stationary_angles, several engine calls a model build) never reads."""

    def __init__(self, compute):
        self._compute, self._items = compute, None

    def _all(self) -> dict:
        if self._items is None:
            self._items, self._compute = self._compute(), None
        return self._items

    def __getitem__(self, key):
        return self._all()[key]

    def __iter__(self):
        return iter(self._all())

    def __len__(self) -> int:
        return len(self._all())


class Picked(Mapping):
    """Another mapping's values at some angles, each sliced when first read: a crank-angle scheme
    takes one angle's kinematics per step (its speed loads), which read a few of a mechanism's
    points (an engine has dozens)."""

    def __init__(self, source: Mapping, pick):
        self._source, self._pick, self._items = source, pick, {}

    def __getitem__(self, key):
        found = self._items.get(key)
        if found is None:
            found = self._items[key] = self._pick(self._source[key])
        return found

    def __iter__(self):
        return iter(self._source)

    def __len__(self) -> int:
        return len(self._source)


@dataclass
class Kinematics:
    """Positions and transfer functions at an array of crank angles.

    ``q[name]``, ``dq[name]``, ``ddq[name]``: each unknown (rad or m) and its first and second
    derivative with respect to phi1 (rad/rad, m/rad, ...). ``point(name)`` gives
    (x, y, dx/dphi1, dy/dphi1, d2x/dphi1^2, d2y/dphi1^2) in m, m/rad, m/rad^2: eq. 11's
    t, p, tt, pp for mass centres. ``link_angle(link)`` gives (phi_j, q_j, qq_j).
    """

    phi1: np.ndarray
    q: dict[str, np.ndarray]
    dq: dict[str, np.ndarray]
    ddq: dict[str, np.ndarray]
    points: Mapping[str, PointMotion]
    link_angles: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]

    def point(self, name: str) -> PointMotion:
        return self.points[name]

    def link_angle(self, link: str):
        return self.link_angles[link]

    def subset(self, index) -> "Kinematics":
        """The same kinematics at some of the angles (an index or slice keeps array shapes)."""
        sel = np.atleast_1d(np.arange(self.phi1.size)[index])
        pick = lambda d: {k: v[sel] for k, v in d.items()}  # noqa: E731
        return Kinematics(
            phi1=self.phi1[sel], q=pick(self.q), dq=pick(self.dq), ddq=pick(self.ddq),
            points=Picked(self.points, lambda v: PointMotion(*(a[sel] for a in v))),
            link_angles=Picked(self.link_angles, lambda v: tuple(a[sel] for a in v)),
        )
