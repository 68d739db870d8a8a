"""Periodic functions of the crank angle as piecewise cubics with a checked error bound: the
construction every table of dynamics/tabulated.py uses (the reduced model, the [[outputs]], the
joint reactions), and native/mechanism/crank_tabulator.c repeats in C.

A function is sampled from its engine (a callable of an array of crank angles giving one row per
function) and held as one local cubic per interval of a uniform grid over the turn, so evaluating
it costs one index computation and a few multiply-adds. First by the Fourier series of a few
samples, then Hermite cubics of it (:func:`from_series`); where the series does not converge (a
load with a kink, a dead point near), by the periodic cubic spline of the samples
(:func:`from_samples`). Either way the cubics are checked against the engine and the largest
relative difference is returned with them.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import SchemeError, format_value
from ..numerics import periodic_cubic_spline, periodic_hermite, periodic_series, series_on_grid

TWO_PI = 2.0 * math.pi


def evaluate_cubics(coefficients: np.ndarray, phi1, period: float = TWO_PI) -> np.ndarray:
    """Periodic piecewise cubics (functions, n, 4) on n intervals of ``period`` rad (one turn, or
    a machine cycle of several) at an array of crank angles."""
    phi1 = np.atleast_1d(np.asarray(phi1, dtype=float))
    n = coefficients.shape[1]
    h = period / n
    wrapped = phi1 - period * np.floor(phi1 / period)
    i = np.minimum((wrapped / h).astype(np.int64), n - 1)
    return horner(coefficients[:, i, :], wrapped - i * h)


def horner(c: np.ndarray, u) -> np.ndarray:
    """Local cubics c0 + u (c1 + u (c2 + u c3)) (coefficients on the last axis) at offsets u."""
    return c[..., 0] + u * (c[..., 1] + u * (c[..., 2] + u * c[..., 3]))

def build_cubics(engine, tolerance: float, n_start: int, n_max: int, loosest: float, named=("the functions", ()),
                 turns: int = 1):
    """(coefficients, checked error, construction) of the functions ``engine`` gives, periodic
    over ``turns`` crank turns (a machine's cycle: a four-stroke engine's gas force repeats every
    2): a Fourier series where it converges, else a spline of samples, on intervals of
    2 pi turns / n. ``named``: (what the functions are, each row's name[, the rows that are
    kinematics only]), for the message of a table that cannot be built. A function that does
    not repeat after the cycle is refused first, by name."""
    not_periodic = _not_periodic(engine, named, turns)
    if not_periodic:
        raise SchemeError(not_periodic)
    # the constructions work on one period of 2 pi: in theta = phi1 / turns, then the cubics are
    # rescaled to phi1 (u_phi = turns u_theta: c_k / turns^k; exact, so one turn is unchanged)
    on_theta = (lambda theta: engine(np.asarray(theta) * turns)) if turns != 1 else engine  # noqa: E731
    coefficients, error, construction = (from_series(on_theta, tolerance)
                                         or from_samples(on_theta, tolerance, n_start, n_max, loosest, named, turns))
    if turns == 1:
        return coefficients, error, construction
    return coefficients / (float(turns) ** np.arange(4)), error, f"{construction} over a cycle of {turns} turns"


def _name(named, row: int) -> str:
    names = named[1]
    return names[row] if row < len(names) else f"function {row}"


def _not_periodic(engine, named, turns: int = 1, probes: int = 36) -> str | None:
    """Why the functions cannot be held over the declared cycle of ``turns`` crank turns, if one of
    them differs from itself a cycle later (a four-stroke engine's gas force repeats every two
    turns): such a function is no jump nor dead point but a longer cycle, and the message says
    which cycle_turns holds it. None if each repeats after the cycle to round-off. (Non-finite
    values are left to the tabulator's message.)"""
    cycle = turns * TWO_PI
    phi = (np.arange(probes * turns) + 0.37) * (TWO_PI / probes)
    first, next_cycle = engine(phi), engine(phi + cycle)
    if not (np.isfinite(first).all() and np.isfinite(next_cycle).all()):
        return None
    scale = np.maximum(_scale(first), _scale(next_cycle))
    gap = np.abs(next_cycle - first) / scale[:, None]
    row, k = np.unravel_index(int(np.argmax(gap)), gap.shape)
    if gap[row, k] <= 1e-9:
        return None
    longer = [n for n in range(turns + 1, 4 * turns + 1) if n % turns == 0 or turns == 1] + [6, 8]
    found = next((n for n in dict.fromkeys(longer) if n > turns
                  and np.max(np.abs(engine(phi + n * TWO_PI) - first) / scale[:, None]) <= 1e-9), None)
    declared = "one crank turn" if turns == 1 else f"the declared cycle of {turns} turns (cycle_turns = {turns})"
    later = "a turn" if turns == 1 else "a cycle"
    if found:
        way = (f"it repeats every {found} turns" + (" (a four-stroke engine's cycle)" if found == 2 else "")
               + f": declare cycle_turns = {found} at the scenario's top level")
    else:
        way = (f"it does not repeat after {', '.join(str(n) for n in dict.fromkeys(longer) if n > turns)} turns "
               "either: a load must repeat over the machine's cycle (write it periodic, or use method 'reference', "
               "which evaluates the loads at every angle)")
    return (f"{named[0]}: {_name(named, row)} is not periodic over {declared}: {first[row, k]:.6g} at "
            f"phi1 = {math.degrees(phi[k]):.2f} deg but {next_cycle[row, k]:.6g} {later} later "
            f"(phi1 = {math.degrees(phi[k] + cycle):.2f} deg); {way}")


def _not_finite(what: str, name: str, value: float, phi1: float, digits: int = 2) -> str:
    return (f"{what}: {name} is not finite ({value:g}) at phi1 = {math.degrees(phi1):.{digits}f} deg: an expression "
            "of the data file divides by zero or overflows there (crankfmu check names it)")


def _why_not_tabulated(values: np.ndarray, errors: np.ndarray, named, tolerance: float, n: int, engine=None,
                       turns: int = 1) -> str:
    """The message of a table that cannot be built: which function, and why. A value that is not
    finite; a jump (a discontinuity in phi1, e.g. a closed form's branch cut: no number of
    intervals follows it); a dead point (the kinematics themselves steep); or a steep but
    continuous load that needs more intervals than the limit (its slope, and the way out)."""
    what = named[0]
    finite = np.isfinite(values)
    if not finite.all():       # NaN or infinite: no table of any size follows it, and it is no dead point
        row = int(np.argmin(finite.all(axis=1)))
        k = int(np.flatnonzero(~finite[row])[0])
        return _not_finite(what, _name(named, row), values[row, k], turns * k * TWO_PI / n)
    row = int(np.argmax(errors))
    name = _name(named, row)
    h = TWO_PI / n
    steps = np.abs(np.diff(np.append(values[row], values[row, 0])))
    k = int(np.argmax(steps))
    at = f"phi1 = {math.degrees(turns * k * h):.2f} to {math.degrees(turns * (k + 1) * h):.2f} deg"
    head = f"{what}: {name} cannot be tabulated to {format_value(tolerance)} with {n} intervals (error {errors[row]:.2g})"
    change = values[row, (k + 1) % n] - values[row, k]
    kinematic = set(named[2]) if len(named) > 2 else set(range(values.shape[0]))
    inside = fine = None
    if engine is not None:
        # look inside the interval (crank_tabulator.c does the same): a jump stays in one of 1024
        # sub-intervals however fine; a steep function (the kinematics near a dead point, a peaky
        # load) spreads its change over many
        fine = np.linspace(k * h, (k + 1) * h, 1025)
        inside = engine(fine)[row]
        if not np.isfinite(inside).all():
            bad = int(np.flatnonzero(~np.isfinite(inside))[0])
            return _not_finite(what, name, inside[bad], turns * fine[bad], digits=4)
        sub = np.abs(np.diff(inside))
        jump = abs(change) > 0 and sub.max() > 0.5 * abs(change) and sub.max() > 1e3 * np.median(sub) + 1e-300
    else:
        jump = steps[k] > 1e3 * (float(np.median(steps)) + 1e-300)
    if jump:
        return (f"{head}: it jumps by {change:.4g} between {at}, a discontinuity in the crank angle (a closed "
                "form's branch cut, or a load written with a step), not a dead point; no number of intervals follows a "
                "jump: write the function continuous, or use method 'reference'")
    kinematics_fine = all(errors[r] <= tolerance for r in kinematic if r < len(errors))
    if row not in kinematic and kinematics_fine:
        slope = (float(np.max(np.abs(np.diff(inside) / np.diff(fine)))) if inside is not None else steps[k] / h) / turns
        needed = n * max(2.0, (errors[row] / tolerance) ** 0.25)
        return (f"{head}: it is continuous but steep, up to {slope:.4g} per rad near {at} (the mechanism's "
                f"kinematics tabulate well there: no dead point); it needs about {needed:.3g} intervals, beyond the "
                f"limit of {n}: use method 'reference', which evaluates it at every angle, or make the load less steep")
    return (f"{head}: it changes fastest between {at}; the mechanism is too close to a dead point there; "
            "use method 'reference'")


def _scale(values: np.ndarray) -> np.ndarray:
    """Each function's largest magnitude: what its error is relative to."""
    return np.maximum(np.max(np.abs(values), axis=1), 1e-300)


def from_series(engine, tolerance: float, n_first: int = 64, n_last: int = 4096, m_last: int = 1 << 16):
    """(coefficients, checked error, construction) from the functions' Fourier series, or None.

    J, 0.5 J' and the smooth loads are periodic and analytic in phi1 away from dead points: their
    trigonometric interpolant on n samples converges geometrically (seed 000: 1e-13 at n = 128),
    so far fewer engine evaluations are needed than for a spline to the same error. The samples
    double until the interpolant agrees with the engine to half ``tolerance`` at the midpoints
    between samples (where its error peaks; they become the next level's samples) and at a
    staggered quarter of them (0.3 of an interval in). The kernel's piecewise cubics are then the
    Hermite cubics of the series' values and slopes on m intervals, m growing until they agree
    with the series to the other half: proven by the series' bound on the fourth derivative, or
    else checked at every interval's midpoint (where a Hermite cubic's error peaks). None when
    the samples stop converging geometrically (a load with a kink in phi1, a dead point near):
    the spline of the samples takes over.
    """
    budget = 0.5 * tolerance

    def checks(n):                # the midpoints between n samples, then a staggered quarter of them
        h = TWO_PI / n
        return np.concatenate([(np.arange(n) + 0.5) * h, (np.arange(0, n, 4) + 0.3) * h])

    n = n_first
    first = engine(np.concatenate([np.arange(n) * (TWO_PI / n), checks(n)]))     # one engine call
    samples, exact = first[:, :n], first[:, n:]
    last = math.inf
    while True:
        h = TWO_PI / n
        scale = np.maximum(_scale(samples), _scale(exact))
        series = periodic_series(samples)
        interpolant = np.concatenate([series_on_grid(series, n, n, 0.5 * h),
                                      series_on_grid(series, n, n, 0.3 * h)[:, ::4]], axis=1)
        error = float(np.max(np.max(np.abs(interpolant - exact), axis=1) / scale))
        if error <= budget:
            break
        if 2 * n > n_last or (n >= 4 * n_first and error > 0.25 * last):
            return None
        last = error
        merged = np.empty((samples.shape[0], 2 * n))
        merged[:, 0::2], merged[:, 1::2] = samples, exact[:, :n]
        samples, n = merged, 2 * n
        exact = engine(checks(n))
    # a Hermite cubic's error at an interval's midpoint is h^4 / 384 times the fourth derivative
    # there, which the series bounds by sum k^4 |a_k|: start at the power of two nearest the m this
    # predicts (the bound is pessimistic, by up to 1.4 in m on the seeds), so one build usually does
    amplitude = np.abs(series) * (2.0 / n)
    amplitude[:, 0] *= 0.5
    fourth = float(np.max(np.sum(np.arange(series.shape[1]) ** 4 * amplitude, axis=1) / scale))
    m = max(n, 2 ** round(math.log2(max(TWO_PI * (fourth / (384.0 * budget)) ** 0.25, 1.0))))
    m = min(m, m_last)
    while True:
        hm = TWO_PI / m
        cubics = periodic_hermite(series_on_grid(series, n, m), series_on_grid(series, n, m, derivative=True), TWO_PI)
        cubic_error = hm ** 4 / 384.0 * fourth                   # proven: no angle can exceed it
        if cubic_error > budget:                                 # the bound is pessimistic: measure
            at_midpoints = horner(cubics, 0.5 * hm)
            cubic_error = float(np.max(np.max(np.abs(at_midpoints - series_on_grid(series, n, m, 0.5 * hm)),
                                              axis=1) / scale))
        if cubic_error <= budget:
            return cubics, error + cubic_error, f"Fourier series of {n} samples, Hermite cubics on {m} intervals"
        # a Hermite cubic's error falls as h^4: jump to the m it predicts (at least doubling)
        m *= 2 ** max(1, math.ceil(0.25 * math.log2(cubic_error / budget)))
        if m > m_last:
            return None


def from_samples(engine, tolerance: float, n_start: int, n_max: int, loosest: float,
                  named=("the functions", ()), turns: int = 1):
    """(coefficients, checked error, construction) of the periodic cubic spline of the engine's
    samples, the intervals halved until the spline agrees with the engine to ``tolerance``."""
    n = n_start
    while True:
        nodes = np.linspace(0.0, TWO_PI, n + 1)
        values = engine(nodes[:-1])
        coefficients = periodic_cubic_spline(values, TWO_PI)
        # the error of a cubic spline peaks near the interval midpoints; the staggered set
        # (0.3 of an interval in) catches a spline that is right at midpoints only
        h = TWO_PI / n
        check = np.concatenate([nodes[:-1] + 0.5 * h, nodes[:-1] + 0.3 * h])
        errors = np.max(np.abs(evaluate_cubics(coefficients, check) - engine(check)), axis=1) / _scale(values)
        error = float(np.max(errors))
        if error <= tolerance:
            break
        if 2 * n > n_max:
            if error <= loosest:
                break
            raise SchemeError(_why_not_tabulated(values, errors, named, tolerance, n, engine, turns))
        n *= 2
    return coefficients, error, f"cubic spline of {n} samples"
