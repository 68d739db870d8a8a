"""A mechanism file read into its definition: the contours' vector chains parsed into terms, the
points, links and joints, the assembly (closed form or guess). The contour engine (contour.py)
binds a definition to parameter values and solves it."""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from ..errors import DefinitionError
from ..expressions import Expression, parse


# --------------------------------------------------------------------------------------------
# parsing vector chains
# --------------------------------------------------------------------------------------------

@dataclass
class _TermSource:
    sign: float
    coefficient: str          # scalar expression of parameters
    length: str | None        # name of a displacement unknown, or None
    angle: str | None         # "phi1", an angle unknown, or None (constant direction)
    offset: str               # scalar expression of parameters (rad)


def _flatten_sum(node: ast.AST, sign: float, out: list):
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
        _flatten_sum(node.left, sign, out)
        _flatten_sum(node.right, sign if isinstance(node.op, ast.Add) else -sign, out)
    elif isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        _flatten_sum(node.operand, -sign if isinstance(node.op, ast.USub) else sign, out)
    else:
        out.append((sign, node))


def _flatten_product(node: ast.AST, out: list, divide: bool = False):
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        _flatten_product(node.left, out, divide)
        _flatten_product(node.right, out, divide)
    elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
        _flatten_product(node.left, out, divide)
        _flatten_product(node.right, out, not divide)
    else:
        out.append((node, divide))


def _parse_chain(source: str, where: str, variables: Mapping[str, str], points: Mapping[str, object]):
    """Split ``source`` into vector terms and named points it starts from.

    ``variables`` maps each name of q to its kind ("angle" or "length"); ``points`` holds the
    names that may stand alone as a base point (fixed points and points defined earlier).
    Returns (terms, base_points) with base_points a list of (sign, name).
    """
    tree = parse(source, where)
    flat: list = []
    _flatten_sum(tree.body, 1.0, flat)
    terms, bases = [], []
    for sign, node in flat:
        if isinstance(node, ast.Name) and node.id in points:
            bases.append((sign, node.id))
            continue
        factors: list = []
        _flatten_product(node, factors)
        unit = [f for f in factors if isinstance(f[0], ast.Call) and f[0].func.id == "u"]
        if len(unit) != 1 or unit[0][1]:
            raise DefinitionError(
                f"{where}: each term must be [coefficient *] [displacement *] u(angle), "
                f"got {ast.unparse(node)!r} in {source!r}"
            )
        call = unit[0][0]
        if len(call.args) != 1:
            raise DefinitionError(f"{where}: u() takes one angle, got {ast.unparse(call)!r}")
        length = None
        scalar_parts = []
        for f, divide in factors:
            if f is call:
                continue
            if isinstance(f, ast.Name) and f.id in variables:
                if variables[f.id] != "length" or divide or length is not None:
                    raise DefinitionError(
                        f"{where}: {f.id!r} cannot multiply u() in {source!r}: only one slider "
                        "displacement (a 'length' unknown) may scale a term"
                    )
                length = f.id
                continue
            text = ast.unparse(f)
            if any(isinstance(n, ast.Name) and n.id in variables for n in ast.walk(f)):
                raise DefinitionError(
                    f"{where}: unknowns may appear only as the displacement or inside u(); "
                    f"got {text!r} in {source!r}"
                )
            scalar_parts.append(f"/({text})" if divide else f"*({text})")
        coefficient = "1" + "".join(scalar_parts)
        # angle: [variable] [+/- constant]
        angle_flat: list = []
        _flatten_sum(call.args[0], 1.0, angle_flat)
        angle = None
        offset_parts = []
        for asign, anode in angle_flat:
            if isinstance(anode, ast.Name) and anode.id in variables:
                if variables[anode.id] != "angle" or asign < 0 or angle is not None:
                    raise DefinitionError(
                        f"{where}: u() takes one angle variable with a + sign plus constants, "
                        f"got {ast.unparse(call)!r}"
                    )
                angle = anode.id
            else:
                if any(isinstance(n, ast.Name) and n.id in variables for n in ast.walk(anode)):
                    raise DefinitionError(f"{where}: bad angle {ast.unparse(call)!r}")
                offset_parts.append(("+" if asign > 0 else "-") + f"({ast.unparse(anode)})")
        offset = "0" + "".join(offset_parts)
        terms.append(_TermSource(sign, coefficient, length, angle, offset))
    return terms, bases


# --------------------------------------------------------------------------------------------
# the definition (a parsed mechanism file) and the mechanism bound to parameter values
# --------------------------------------------------------------------------------------------

@dataclass
class LinkDefinition:
    name: str
    number: int
    angle: str           # "phi1", an angle unknown, or a constant expression
    centre: str          # point name
    mass: str            # expression
    inertia: str         # expression (about the centre)


@dataclass
class JointDefinition:
    """A joint between two links (or a link and ``"ground"``), where the reactions act.

    ``revolute``: a pin at ``point`` carrying a force (2 unknowns). ``prismatic``: a slide through
    ``point`` along the direction ``axis`` (an angle: a constant, or a link angle unknown such as
    ``"phi3"`` for a guide on a turning link) carrying a force normal to the axis and a couple
    (2 unknowns). The reactions are those of ``links[0]`` on ``links[1]``.
    """

    name: str
    kind: str             # "revolute" | "prismatic"
    point: str
    links: tuple[str, str]
    axis: str = "0"       # prismatic only: angle of the slide direction (rad)
    #: Coulomb friction (dynamics.friction): {"mu": expr, "radius": expr} for a pin, {"mu": expr}
    #: for a slide, expressions of the scenario's parameters; None: frictionless
    friction: dict | None = None


@dataclass
class MechanismDefinition:
    """A mechanism file, parsed and checked, not yet bound to parameter values."""

    name: str
    title: str
    unknowns: dict[str, str]                      # name -> "angle" | "length"
    fixed_points: dict[str, tuple[str, str]]
    contours: list[tuple[str, list[_TermSource]]]
    points: dict[str, tuple[list[_TermSource], tuple[str, str]]]  # flattened terms, constant
    links: dict[str, LinkDefinition]
    branch: str
    closed_form: list[tuple[str, Expression]] | None
    guess: dict[str, str] | None
    #: [assembly] constants: numbers, or expressions of the parameters and the constants above them
    #: (a triangle's angle that follows its sides), evaluated whenever the parameters are bound
    constants: dict[str, float | Expression] = field(default_factory=dict)
    source: str = ""
    joints: list[JointDefinition] = field(default_factory=list)
    point_sources: dict[str, str] = field(default_factory=dict)   # [points] as written
    contour_sources: list[tuple[str, str]] = field(default_factory=list)  # (name, equation) as written

    @property
    def variables(self) -> list[str]:
        return ["phi1", *self.unknowns]

    def constant_values(self, parameters: Mapping[str, float]) -> dict[str, float]:
        """The constants' values at these parameter values, in the file's order."""
        env = {**parameters}
        out = {}
        for name, value in self.constants.items():
            if isinstance(value, Expression):
                with np.errstate(all="ignore"):
                    value = float(value.evaluate(env))
                if not math.isfinite(value):
                    raise DefinitionError(f"{self.constants[name].where} = {self.constants[name].source!r} is not "
                                          f"finite ({value:g}) at these parameter values: a constant must be a "
                                          "finite number")
            env[name] = out[name] = value
        return out

    def _through_constants(self, names: set[str]) -> set[str]:
        """``names`` with the parameters that the constants among them are expressions of."""
        for name, value in reversed(list(self.constants.items())):
            if name in names and isinstance(value, Expression):
                names = names | value.names
        return names

    @property
    def geometry_parameters(self) -> list[str]:
        """Parameters the positions depend on (used to name them in assembly errors)."""
        names: set[str] = set()
        for _, terms in self.contours:
            for t in terms:
                names |= Expression(t.coefficient).names | Expression(t.offset).names
        if self.closed_form:
            assigned = {n for n, _ in self.closed_form}
            for _, expr in self.closed_form:
                names |= expr.names - assigned
        names = self._through_constants(names)
        names -= set(self.variables) | set(self.constants)
        return sorted(names)

    @property
    def mass_parameters(self) -> list[str]:
        """Parameters the links' masses and inertias depend on."""
        names: set[str] = set()
        for link in self.links.values():
            names |= Expression(link.mass).names | Expression(link.inertia).names
        return sorted(self._through_constants(names) - set(self.constants))

    @classmethod
    def from_dict(cls, data: Mapping, where: str = "mechanism") -> "MechanismDefinition":
        try:
            name = data["name"]
            unknowns = dict(data["unknowns"])
            contour_list = data["contours"]
        except KeyError as exc:
            raise DefinitionError(f"{where}: missing section {exc.args[0]!r}") from None
        for u, kind in unknowns.items():
            if kind not in ("angle", "length"):
                raise DefinitionError(f"{where}: unknown {u!r} has kind {kind!r}; use 'angle' or 'length'")
        if "phi1" in unknowns:
            raise DefinitionError(f"{where}: phi1 is the crank angle, not an unknown")
        variables = {"phi1": "angle", **unknowns}

        fixed = {}
        for p, xy in data.get("fixed_points", {}).items():
            if not isinstance(xy, (list, tuple)) or len(xy) != 2:
                raise DefinitionError(f"{where}: fixed point {p!r} must be [x, y]")
            fixed[p] = (str(xy[0]), str(xy[1]))

        contours, contour_sources = [], []
        for i, c in enumerate(contour_list):
            cname = c.get("name", str(i + 1))
            terms, bases = _parse_chain(c["equation"], f"{where}: contour {cname}", variables, {})
            if bases:
                raise DefinitionError(f"{where}: contour {cname} must be a sum of u() terms")
            contours.append((cname, terms))
            contour_sources.append((cname, str(c["equation"])))
        n_equations = 2 * len(contours)
        if n_equations != len(unknowns):
            raise DefinitionError(
                f"{where}: {len(contours)} contour(s) give {n_equations} equations for "
                f"{len(unknowns)} unknowns ({', '.join(unknowns)}); they must match"
            )

        points: dict = {p: ([], xy) for p, xy in fixed.items()}
        for p, src in data.get("points", {}).items():
            if p in points:
                raise DefinitionError(f"{where}: point {p!r} defined twice")
            terms, bases = _parse_chain(src, f"{where}: point {p}", variables, points)
            if len(bases) != 1 or bases[0][0] < 0:
                raise DefinitionError(
                    f"{where}: point {p} = {src!r} must start from exactly one known point "
                    f"(one of {', '.join(points)}) with a + sign"
                )
            base_terms, base_xy = points[bases[0][1]]
            points[p] = (base_terms + terms, base_xy)

        links = {}
        for lname, ld in data.get("links", {}).items():
            for key in ("centre", "mass", "inertia"):
                if key not in ld:
                    raise DefinitionError(f"{where}: link {lname!r} needs {key!r}")
            if ld["centre"] not in points:
                raise DefinitionError(f"{where}: link {lname!r}: centre {ld['centre']!r} is not a point")
            angle = str(ld.get("angle", "0"))
            if angle not in variables:
                Expression(angle, f"{where}: link {lname} angle")  # a constant expression
            elif variables[angle] != "angle":
                raise DefinitionError(f"{where}: link {lname!r}: {angle!r} is not an angle")
            links[lname] = LinkDefinition(
                lname, int(ld.get("number", len(links) + 1)), angle, ld["centre"],
                str(ld["mass"]), str(ld["inertia"]),
            )

        joints = _parse_joints(data.get("joints", []), where, variables, points, links)

        assembly = data.get("assembly", {})
        branch = assembly.get("branch", "")
        if not branch:
            raise DefinitionError(f"{where}: [assembly] must state the branch in words ('branch = ...')")
        constants = {}
        for k, v in assembly.get("constants", {}).items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                constants[k] = float(v)
            elif isinstance(v, str):
                constants[k] = Expression(v, f"{where}: [assembly] constants {k}")
                later = constants[k].names & ({*assembly.get("constants", {})} - {*constants} | {k})
                if later:
                    raise DefinitionError(f"{where}: [assembly] constants {k} = {v!r} uses {', '.join(sorted(later))}, "
                                          "defined after it (or itself): a constant may use the parameters and the "
                                          "constants above it")
            else:
                raise DefinitionError(f"{where}: [assembly] constants {k} = {v!r} must be a number or an expression "
                                      "string of the parameters")
        closed_form = None
        if "closed_form" in assembly:
            closed_form = []
            for line in assembly["closed_form"]:
                if "=" not in line:
                    raise DefinitionError(f"{where}: closed-form step {line!r} is not 'name = expression'")
                lhs, rhs = (s.strip() for s in line.split("=", 1))
                closed_form.append((lhs, Expression(rhs, f"{where}: closed form {lhs}")))
            missing = set(unknowns) - {n for n, _ in closed_form}
            if missing:
                raise DefinitionError(f"{where}: the closed form does not assign {', '.join(sorted(missing))}")
        guess = assembly.get("guess")
        if closed_form is None and guess is None:
            raise DefinitionError(
                f"{where}: [assembly] needs a closed_form or a guess (unknown values at a crank angle)"
            )
        if guess is not None:
            guess = {k: str(v) for k, v in guess.items()}
            missing = set(unknowns) - set(guess)
            if missing:
                raise DefinitionError(f"{where}: the assembly guess lacks {', '.join(sorted(missing))}")
        return cls(
            name=name, title=data.get("title", name), unknowns=unknowns, fixed_points=fixed,
            contours=contours, points=points, links=links, branch=branch,
            closed_form=closed_form, guess=guess, constants=constants, source=data.get("source", ""),
            joints=joints, point_sources={p: str(src) for p, src in data.get("points", {}).items()},
            contour_sources=contour_sources,
        )


def _parse_joints(entries, where, variables, points, links) -> list[JointDefinition]:
    """Check the ``[[joints]]`` list: known links and points, and as many reaction unknowns (two per
    joint, plus the driving moment) as Newton-Euler equations (three per moving link)."""
    joints = []
    for i, jd in enumerate(entries):
        name = jd.get("name", f"joint {i + 1}")
        kind = jd.get("kind")
        if kind not in ("revolute", "prismatic"):
            raise DefinitionError(f"{where}: joint {name!r}: kind must be 'revolute' or 'prismatic', got {kind!r}")
        pair = tuple(jd.get("links", ()))
        if len(pair) != 2 or pair[0] == pair[1]:
            raise DefinitionError(f"{where}: joint {name!r}: links must name two different links, got {pair!r}")
        for link in pair:
            if link != "ground" and link not in links:
                raise DefinitionError(f"{where}: joint {name!r}: {link!r} is not a link "
                                      f"(known: ground, {', '.join(links)})")
        if jd.get("point") not in points:
            raise DefinitionError(f"{where}: joint {name!r}: point {jd.get('point')!r} is not a point")
        axis = str(jd.get("axis", "0"))
        if axis not in variables:
            Expression(axis, f"{where}: joint {name} axis")
        elif variables[axis] != "angle":
            raise DefinitionError(f"{where}: joint {name!r}: axis {axis!r} is not an angle")
        friction = None
        if "friction" in jd:
            friction = parse_friction_entry(jd["friction"], name, kind, where)
        joints.append(JointDefinition(name, kind, jd["point"], pair, axis, friction))
    if joints and 2 * len(joints) + 1 != 3 * len(links):
        raise DefinitionError(
            f"{where}: {len(joints)} joints give {2 * len(joints)} reaction unknowns plus the driving "
            f"moment, but {len(links)} moving links give {3 * len(links)} Newton-Euler equations")
    return joints


def parse_friction_entry(entry, joint_name: str, kind: str, where: str) -> dict:
    """Check one joint's ``friction = { mu = "...", radius = "..." }`` (a slide takes no radius)
    and return it with its expressions as text."""
    if not isinstance(entry, dict):
        form = '{ mu = "...", radius = "..." }' if kind == "revolute" else '{ mu = "..." }'
        raise DefinitionError(f"{where}: joint {joint_name!r}: friction must be a table {form}, got {entry!r}")
    wanted = {"mu", "radius"} if kind == "revolute" else {"mu"}
    unknown = set(entry) - wanted
    if unknown:
        extra = " (a slide's friction is mu |N|: it has no radius)" if "radius" in unknown else ""
        raise DefinitionError(f"{where}: joint {joint_name!r}: friction takes {' and '.join(sorted(wanted))}, "
                              f"not {', '.join(sorted(unknown))}{extra}")
    missing = wanted - set(entry)
    if missing:
        raise DefinitionError(f"{where}: joint {joint_name!r}: friction needs {' and '.join(sorted(missing))} "
                              f"({'the friction coefficient' if 'mu' in missing else 'the pin radius, m'})")
    out = {}
    for key in sorted(wanted):
        text = entry[key]
        if isinstance(text, bool) or not isinstance(text, (str, int, float)):
            raise DefinitionError(f"{where}: joint {joint_name!r}: friction {key} must be an expression of "
                                  f"the parameters, got {text!r}")
        Expression(str(text), f"{where}: joint {joint_name} friction {key}")
        out[key] = str(text)
    return out
