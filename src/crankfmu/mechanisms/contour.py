"""The contour engine: planar one-degree-of-freedom mechanisms described as data.

A mechanism is the set of its independent contours, each a closed vector sum
projected on x and y (seed 000 eq. 19, seed 001 eqs. 2-4, seed 004 eqs. 1-2)::

    l1*u(phi1) + l2*u(phi2) + l3*u(phi3) - l0*u(0) = 0

with ``u(a) = (cos a, sin a)``. Every term is ``coefficient * [displacement] * u(angle + offset)``
where the coefficient is a product of parameters, the optional displacement is an unknown slider
coordinate and the angle is the crank angle ``phi1``, an unknown link angle or a constant.

With ``q = (phi1, unknowns...)`` and primes for d/dphi1, one term ``r = L u(theta)`` gives

    r'  = L' u + L theta' n                                   (n = u(theta + pi/2))
    r'' = L'' u + L theta'' n + 2 L' theta' n - L theta'^2 u

so the contour equations F(q) = 0 give the transfer functions by two linear solves with the
same Jacobian F_u (no finite differences):

    F_u u'  = -F_phi1
    F_u u'' = -(2 L' theta' n - L theta'^2 u summed over the terms)

Mass centres and any other point are vector chains of the same terms, so their coordinates and
first and second derivatives (eq. 11's t, tt, p, pp) come out of the same formulas; link angles
give q and qq directly.

Positions are solved in closed form where the mechanism file gives one (an ordered list of
assignments), otherwise by Newton's method started from a continuation table built once over the
whole turn from the file's assembly guess, which also fixes the assembly branch. Either way every
angle is continuous along the turn and counts whole turns (Mechanism.turn_table). The file itself
is read into its definition by definition.py; the checks and searches over the whole turn are
assembly.py's, and what the engine gives at a set of angles is kinematics.py's.
"""

from __future__ import annotations

import math
from typing import Mapping, NamedTuple

import numpy as np

from ..errors import AssemblyError, DefinitionError
from ..expressions import Expression
from .assembly import TWO_PI, TurnChecks
from .definition import MechanismDefinition
from .kinematics import Kinematics, PointMotion, OnDemand


class MotionNames(NamedTuple):
    points: frozenset
    unknowns: frozenset


#: angles of the turn table (Mechanism.turn_table) that positions are made continuous by
TURN_POINTS = 720


class Mechanism(TurnChecks):
    """A mechanism definition bound to numeric parameter values.

    All methods take an array (or scalar) of crank angles phi1 in rad.
    """

    def __init__(self, definition: MechanismDefinition, parameters: Mapping[str, float],
                 *, use_closed_form: bool = True):
        self.definition = definition
        self.parameters = dict(parameters)
        #: the [assembly] constants at these parameters (an expression's value follows them)
        self.constants = definition.constant_values(self.parameters)
        env = {**self.parameters, **self.constants}
        names = definition.variables
        self._index = {n: i for i, n in enumerate(names)}
        self.n_unknowns = len(definition.unknowns)
        self.unknown_names = list(definition.unknowns)

        # chains: contours first (their rows form F), then points
        chain_terms = [t for _, t in definition.contours]        # definition._TermSource lists
        self.point_names = list(definition.points)
        #: the points and unknowns as sets, for the load expressions' names (P_x, P_vx, U_dot) that
        #: every right-hand side of an engine looks up
        self.motion_names = MotionNames(frozenset(self.point_names), frozenset(self.unknown_names))
        chain_terms += [definition.points[p][0] for p in self.point_names]
        coef, li, ai, off, owner = [], [], [], [], []
        for c, terms in enumerate(chain_terms):
            for t in terms:
                coef.append(t.sign * _scalar(t.coefficient, env, f"{definition.name}: coefficient"))
                li.append(self._index[t.length] if t.length else -1)
                ai.append(self._index[t.angle] if t.angle else -1)
                off.append(_scalar(t.offset, env, f"{definition.name}: angle offset"))
                owner.append(c)
        n_terms, n_chains, n_q = len(coef), len(chain_terms), len(names)
        self._coef = np.array(coef, dtype=float)
        self._offset = np.array(off, dtype=float)
        self._len_idx = np.array(li, dtype=int)
        self._ang_idx = np.array(ai, dtype=int)
        self._has_len = self._len_idx >= 0
        self._has_ang = self._ang_idx >= 0
        # terms share few distinct angles (a link's angle, plus a constant offset): cos and sin are
        # taken once per distinct angle and spread over the terms, a third of the work on a four-bar
        angle_keys = list(zip(self._ang_idx.tolist(), self._offset.tolist()))
        distinct = sorted(set(angle_keys))
        self._angle_of_term = np.array([distinct.index(key) for key in angle_keys], dtype=int)
        self._distinct_idx = np.array([i for i, _ in distinct], dtype=int)
        self._distinct_has = self._distinct_idx >= 0
        self._distinct_offset = np.array([o for _, o in distinct], dtype=float)
        # incidence matrices turn per-term values into per-chain sums with one matmul
        self._sum = np.zeros((n_terms, n_chains))
        self._sum[np.arange(n_terms), owner] = 1.0
        self._len_incidence = np.zeros((n_terms, n_q))
        self._len_incidence[self._has_len, self._len_idx[self._has_len]] = 1.0
        self._ang_incidence = np.zeros((n_terms, n_q))
        self._ang_incidence[self._has_ang, self._ang_idx[self._has_ang]] = 1.0
        self._n_contour_rows = len(definition.contours)
        self._n_q = n_q
        # (term, contour, q) incidences flattened so the Jacobian is two matmuls
        k = self._n_contour_rows
        S = self._sum[:, :k]
        self._jac_len = (S[:, :, None] * self._len_incidence[:, None, :]).reshape(n_terms, k * n_q)
        self._jac_ang = (S[:, :, None] * self._ang_incidence[:, None, :]).reshape(n_terms, k * n_q)
        const = [(_scalar(xy[0], env, "fixed point"), _scalar(xy[1], env, "fixed point"))
                 for xy in [("0", "0")] * self._n_contour_rows
                 + [definition.points[p][1] for p in self.point_names]]
        self._const = np.array(const).T  # (2, n_chains)
        self.length_scale = float(np.max(np.abs(self._coef))) if n_terms else 1.0

        self._links = {}
        for lname, ld in definition.links.items():
            if ld.angle in self._index:
                self._links[lname] = (self._index[ld.angle], 0.0)
            else:
                self._links[lname] = (-1, _scalar(ld.angle, env, f"link {lname} angle"))

        self._closed_form = definition.closed_form if use_closed_form else None
        self._env = env
        self._table = None
        self._scan = None
        # the angle unknowns (columns of q): continuous along the turn, counting whole turns
        self._angle_columns = np.array([j for j, u in enumerate(self.unknown_names, start=1)
                                        if definition.unknowns[u] == "angle"], dtype=int)
        self._turn = None
        if self._closed_form is None:
            self._table = self._continuation_table()

    # ---------------------------------------------------------------- terms
    def _terms(self, q):
        L = self._coef * np.where(self._has_len, q[:, self._len_idx], 1.0)
        theta = np.where(self._distinct_has, q[:, self._distinct_idx], 0.0) + self._distinct_offset
        return L, np.cos(theta)[:, self._angle_of_term], np.sin(theta)[:, self._angle_of_term]

    def _chain_sums(self, L, c, s, dq=None, second: bool = True):
        """Positions, and with dq first derivatives and the second derivatives at ddq = 0, of every
        chain; with ``second`` False the second derivatives are NaN, not computed."""
        x = (L * c) @ self._sum + self._const[0]
        y = (L * s) @ self._sum + self._const[1]
        if dq is None:
            return x, y
        dL = self._coef * (dq @ self._len_incidence.T)
        dth = dq @ self._ang_incidence.T
        dx = (dL * c - L * dth * s) @ self._sum
        dy = (dL * s + L * dth * c) @ self._sum
        if not second:
            unknown = np.full_like(dx, np.nan)
            return x, y, dx, dy, unknown, unknown
        # r'' = L'' u + L th'' n + 2 L' th' n - L th'^2 u: here its part quadratic in dq (ddq = 0),
        # _second_linear_part adds the rest
        along = -L * dth * dth
        across = 2.0 * dL * dth
        ddx = (along * c - across * s) @ self._sum
        ddy = (along * s + across * c) @ self._sum
        return x, y, dx, dy, ddx, ddy

    def _second_linear_part(self, L, c, s, ddq, ddx0, ddy0):
        """Every chain's second derivatives: ``ddx0, ddy0`` (those at ddq = 0, _chain_sums) plus
        the part linear in ddq, L'' u + L theta'' n."""
        ddL = self._coef * (ddq @ self._len_incidence.T)
        ddth = ddq @ self._ang_incidence.T
        return (ddx0 + (ddL * c - L * ddth * s) @ self._sum,
                ddy0 + (ddL * s + L * ddth * c) @ self._sum)

    def _jacobian(self, L, c, s):
        """dF/dq for the contour rows: shape (N, 2k, n_q)."""
        # d(x_term)/dq_j = coef cos(th) [j is its length] - L sin(th) [j is its angle]
        # d(y_term)/dq_j = coef sin(th) [j is its length] + L cos(th) [j is its angle]
        n = L.shape[0]
        jx = (self._coef * c) @ self._jac_len - (L * s) @ self._jac_ang
        jy = (self._coef * s) @ self._jac_len + (L * c) @ self._jac_ang
        J = np.empty((n, self._n_contour_rows, 2, self._n_q))
        J[:, :, 0] = jx.reshape(n, self._n_contour_rows, self._n_q)
        J[:, :, 1] = jy.reshape(n, self._n_contour_rows, self._n_q)
        return J.reshape(n, 2 * self._n_contour_rows, self._n_q)

    def residual(self, q):
        """Contour equations F(q) (rows x1, y1, x2, y2, ...), m."""
        return self._residual_of(*self._terms(q))

    def _residual_of(self, L, c, s):
        x, y = self._chain_sums(L, c, s)
        k = self._n_contour_rows
        F = np.empty((L.shape[0], 2 * k))
        F[:, 0::2] = x[:, :k]
        F[:, 1::2] = y[:, :k]
        return F

    # ---------------------------------------------------------------- positions
    def positions(self, phi1) -> np.ndarray:
        """q = (phi1, unknowns...) at each crank angle, shape (N, 1 + n_unknowns).

        Raises AssemblyError where the mechanism cannot be assembled.
        """
        phi1 = np.atleast_1d(np.asarray(phi1, dtype=float))
        q = self._closed_form_positions(phi1) if self._closed_form is not None else self._newton_from_table(phi1)
        return self._count_turns(q)

    def _closed_form_positions(self, phi1) -> np.ndarray:
        """q from the file's closed form, its angles as the expressions give them (an atan2 stays
        in (-pi, pi]): :meth:`_count_turns` makes them continuous."""
        env = dict(self._env)
        # at one crank angle (the reference integrator's right-hand side) a numpy scalar: the same
        # ufunc loops, the same numbers to the bit, without an array for each operation
        one = phi1.shape == (1,)
        env["phi1"] = phi1[0] if one else phi1
        with np.errstate(invalid="ignore", divide="ignore"):
            for name, expr in self._closed_form:
                value = expr.evaluate(env, one_angle=one)
                env[name] = value if one or np.shape(value) == phi1.shape else np.broadcast_to(value, phi1.shape)
        q = np.empty((phi1.size, 1 + len(self.unknown_names)))
        q[:, 0] = phi1
        for j, u in enumerate(self.unknown_names, start=1):
            q[:, j] = env[u]
        if not np.isfinite(q).all():
            bad = ~np.all(np.isfinite(q), axis=1)
            raise self._assembly_error(phi1[bad][0], "the contour equations have no real solution")
        return q

    # ---------------------------------------------------------------- whole turns
    def turn_table(self):
        """(grid, q on it, winding): one crank turn from the assembly's start (the guess's phi1, or 0
        for a closed form) on TURN_POINTS + 1 angles, every angle unknown continuous along it, and
        each angle unknown's whole turns per crank turn (1 for a link that turns fully with the
        crank, 0 for one that oscillates). The reference every position is made continuous by.

        A closed form may use atan2 with its branch cut: its angles are unwrapped along the turn
        (a jump of a whole turn between neighbouring angles is the cut, not the motion). A jump
        that is not a whole turn cannot be unwrapped: the closed form is refused, naming it."""
        if self._turn is None:
            if self._closed_form is None:
                grid, table = self._table
                table = table.copy()
                raw = None
            else:
                grid = np.linspace(0.0, TWO_PI, TURN_POINTS + 1)
                table = self._closed_form_positions(grid)
                raw = table[:, self._angle_columns].copy()
                table[:, self._angle_columns] = np.unwrap(raw, axis=0)
            cols = self._angle_columns
            winding = np.round((table[-1, cols] - table[0, cols]) / TWO_PI)
            self._turn = (grid, table, winding)
            # positions need no counting when every angle swings (no whole turns) and the closed
            # form's values are the continuous ones, away from any odd multiple of pi (a cut could
            # lie between two table angles there): the common case, and half the cost of a position
            away = raw is None or (np.array_equal(raw, table[:, cols])
                                   and np.min(np.abs(np.mod(raw, TWO_PI) - math.pi)) > 0.1)
            self._counting = bool(np.any(winding != 0) or not away)
            self._nearest = (float(grid[0]), 1.0 / float(grid[1] - grid[0]), np.ascontiguousarray(table[:, cols]),
                             winding if np.any(winding != 0) else None)
        return self._turn

    def _count_turns(self, q) -> np.ndarray:
        """q with each angle unknown moved by whole turns to the continuous branch: the turn table's
        value nearest in phi1, plus winding whole turns per crank turn since the table's start."""
        cols = self._angle_columns
        if cols.size == 0:
            return q
        self.turn_table()
        if not self._counting:
            return q
        start, inverse_h, angles, winding = self._nearest
        rel = q[:, 0] - start
        turns = np.floor(rel * (1.0 / TWO_PI))
        # rel - 2 pi turns lies in [0, 2 pi): its nearest table angle is 0..TURN_POINTS (clipped: a
        # huge or non-finite phi1 a host's wild state gives loses that to round-off)
        with np.errstate(invalid="ignore"):
            nearest = ((rel - TWO_PI * turns) * inverse_h + 0.5).astype(np.intp)
        near = angles[np.minimum(np.maximum(nearest, 0), TURN_POINTS)]     # np.clip: 10x the overhead
        if winding is not None:
            near = near + TWO_PI * turns[:, None] * winding
        q[:, cols] += TWO_PI * np.round((near - q[:, cols]) * (1.0 / TWO_PI))
        return q

    def _newton(self, q, max_iter=50):
        tol = 1e-13 * self.length_scale
        for _ in range(max_iter):
            F = self.residual(q)
            if np.max(np.abs(F)) <= tol:
                return q, True
            L, c, s = self._terms(q)
            Ju = self._jacobian(L, c, s)[:, :, 1:]
            try:
                step = np.linalg.solve(Ju, F[..., None])[..., 0]
            except np.linalg.LinAlgError:
                return q, False
            q = q.copy()
            q[:, 1:] -= step
        return q, np.max(np.abs(self.residual(q))) <= 1e3 * tol

    def _continuation_table(self, n=720):
        """Newton continuation over one turn from the file's assembly guess."""
        g = self.definition.guess
        env = dict(self._env)
        phi_start = _scalar(g.get("phi1", "0"), env, "assembly guess phi1")
        q = np.array([[phi_start] + [_scalar(g[u], env, f"assembly guess {u}") for u in self.unknown_names]])
        q, ok = self._newton(q)
        if not ok:
            raise self._assembly_error(phi_start, "Newton's method did not converge from the file's guess")
        grid = phi_start + np.linspace(0.0, TWO_PI, n + 1)
        table = np.empty((n + 1, q.shape[1]))
        table[0] = q[0]
        h = grid[1] - grid[0]
        for i in range(1, n + 1):
            k = self.kinematics_from_q(table[i - 1:i])
            d = np.array([[1.0] + [k.dq[u][0] for u in self.unknown_names]])
            dd = np.array([[0.0] + [k.ddq[u][0] for u in self.unknown_names]])
            guess = table[i - 1:i] + h * d + 0.5 * h * h * dd
            qi, ok = self._newton(guess)
            if not ok:
                raise self._assembly_error(grid[i], "the continuation lost the assembly")
            table[i] = qi[0]
        # one turn of the crank must bring every unknown back (angles modulo 2 pi)
        for j, u in enumerate(self.unknown_names, start=1):
            delta = table[-1, j] - table[0, j]
            if self.definition.unknowns[u] == "angle":
                delta = (delta + math.pi) % TWO_PI - math.pi
            if abs(delta) > 1e-8 * max(1.0, self.length_scale):
                raise self._assembly_error(
                    grid[-1], f"after one crank turn {u} does not return to its start (branch change)")
        return grid, table

    def _newton_from_table(self, phi1):
        grid, table = self._table
        h = grid[1] - grid[0]
        rel = np.mod(phi1 - grid[0], TWO_PI)
        idx = np.rint(rel / h).astype(int)
        idx = np.clip(idx, 0, len(grid) - 1)
        dphi = rel - (grid[idx] - grid[0])
        base = table[idx].copy()
        kin = self.kinematics_from_q(base)
        d = np.column_stack([np.ones_like(dphi)] + [kin.dq[u] for u in self.unknown_names])
        dd = np.column_stack([np.zeros_like(dphi)] + [kin.ddq[u] for u in self.unknown_names])
        q = base + dphi[:, None] * d + 0.5 * (dphi ** 2)[:, None] * dd
        q[:, 0] = phi1
        q, ok = self._newton(q)
        if not ok:
            raise self._assembly_error(phi1[0], "Newton's method did not converge")
        return q

    # ---------------------------------------------------------------- derivatives
    def kinematics(self, phi1) -> Kinematics:
        """Positions and first and second transfer functions at each crank angle."""
        return self.kinematics_from_q(self.positions(phi1))

    def kinematics_from_q(self, q, second: bool = True, terms=None) -> Kinematics:
        """Kinematics at solved positions ``q``; with ``second`` False the second transfer functions
        are not solved for and are NaN (a search on first transfer functions skips that solve).
        ``terms``: the positions' terms (``_terms(q)``), when the caller has them."""
        L, c, s = self._terms(q) if terms is None else terms
        J = self._jacobian(L, c, s)
        Ju, Jphi = J[:, :, 1:], J[:, :, 0]
        n = q.shape[0]
        dq = np.zeros_like(q)
        dq[:, 0] = 1.0
        try:
            dq[:, 1:] = np.linalg.solve(Ju, -Jphi[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise self._assembly_error(q[0, 0], "the contour Jacobian is singular (dead point)") from None
        k = self._n_contour_rows
        if second:
            # every chain's position and derivatives, its second derivatives those at ddq = 0 (the
            # part quadratic in dq): the contour rows of that part are the second solve's right side
            sums = self._chain_sums(L, c, s, dq)
            rhs = np.empty((n, 2 * k))
            rhs[:, 0::2] = sums[4][:, :k]
            rhs[:, 1::2] = sums[5][:, :k]
            ddq = np.zeros_like(q)
            ddq[:, 1:] = np.linalg.solve(Ju, -rhs[..., None])[..., 0]
        else:
            ddq = np.full_like(q, np.nan)

        def points():
            # r'' is linear in ddq: the quadratic part above plus L'' u + L theta'' n
            x, y, dx, dy, ddx, ddy = (sums[:4] + self._second_linear_part(L, c, s, ddq, *sums[4:]) if second
                                      else self._chain_sums(L, c, s, dq, second=False))
            return {p: PointMotion(x[:, k + i], y[:, k + i], dx[:, k + i], dy[:, k + i], ddx[:, k + i], ddy[:, k + i])
                    for i, p in enumerate(self.point_names)}
        names = self.unknown_names
        links = {}
        for lname, (idx, const) in self._links.items():
            if idx >= 0:
                links[lname] = (q[:, idx], dq[:, idx], ddq[:, idx])
            else:
                z = np.zeros(n)
                links[lname] = (np.full(n, const), z, z)
        return Kinematics(
            phi1=q[:, 0],
            q={u: q[:, j + 1] for j, u in enumerate(names)},
            dq={u: dq[:, j + 1] for j, u in enumerate(names)},
            ddq={u: ddq[:, j + 1] for j, u in enumerate(names)},
            points=OnDemand(points),
            link_angles=links,
        )

    def angle_of(self, angle: str, kin: Kinematics) -> np.ndarray:
        """An angle named in the file (a slide's axis, a link's angle) at the kinematics' crank
        angles, rad: phi1, an angle unknown, or a constant expression of the parameters."""
        if angle == "phi1":
            return kin.phi1
        if angle in kin.q:
            return kin.q[angle]
        return np.full(kin.phi1.shape, _scalar(angle, self._env, f"{self.definition.name}: angle {angle}"))

    # ---------------------------------------------------------------- refusals
    def _assembly_error(self, phi1, reason):
        params = self.definition.geometry_parameters
        values = ", ".join(f"{p} = {self.parameters[p]:g}" for p in params if p in self.parameters)
        return AssemblyError(
            f"{self.definition.name}: the geometry cannot be assembled over the whole crank turn: "
            f"at phi1 = {math.degrees(float(phi1)) % 360:.3f} deg {reason} "
            f"(branch: {self.definition.branch}; geometry parameters {values})",
            parameter=", ".join(params),
        )


def _scalar(source: str, env: Mapping[str, float], where: str) -> float:
    value = Expression(source, where).evaluate(env)
    value = float(np.asarray(value))
    if not math.isfinite(value):
        raise DefinitionError(f"{where}: {source!r} is not finite")
    return value
