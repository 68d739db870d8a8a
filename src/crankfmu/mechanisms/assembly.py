"""The contour engine's checks over the whole crank turn (contour.Mechanism inherits them): the
assembly check (the conditioning's sign followed over the turn scan, the worst refined, a closed
form's residual and jumps), and the crank angles where a quantity crosses given levels (a rocker's
or a slider's extremes, the loads' switch angles).

They read the engine's terms, positions and kinematics: the methods ``_terms``, ``_jacobian``,
``_residual_of``, ``positions``, ``_closed_form_positions``, ``kinematics_from_q``, ``turn_table``
and ``_assembly_error``, and the attributes ``_scan`` (None until the scan is made),
``_closed_form``, ``_angle_columns``, ``unknown_names``, ``length_scale`` and ``definition``.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import DefinitionError
from ..numerics import bracketed_roots, determinants

TWO_PI = 2.0 * math.pi
#: crank angles of the turn scan (every 0.25 deg): the assembly check and stationary angles
SCAN_POINTS = 1440
#: the slowest conditioning the assembly check accepts (the contour Jacobian's determinant over its
#: scale): below it the mechanism locks
MIN_CONDITIONING = 1e-6


class TurnChecks:
    """The checks and searches over one crank turn of a bound mechanism (contour.Mechanism)."""

    def conditioning(self, phi1) -> np.ndarray:
        """|det| of the column-normalised contour Jacobian: 1 = orthogonal columns, 0 = dead point.

        By Hadamard's inequality it lies in [0, 1]; for the four-bar it is |sin(phi3 - phi2)|,
        the sine of the transmission angle.
        """
        return np.abs(self._signed_conditioning(phi1))

    def _signed_conditioning(self, phi1) -> np.ndarray:
        return self._signed_conditioning_of(*self._terms(self.positions(phi1)))

    def _signed_conditioning_of(self, L, c, s) -> np.ndarray:
        """det of the column-normalised contour Jacobian: continuous along an assembly branch, so a
        change of its sign between two crank angles puts a dead point between them."""
        Ju = self._jacobian(L, c, s)[:, :, 1:]
        return determinants(Ju / np.linalg.norm(Ju, axis=1, keepdims=True))

    def _turn_scan(self):
        """(crank angles, positions, their terms) every 0.25 deg over one turn, computed once per
        bound mechanism: the assembly check and the search for stationary angles both start there."""
        if self._scan is None:
            grid = np.linspace(0.0, TWO_PI, SCAN_POINTS, endpoint=False)
            q = self.positions(grid)
            self._scan = (grid, q, self._terms(q))
        return self._scan

    def stationary_angles(self, transfer, n_grid: int = 720) -> list[tuple[float, bool]]:
        """Crank angles (rad, in [0, 2 pi)) where ``transfer(kinematics)`` (a first transfer function,
        e.g. dphi3/dphi1) vanishes, each with whether it rises through zero there: the extreme
        positions of a rocker or a slider."""
        return [(angle, rising) for angle, rising, _ in self.crossings(transfer, [0.0], n_grid)]

    def crossings(self, quantity, levels, n_grid: int = 720) -> list[tuple[float, bool, float]]:
        """(crank angle rad in [0, 2 pi), whether it rises there, level) wherever
        ``quantity(kinematics)`` (positions and first transfer functions: a slider's position, a
        rocker's rate) crosses one of ``levels`` over a turn, sorted by angle. Sign changes on
        ``n_grid`` angles of the turn scan (n_grid divides its 1440), then every crossing at once by
        the secant method in its bracket (numerics.bracketed_roots) on the analytic quantity."""
        if SCAN_POINTS % n_grid:
            raise ValueError(f"crossings: n_grid must divide {SCAN_POINTS}, got {n_grid}")
        at = lambda a: quantity(self.kinematics_from_q(self.positions(a), second=False))  # noqa: E731
        scan, q, terms = self._turn_scan()
        every = SCAN_POINTS // n_grid
        values = quantity(self.kinematics_from_q(q[::every], second=False, terms=[t[::every] for t in terms]))
        grid, values = np.append(scan[::every], TWO_PI), np.append(values, values[0])    # periodic
        i, level = [], []
        for value in levels:
            d = values - value
            found = np.nonzero((d[:-1] == 0.0) | (d[:-1] * d[1:] < 0.0))[0]
            i, level = i + list(found), level + [value] * found.size
        i, level = np.array(i, dtype=int), np.array(level, dtype=float)
        roots = bracketed_roots(at, grid[i], grid[i + 1], values[i] - level, values[i + 1] - level,
                                xtol=1e-15, rtol=1e-15, ftol=16 * np.finfo(float).eps * np.max(np.abs(values)),
                                levels=level)
        return sorted((float(root) % TWO_PI, bool(rising), float(v))
                      for root, rising, v in zip(roots, values[i + 1] > level, level))

    def check_assembly(self, coarse: bool = False, min_conditioning: float = MIN_CONDITIONING):
        """Refuse a geometry that cannot be assembled over the whole turn, or locks at a dead point.

        The conditioning's sign is followed over the turn scan (every 0.25 deg; every 0.5 deg if
        ``coarse``): a change of sign between two angles is a dead point between them. Where it keeps
        its sign, its smallest magnitude is refined on 65 angles between the neighbouring scan
        angles, whose signs are followed too: a lock too narrow to change the sign of any of them
        still brings the magnitude there down quadratically. Returns (worst conditioning, crank
        angle where it occurs in rad), the worst value to about 3e-9.
        """
        if coarse:
            grid = np.linspace(0.0, TWO_PI, SCAN_POINTS // 2, endpoint=False)
            terms = self._terms(self.positions(grid))
        else:
            grid, _, terms = self._turn_scan()
        scale = np.max(np.abs(self._residual_of(*terms)))
        if scale > 1e-9 * self.length_scale:
            raise DefinitionError(
                f"{self.definition.name}: the closed form does not satisfy the contour equations "
                f"(residual {scale:.3g} m); check the mechanism file")
        signed = self._signed_conditioning_of(*terms)
        h = grid[1] - grid[0]
        self._refuse_sign_change(grid, h, signed, np.append(signed[1:], signed[0]))
        i = int(np.argmin(np.abs(signed)))
        # refine the minimum between scan angles: a lock can hide between two of them
        near = np.linspace(grid[i] - h, grid[i] + h, 65)
        near_signed = self._signed_conditioning(near)
        self._refuse_sign_change(near[:-1], near[1] - near[0], near_signed[:-1], near_signed[1:])
        j = int(np.argmin(np.abs(near_signed)))
        worst, at = min((abs(float(near_signed[j])), float(near[j])), (abs(float(signed[i])), float(grid[i])))
        if worst < min_conditioning:
            raise self._assembly_error(
                at, f"the mechanism locks at a dead point (conditioning {worst:.2e} < {min_conditioning:g})")
        if self._closed_form is not None:
            self._refuse_jumps()
        return worst, at

    def _refuse_sign_change(self, angles, h, signed, signed_next):
        """AssemblyError at the first dead point that a sign change of the conditioning between
        ``angles`` and ``angles + h`` puts there, located to rounding."""
        flips = np.nonzero(np.signbit(signed) != np.signbit(signed_next))[0]
        if flips.size:
            k = flips[:1]
            at = bracketed_roots(self._signed_conditioning, angles[k], angles[k] + h, signed[k], signed_next[k])[0]
            raise self._assembly_error(
                at, "the mechanism passes a dead point (the contour Jacobian's determinant changes sign; "
                    "or the closed form jumps between assembly branches)")

    def _refuse_jumps(self):
        """DefinitionError where an unwrapped closed-form unknown still jumps: its increment between
        neighbouring angles of the turn table against the trapezoid rule on its exact transfer
        function (the assembly check runs it last, on a geometry that closes and has no dead point)."""
        grid, table, _ = self.turn_table()
        cols = self._angle_columns
        # the transfer functions on the table, once for every unknown
        rates = self.kinematics_from_q(self._closed_form_positions(grid), second=False).dq
        for j, name in enumerate(self.unknown_names, start=1):
            scale = TWO_PI if j in cols else max(self.length_scale, 1e-300)
            a, b = grid[:-1], grid[1:]
            miss = np.abs(np.diff(table[:, j]) - 0.5 * (b - a) * (rates[name][:-1] + rates[name][1:]))
            i = int(np.argmax(miss))
            # a steep but continuous function misses by h^3/12 |q'''|: refine the worst interval until
            # it either closes (smooth) or keeps the same gap however fine (a jump)
            lo, hi = float(a[i]), float(b[i])
            gaps = [float(miss[i])]
            for _ in range(3):
                if gaps[-1] <= 1e-3 * scale or (len(gaps) > 1 and gaps[-1] < 0.25 * gaps[-2]):
                    break                    # closed, or closing as the interval shrinks: steep, not a jump
                fine = np.linspace(lo, hi, 65)
                q = self._closed_form_positions(fine)
                q[:, cols] = np.unwrap(q[:, cols], axis=0)
                q[:, cols] += TWO_PI * np.round((table[i, cols] - q[0, cols]) / TWO_PI)
                miss = self._trapezoid_miss(fine[:-1], fine[1:], q[:-1, j], q[1:, j], j)
                i = int(np.argmax(miss))
                lo, hi = float(fine[i]), float(fine[i + 1])
                gap = float(q[i + 1, j] - q[i, j])
                gaps.append(float(miss[i]))
            else:
                unit = "rad" if j in cols else "m"
                what = "not a whole turn, so it cannot be made continuous" if unit == "rad" else "a length cannot jump"
                raise DefinitionError(
                    f"{self.definition.name}: the closed form of {name} jumps by {gap:.4g} {unit} at phi1 = "
                    f"{math.degrees(lo):.4f} deg ({what}); write it continuous along the turn, or give a guess "
                    "instead of a closed form")

    def _trapezoid_miss(self, a, b, qa, qb, j) -> np.ndarray:
        """|q(b) - q(a) - (b - a) (q'(a) + q'(b)) / 2| for unknown column j on each interval (the
        transfer functions from the closed form as written: they do not see whole turns)."""
        name = self.unknown_names[j - 1]
        ka = self.kinematics_from_q(self._closed_form_positions(np.asarray(a, dtype=float)), second=False)
        kb = self.kinematics_from_q(self._closed_form_positions(np.asarray(b, dtype=float)), second=False)
        return np.abs(qb - qa - 0.5 * (b - a) * (ka.dq[name] + kb.dq[name]))
