"""Errors between an FMU run and its reference, and the invariants every run must satisfy.

All functions take plain arrays (or the ``values`` dicts of FmuRun / ReferenceRun), so the
harness's own tests can feed them a deliberately wrong run.
"""

from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi


def max_abs_error(a, b) -> float:
    """max |a - b| over the common samples (NaN anywhere makes it NaN: a NaN never passes)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"cannot compare arrays of shapes {a.shape} and {b.shape}")
    d = np.abs(a - b)
    return float("nan") if np.isnan(d).any() else float(np.max(d, initial=0.0))


def relative_error(a, b) -> float:
    """max |a - b| / max |b|: an error on the scale of the quantity."""
    scale = float(np.max(np.abs(b), initial=0.0))
    return max_abs_error(a, b) / scale if scale > 0 else max_abs_error(a, b)


def energy_residual(values) -> float:
    """max over the run of |W_motor + W_load + W_ext + W_friction - (E_kin - E_kin(0))| over the work
    scale (W_friction: the joints' friction's work, where the FMU has joint friction).

    The works are integrated with the state, so this measures the integration error only; the
    scale is the largest |W_motor| + |W_load| + |W_ext| + |W_friction| reached (the energy that flowed).
    """
    works = [np.asarray(values[name]) for name in ("W_motor", "W_load", "W_ext", "W_friction") if name in values]
    E = np.asarray(values["E_kin"])
    W = sum(works)
    scale = float(np.max(sum(np.abs(w) for w in works)))
    gap = np.abs(W - (E - E[0]))
    if np.isnan(gap).any():
        return float("nan")
    return float(np.max(gap) / scale) if scale > 0 else float(np.max(gap))


def phi_quadrature_residual(time, phi, omega, epsilon) -> float:
    """max |phi1(t) - phi1(0) - integral of omega1| (rad), the integral by the Hermite rule

        int_{t_i}^{t_i+1} omega dt = h (omega_i + omega_i+1) / 2 + h^2 (eps_i - eps_i+1) / 12,

    fourth order where omega1 is smooth. A run whose phi1 is consistent with its omega1 leaves only
    the rule's own error, which the harness measures on the exact reference at the same grid.
    """
    t, phi, w, e = (np.asarray(x, dtype=float) for x in (time, phi, omega, epsilon))
    h = np.diff(t)
    pieces = h * (w[:-1] + w[1:]) / 2.0 + h * h * (e[:-1] - e[1:]) / 12.0
    integral = np.concatenate([[0.0], np.cumsum(pieces)])
    return max_abs_error(phi - phi[0], integral)


def turn_times(t, phi, w, levels) -> np.ndarray:
    """Where the cubic Hermite interpolant of an increasing phi1 (omega1 its slope) reaches each of
    ``levels``: each in its own sample interval (found by bisection of the samples), then Newton's
    method on that interval's cubic from the chord's root, all levels at once (a thousand turns cost
    what one does; scipy's PPoly.solve searched every interval per level)."""
    levels = np.asarray(levels, dtype=float)
    i = np.clip(np.searchsorted(phi, levels, side="left") - 1, 0, t.size - 2)
    t0, h = t[i], t[i + 1] - t[i]
    p0, p1, m0, m1 = phi[i], phi[i + 1], w[i] * h, w[i + 1] * h
    target = levels - p0
    s = np.clip(target / (p1 - p0), 0.0, 1.0)
    for _ in range(30):
        # Hermite basis on s in [0, 1]: p(s) and dp/ds
        value = (2 * s**3 - 3 * s**2) * (p0 - p1) + (s**3 - 2 * s**2 + s) * m0 + (s**3 - s**2) * m1
        slope = (6 * s**2 - 6 * s) * (p0 - p1) + (3 * s**2 - 4 * s + 1) * m0 + (3 * s**2 - 2 * s) * m1
        step = (value - target) / np.where(slope > 0, slope, p1 - p0)
        s = np.clip(s - step, 0.0, 1.0)
        if np.all(np.abs(step) <= 1e-15):
            break
    return t0 + s * h


def cycles(time, phi, omega) -> list[dict]:
    """Each complete crank turn in the samples: start and end time (phi1 = phi1(0) + 2 pi k, found
    on the cubic Hermite interpolant of phi1 with omega1 as its slope), omega1 min and max at the
    samples (and at the turn's ends), the time mean 2 pi / T and delta = (max - min) / mean. Needs phi1 increasing."""
    t, phi, w = (np.asarray(x, dtype=float) for x in (time, phi, omega))
    if t.size < 4 or np.any(np.diff(phi) <= 0):
        return []
    turns = int(math.floor((phi[-1] - phi[0]) / TWO_PI))
    marks = [t[0], *turn_times(t, phi, w, phi[0] + TWO_PI * np.arange(1, turns + 1))]
    out = []
    for k in range(1, len(marks)):
        t0, t1 = marks[k - 1], marks[k]
        inside = (t >= t0) & (t <= t1)
        ends = np.interp([t0, t1], t, w)       # the turn's ends count even between samples
        samples = np.concatenate([w[inside], ends])
        lo, hi = float(np.min(samples)), float(np.max(samples))
        mean = TWO_PI / (t1 - t0)
        out.append({"cycle": k, "t_start": t0, "t_end": t1, "omega1_min": lo, "omega1_max": hi,
                    "omega1_mean": mean, "delta": (hi - lo) / mean})
    return out


def compare_builds(native, python, checks, native_run, python_run, tolerance_of) -> dict:
    """A native FMU against the Python FMU of the same data file on the same run: every output the
    Python FMU declares, the native one must declare too and match to ``tolerance_of(name)``
    (tolerance, group) of the output's scale."""
    prefix = f"{native.name}.{native.kind.build}_vs_python"
    rows = []
    for name in python.outputs:
        if name not in native.outputs:
            checks.holds(f"{prefix}.{name}_declared_by_both", False, note="the native FMU does not declare it")
            continue
        tol, group = tolerance_of(name)
        r = relative_error(native_run[name], python_run[name])
        checks.at_most(f"{prefix}.{name}_rel_difference", r, tol)
        rows.append({"output": name, "rel": r, "tol": tol, "group": group})
    return {"rows": rows}
