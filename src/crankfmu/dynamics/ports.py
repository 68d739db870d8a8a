"""Ports: where another model couples to the mechanism (a scenario's ``[[ports]]``).

A ``force`` port is a force F (N) on ``link`` at ``point`` along the constant direction ``axis``
(rad from x, counter-clockwise): the master sets F, and reads the point's coordinate along the
axis, its velocity and acceleration, s, v and a (m, m/s, m/s2). A ``couple`` port is a couple M
(N.m, counter-clockwise) on ``link``: the master reads the link's angle, angular velocity and
acceleration. Either way the port is a coordinate s(phi1) of the mechanism and its input a
generalised force on that coordinate, so its power is input x ds/dt = input x s'(phi1) omega1:
the crank feels the torque input x s'(phi1) (seed 000 eq. 13 with one load), and the work is
accounted in W_ext beside tau_ext's. Its outputs are those of any mechanism quantity:
s, s' omega1 and s'' omega1^2 + s' epsilon1 (mechanisms.quantities).

A ``rope`` port is a rope (a wireline, the polished rod under a horsehead) that leaves an arc
centred at ``point`` on ``link`` along the constant direction ``axis``: F (N) is its pull along
``axis``. Its signed moment arm ``lever`` (m, an expression of the parameters) is what makes it
a rope and not a force at a point: the rope's travel along the axis is the centre's plus lever x
the link's rotation, s = (point . axis) + lever x angle, exact for any swing (a force at a point
of the arc would see the arc's sine instead); on the link it is the force F along the axis
through the centre plus the couple lever x F.

Names: a port ``ram`` of kind force gives the input ``ram_F`` and the outputs ``ram_s``,
``ram_v``, ``ram_a``; a port ``arm`` of kind couple gives ``arm_M``, ``arm_angle``,
``arm_omega``, ``arm_epsilon``; a rope port ``rod`` gives ``rod_F``, ``rod_s``, ``rod_v``, ``rod_a``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..errors import DefinitionError
from ..expressions import Expression
from ..mechanisms.quantities import Quantity
from .loads import AppliedLoad

#: per kind: the input's suffix and unit, and the outputs' suffixes
KINDS = {
    "force": ("F", "N", ("s", "v", "a")),
    "couple": ("M", "N.m", ("angle", "omega", "epsilon")),
    "rope": ("F", "N", ("s", "v", "a")),
}
_KEYS = {"name", "kind", "link", "point", "axis", "lever", "description"}
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class Port:
    name: str
    kind: str                      # "force", "couple" or "rope"
    link: str
    point: str | None = None       # a force's point of application; a rope's arc centre
    axis: float = 0.0              # rad: a force's (a rope's) constant direction
    description: str = ""
    lever: float = 0.0             # m: a rope's signed moment arm about its arc centre

    @property
    def input_name(self) -> str:
        return f"{self.name}_{KINDS[self.kind][0]}"

    @property
    def input_unit(self) -> str:
        return KINDS[self.kind][1]

    @property
    def input_description(self) -> str:
        if self.kind == "force":
            return (f"port {self.name}: force on {self.link} at {self.point} along {math.degrees(self.axis):g} deg "
                    f"from x (N){': ' + self.description if self.description else ''}")
        if self.kind == "rope":
            return (f"port {self.name}: pull of a rope along {math.degrees(self.axis):g} deg from x, leaving an arc "
                    f"of {abs(self.lever):g} m about {self.point} on {self.link} (N)"
                    f"{': ' + self.description if self.description else ''}")
        return (f"port {self.name}: couple on {self.link}, counter-clockwise (N.m)"
                f"{': ' + self.description if self.description else ''}")

    def transfer(self, kin):
        """(s, s', s''): the port's coordinate and its derivatives in phi1 (m or rad, per rad)."""
        if self.kind == "couple":
            return kin.link_angle(self.link)
        x, y, dx, dy, ddx, ddy = kin.point(self.point)
        c, s = math.cos(self.axis), math.sin(self.axis)
        along = (x * c + y * s, dx * c + dy * s, ddx * c + ddy * s)
        if self.kind == "force":
            return along
        return tuple(a + self.lever * b for a, b in zip(along, kin.link_angle(self.link)))

    def torque(self, kin, value):
        """The torque on the crank (N.m) of the input ``value`` (N or N.m)."""
        return value * self.transfer(kin)[1]

    def applied(self, kin, value) -> list[AppliedLoad]:
        """The input as a load on its link (what the joint reactions see)."""
        if self.kind == "couple":
            return [AppliedLoad(self.link, None, moment=value)]
        force = AppliedLoad(self.link, self.point, fx=value * math.cos(self.axis), fy=value * math.sin(self.axis))
        return [force] if self.kind == "force" else [force, AppliedLoad(self.link, None, moment=self.lever * value)]

    @property
    def quantities(self) -> list["PortQuantity"]:
        """The port's three outputs, as mechanism quantities (position, velocity, acceleration)."""
        return [PortQuantity(f"{self.name}_{suffix}", f"port {self.name}", order,
                             f"port {self.name}: {what}", self)
                for order, (suffix, what) in enumerate(zip(KINDS[self.kind][2], self._what()))]

    def _what(self):
        if self.kind == "couple":
            return (f"angle of {self.link} (rad)", f"angular velocity of {self.link} (rad/s)",
                    f"angular acceleration of {self.link} (rad/s2)")
        along = (f"{self.point} on {self.link} along {math.degrees(self.axis):g} deg" if self.kind == "force" else
                 f"the rope of {self.link} along {math.degrees(self.axis):g} deg")
        return (f"position of {along} (m)", f"velocity of {along} (m/s)", f"acceleration of {along} (m/s2)")


@dataclass(frozen=True)
class PortQuantity(Quantity):
    """One output of a port: a mechanism quantity whose coordinate is the port's (its unit is
    Quantity.unit's, from whether the coordinate is an angle)."""

    port: Port | None = None

    def is_angle(self, definition=None) -> bool:
        return self.port.kind == "couple"

    def transfer(self, kin):
        return self.port.transfer(kin)


def _constant(text, at: str, what: str, values: dict) -> tuple[float, str]:
    """(value, reason it is not finite) of an expression of the parameters ``values``."""
    try:
        return float(Expression(str(text), f"{at} {what}").evaluate(values)), ""
    except (DefinitionError, ArithmeticError, TypeError, ValueError) as exc:
        return math.nan, f": {exc}"


def parse_ports(items, definition, where: str, values: dict | None = None) -> list[Port]:
    """The ``[[ports]]`` entries of a scenario file, checked against the mechanism definition
    (a rope's lever is evaluated with the parameters ``values``)."""
    if not isinstance(items, list):
        raise DefinitionError(f"{where}: [[ports]] must be a list of tables")
    ports = []
    for i, item in enumerate(items):
        at = f"{where}: port {i + 1}"
        if not isinstance(item, dict):
            raise DefinitionError(f"{at}: must be a table (name, kind, link, ...)")
        unknown = set(item) - _KEYS
        if unknown:
            raise DefinitionError(f"{at}: unknown key(s) {', '.join(sorted(unknown))} (known: {', '.join(sorted(_KEYS))})")
        name = item.get("name")
        if not isinstance(name, str) or not _NAME.match(name):
            raise DefinitionError(f"{at}: name must be an identifier (letters, digits, _), got {name!r}")
        kind = item.get("kind")
        if kind not in KINDS:
            raise DefinitionError(f"{at} ({name}): kind must be 'force', 'couple' or 'rope', got {kind!r}")
        link = item.get("link")
        if link not in definition.links:
            raise DefinitionError(f"{at} ({name}): link must be one of the mechanism's links "
                                  f"({', '.join(definition.links)}), got {link!r}")
        point, axis, lever = None, 0.0, 0.0
        if kind in ("force", "rope"):
            point = item.get("point")
            if point not in definition.points:
                raise DefinitionError(f"{at} ({name}): a {kind} port needs point = one of the mechanism's points "
                                      f"({', '.join(definition.points)}), got {point!r}")
            if "axis" not in item:
                raise DefinitionError(f"{at} ({name}): a {kind} port needs axis = its direction in rad from x "
                                      "(a number or an expression such as \"pi/2\")")
            axis, reason = _constant(item["axis"], at, "axis", {})
            if not math.isfinite(axis):
                raise DefinitionError(f"{at} ({name}): axis = {str(item['axis'])!r} must be a finite angle in rad "
                                      f"(a number, or an expression of pi: a constant direction){reason}")
        elif "point" in item or "axis" in item:
            raise DefinitionError(f"{at} ({name}): a couple port acts on its link as a whole: no point or axis")
        if kind == "rope":
            if "lever" not in item:
                raise DefinitionError(f"{at} ({name}): a rope port needs lever = its signed moment arm about {point} "
                                      "(m, an expression of the parameters, such as \"-arm_A\")")
            lever, reason = _constant(item["lever"], at, "lever", dict(values or {}))
            if not math.isfinite(lever) or lever == 0.0:
                raise DefinitionError(f"{at} ({name}): lever = {str(item['lever'])!r} must be a non-zero finite length "
                                      f"in m (an expression of the parameters){reason}")
        elif "lever" in item:
            raise DefinitionError(f"{at} ({name}): only a rope port has a lever")
        ports.append(Port(name, kind, link, point, axis, str(item.get("description", "")), lever))
    names = [p.name for p in ports]
    if len(set(names)) != len(names):
        raise DefinitionError(f"{where}: [[ports]] names must be unique, got {names}")
    return ports

