"""A scenario compiled into the C model's program (dynamics/program.py): its mechanism file's
contours, points and links, its loads (program_loads.py), ports, [[outputs]] and joints, as
register arithmetic and tables, once per mechanism and load set (every parameter a register the
binding fills, so one program serves every design).
"""

from __future__ import annotations

import numpy as np

from .program import (CLOSED, FIRST_SEARCH, FRICTION_RATE, LAWS, OUTPUTS, REACTIONS, REVERSALS, ROCKER, ROWS, SETUP,
                      VALUES, Program, Unsupported, _Code, optimise)
from .program_loads import LoadClauses


class _Compiler(LoadClauses):
    """A scenario (its mechanism definition, loads, ports, [[outputs]] and joints) to a Program."""

    def __init__(self, scenario):
        self.scenario = scenario
        self.definition = d = scenario.mechanism_definition()
        self.parameters = tuple(sorted(scenario.parameters))
        self.c = _Code(len(self.parameters))
        self.env = {name: i for i, name in enumerate(self.parameters)}
        self.unknowns = list(d.unknowns)
        self.points = list(d.points)
        self.checks: list[tuple[int, str]] = []
        self.found: list[tuple[int, str, int]] = []

    # ---------------------------------------------------------------- registers of the kinematics
    def q(self, name):
        """(q, q', q'') registers of phi1 or an unknown."""
        if name == "phi1":
            return self.phi1, self.one, self.zero
        j = self.unknowns.index(name)
        base = self.kin + 3 * j
        return base, base + 1, base + 2

    def point(self, name):
        """(x, y, dx, dy, ddx, ddy) registers of a point."""
        base = self.kin + 3 * len(self.unknowns) + 6 * self.points.index(name)
        return tuple(range(base, base + 6))

    def link_angle(self, link):
        angle = self.definition.links[link].angle
        if angle == "phi1" or angle in self.unknowns:
            return self.q(angle)
        return self.link_constants[link], self.zero, self.zero

    def position_names(self):
        """Names a user load's expression may read: parameters, phi1, unknowns, P_x, P_y."""
        names = {**self.env, "phi1": self.phi1}
        for u in self.unknowns:
            names[u] = self.q(u)[0]
        for p in self.points:
            x, y = self.point(p)[:2]
            names[f"{p}_x"], names[f"{p}_y"] = x, y
        return names

    # ---------------------------------------------------------------- the program
    def compile(self, optimised: bool = True) -> Program:
        d, c = self.definition, self.c
        c.begin(SETUP)
        self.one, self.zero = c.literal(1.0), c.literal(0.0)
        for name, value in d.constants.items():     # an expression's at binding: it follows the parameters
            self.env[name] = c.literal(value) if isinstance(value, float) else \
                c.expression(value.source, self.env, value.where)
        chains = [terms for _, terms in d.contours] + [d.points[p][0] for p in self.points]
        variables = d.variables
        terms, offsets = [], {}
        for chain, chain_terms in enumerate(chains):
            for t in chain_terms:
                coef = c.expression(t.coefficient, self.env, f"{d.name}: coefficient")
                if t.sign != 1.0:
                    coef = c.emit("mul", c.literal(t.sign), coef)
                if t.offset not in offsets:       # one register per offset: the terms' distinct angles
                    offsets[t.offset] = c.expression(t.offset, self.env, f"{d.name}: angle offset")
                offset = offsets[t.offset]
                terms.append((chain, coef, variables.index(t.length) if t.length else -1,
                              variables.index(t.angle) if t.angle else -1, offset))
        constants = [(-1, -1)] * len(d.contours)
        for p in self.points:
            x, y = d.points[p][1]
            constants.append((c.expression(x, self.env, "fixed point"), c.expression(y, self.env, "fixed point")))
        guess = -1
        if d.closed_form is None:
            g = d.guess
            values = [c.expression(g.get("phi1", "0"), self.env, "assembly guess phi1")]
            values += [c.expression(g[u], self.env, f"assembly guess {u}") for u in self.unknowns]
            guess = c.block(len(values))
            for i, v in enumerate(values):
                c.emit("copy", v, into=guess + i)
        self.link_constants = {}
        self.links = {}
        for name, ld in d.links.items():
            if ld.angle != "phi1" and ld.angle not in self.unknowns:
                self.link_constants[name] = c.expression(ld.angle, self.env, f"link {name} angle")
            mass = c.expression(ld.mass, self.env, f"mass of {name}")
            inertia = c.expression(ld.inertia, self.env, f"inertia of {name}")
            self.checks += [(mass, f"the mass of link {name}"), (inertia, f"the inertia of link {name}")]
            self.links[name] = (ld.centre, mass, inertia)
        # the per-angle registers: phi1, then (q, q', q'') per unknown, then 6 per point
        self.phi1 = c.register()
        self.kin = c.block(3 * len(self.unknowns) + 6 * len(self.points))
        self.kin_end = c.n                   # one past the block, just allocated
        self.omega1 = c.register()
        self.law_speed = c.register()         # the crank speed the LAWS section reads (at each step)
        loads = self._loads_setup()
        self.frictions = self._friction_setup()
        c.end()

        c.begin(CLOSED)
        if d.closed_form is not None:
            names = {**self.env, "phi1": self.phi1}
            for name, expr in d.closed_form:
                reg = c.expression(expr.source, names, f"closed form {name}")
                if name in self.unknowns:
                    reg = c.emit("copy", reg, into=self.q(name)[0])
                names[name] = reg
        c.end()

        c.begin(ROWS)
        rows, row_names = self._rows(loads)
        c.end()
        c.begin(VALUES)
        columns = [v for load in loads if load.get("values") for v in load["values"]()]
        c.end()
        c.begin(OUTPUTS)
        coordinates, coordinate_names = self._coordinates()
        c.end()
        c.begin(REACTIONS)
        reactions = self._reactions(loads) if d.joints else {}
        c.end()
        c.begin(LAWS)
        laws = [r for load in loads
                for r in (load["laws"]() if "laws" in load else [-1] * len(load.get("column_names", ())))]
        c.end()
        searches = []
        for i, (joint, _, _) in enumerate(self.frictions):
            section = FIRST_SEARCH + len(searches) * 2
            c.begin(section)
            c.emit("copy", self._friction_rate(joint))
            c.end()
            searches.append((FRICTION_RATE, section, -1, i, -1, -1, -1))
        for load in loads:
            for search in load.get("searches", ()):
                kind, quantity, aux, *regs = search
                section = FIRST_SEARCH + len(searches) * 2
                c.begin(section)
                c.emit("copy", quantity())
                c.end()
                c.begin(section + 1)
                if aux is not None:
                    c.emit("copy", aux())
                c.end()
                searches.append((kind, section, section + 1 if aux is not None else -1, *regs))
        distinct = sorted({t[3:5] for t in terms})
        # the registers the C model writes itself: per angle phi1, the kinematics and the crank's
        # direction; after binding what the rocker and reversal searches find
        runtime = set(range(self.phi1, self.kin_end)) | {self.omega1, self.law_speed}
        runtime |= {r for search in searches if search[0] in (ROCKER, REVERSALS) for r in search[3:5] if r >= 0}
        code, placed = optimise(c.code, c.sections, runtime, c.literals) if optimised else (c.code, c.sections)
        n_sections = max(placed) + 1
        sections = np.array([placed.get(i, (0, 0)) for i in range(n_sections)], dtype=np.int32)
        program = Program(
            parameters=self.parameters, n_registers=c.n,
            code=np.array(code, dtype=np.int32).reshape(-1, 5), literals=np.array(c.literals or [0.0]),
            sections=sections, n_q=len(variables), n_contours=len(d.contours), n_chains=len(chains),
            terms=np.array([t + (distinct.index(t[3:5]),) for t in terms], dtype=np.int32).reshape(-1, 6),
            angles=np.array(distinct, dtype=np.int32).reshape(-1, 2),
            chain_constants=np.array(constants, dtype=np.int32).reshape(-1, 2),
            angle_column=np.array([0] + [int(d.unknowns[u] == "angle") for u in self.unknowns], dtype=np.int32),
            closed_form=int(d.closed_form is not None), guess=guess, phi1=self.phi1, kinematics=self.kin,
            n_points=len(self.points), omega1=self.omega1,
            rows=np.array(rows, dtype=np.int32), columns=np.array(columns or [0], dtype=np.int32)[:len(columns)],
            searches=np.array(searches, dtype=np.int32).reshape(-1, 7),
            checks=np.array([r for r, _ in self.checks] or [0], dtype=np.int32)[:len(self.checks)],
            check_names=tuple(n for _, n in self.checks), row_names=tuple(row_names),
            n_ports=len(self.scenario.data.get("ports", [])),
            column_names=tuple(n for load in loads for n in load.get("column_names", ())),
            column_powers=np.array([p for load in loads
                                    for p in load.get("powers", (0,) * len(load.get("column_names", ())))],
                                   dtype=np.int32),
            law_speed=self.law_speed, laws=np.array(laws, dtype=np.int32),
            column_laws=tuple(s for load in loads
                              for s in load.get("law_sources", (None,) * len(load.get("column_names", ())))),
            table_parameters=tuple(sorted(c.used)), found=tuple(self.found),
            coordinates=np.array(coordinates, dtype=np.int32).reshape(-1, 4), coordinate_names=tuple(coordinate_names),
            cycle_turns=self.scenario.cycle_turns, **reactions,
            frictions=np.array([(self.definition.joints.index(joint), coefficient, rate)
                                for joint, coefficient, rate in self.frictions], dtype=np.int32).reshape(-1, 3),
        )
        return program

    # ---------------------------------------------------------------- the table's functions
    def _rows(self, loads):
        """The reduced table's functions in tabulated.ReducedTable's order."""
        c = self.c
        J, half = [], []
        for name, (centre, mass, inertia) in self.links.items():
            _, _, t, p, tt, pp = self.point(centre)
            _, q, qq = self.link_angle(name)
            J.append(c.add(c.mul(mass, c.add(c.mul(t, t), c.mul(p, p))), c.mul(inertia, q, q)))
            half.append(c.add(c.mul(mass, c.add(c.mul(t, tt), c.mul(p, pp))), c.mul(inertia, q, qq)))
        rows = [c.add(*J), c.add(*half),
                c.add(*(load["position"]() for load in loads if "position" in load)),
                c.add(*(load["viscous"]() for load in loads if "viscous" in load))]
        names = ["J_links", "half_dJ", "Q_position", "Q_viscous"]
        for load in loads:
            if "columns" in load:
                rows += load["columns"]()
                names += list(load["column_names"])
        for i, port in enumerate(self.scenario.data.get("ports", [])):
            rows.append(self._port_transfer(port, f"port {i + 1}")[1])
            names.append(f"port {port['name']}")
        return rows, names

    def _port_transfer(self, port, at):
        """(s, s', s'') registers of a port's coordinate (Port.transfer)."""
        c = self.c
        if port["kind"] == "couple":
            return self.link_angle(port["link"])
        x = self.point(port["point"])
        axis = c.expression(port["axis"], self.env, f"{at} axis")
        cos, sin = c.emit("cos", axis), c.emit("sin", axis)
        along = [c.add(c.mul(x[k], cos), c.mul(x[k + 1], sin)) for k in (0, 2, 4)]
        if port["kind"] == "force":
            return tuple(along)
        lever = c.expression(port["lever"], self.env, f"{at} lever")
        return tuple(c.add(a, c.mul(lever, b)) for a, b in zip(along, self.link_angle(port["link"])))

    # ---------------------------------------------------------------- outputs and reactions
    def _coordinates(self):
        """The [[outputs]] and ports' coordinates (tabulated.tabulate_quantities' order): their
        (q, q', q'') registers and whether each is an angle (its whole turns are counted)."""
        d, rows, names = self.definition, [], []
        for q in self.scenario.quantities:
            if q.of in names:
                continue
            if "." in q.of:
                point, _, axis = q.of.partition(".")
                x = self.point(point)
                regs = (x[0], x[2], x[4]) if axis == "x" else (x[1], x[3], x[5])
            else:
                regs = self.q(q.of)
            rows.append((*regs, int(q.is_angle(d))))
            names.append(q.of)
        for i, port in enumerate(self.scenario.data.get("ports", [])):
            rows.append((*self._port_transfer(port, f"port {i + 1}"), int(port["kind"] == "couple")))
            names.append(f"port {port['name']}")
        return rows, names

    def _reactions(self, loads) -> dict:
        """The Newton-Euler solve's tables (dynamics/reactions.py) and the loads each term of the
        reaction table applies (reaction_table.tabulate_reactions: "1" the position-only loads, epsilon1
        and omega1^2 the inertia, omega1 the viscous loads, then each switched column at value 1
        and each port's input at 1)."""
        from .reactions import reaction_outputs

        c, d = self.c, self.definition
        names = list(self.links)
        crank = [n for n, ld in d.links.items() if ld.angle == "phi1"]
        if len(crank) != 1 or 2 * len(d.joints) + 1 != 3 * len(names):
            raise Unsupported("the joints do not give a square Newton-Euler system")
        index = lambda link: -1 if link == "ground" else names.index(link)       # noqa: E731
        point = lambda p: -1 if p is None else self.points.index(p)              # noqa: E731
        links = [(point(centre), mass, inertia, *self.link_angle(n)[1:]) for n, (centre, mass, inertia)
                 in self.links.items()]
        joints = []
        for joint in d.joints:
            axis = -1
            if joint.kind == "prismatic":
                axis = self.q(joint.axis)[0] if joint.axis in self.unknowns or joint.axis == "phi1" else \
                    c.expression(joint.axis, self.env, f"joint {joint.name} axis")
            joints.append((int(joint.kind == "prismatic"), point(joint.point), index(joint.links[0]),
                           index(joint.links[1]), axis))
        terms = [("1",), ("epsilon1",), ("omega1^2",), ("omega1",)]
        terms += [("column", load, j) for load in loads if "columns" in load for j in range(len(load["column_names"]))]
        terms += [("port", port) for port in self.scenario.data.get("ports", [])]
        # each joint friction at value 1 (its unit term), and its relative rate per angle
        terms += [("friction", joint) for joint, _, _ in self.frictions]
        self.frictions = [(joint, coefficient, self._friction_rate(joint)) for joint, coefficient, _ in self.frictions]
        inertia = {"epsilon1": (1, 0), "omega1^2": (0, 1)}
        applied = []
        for t, term in enumerate(terms):
            records = []
            if term[0] in ("1", "omega1"):
                records = [r for load in loads for r in load.get("applied", {}).get(term[0], lambda: [])()]
            elif term[0] == "column":
                records = term[1]["applied"][("column", term[2])]()
            elif term[0] == "port":
                records = self._port_applied(term[1], f"port {term[1]['name']}")
            elif term[0] == "friction":
                records = self._friction_applied(term[1])
            for link, p, fx, fy, m in records:
                if link == "ground":        # a spring anchored on the frame: the frame carries that end
                    continue
                applied.append((t, index(link), point(p), *(-1 if r is None else r for r in (fx, fy, m))))
        return {"links": np.array(links, dtype=np.int32).reshape(-1, 5), "crank": names.index(crank[0]),
                "joints": np.array(joints, dtype=np.int32).reshape(-1, 5),
                "term_inertia": np.array([inertia.get(term[0], (0, 0)) for term in terms], dtype=np.int32),
                "applied": np.array(applied, dtype=np.int32).reshape(-1, 6),
                "reaction_names": tuple(name for name, _, _ in reaction_outputs(d))}

    # ---------------------------------------------------------------- joint friction
    def _friction_setup(self):
        """(joint, coefficient register, -1) of each joint with a friction entry, in the joints'
        order: c = mu r (a pin) or mu (a slide) at binding (dynamics.friction.JointFriction); a
        friction whose c is 0 is not active (crank_mechanism.h)."""
        c, d = self.c, self.definition
        entries = self.scenario.friction_entries(d)
        out = []
        for joint in d.joints:
            entry = entries.get(joint.name)
            if entry is None:
                continue
            at = f"friction of joint {joint.name}"
            mu = c.expression(entry["mu"], self.env, f"{at}: mu")
            # mu in [0, 1], as dynamics.friction.joint_frictions requires of it: a design outside is
            # refused by name when the FMU initialises, whatever range the parameter declares
            self.checks += [(mu, f"the {at}: mu"), (c.emit("sub", self.one, mu), f"the {at}: 1 - mu")]
            coefficient = mu
            if joint.kind == "revolute":
                radius = c.expression(entry["radius"], self.env, f"{at}: radius")
                self.checks.append((radius, f"the {at}: the pin's radius"))
                coefficient = c.mul(mu, radius)
            out.append((joint, coefficient, -1))
        if len(out) > 16:                   # crank_mechanism.h's MM_MAX_FRICTIONS
            raise Unsupported("more than 16 joints with friction")
        return out

    def _velocity(self, link, point):
        """(vx, vy) registers per crank speed (m/rad) of the material point of ``link`` at ``point``
        (None for the frame), as dynamics.friction.JointFrictions._velocity."""
        if link == "ground":
            return None
        c = self.c
        centre = self.point(self.links[link][0])
        at = self.point(point)
        q = self.link_angle(link)[1]
        return (c.emit("sub", centre[2], c.mul(q, c.emit("sub", at[1], centre[1]))),
                c.add(centre[3], c.mul(q, c.emit("sub", at[0], centre[0]))))

    def _friction_rate(self, joint) -> int:
        """The register of a joint friction's relative rate k (rad/rad or m/rad) at the current
        angle (dynamics.friction.JointFrictions._raw_rates), emitted in the open section."""
        c = self.c
        first, second = joint.links
        if joint.kind == "revolute":
            spin = lambda link: self.zero if link == "ground" else self.link_angle(link)[1]    # noqa: E731
            return c.emit("sub", spin(second), spin(first))
        axis = self._axis(joint)
        cos, sin = c.emit("cos", axis), c.emit("sin", axis)
        v2, v1 = self._velocity(second, joint.point), self._velocity(first, joint.point)
        dx = v2[0] if v1 is None else (c.emit("neg", v1[0]) if v2 is None else c.emit("sub", v2[0], v1[0]))
        dy = v2[1] if v1 is None else (c.emit("neg", v1[1]) if v2 is None else c.emit("sub", v2[1], v1[1]))
        return c.add(c.mul(dx, cos), c.mul(dy, sin))

    def _axis(self, joint) -> int:
        """The register of a slide's axis angle (rad; Mechanism.angle_of)."""
        if joint.axis in self.unknowns or joint.axis == "phi1":
            return self.q(joint.axis)[0]
        return self.c.expression(joint.axis, self.env, f"joint {joint.name} axis")

    def _friction_applied(self, joint):
        """A joint friction at value 1 as loads (JointFrictions.unit_loads): 1 N.m on the second
        link and -1 on the first for a pin, 1 N along the axis at the joint's point for a slide."""
        c = self.c
        first, second = joint.links
        if joint.kind == "revolute":
            return [(second, None, None, None, self.one), (first, None, None, None, c.literal(-1.0))]
        axis = self._axis(joint)
        cos, sin = c.emit("cos", axis), c.emit("sin", axis)
        return [(second, joint.point, cos, sin, None),
                (first, joint.point, c.emit("neg", cos), c.emit("neg", sin), None)]

    def _port_applied(self, port, at):
        """A port's input at 1 as a load on its link (Port.applied)."""
        c = self.c
        if port["kind"] == "couple":
            return [(port["link"], None, None, None, self.one)]
        axis = c.expression(port["axis"], self.env, f"{at} axis")
        force = (port["link"], port["point"], c.emit("cos", axis), c.emit("sin", axis), None)
        if port["kind"] == "force":
            return [force]
        return [force, (port["link"], None, None, None, c.expression(port["lever"], self.env, f"{at} lever"))]


_PROGRAMS: dict = {}


def compile_scenario(scenario, optimised: bool = True) -> Program | None:
    """The scenario's program (cached per mechanism and loads), or None where a part of it is not
    one the C model evaluates (the Python engine then tabulates it). ``optimised=False``: the
    instructions as the files' expressions state them (program.optimise's tests compare the two)."""
    d = scenario.mechanism_definition()
    key = (id(d), repr(scenario.data.get("loads")), repr(scenario.data.get("ports")), repr(scenario.data.get("friction")),
           repr(scenario.data.get("outputs")), tuple(sorted(scenario.parameters)), scenario.cycle_turns, optimised)
    if key not in _PROGRAMS:
        try:
            _PROGRAMS[key] = (d, _Compiler(scenario).compile(optimised))
        except (Unsupported, KeyError, ValueError):
            _PROGRAMS[key] = (d, None)
    return _PROGRAMS[key][1]
