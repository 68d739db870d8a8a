"""One ``[[loads]]`` entry of kind force, couple or spring_damper, read into its load objects.

Apart from user_loads.py (the loads of the position and the affine loads of the speed) and
speed_loads.py (the loads of degree 2 in the speeds), which both build on user_loads' classes:
reading an entry chooses between them, so it sits above both and neither imports the other's
caller.
"""

from __future__ import annotations

import numpy as np

from ..errors import DefinitionError
from ..expressions import Expression
from ..mechanisms import Mechanism
from .speed_laws import SpeedLawLoad, split_laws
from .speed_loads import speed_load
from .user_loads import Damper, ExpressionLoad, KinkedLoad, Spring, fixed_names, kinked, known_names, speed_names


def parse_user_load(spec, mechanism: Mechanism, links: set[str], values: dict, where: str) -> list:
    """The load objects of one ``[[loads]]`` entry of kind force, couple or spring_damper."""
    kind = spec.get("kind")
    known = known_names(mechanism)

    speeds = speed_names(mechanism)

    def expression(text, key, may_read_speeds=False):
        expr = Expression(str(text), f"{where}: {kind} {key}")
        strange = expr.names - known - (speeds if may_read_speeds else set())
        if strange:
            if strange & speeds:
                raise DefinitionError(
                    f"{where}: {kind} {key} = {text!r} reads the speed(s) {', '.join(sorted(strange & speeds))}: only a "
                    "force or couple without direction_of may (a spring_damper has its own damping; a "
                    "direction-dependent load depends on the speed through its direction only)")
            raise DefinitionError(f"{where}: {kind} {key} = {text!r} uses unknown name(s) {', '.join(sorted(strange))} "
                                  "(known: parameters, phi1, the unknowns, P_x and P_y of each point; a force or couple "
                                  "also omega1, P_vx, P_vy and U_dot of each unknown U)")
        return expr

    def link_of(key="link"):
        link = spec.get(key)
        if link not in links:
            raise DefinitionError(f"{where}: {kind} needs {key} = one of the links ({', '.join(sorted(links))}), got {link!r}")
        return link

    def point_of(key="point"):
        point = spec.get(key)
        if point not in mechanism.point_names:
            raise DefinitionError(f"{where}: {kind} needs {key} = one of the points "
                                  f"({', '.join(mechanism.point_names)}), got {point!r}")
        return point

    if kind in ("force", "couple"):
        keys = ("fx", "fy") if kind == "force" else ("moment",)
        link = link_of()
        point = point_of() if kind == "force" else None
        direction = spec.get("direction_of")
        if direction is None:
            if not any(k in spec for k in keys):
                raise DefinitionError(f"{where}: {kind} needs {' or '.join(keys)} (expressions)")
            expressions = {k: expression(spec[k], k, may_read_speeds=True) for k in keys if k in spec}
            polynomial, laws = split_laws(expressions, speeds, fixed_names(mechanism), f"{where}: {kind}")
            out = [SpeedLawLoad(link, point, coefficients, mechanism=mechanism, law=law) for law, coefficients in laws]
            if not polynomial:
                return out
            if any(e.names & speeds for e in polynomial.values()):
                return [speed_load(link, point, polynomial, mechanism, speeds, values, f"{where}: {kind}")] + out
            kinks = kinked(polynomial, f"{where}: {kind}")
            if kinks:
                return [KinkedLoad(link, point, polynomial, mechanism=mechanism, arguments=kinks[0],
                                   branches=kinks[1], calls=kinks[2])] + out
            return [ExpressionLoad(link, point, polynomial, mechanism=mechanism)] + out
        if "." in str(direction):
            p, _, axis = str(direction).partition(".")
            if p not in mechanism.point_names or axis not in ("x", "y"):
                raise DefinitionError(f"{where}: direction_of = {direction!r} must be POINT.x, POINT.y or an unknown")
        elif direction not in mechanism.unknown_names:
            raise DefinitionError(f"{where}: direction_of = {direction!r} must be POINT.x, POINT.y or an unknown "
                                  f"({', '.join(mechanism.unknown_names)})")
        sides = {}
        for side in ("increasing", "decreasing"):
            table = spec.get(side)
            if not isinstance(table, dict) or not any(k in table for k in keys):
                raise DefinitionError(f"{where}: {kind} with direction_of needs {side} = {{ {keys[0]} = \"...\" }}")
            sides[side] = {k: expression(table[k], f"{side}.{k}") for k in keys if k in table}
        return [ExpressionLoad(link, point, sides["increasing"], sides["decreasing"], str(direction), mechanism)]
    if kind == "spring_damper":
        pair = spec.get("links")
        if not isinstance(pair, list) or len(pair) != 2 or any(l not in links | {"ground"} for l in pair):
            raise DefinitionError(f"{where}: spring_damper needs links = [link of point a, link of point b]")
        a, b = point_of("a"), point_of("b")
        k = float(expression(spec.get("stiffness", "0"), "stiffness").evaluate(values))
        c = float(expression(spec.get("damping", "0"), "damping").evaluate(values))
        d0 = float(expression(spec.get("free_length", "0"), "free_length").evaluate(values))
        for name, v in (("stiffness", k), ("damping", c), ("free_length", d0)):
            if not (np.isfinite(v) and v >= 0):
                raise DefinitionError(f"{where}: spring_damper {name} = {v:g} must be finite and >= 0")
        out = [Spring(a, b, pair[0], pair[1], k, d0)] if k else []
        return out + ([Damper(a, b, pair[0], pair[1], c, 0.0)] if c else [])
    raise DefinitionError(f"{where}: not a user load kind: {kind!r}")
