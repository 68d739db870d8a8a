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
    cubics through ``values`` with ``slopes`` at k * period / n."""
    h = period / values.shape[1]
    y_next = np.concatenate([values[:, 1:], values[:, :1]], axis=1)     # np.roll(values, -1), faster
    d_next = np.concatenate([slopes[:, 1:], slopes[:, :1]], axis=1)
    secant = (y_next - values) / h
    c = np.empty(values.shape + (4,))
    c[..., 0] = values
    c[..., 1] = slopes
    c[..., 2] = (3.0 * secant - 2.0 * slopes - d_next) / h
    c[..., 3] = (slopes + d_next - 2.0 * secant) / (h * h)
    return c
