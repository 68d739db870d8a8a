"""Joint reactions by Newton-Euler, link by link: the forces bearings and slides must carry, and
the driving moment, found without the power balance (an independent check of eq. 1).

For every moving link j (mass m_j, central inertia I_j, mass centre C_j)::

    sum of forces on j           = m_j a_Cj
    sum of moments about C_j     = I_j eps_j          (+ the flywheel's J eps1 on the crank)

The unknowns are two per joint (a pin's force; a slide's normal force and couple) and the
driving moment on the crank: 2 n_joints + 1 = 3 n_links for a one-degree-of-freedom mechanism,
so at each crank angle one square linear solve gives them all. Reactions are those of the
joint's first link on its second (``ground`` is the frame).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import DefinitionError
from .inverse import prescribed_motion
from .reduced import ReducedModel


@dataclass
class JointReactions:
    """Reactions at an array of crank angles.

    force[joint]   (Fx, Fy) in N, of the joint's first link on its second
    couple[joint]  N.m, the couple a slide transmits (zero array for pins)
    normal[joint]  N, a slide's force across its axis (the force's one component; zero for pins)
    driving_moment N.m, the moment the drive applies to the crank (M_e)
    """

    phi1: np.ndarray
    force: dict[str, tuple[np.ndarray, np.ndarray]]
    couple: dict[str, np.ndarray]
    kind: dict[str, str]
    driving_moment: np.ndarray
    normal: dict[str, np.ndarray]
    #: with joint friction (dynamics.friction): each friction joint's friction (N.m for a pin, N
    #: for a slide, on its second link) and its power (W) in the prescribed motion
    friction: dict[str, np.ndarray] = field(default_factory=dict)
    friction_power: dict[str, np.ndarray] = field(default_factory=dict)

    def magnitude(self, joint: str) -> np.ndarray:
        """|F| at the joint, N."""
        fx, fy = self.force[joint]
        return np.hypot(fx, fy)

    def peaks(self) -> dict[str, dict[str, float]]:
        """Per joint the largest force magnitude (N) and, for slides, the largest |couple| (N.m)."""
        out = {}
        for name in self.force:
            entry = {"kind": self.kind[name], "max_force_N": float(np.max(self.magnitude(name)))}
            if self.kind[name] == "prismatic":
                entry["max_couple_Nm"] = float(np.max(np.abs(self.couple[name])))
            out[name] = entry
        return out


class NewtonEuler:
    """The Newton-Euler equations of every moving link at the kinematics ``kin``: the matrix of
    the unknowns (each joint's two reaction components, then the driving moment M_e on the crank)
    and the right-hand sides of what acts (inertia, applied loads), so that a caller may solve
    several right-hand sides on one factorisation (dynamics.friction: the reactions' parts per
    unit acceleration and per unit friction)."""

    def __init__(self, reduced: ReducedModel, kin):
        mechanism = reduced.mechanism
        definition = mechanism.definition
        self.joints = definition.joints
        if not self.joints:
            raise DefinitionError(f"mechanism {definition.name!r} declares no [[joints]]: the reactions "
                                  "need them")
        self.reduced, self.kin = reduced, kin
        n = kin.phi1.size
        links = [link.name for link in reduced.links]
        self.row = {name: 3 * i for i, name in enumerate(links)}
        self.size = size = 3 * len(links)
        A = np.zeros((n, size, size))
        self.centre = {link.name: kin.point(link.centre)[:2] for link in reduced.links}
        self.axis = {j.name: mechanism.angle_of(j.axis, kin) for j in self.joints if j.kind == "prismatic"}
        for k, joint in enumerate(self.joints):
            first, second = joint.links
            px, py = kin.point(joint.point)[:2]
            c = 2 * k
            if joint.kind == "revolute":
                for col, (ux, uy) in ((c, (1.0, 0.0)), (c + 1, (0.0, 1.0))):
                    self._force(A, second, col, px, py, ux, uy)
                    self._force(A, first, col, px, py, -ux, -uy)
            else:
                nx, ny = -np.sin(self.axis[joint.name]), np.cos(self.axis[joint.name])
                self._force(A, second, c, px, py, nx, ny)
                self._force(A, first, c, px, py, -nx, -ny)
                for link, sign in ((second, 1.0), (first, -1.0)):
                    if link != "ground":
                        A[:, self.row[link] + 2, c + 1] += sign
        crank = [name for name, ld in definition.links.items() if ld.angle == "phi1"]
        if len(crank) != 1:
            raise DefinitionError(f"mechanism {definition.name!r}: exactly one link must turn with phi1 (the crank)")
        self.crank = crank[0]
        self.driver = size - 1
        A[:, self.row[self.crank] + 2, self.driver] = 1.0
        self.A = A

    def _force(self, A, link, col, px, py, fx, fy):
        """Unknown (col) times the force (fx, fy) at (px, py), acting on ``link``."""
        if link == "ground":
            return
        r = self.row[link]
        cx, cy = self.centre[link]
        A[:, r, col] += fx
        A[:, r + 1, col] += fy
        A[:, r + 2, col] += (px - cx) * fy - (py - cy) * fx

    def inertia(self, b, omega1, epsilon1):
        """Add m a and I eps (the flywheel's J eps1 on the crank) to the right-hand side ``b``."""
        kin, w2 = self.kin, omega1 * omega1
        for link in self.reduced.links:
            r = self.row[link.name]
            _, _, t, p, tt, pp = kin.point(link.centre)
            _, q, qq = kin.link_angle(link.name)
            b[:, r] += link.mass * (epsilon1 * t + w2 * tt)
            b[:, r + 1] += link.mass * (epsilon1 * p + w2 * pp)
            b[:, r + 2] += link.inertia * (epsilon1 * q + w2 * qq)
        b[:, self.row[self.crank] + 2] += self.reduced.J_flywheel * epsilon1

    def applied(self, b, forces):
        """Subtract the applied loads ``forces`` (loads.AppliedLoad) from the right-hand side ``b``."""
        for f in forces:
            if f.link == "ground":          # a spring anchored on the frame: the frame carries that end
                continue
            r = self.row[f.link]
            cx, cy = self.centre[f.link]
            b[:, r] -= f.fx
            b[:, r + 1] -= f.fy
            b[:, r + 2] -= f.moment
            if f.point is not None:
                px, py = self.kin.point(f.point)[:2]
                b[:, r + 2] -= (px - cx) * f.fy - (py - cy) * f.fx

    def rhs(self):
        """A zero right-hand side."""
        return np.zeros((self.kin.phi1.size, self.size))

    def loaded(self, forces=(), omega1=None, epsilon1=None):
        """The right-hand side of a motion: the inertia of (omega1, epsilon1) where given (none:
        the statics), less the applied loads ``forces`` (loads.AppliedLoad)."""
        b = self.rhs()
        if omega1 is not None:
            self.inertia(b, omega1, epsilon1)
        self.applied(b, forces)
        return b

    def solve(self, b):
        """The unknowns for the right-hand side(s) ``b``: (n, size) or (n, size, k) columns."""
        if b.ndim == 2:
            return np.linalg.solve(self.A, b[..., None])[..., 0]
        return np.linalg.solve(self.A, b)

    def package(self, x) -> JointReactions:
        """The solved unknowns ``x`` (n, size) as reactions."""
        n = x.shape[0]
        force, couple, kind, normal = {}, {}, {}, {}
        for k, joint in enumerate(self.joints):
            kind[joint.name] = joint.kind
            if joint.kind == "revolute":
                force[joint.name] = (x[:, 2 * k], x[:, 2 * k + 1])
                couple[joint.name] = normal[joint.name] = np.zeros(n)
            else:
                axis = self.axis[joint.name]
                normal[joint.name] = x[:, 2 * k]
                force[joint.name] = (-np.sin(axis) * normal[joint.name], np.cos(axis) * normal[joint.name])
                couple[joint.name] = x[:, 2 * k + 1]
        return JointReactions(phi1=self.kin.phi1, force=force, couple=couple, kind=kind,
                              driving_moment=x[:, self.driver], normal=normal)


def joint_reactions(reduced: ReducedModel, phi1, omega1, epsilon1=0.0, inertia: bool = True,
                    extra=None, kin=None, loads=None, direction: float = 1.0) -> JointReactions:
    """Solve every joint's reaction and the driving moment at a prescribed crank motion.

    ``inertia=False`` neglects the inertia forces and moments (the static equilibrium moment).
    ``extra(kin)``: more applied loads (loads.AppliedLoad) at the kinematics, beside the model's
    own: the ports' inputs (dynamics.ports). ``kin``: the kinematics at phi1, where the caller has
    them already. ``loads``: the model's loads that act (default all; the reactions are linear in
    the loads, and their tables, dynamics.reaction_table.tabulate_reactions, take them part by part).
    With joint friction (dynamics.friction) the reactions and M_e are those with the friction
    moments and forces of the prescribed motion, turning the way omega1's sign says, or
    ``direction`` where omega1 is 0 (the static friction a start from rest meets).
    """
    phi1, omega1, epsilon1 = prescribed_motion(phi1, omega1, epsilon1, forward=False)
    if kin is None:
        kin = reduced.mechanism.kinematics(phi1)
    ne = NewtonEuler(reduced, kin)
    # right-hand side: m a - applied forces; I eps - applied moments
    forces = [f for load in (reduced.loads if loads is None else loads) for f in load.applied(kin, omega1)]
    b = ne.loaded(forces + list(extra(kin) if extra else ()), *((omega1, epsilon1) if inertia else ()))
    x = ne.solve(b)
    friction = getattr(reduced, "friction", None)
    if friction is None or loads is not None:
        return ne.package(x)
    moving = np.where(omega1 != 0.0, np.sign(omega1), np.sign(direction)) + np.zeros_like(phi1)
    x, f = friction.prescribed(ne, x, moving)
    out = ne.package(x)
    rates = friction.rates(kin)
    for i, joint in enumerate(friction.frictions):
        out.friction[joint.name] = f[:, i]
        out.friction_power[joint.name] = f[:, i] * rates[i] * omega1
    return out


#: the FMU outputs of a joint's reaction, by joint kind: (suffix, unit, what)
REACTION_OUTPUTS = {
    "revolute": (("Fx", "N", "x component"), ("Fy", "N", "y component")),
    "prismatic": (("N", "N", "force across the slide's axis"), ("M", "N.m", "couple the slide transmits")),
}


def reaction_outputs(definition) -> list[tuple[str, str, str]]:
    """(name, unit, description) of the FMU outputs the joint reactions give: for a pin
    ``<joint>_Fx``, ``<joint>_Fy`` (N); for a slide ``<joint>_N`` (N, across its axis) and
    ``<joint>_M`` (N.m). Each is the force of the joint's first link on its second."""
    return [(f"{joint.name}_{suffix}", unit,
             f"joint {joint.name}: reaction of {joint.links[0]} on {joint.links[1]}, {what} (Newton-Euler)")
            for joint in definition.joints for suffix, unit, what in REACTION_OUTPUTS[joint.kind]]


def reaction_arrays(reactions: JointReactions) -> dict[str, np.ndarray]:
    """The outputs of ``reaction_outputs`` at every solved state."""
    out = {}
    for name, kind in reactions.kind.items():
        fx, fy = reactions.force[name]
        values = (fx, fy) if kind == "revolute" else (reactions.normal[name], reactions.couple[name])
        for (suffix, _, _), value in zip(REACTION_OUTPUTS[kind], values):
            out[f"{name}_{suffix}"] = value
    return out


def reaction_values(reactions: JointReactions, index: int = 0) -> dict[str, float]:
    """The outputs of ``reaction_outputs`` at one of the solved states."""
    return {name: float(value[index]) for name, value in reaction_arrays(reactions).items()}
