"""Each load kind of a scenario file in the C model's program (the compiler's part that knows the
loads): its torque on the crank (dynamics/loads.py, user_loads.py restated as register
arithmetic), its switched columns and their values, the searches for its switch angles, and the
forces and couples it applies link by link (what the joint reactions' Newton-Euler solve needs:
``AppliedLoad``), term by term of the reaction table (dynamics.reaction_table.REACTION_TERMS).

A load is a dict of closures, each run in the section it belongs to:

position   its torque when it depends on the position only (the table's Q row)
viscous    its torque per omega1 (linear in omega1: the viscous row)
columns    its switched columns (functions of phi1); values: their values for a direction
searches   (kind, quantity, aux quantity, registers...) run over the turn before the rows
found      {name: register} of what the searches find that the Python load holds (a rocker's
           extremes phi1d and phi1a, a slider's low and high): Scenario.build takes them from
           the C model instead of searching again
applied    {term: [(link, point or None, fx, fy, moment registers or None)]}, term "1" (the
           position-only loads), "omega1" (the viscous ones at omega1 = 1) or ("column", j)
"""

from __future__ import annotations

from ..expressions import Expression
from .program import BAND, REVERSALS, ROCKER, ZEROS, Unsupported
from .speed_laws import LAW, law_column_name, split_laws
from .speed_loads import SPEED_COLUMNS, kinked_speed_load, quadratic_parts, speed_class, speed_scale
from .user_loads import kinked


class _Registers:
    """A vector of registers with the arithmetic speed_loads.quadratic_parts does on arrays, emitted
    as the program's instructions."""

    def __init__(self, c, regs):
        self.c, self.regs = c, list(regs)

    def _apply(self, other, op, swap=False):
        if isinstance(other, _Registers):
            pairs = zip(self.regs, other.regs)
        else:
            literal = self.c.literal(float(other))
            pairs = ((r, literal) for r in self.regs)
        return _Registers(self.c, [self.c.emit(op, *((b, a) if swap else (a, b))) for a, b in pairs])

    def __add__(self, other):
        return self._apply(other, "add")

    def __sub__(self, other):
        return self._apply(other, "sub")

    def __mul__(self, other):
        return self._apply(other, "mul")

    def __truediv__(self, other):
        return self._apply(other, "div")

    __radd__ = __add__
    __rmul__ = __mul__

    def __rsub__(self, other):
        return self._apply(other, "sub", swap=True)


class LoadClauses:
    """What the scenario compiler (program_scenario._Compiler) knows of the loads."""

    def _value(self, spec, key, at):
        """A load's magnitude register, checked >= 0 at binding (scenario_loads.load_value)."""
        reg = self.c.expression(spec[key], self.env, f"{at} {key}")
        self.checks.append((reg, f"{at}: the load's {key} {spec[key]}"))
        return reg

    def _acting_link(self, spec):
        """The link a point load acts on: the file's, or the link whose mass centre the point is."""
        link = spec.get("link") or next((n for n, (centre, _, _) in self.links.items() if centre == spec["point"]),
                                        None)
        if link not in self.links:
            raise Unsupported(f"no link for the load on {spec['point']}")
        return link

    def _loads_setup(self) -> list[dict]:
        out = []
        for i, spec in enumerate(self.scenario.data.get("loads", [])):
            kind, at, start = spec.get("kind"), f"load {i + 1}", len(out)
            if kind == "weights":
                out.append(self._weights())
            elif kind == "dead_point_moment":
                out.append(self._dead_point_moment(spec, at))
            elif kind == "viscous_force":
                axis = {"x": 0, "y": 1}[spec["axis"]]
                coefficient = self._value(spec, "coefficient", at)
                out.append(self._viscous(spec["point"], axis, coefficient, self._acting_link(spec)))
            elif kind == "slider_force":
                out.append(self._slider_force(spec, {"x": 0, "y": 1}[spec["axis"]], at))
            elif kind in ("force", "couple"):
                out += self._user_force(spec, kind, at)
            elif kind == "spring_damper":
                out += self._spring_damper(spec, at)
            else:
                raise Unsupported(f"{at}: load kind {kind!r}")
            self.found += [(i, name, reg) for load in out[start:] for name, reg in load.get("found", {}).items()]
        return out

    def _weights(self):
        c, g = self.c, self.env["g"]
        c.used.add(g)

        def weight(mass):
            return c.emit("neg", c.mul(mass, g))
        return {"position": lambda: c.add(*(c.mul(weight(mass), self.point(centre)[3])
                                            for centre, mass, _ in self.links.values())),
                "applied": {"1": lambda: [(link, centre, None, weight(mass), None)
                                          for link, (centre, mass, _) in self.links.items()]}}

    def _viscous(self, point, axis, coefficient, link):
        c = self.c

        def force():                        # -c v at omega1 = 1
            return c.emit("neg", c.mul(coefficient, self.point(point)[2 + axis]))

        def record():
            f = force()
            return [(link, point, f if axis == 0 else None, f if axis == 1 else None, None)]
        return {"viscous": lambda: c.mul(force(), self.point(point)[2 + axis]), "applied": {"omega1": record}}

    def _dead_point_moment(self, spec, at):
        c = self.c
        amplitude = c.expression(spec["amplitude"], self.env, f"{at} amplitude")
        rise, fall = c.register(), c.register()
        link = spec["link"]
        rate = lambda: self.link_angle(link)[1]     # noqa: E731

        def moment():                       # loads.DeadPointMoment.moment
            half = c.literal(0.5)
            s1 = c.emit("sin", c.mul(half, c.emit("sub", self.phi1, rise)))
            s2 = c.emit("sin", c.mul(half, c.emit("sub", self.phi1, fall)))
            return c.mul(amplitude, s1, s2)
        return {"position": lambda: c.mul(moment(), rate()), "searches": [(ROCKER, rate, None, rise, fall, -1, -1)],
                "found": {"phi1d": rise, "phi1a": fall},
                "applied": {"1": lambda: [(link, None, None, None, moment())]}}

    def _slider_force(self, spec, axis, at):
        c = self.c
        forward, backward = self._value(spec, "forward", at), self._value(spec, "backward", at)
        band = [float(v) for v in spec.get("band", [0.0, 1.0])]
        low, high = c.register(), c.register()
        lo, hi = c.literal(band[0]), c.literal(band[1])
        point, link = spec["point"], self._acting_link(spec)
        position = lambda: self.point(point)[axis]        # noqa: E731
        rate = lambda: self.point(point)[2 + axis]        # noqa: E731
        searches = [(REVERSALS, rate, position, low, high, -1, -1)]
        if band != [0.0, 1.0]:
            searches.append((BAND, position, None, low, high, lo, hi))

        def values():
            # loads.SliderForce.force with omega1 = +-1: on the extreme itself the stroke entered decides
            r, curvature = self.point(point)[2 + axis], self.point(point)[4 + axis]
            at_extreme = c.emit("not_above", c.emit("abs", r), c.mul(c.literal(1e-12), c.emit("abs", curvature)))
            velocity = c.emit("if_positive", at_extreme, c.mul(curvature, c.emit("abs", self.omega1)),
                              c.mul(r, self.omega1))
            force = c.emit("if_positive", velocity, c.emit("neg", forward),
                           c.emit("if_negative", velocity, backward, self.zero))
            if band != [0.0, 1.0]:
                x = self.point(point)[axis]
                stroke = c.emit("sub", high, low)
                done = c.emit("div", c.emit("if_positive", velocity, c.emit("sub", x, low), c.emit("sub", high, x)),
                              stroke)
                inside = c.mul(c.emit("not_above", lo, done), c.emit("not_above", done, hi))
                force = c.emit("if_positive", inside, force, self.zero)
            return [force]
        unit = (self.one, None) if axis == 0 else (None, self.one)
        return {"columns": lambda: [rate()], "values": values, "searches": searches,
                "found": {"low": low, "high": high}, "column_names": (f"{point}.{'xy'[axis]}",),
                "applied": {("column", 0): lambda: [(link, point, *unit, None)]}}

    def _user_components(self, expressions, at, speeds=None):
        """The registers of a user load's fx, fy, moment; ``speeds``: None (a load of the position),
        "rest" (its speeds at 0) or "per_omega1" (its speeds at omega1 = 1: each a transfer function)."""
        names = self.position_names()
        if speeds is not None:
            names.update(self.speed_names(at_rest=speeds == "rest"))
        return {k: self.c.expression(expressions[k], names, f"{at} {k}") for k in ("fx", "fy", "moment")
                if k in expressions}

    def speed_names(self, at_rest: bool):
        """user_loads.speed_names as registers: 0 at rest, else the transfer functions (omega1 = 1)."""
        names = {"omega1": self.zero if at_rest else self.one}
        for u in self.unknowns:
            names[f"{u}_dot"] = self.zero if at_rest else self.q(u)[1]
        for p in self.points:
            x = self.point(p)
            names[f"{p}_vx"], names[f"{p}_vy"] = (self.zero, self.zero) if at_rest else (x[2], x[3])
        return names

    def _user_torque(self, link, point, regs):
        c, parts = self.c, []
        if "moment" in regs:
            parts.append(c.mul(regs["moment"], self.link_angle(link)[1]))
        if point is not None:
            x = self.point(point)
            parts += [c.mul(regs[k], x[2 + i]) for i, k in enumerate(("fx", "fy")) if k in regs]
        return c.add(*parts)

    def _user_force(self, spec, kind, at) -> list[dict]:
        """A force or couple: its terms of general laws of the speed (speed_laws.split_laws) each a
        column, the rest as one load (_user_force_rest)."""
        keys = [k for k in ("fx", "fy", "moment") if k in spec]
        if spec.get("direction_of") is not None:
            return [self._user_force_rest(spec, kind, at)]
        expressions = {k: Expression(str(spec[k]), f"{at} {k}") for k in keys}
        polynomial, laws = split_laws(expressions, set(self.speed_names(at_rest=True)), set(self.env), at)
        if not laws:
            return [self._user_force_rest(spec, kind, at)]
        link, point = spec["link"], spec.get("point") if kind == "force" else None
        out = [self._speed_law(link, point, law, coefficients, at) for law, coefficients in laws]
        if polynomial:
            rest = {k: v for k, v in spec.items() if k not in keys} | {k: e.source for k, e in polynomial.items()}
            out.insert(0, self._user_force_rest(rest, kind, at))
        return out

    def _speed_law(self, link, point, law, coefficients, at) -> dict:
        """speed_laws.SpeedLawLoad: its coefficients' torque a column of power LAW, its value 1 in
        either direction, its law g(omega1) in the LAWS section (read at each step)."""
        c = self.c
        sources = {k: e.source for k, e in coefficients.items()}

        def record():
            regs = self._user_components(sources, at)
            return [(link, point, regs.get("fx"), regs.get("fy"), regs.get("moment"))]
        return {"columns": lambda: [self._user_torque(link, point, self._user_components(sources, at))],
                "values": lambda: [self.one], "powers": (LAW,),
                "laws": lambda: [c.expression(law.source, {**self.env, "omega1": self.law_speed}, law.where)],
                "law_sources": (law.source,), "column_names": (law_column_name(link, law.source),),
                "applied": {("column", 0): record}}

    def _user_force_rest(self, spec, kind, at) -> dict:
        c = self.c
        link, point = spec["link"], spec.get("point") if kind == "force" else None

        def record(expressions):
            regs = self._user_components(expressions, at)
            return [(link, point, regs.get("fx"), regs.get("fy"), regs.get("moment"))]
        direction = spec.get("direction_of")
        speeds = set(self.speed_names(at_rest=True))
        reads_speed = direction is None and any(Expression(str(spec[k]), at).names & speeds
                                                for k in ("fx", "fy", "moment") if k in spec)
        if reads_speed:
            expressions = {k: Expression(str(spec[k]), f"{at} {k}") for k in ("fx", "fy", "moment") if k in spec}
            signed = speed_class(expressions, speeds, at)
            with_kinks = kinked_speed_load(link, point, expressions, None, speeds, self.scenario.values, at)
            if with_kinks is not None:
                return self._kinked_speed_force(link, point, with_kinks, at)
            if signed is not None:
                return self._speed_polynomial(spec, link, point, signed, at)
        if reads_speed:
            # user_loads.SpeedLoad, affine in omega1: its value at rest with the position's loads, the
            # rest per omega1 as the viscous row (the difference of the two: the load at omega1 = 1
            # less the load at rest)
            def part(speeds):
                return self._user_components(spec, at, speeds)

            def per_omega(rest, unit):
                return {k: c.emit("sub", unit[k], rest[k]) for k in rest}

            def parts_record(which):
                rest = part("rest")
                regs = rest if which == "rest" else per_omega(rest, part("per_omega1"))
                return [(link, point, regs.get("fx"), regs.get("fy"), regs.get("moment"))]
            return {"position": lambda: self._user_torque(link, point, part("rest")),
                    "viscous": lambda: self._user_torque(link, point, per_omega(part("rest"), part("per_omega1"))),
                    "applied": {"1": lambda: parts_record("rest"), "omega1": lambda: parts_record("per_omega1")}}
        kinks = None if direction is not None else kinked(
            {k: Expression(str(spec[k]), f"{at} {k}") for k in ("fx", "fy", "moment") if k in spec}, at)
        if kinks:
            return self._kinked_force(link, point, kinks, at)
        if direction is None:
            return {"position": lambda: self._user_torque(link, point, self._user_components(spec, at)),
                    "applied": {"1": lambda: record(spec)}}

        def rate():
            if "." in direction:
                p, _, axis = direction.partition(".")
                return self.point(p)[2 + "xy".index(axis)]
            return self.q(direction)[1]

        def values():
            rising = c.mul(rate(), self.omega1)
            return [c.emit("if_positive", rising, self.one, self.zero),
                    c.emit("if_negative", rising, self.one, self.zero)]
        sides = (spec["increasing"], spec["decreasing"])
        return {"columns": lambda: [self._user_torque(link, point, self._user_components(side, at)) for side in sides],
                "values": values, "searches": [(REVERSALS, rate, None, -1, -1, -1, -1)],
                "column_names": (f"{link} {direction} rising", f"{link} {direction} falling"),
                "applied": {("column", j): (lambda side=side: record(side)) for j, side in enumerate(sides)}}

    def speed_names_at(self, omega1: float):
        """user_loads.speed_names as registers at the crank speed ``omega1`` (rad/s): each speed is
        omega1 times its transfer function."""
        c, w = self.c, self.c.literal(omega1)
        names = {"omega1": w}
        for u in self.unknowns:
            names[f"{u}_dot"] = c.mul(self.q(u)[1], w)
        for p in self.points:
            x = self.point(p)
            names[f"{p}_vx"], names[f"{p}_vy"] = c.mul(x[2], w), c.mul(x[3], w)
        return names

    def _speed_polynomial(self, spec, link, point, signed, at):
        """speed_loads.PolynomialSpeedLoad: its parts at rest and per omega1 with the position's loads
        and the dampers, its omega1^2 part (and by direction, its parts of each power) as columns
        whose values the kernel multiplies by omega1's powers; the parts fitted at six speeds."""
        c = self.c
        scale = speed_scale(self.scenario.values)
        keys = [k for k in ("fx", "fy", "moment") if k in spec]

        def parts():
            def at_speed(w):                  # a vector of registers: one per key
                names = {**self.position_names(), **self.speed_names_at(w)}
                return _Registers(c, [c.expression(spec[k], names, f"{at} {k}") for k in keys])
            sym, anti = quadratic_parts(at_speed, scale)
            as_dict = lambda v: dict(zip(keys, v.regs))          # noqa: E731
            return [as_dict(v) for v in sym], [as_dict(v) for v in anti]

        def torque(part, index):
            return lambda: self._user_torque(link, point, parts()[part][index])

        def record(part, index):
            return lambda: [(link, point, *(parts()[part][index].get(k) for k in ("fx", "fy", "moment")))]
        chosen = [(0, 2)] + ([(1, 0), (1, 1), (1, 2)] if signed else [])
        n = len(chosen)

        def values():
            side = c.emit("if_positive", self.omega1, self.one, c.emit("neg", self.one))
            return [self.one] + [side] * (n - 1)
        return {"position": torque(0, 0), "viscous": torque(0, 1),
                "columns": lambda: [torque(part, index)() for part, index in chosen],
                "values": values, "powers": tuple(power for _, power in SPEED_COLUMNS[:n]),
                "column_names": tuple(f"{link} {name}" for name, _ in SPEED_COLUMNS[:n]),
                "applied": {"1": record(0, 0), "omega1": record(0, 1),
                            **{("column", j): record(part, index) for j, (part, index) in enumerate(chosen)}}}

    def _kinked_speed_force(self, link, point, load, at):
        """speed_loads.KinkedSpeedLoad: per pattern of the kinks' sides, its branch's parts per power
        of omega1 (fitted at six speeds as _speed_polynomial's) as columns, each valued by the
        pattern's indicator and multiplied by omega1's power; the arguments' zeros the switch angles."""
        c = self.c
        scale, n_powers = load.scale, load.degree + 1
        kinks = self._kinked_force(link, point, (load.arguments, load.branches, load.calls), at)

        def parts(branch):                    # [power] -> {key: register}
            keys = list(branch)

            def at_speed(w):
                names = {**self.position_names(), **self.speed_names_at(w)}
                return _Registers(c, [c.expression(branch[k].source, names, branch[k].where) for k in keys])
            sym, _ = quadratic_parts(at_speed, scale)
            return [dict(zip(keys, v.regs)) for v in sym[:n_powers]]

        def record(pattern, power):
            return lambda: [(link, point, *(parts(load.branches[pattern])[power].get(k) for k in ("fx", "fy", "moment")))]
        return {"columns": lambda: [self._user_torque(link, point, part) for b in load.branches for part in parts(b)],
                "values": lambda: [v for v in kinks["values"]() for _ in range(n_powers)],
                "powers": load.column_powers, "searches": kinks["searches"], "column_names": load.column_names,
                "applied": {("column", j): record(*divmod(j, n_powers)) for j in range(len(load.column_names))}}

    def _kinked_force(self, link, point, kinks, at):
        """user_loads.KinkedLoad: a column per pattern of its kinks' sides (the expressions on that
        pattern's branches), the pattern of the arguments' signs 1 and the others 0 on each
        interval, the arguments' zeros the switch angles."""
        c = self.c
        arguments, branches, _ = kinks
        names = self.position_names()

        def argument(a):
            return c.expression(a.source, names, a.where)

        def branch(expressions):
            return {k: c.expression(e.source, names, e.where) for k, e in expressions.items()}

        def values():
            signs = [c.emit("if_positive", argument(a), self.one, self.zero) for a in arguments]
            out = []
            for pattern in range(len(branches)):
                factors = [s if (pattern >> i) & 1 else c.emit("sub", self.one, s) for i, s in enumerate(signs)]
                out.append(c.mul(*factors) if len(factors) > 1 else factors[0])
            return out
        n = len(arguments)
        return {"columns": lambda: [self._user_torque(link, point, branch(b)) for b in branches],
                "values": values,
                "searches": [(ZEROS, (lambda a=a: argument(a)), None, -1, -1, -1, -1) for a in arguments],
                "column_names": tuple(f"{link} kink pattern {j:0{n}b}" for j in range(len(branches))),
                "applied": {("column", j): (lambda b=b: [(link, point, *(branch(b).get(k) for k in ("fx", "fy", "moment")))])
                            for j, b in enumerate(branches)}}

    def _spring_damper(self, spec, at):
        c = self.c
        k = self._value({**spec, "stiffness": spec.get("stiffness", "0")}, "stiffness", at)
        damping = self._value({**spec, "damping": spec.get("damping", "0")}, "damping", at)
        d0 = self._value({**spec, "free_length": spec.get("free_length", "0")}, "free_length", at)
        link_a, link_b = spec["links"]

        def geometry():                       # user_loads.Spring.geometry: d, the unit vector, dd/dphi1
            xa, ya, dxa, dya = self.point(spec["a"])[:4]
            xb, yb, dxb, dyb = self.point(spec["b"])[:4]
            ex, ey = c.emit("sub", xb, xa), c.emit("sub", yb, ya)
            d = c.emit("hypot", ex, ey)
            ux, uy = c.emit("div", ex, d), c.emit("div", ey, d)
            dd = c.add(c.mul(ux, c.emit("sub", dxb, dxa)), c.mul(uy, c.emit("sub", dyb, dya)))
            return d, ux, uy, dd

        def spring_tension():
            d, ux, uy, dd = geometry()
            return c.mul(k, c.emit("sub", d, d0)), ux, uy, dd

        def damper_tension():                 # at omega1 = 1
            _, ux, uy, dd = geometry()
            return c.mul(damping, dd), ux, uy, dd

        def records(tension):
            t, ux, uy, _ = tension()
            fx, fy = c.mul(t, ux), c.mul(t, uy)
            return [(link_a, spec["a"], fx, fy, None), (link_b, spec["b"], c.emit("neg", fx), c.emit("neg", fy), None)]

        def torque(tension):
            t, _, _, dd = tension()
            return c.emit("neg", c.mul(t, dd))
        return [{"position": lambda: torque(spring_tension), "applied": {"1": lambda: records(spring_tension)}},
                {"viscous": lambda: torque(damper_tension), "applied": {"omega1": lambda: records(damper_tension)}}]
