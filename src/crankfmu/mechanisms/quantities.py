"""Mechanism-specific outputs, declared in a scenario file and computed from the analytic
transfer functions only when something asks for them.

A quantity is a position (``order = 0``), velocity (1) or acceleration (2) of either a point
coordinate (``of = "B.x"``) or an unknown of the contours (``of = "phi3"``, ``of = "s5"``):

    value        q
    velocity     q' omega1
    acceleration q'' omega1^2 + q' epsilon1

with q', q'' the first and second derivatives with respect to phi1 (rad, no finite differences).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DefinitionError

_SUFFIX = {"m": ("m", "m/s", "m/s2"), "rad": ("rad", "rad/s", "rad/s2")}


@dataclass(frozen=True)
class Quantity:
    name: str
    of: str                # "POINT.x", "POINT.y" or an unknown's name
    order: int             # 0 position, 1 velocity, 2 acceleration
    description: str = ""

    def unit(self, definition) -> str:
        base = "rad" if self.is_angle(definition) else "m"
        return _SUFFIX[base][self.order]

    def is_angle(self, definition) -> bool:
        return definition.unknowns.get(self.of) == "angle"

    def transfer(self, kin):
        """(q, q', q''): the coordinate and its first two derivatives with respect to phi1 at the
        kinematics' crank angles (what the native FMU tabulates)."""
        if "." in self.of:
            point, axis = self.of.split(".")
            x, y, dx, dy, ddx, ddy = kin.point(point)
            return (x, dx, ddx) if axis == "x" else (y, dy, ddy)
        return kin.q[self.of], kin.dq[self.of], kin.ddq[self.of]

    def evaluate(self, kin, omega1, epsilon1=0.0):
        """The quantity at the kinematics' crank angles with crank speed omega1 (rad/s) and
        acceleration epsilon1 (rad/s2), scalars or arrays of the same length."""
        q, dq, ddq = self.transfer(kin)
        if self.order == 0:
            return q
        if self.order == 1:
            return dq * omega1
        return ddq * omega1 * omega1 + dq * epsilon1


def parse_quantities(items, definition, where: str) -> list[Quantity]:
    out = []
    for item in items:
        try:
            quantity = Quantity(str(item["name"]), str(item["of"]), int(item.get("order", 0)),
                                str(item.get("description", "")))
        except KeyError as exc:
            raise DefinitionError(f"{where}: each [[outputs]] entry needs {exc.args[0]!r}") from None
        if "." in quantity.of:
            point, _, axis = quantity.of.partition(".")
            if point not in definition.points or axis not in ("x", "y"):
                raise DefinitionError(f"{where}: output {quantity.name!r}: of = {quantity.of!r} must be "
                                      f"POINT.x or POINT.y with POINT one of {', '.join(definition.points)}")
        elif quantity.of not in definition.unknowns:
            raise DefinitionError(f"{where}: output {quantity.name!r}: {quantity.of!r} is neither a point "
                                  f"coordinate nor an unknown ({', '.join(definition.unknowns)})")
        if quantity.order not in (0, 1, 2):
            raise DefinitionError(f"{where}: output {quantity.name!r}: order must be 0, 1 or 2")
        out.append(quantity)
    names = [q.name for q in out]
    if len(set(names)) != len(names):
        raise DefinitionError(f"{where}: [[outputs]] names must be unique, got {names}")
    return out


def evaluate_all(quantities, kin, omega1, epsilon1=0.0) -> dict[str, np.ndarray]:
    return {q.name: q.evaluate(kin, omega1, epsilon1) for q in quantities}
