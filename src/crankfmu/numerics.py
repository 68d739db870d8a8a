"""Small numerical tools of the core, on numpy alone.

The core (mechanisms, dynamics, the fast integrator) runs inside the FMUs, where only numpy may be
assumed on the host's machine; scipy stays for the studies and the reference integrators, which
run in crankfmu's own environment. Each tool here is the textbook method, stated once:

- ``bracketed_roots``: the secant method kept in its brackets, on many brackets at once, one
  vectorised call of f per iteration;
- ``determinants``: determinants of a batch of small matrices;
- ``periodic_cubic_spline``: the C2 periodic cubic spline on a uniform grid; its second
  derivatives solve a circulant system (M[i-1] + 4 M[i] + M[i+1] = 6 d2y[i] / h**2), diagonal in
  Fourier space, so one FFT solves it exactly.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import DefinitionError

_EPS = np.finfo(float).eps


def bracketed_roots(f, a, b, fa, fb, xtol: float = 1e-15, rtol: float = 4 * _EPS, ftol: float = 0.0,
                    maxiter: int = 100, levels=None) -> np.ndarray:
    """A root of the vectorised ``f`` in each bracket [a_i, b_i] (f(a_i), f(b_i) of opposite signs
    or one zero), all brackets at once: one call of ``f`` per iteration on the brackets not yet
    converged. The secant through the last two iterates (superlinear), kept inside the bracket,
    which every value of f narrows: a secant point outside it, or not finite, is replaced by the
    bracket's midpoint. A root is done when the step falls to xtol + 2 rtol |x|, or |f| to ``ftol``
    (f's rounding level, below which a secant only follows rounding noise).

    With ``levels``, bracket i seeks f = levels[i] instead (fa, fb, ftol stay those of f - level):
    the crossings of several levels by one function in one search."""
    a, b = np.array(a, dtype=float), np.array(b, dtype=float)
    fa, fb = np.array(fa, dtype=float), np.array(fb, dtype=float)
    levels = np.broadcast_to(np.asarray(0.0 if levels is None else levels, dtype=float), a.shape)
    if np.any(fa * fb > 0.0):
        raise DefinitionError("bracketed_roots: f has the same sign at both ends of a bracket")
    x0, f0, x1, f1 = a.copy(), fa.copy(), b.copy(), fb.copy()
    root = np.where(fa == 0.0, a, b)
    active = (fa != 0.0) & (fb != 0.0)
    for _ in range(maxiter):
        if not np.any(active):
            break
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        with np.errstate(invalid="ignore", divide="ignore"):
            c = x1 - f1 * (x1 - x0) / (f1 - f0)
        c = np.where((c >= lo) & (c <= hi), c, 0.5 * (lo + hi))
        fc = np.zeros_like(c)
        fc[active] = f(c[active]) - levels[active]
        keep_a = fc * fa < 0.0                       # the root lies between a and c
        b, fb = np.where(keep_a, c, b), np.where(keep_a, fc, fb)
        a, fa = np.where(keep_a, a, c), np.where(keep_a, fa, fc)
        step = np.abs(c - x1)
        x0, f0, x1, f1 = x1, f1, c, fc
        root = np.where(active, c, root)
        tol = 2.0 * rtol * np.abs(c) + xtol
        active &= (np.abs(fc) > ftol) & (step > 0.5 * tol) & (np.abs(b - a) > tol)
    return root


def determinants(A: np.ndarray) -> np.ndarray:
    """det of each matrix of a batch (..., k, k). For k <= 2 by the formula: numpy's det factors
    each matrix in its own LAPACK call, ten times slower on the turn scan's 1440 2x2 matrices."""
    k = A.shape[-1]
    if k == 1:
        return A[..., 0, 0].copy()
    if k == 2:
        return A[..., 0, 0] * A[..., 1, 1] - A[..., 0, 1] * A[..., 1, 0]
    return np.linalg.det(A)


def periodic_cubic_spline(values: np.ndarray, period: float) -> np.ndarray:
    """Local cubic coefficients of the C2 periodic spline through ``values`` (functions x n samples
    at k * period / n, k = 0..n-1): shape (functions, n, 4), c0 + u (c1 + u (c2 + u c3)) with u the
    distance from the interval's left node."""
    y = np.atleast_2d(np.asarray(values, dtype=float))
    n = y.shape[1]
    h = period / n
    y_next = np.roll(y, -1, axis=1)
    second_difference = y_next - 2.0 * y + np.roll(y, 1, axis=1)
    eigen = 4.0 + 2.0 * np.cos(2.0 * math.pi * np.arange(n) / n)          # circulant [1 4 1]
    M = np.fft.ifft(np.fft.fft(6.0 * second_difference / (h * h), axis=1) / eigen, axis=1).real
    M_next = np.roll(M, -1, axis=1)
    c = np.empty(y.shape + (4,))
    c[..., 0] = y
    c[..., 1] = (y_next - y) / h - h * (2.0 * M + M_next) / 6.0
    c[..., 2] = 0.5 * M
    c[..., 3] = (M_next - M) / (6.0 * h)
    return c


def periodic_series(samples: np.ndarray) -> np.ndarray:
    """The trigonometric interpolant of ``samples`` (functions x n at k 2 pi / n, n even) as its
    real-FFT coefficients, shape (functions, n / 2 + 1); evaluated by :func:`series_on_grid`."""
    return np.fft.rfft(np.atleast_2d(samples), axis=1)


def series_on_grid(series: np.ndarray, n: int, m: int, shift: float = 0.0, derivative: bool = False) -> np.ndarray:
    """The interpolant of ``n`` samples (``series`` from :func:`periodic_series`), or its first
    derivative, at the ``m`` angles k 2 pi / m + shift (m a multiple of n): zero padding of the
    spectrum, the n / 2 term split between +n/2 and -n/2 once it is no longer the grid's last."""
    k = np.arange(m // 2 + 1)
    padded = np.zeros((series.shape[0], m // 2 + 1), dtype=complex)
    padded[:, :n // 2 + 1] = series * (m / n)
    if m > n:
        padded[:, n // 2] *= 0.5
    if shift:
        padded *= np.exp(1j * k * shift)
    if derivative:
        padded *= 1j * k
    return np.fft.irfft(padded, m, axis=1)


def periodic_hermite(values: np.ndarray, slopes: np.ndarray, period: float) -> np.ndarray:
    """Local cubic coefficients (as :func:`periodic_cubic_spline`) of the C1 periodic Hermite
    cubics through ``values`` with ``slopes`` at k * period / n.

    Written in place in the result: the tables are large (4096 intervals), and every temporary
    array of that size costs fresh pages from the allocator (6x the arithmetic, measured)."""
    h = period / values.shape[1]
    c = np.empty(values.shape + (4,))
    c[..., 0] = values
    c[..., 1] = slopes
    secant, quadratic, cubic = np.empty_like(values), c[..., 2], c[..., 3]
    np.subtract(values[:, 1:], values[:, :-1], out=secant[:, :-1])           # y_next - y, periodic
    np.subtract(values[:, :1], values[:, -1:], out=secant[:, -1:])
    secant *= 1.0 / h
    np.add(slopes[:, 1:], slopes[:, :-1], out=cubic[:, :-1])                  # d + d_next
    np.add(slopes[:, :1], slopes[:, -1:], out=cubic[:, -1:])
    cubic -= secant
    cubic -= secant                                                           # d + d_next - 2 secant
    np.subtract(secant, slopes, out=quadratic)                                # (3 secant - 2 d - d_next)
    quadratic -= cubic                                                        #   / h
    quadratic *= 1.0 / h
    cubic *= 1.0 / (h * h)                                                    # (d + d_next - 2 secant) / h^2
    return c


def expm(M) -> np.ndarray:
    """exp(M) of a small square matrix, by scaling and squaring of its Taylor series (numpy only:
    the FMUs carry no scipy). M / 2^s has norm <= 1/2, where 20 terms reach rounding; measured
    against scipy.linalg.expm: 1e-13 relative for norms up to 100."""
    M = np.asarray(M, dtype=float)
    norm = float(np.max(np.sum(np.abs(M), axis=1)))
    s = max(0, int(math.ceil(math.log2(norm))) + 1) if norm > 0 else 0
    X = M / 2.0 ** s
    term = np.eye(M.shape[0])
    out = term.copy()
    for k in range(1, 21):
        term = term @ X / k
        out = out + term
    for _ in range(s):
        out = out @ out
    return out


#: golden section's interval ratio
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def one_sided_limits(f, at: np.ndarray, side: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """lim f(x) as x -> at from ``side`` (+1: from above, -1: from below) of each row of a vectorised
    ``f`` (rows: functions): f at at + side*k*step, k = 1, 2, 3, extrapolated to ``at`` by the
    quadratic through them (3 f1 - 3 f2 + f3, error O(step^3 f''')). The samples lie well off the
    angle itself, whose side a load decides from its own rounding."""
    k = np.array([1.0, 2.0, 3.0])
    x = (np.asarray(at, float)[:, None] + np.asarray(side, float)[:, None] * step * k[None, :]).ravel()
    values = np.atleast_2d(f(x)).reshape(-1, len(at), 3)
    return 3.0 * values[..., 0] - 3.0 * values[..., 1] + values[..., 2]


def extremes(f, breaks, cells: int = 1440, xtol: float = 1e-8, margin: float = 0.05) -> dict[str, np.ndarray]:
    """The minimum and maximum of each row of the vectorised ``f`` (x -> (functions, x.size)) over
    [breaks[0], breaks[-1]], and where they lie: located, not sampled.

    ``breaks`` are where f may jump (a load switching on): between two of them f is smooth, and at
    each its one-sided limits are candidates (a corner of M_e is the limit there, not a sample
    near it). Each smooth piece is scanned on its own grid of about ``cells`` cells per span (not a
    caller's output grid, so the result does not depend on one); every sample that is a local
    extreme of the scan within ``margin`` of the row's range from its best sample is refined by
    golden section between its neighbours to ``xtol`` (a cell's extreme differs from its samples
    by at most h^2/8 max|f''|, far below 5 % of the range at a 0.25 deg scan; near an extreme f
    differs from its peak by f''/2 dx^2, so dx = 1e-8 rad leaves the value exact to rounding).
    Returns ``min``, ``min_at``, ``max``, ``max_at``: arrays with one entry per row."""
    breaks = np.unique(np.asarray(breaks, dtype=float))
    width = (breaks[-1] - breaks[0]) / cells
    xs, piece = [], []
    for i, (a, b) in enumerate(zip(breaks[:-1], breaks[1:])):
        n = max(2, int(math.ceil((b - a) / width)))
        xs.append(np.linspace(a, b, n + 1))
        piece.append(np.full(n + 1, i))
    x, piece = np.concatenate(xs), np.concatenate(piece)
    first = np.r_[True, piece[1:] != piece[:-1]]
    last = np.r_[piece[1:] != piece[:-1], True]
    inner = ~(first | last)
    scanned = np.atleast_2d(f(x[inner]))
    y = np.empty((scanned.shape[0], x.size))
    y[:, inner] = scanned
    ends = ~inner
    y[:, ends] = one_sided_limits(f, x[ends], np.where(first[ends], 1.0, -1.0))
    out = {}
    for name, sign in (("min", 1.0), ("max", -1.0)):
        s = sign * y
        left = np.where(first, np.inf, np.roll(s, 1, axis=1))   # a piece's first sample has no left
        right = np.where(last, np.inf, np.roll(s, -1, axis=1))
        span = np.max(s, axis=1, keepdims=True) - np.min(s, axis=1, keepdims=True)
        near = s <= np.min(s, axis=1, keepdims=True) + margin * span
        # strict on the left: a plateau (a row constant over a stretch, or everywhere) gives one candidate
        rows, idx = np.nonzero((s < left) & (s <= right) & near)

        def on_rows(z, r):           # sign * f at z[i] on row r[i]: one call of f for all candidates
            return sign * np.atleast_2d(f(z))[r, np.arange(z.size)]

        # the bracket (a, b, c), f(b) lowest, around each candidate: its scan neighbours; at a
        # piece's end, the end itself (its one-sided limit), the cell's midpoint and the next sample
        end = first[idx] | last[idx]
        other = np.clip(np.where(end, idx + np.where(first[idx], 1, -1), idx + 1), 0, x.size - 1)
        before = np.maximum(idx - 1, 0)
        a = np.where(end, x[idx], x[before])
        c = x[other]
        fa = np.where(end, s[rows, idx], s[rows, before])
        fc = s[rows, other]
        b, fb = x[idx].copy(), s[rows, idx].copy()
        if np.any(end):
            b[end] = 0.5 * (a[end] + c[end])
            fb[end] = on_rows(b[end], rows[end])
        # a bracket whose middle is lowest holds a smooth minimum; else the end's limit is the least
        at, value = x[idx].copy(), s[rows, idx].copy()
        keep = np.nonzero(~end | (fb < np.minimum(fa, fc)))[0]
        if keep.size:
            lo, hi = np.minimum(a[keep], c[keep]), np.maximum(a[keep], c[keep])
            f_lo = np.where(a[keep] <= c[keep], fa[keep], fc[keep])
            f_hi = np.where(a[keep] <= c[keep], fc[keep], fa[keep])
            found, low = _parabolic_minimum(lambda z, which: on_rows(z, rows[keep][which]),
                                            lo, b[keep], hi, f_lo, fb[keep], f_hi, xtol)
            better = low < value[keep]
            at[keep] = np.where(better, found, at[keep])
            value[keep] = np.where(better, low, value[keep])
        best_value = np.full(y.shape[0], np.inf)
        best_at = np.full(y.shape[0], np.nan)
        for r, a, v in zip(rows, at, value):
            if v < best_value[r]:
                best_value[r], best_at[r] = v, a
        out[name], out[f"{name}_at"] = sign * best_value, best_at
    return out


def _parabolic_minimum(f, a, b, c, fa, fb, fc, xtol, maxiter: int = 60):
    """A minimum of ``f`` inside each bracket a < b < c with f(b) <= f(a), f(c), all brackets at
    once (one vectorised call of f per iteration): successive parabolic interpolation through the
    bracket, safeguarded as in Brent's method (a vertex outside the bracket, or closer than xtol/2
    to b, is replaced by the golden-section point of the larger side), until the bracket is
    narrower than xtol or the step falls below it. Returns (x, f(x)) of the lowest point."""
    a, b, c = (np.array(v, float) for v in (a, b, c))
    fa, fb, fc = (np.array(v, float) for v in (fa, fb, fc))
    active = np.ones(a.size, bool)
    for _ in range(maxiter):
        if not np.any(active):
            break
        with np.errstate(invalid="ignore", divide="ignore"):
            p = (b - a) ** 2 * (fb - fc) - (b - c) ** 2 * (fb - fa)
            q = (b - a) * (fb - fc) - (b - c) * (fb - fa)
            u = b - 0.5 * p / q
        golden = np.where(c - b > b - a, b + (1 - _GOLDEN) * (c - b), b - (1 - _GOLDEN) * (b - a))
        bad = ~np.isfinite(u) | (u <= a) | (u >= c) | (np.abs(u - b) < 0.5 * xtol)
        u = np.where(bad, golden, u)
        fu = np.full(u.shape, np.inf)
        fu[active] = f(u[active], np.nonzero(active)[0])
        step = np.abs(u - b)
        lower = fu < fb
        right = u > b
        # the new bracket: u replaces b when lower (b becomes an end), else u becomes an end
        na = np.where(lower, np.where(right, b, a), np.where(right, a, u))
        nfa = np.where(lower, np.where(right, fb, fa), np.where(right, fa, fu))
        nc = np.where(lower, np.where(right, c, b), np.where(right, u, c))
        nfc = np.where(lower, np.where(right, fc, fb), np.where(right, fu, fc))
        nb, nfb = np.where(lower, u, b), np.where(lower, fu, fb)
        a = np.where(active, na, a); fa = np.where(active, nfa, fa)
        c = np.where(active, nc, c); fc = np.where(active, nfc, fc)
        b = np.where(active, nb, b); fb = np.where(active, nfb, fb)
        active &= (c - a > xtol) & (step > 0.5 * xtol)
    return b, fb
