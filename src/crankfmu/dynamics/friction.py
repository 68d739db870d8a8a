"""Coulomb friction in the joints: the friction circle of a pin, the friction of a slide.

A revolute joint with friction coefficient mu and pin radius r carries, beside its reaction R, a
moment of magnitude mu r |R| on its second link (the opposite on its first) that opposes their
relative rotation: the reaction acts off the pin's centre, tangent to the friction circle of
radius mu r. A prismatic joint carries a force of magnitude mu |N| along its axis at the joint's
point on its second link (the opposite on its first) that opposes their relative sliding, N the
slide's force across its axis (the couple it transmits is not loaded: no pair of edges).

Friction i, of signed value f_i (N.m for a pin, N for a slide) on its joint's second link, does
the power f_i k_i omega1 with k_i its relative rate per crank speed (rad/rad: the two links'
angle transfer functions' difference; m/rad: the relative velocity along the axis at the joint's
point). Coulomb's law is

    f_i = -c_i s_i |R_i|        c_i = mu_i r_i (m) or mu_i,   s_i = sign(k_i omega1)

and the reactions are linear in the crank's acceleration eps and in the frictions (Newton-Euler,
dynamics.reactions), R = R_0 + R_eps eps + G f, while the movement equation gains the friction's
generalised force sum k_i f_i:

    J eps = (M + Q + tau - 0.5 J' omega1^2) + sum_i k_i f_i

so eps and the frictions solve a small nonlinear system at each state (|R| and the signs): n_f
equations in f once eps is eliminated, solved by Newton's method from f = 0 (a few iterations: the
frictions are a small part of the reactions). Its Jacobian I + c s dR/df is singular only when the
friction could lock the mechanism (mu r |dR/df| about 1): such a state is refused by name.

The signs s_i are constant between the angles where a k_i crosses zero (a rocker's or a slider's
reversal): those angles join the slider forces' switch angles (ReducedModel.slider_schedule), so
the integrators locate them as events and hold the signs between them. At omega1 = 0 the crank
sticks while the friction holds it (the rules of a slider force at rest, dynamics.modes). |R_i| has
a kink where the reaction passes through zero; it is continuous there, and the reference
integrator's error control steps onto it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, SchemeError
from .loads import AppliedLoad

#: Newton's iterations on the frictions at most (it converges quadratically: 3 to 5 in practice)
MAX_ITERATIONS = 40
EPSILON = np.finfo(float).eps


@dataclass(frozen=True)
class JointFriction:
    """The friction of one joint: its definition (mechanisms.definition.JointDefinition), its
    index among the mechanism's joints (its reaction's unknowns 2 index, 2 index + 1), mu (1) and
    the pin's radius (m; None for a slide)."""

    joint: object
    index: int
    mu: float
    radius: float | None

    @property
    def name(self) -> str:
        return self.joint.name

    @property
    def coefficient(self) -> float:
        """c: mu r (m) for a pin, mu for a slide: the friction's value per unit of |R| or |N|."""
        return self.mu * self.radius if self.joint.kind == "revolute" else self.mu

    @property
    def output(self) -> tuple[str, str]:
        """(suffix, unit) of its output: a pin's moment ``<joint>_Mf`` (N.m), a slide's force
        ``<joint>_Ff`` (N), each the friction on the joint's second link."""
        return ("Mf", "N.m") if self.joint.kind == "revolute" else ("Ff", "N")


    @property
    def names(self) -> tuple[str, str]:
        """Its outputs' names: its friction (``output``) and its power ``<joint>_Pf``."""
        suffix, _ = self.output
        return f"{self.name}_{suffix}", f"{self.name}_Pf"


def friction_outputs(frictions: list[JointFriction]) -> list[tuple[str, str, str]]:
    """(name, unit, description) of the outputs joint friction gives: one home for their names."""
    out = [("M_friction", "N.m", "the joints' friction reduced to the crank (its generalised force, <= 0 forward)"),
           ("W_friction", "J", "the joints' friction's work since the start (<= 0)")]
    for friction in frictions:
        _, unit = friction.output
        force, power = friction.names
        what = "moment" if friction.joint.kind == "revolute" else "force along the slide"
        first, second = friction.joint.links
        out += [(force, unit, f"joint {friction.name}: friction {what} on {second} (the opposite on {first})"),
                (power, "W", f"joint {friction.name}: friction power (<= 0)")]
    return out


def joint_values(frictions: list[JointFriction], f, rates, omega1) -> dict:
    """Each joint's friction output and its power (W: f_i k_i omega1) by name, from the frictions f
    (n, n_f), the rates k_i (n_f, n) and omega1 (n,): what every path reports (the engine, the fast
    path, the Python FMU)."""
    out = {}
    for i, friction in enumerate(frictions):
        force, power = friction.names
        out[force] = f[:, i]
        out[power] = f[:, i] * rates[i] * omega1
    return out


def joint_frictions(definition, entries: dict, values, where: str) -> list[JointFriction]:
    """The frictions of the joints that have one, their expressions (``entries``: joint name ->
    {"mu": expr, "radius": expr}) evaluated on the parameters ``values``. A joint whose mu is 0
    has none: a model without friction runs exactly as it did before friction existed."""
    from ..expressions import evaluate
    out = []
    for index, joint in enumerate(definition.joints):
        entry = entries.get(joint.name)
        if entry is None:
            continue
        mu = evaluate(entry["mu"], values, f"{where}: friction of joint {joint.name}: mu")
        if not (math.isfinite(mu) and 0.0 <= mu <= 1.0):
            raise ParameterError(f"{where}: friction of joint {joint.name}: mu = {entry['mu']} = {mu:g} must be "
                                 "in [0, 1] (dry steel on steel about 0.15, lubricated 0.01 to 0.1)",
                                 _name(entry["mu"]))
        radius = None
        if joint.kind == "revolute":
            radius = evaluate(entry["radius"], values, f"{where}: friction of joint {joint.name}: radius")
            if not (math.isfinite(radius) and radius > 0.0):
                raise ParameterError(f"{where}: friction of joint {joint.name}: radius = {entry['radius']} = "
                                     f"{radius:g} m must be > 0 (the pin's radius)", _name(entry["radius"]))
        if mu > 0.0:
            out.append(JointFriction(joint, index, float(mu), radius))
    return out


def _name(expression: str) -> str:
    """The parameter an error names: the expression itself where it is one name."""
    return str(expression).strip()


class JointFrictions:
    """The joints' frictions of a reduced model: their rates, switch angles and the solve."""

    def __init__(self, mechanism, links, frictions: list[JointFriction]):
        self.mechanism = mechanism
        self.frictions = list(frictions)
        self.centres = {link.name: link.centre for link in links}
        self.coefficients = np.array([f.coefficient for f in self.frictions])
        self._switch = None
        self._moving = None           # (n_f,) whether each joint's links move relative to each other
        self._peak = None             # (n_f,) each rate's largest |k_i| over the turn

    def __len__(self) -> int:
        return len(self.frictions)

    # ------------------------------------------------------------------ kinematics
    def _spin(self, kin, link):
        """dphi_link/dphi1 (rad/rad): zero for the frame."""
        return 0.0 if link == "ground" else kin.link_angle(link)[1]

    def _velocity(self, kin, link, point):
        """Velocity per crank speed (m/rad) of the material point of ``link`` at ``point``."""
        if link == "ground":
            return 0.0, 0.0
        c = kin.point(self.centres[link])
        p = kin.point(point)
        q = kin.link_angle(link)[1]
        return c.dx - q * (p.y - c.y), c.dy + q * (p.x - c.x)

    @property
    def moving(self) -> np.ndarray:
        """(n_f,) whether each joint's two links move relative to each other somewhere in the turn
        (found once, on 720 angles)."""
        if self._moving is None:
            scan = self._raw_rates(self.mechanism.kinematics(np.linspace(0.0, 2.0 * math.pi, 720, endpoint=False)))
            peak = np.max(np.abs(scan), axis=1)
            self._moving = peak > 1e-12 * max(1.0, float(np.max(peak)))
            self._peak = peak
        return self._moving

    def rates(self, kin) -> np.ndarray:
        """k_i (n_f, n): each friction's relative rate per crank speed, rad/rad or m/rad; exactly 0
        for a joint whose two links never move relative to each other (its friction does no work
        and has no direction: none, rather than one of round-off's sign)."""
        return self._raw_rates(kin) * self.moving[:, None]

    def _raw_rates(self, kin) -> np.ndarray:
        out = []
        for friction in self.frictions:
            joint = friction.joint
            first, second = joint.links
            if joint.kind == "revolute":
                out.append(self._spin(kin, second) - self._spin(kin, first)
                           + np.zeros_like(kin.phi1))
            else:
                axis = self.mechanism.angle_of(joint.axis, kin)
                v2, v1 = self._velocity(kin, second, joint.point), self._velocity(kin, first, joint.point)
                out.append((v2[0] - v1[0]) * np.cos(axis) + (v2[1] - v1[1]) * np.sin(axis))
        return np.array(out).reshape(len(self.frictions), kin.phi1.size)

    def switch_angles(self) -> list[float]:
        """Crank angles (rad, in [0, 2 pi)) where a relative rate k_i crosses zero: its friction
        turns round there (found once)."""
        if self._switch is None:
            found = []
            for i in np.flatnonzero(self.moving):
                found += [angle for angle, _, _ in self.mechanism.crossings(lambda kin, i=i: self._raw_rates(kin)[i],
                                                                           [0.0])]
            self._switch = sorted(found)
        return self._switch

    def unit_loads(self, kin, i) -> list[AppliedLoad]:
        """Friction i at value 1 (1 N.m or 1 N on the second link, the opposite on the first)."""
        joint = self.frictions[i].joint
        first, second = joint.links
        one = np.ones_like(kin.phi1)
        if joint.kind == "revolute":
            return [AppliedLoad(second, None, moment=one), AppliedLoad(first, None, moment=-one)]
        axis = self.mechanism.angle_of(joint.axis, kin)
        ex, ey = np.cos(axis), np.sin(axis)
        return [AppliedLoad(second, joint.point, ex, ey), AppliedLoad(first, joint.point, -ex, -ey)]

    # ------------------------------------------------------------------ the solve
    def magnitudes(self, x, H):
        """|R_i| (n, n_f) of the unknowns x (n, size) and its derivative by the frictions,
        (n, n_f, n_f), x moving as H (n, size, n_f) per unit friction."""
        n, nf = x.shape[0], len(self.frictions)
        mag, grad = np.zeros((n, nf)), np.zeros((n, nf, nf))
        for i, friction in enumerate(self.frictions):
            c = 2 * friction.index
            if friction.joint.kind == "revolute":
                rx, ry = x[:, c], x[:, c + 1]
                m = np.hypot(rx, ry)
                safe = np.where(m > 0.0, m, 1.0)
                mag[:, i] = m
                grad[:, i, :] = np.where((m > 0.0)[:, None],
                                         (rx[:, None] * H[:, c, :] + ry[:, None] * H[:, c + 1, :]) / safe[:, None], 0.0)
            else:
                mag[:, i] = np.abs(x[:, c])
                grad[:, i, :] = np.sign(x[:, c])[:, None] * H[:, c, :]
        return mag, grad

    def solve(self, x_base, H, signs):
        """The frictions f (n, n_f) and the unknowns x = x_base + H f with f_i = -c_i s_i |R_i(x)|
        (Newton's method from f = 0). ``signs`` (n, n_f): s_i, +1, -1 or 0."""
        n, nf = x_base.shape[0], len(self.frictions)
        cs = self.coefficients[None, :] * signs
        f = np.zeros((n, nf))
        eye = np.eye(nf)[None]
        for _ in range(MAX_ITERATIONS):
            x = x_base + np.einsum("nsk,nk->ns", H, f)
            mag, grad = self.magnitudes(x, H)
            residual = f + cs * mag
            step = np.linalg.solve(eye + cs[:, :, None] * grad, residual[..., None])[..., 0]
            f = f - step
            # |R_i| is a difference of reactions as large as the largest unknown: its round-off,
            # weighted by c_i, bounds how closely f_i can settle
            scale = np.abs(f) + self.coefficients[None, :] * np.max(np.abs(x), axis=1)[:, None]
            if np.all(np.abs(step) <= 64 * EPSILON * scale):
                return f, x_base + np.einsum("nsk,nk->ns", H, f)
        worst = int(np.argmax(np.max(np.abs(step), axis=1)))
        raise SchemeError(
            "joint friction: the frictions do not settle (Newton's method on f_i = -mu_i r_i |R_i| does not "
            f"converge at the {worst + 1}th state): the friction is large enough to lock the mechanism "
            f"(mu r {', '.join(f'{f.name} {c:g}' for f, c in zip(self.frictions, self.coefficients))}); "
            "lower mu or the pin radii")

    def signs(self, kin, direction) -> np.ndarray:
        """s_i (n, n_f) where the crank turns in ``direction`` (its sign, an array or a number). On a
        zero of k_i (a dead centre, to 1e-9 of k_i's peak) the sign is that of the motion that
        follows, k_i's a microradian further in ``direction``, as the integrators take it (the
        switch interval entered); a crank at rest (direction 0) has none."""
        rates = self.rates(kin)
        direction = np.sign(direction) + np.zeros(kin.phi1.shape)
        found = np.sign(rates)
        near = (np.abs(rates) <= 1e-9 * self._peak[:, None]) & self.moving[:, None]
        if np.any(near):
            ahead = self.rates(self.mechanism.kinematics(kin.phi1 + 1e-6 * np.where(direction < 0.0, -1.0, 1.0)))
            found = np.where(near, np.sign(ahead), found)
        return (found * direction).T

    def prescribed(self, ne, x, direction):
        """(x, f): the unknowns x (n, size) of a prescribed motion (reactions.joint_reactions)
        with the frictions f (n, n_f) added, the crank turning in ``direction`` (n,): the motion
        fixed, each friction moves the reactions and M_e alone."""
        H = ne.solve(self._unit_rhs(ne))
        f, x = self.solve(x, H, self.signs(ne.kin, direction))
        return x, f

    def _unit_rhs(self, ne, first: int = 0):
        """Right-hand sides (n, size, first + n_f): the frictions at value 1 in the last n_f."""
        b = np.zeros((ne.kin.phi1.size, ne.size, first + len(self.frictions)))
        for i in range(len(self.frictions)):
            b[:, :, first + i] = ne.loaded(self.unit_loads(ne.kin, i))
        return b

    def forward(self, ne, b_free, J, signs, held: bool = False):
        """(eps_friction, f, x, generalised): where the drive's torque is given, the acceleration
        (rad/s2, (n,)) the frictions add to the frictionless one, the frictions f (n, n_f), the
        unknowns x (n, size) with them, and the friction's generalised force on the crank (N.m,
        sum k_i f_i). ``b_free``: the Newton-Euler right-hand side (n, size) at the frictionless
        acceleration. ``held``: the speed is held (the motor sliding on its switch: eps stays 0,
        the drive takes the friction). One solve gives the unknowns of the frictionless motion,
        per unit acceleration and per unit friction."""
        b = self._unit_rhs(ne, 2)
        b[:, :, 0] = b_free
        if not held:
            b[:, :, 1] = ne.loaded(omega1=0.0, epsilon1=1.0)
        X = ne.solve(b)
        H = X[:, :, 2:]
        k = self.rates(ne.kin).T                        # (n, n_f)
        if not held:
            H = H + X[:, :, 1:2] * (k / J[:, None])[:, None, :]
        f, x = self.solve(X[:, :, 0], H, signs)
        generalised = np.sum(k * f, axis=1)
        return (np.zeros_like(generalised) if held else generalised / J), f, x, generalised
