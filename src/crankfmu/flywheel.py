"""Flywheel sizing (seed 003 section 8, eqs. 16-17) and the eq. 3 step-size study.

* The steady cycle: the periodic solution omega1(phi1) of the movement equation written in the
  crank angle, domega1/dphi1 = (M_motor(omega1) + Q - 0.5 J' omega1^2) / (J omega1), with the
  time dt/dphi1 = 1/omega1 carried along. Each smooth piece between two load switches is
  integrated by DOP853 (the switches end a piece, they are not stepped over); the start speed is
  found by a secant iteration on omega1(phi0 + 2 pi) = omega1(phi0).
* delta = (omega_max - omega_min) / omega_m with omega_m = 2 pi / T, the cycle's time mean (the
  definition `crankfmu simulate` uses).
* Eq. 17: J_F = dW_max / (omega_m^2 [delta]) with dW_max = E_max - E_min, the largest swing of
  the work of the loads against a constant driving torque equal to their mean (the paper's
  assumption in eq. 15), omega_m from the steady cycle without flywheel. Eq. 16 subtracts the
  mechanism's own J_e (its cycle mean).
* The simulated flywheel: the J_F whose steady cycle has delta = [delta], by Brent's method on
  delta(J_F). The motor line's slope regulates the speed too, which eqs. 16-17 ignore.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from .equilibrium import cycle_breaks
from .errors import CrankfmuError, ParameterError, SchemeError
from .output import pyplot
from .scenario import load_scenario

TWO_PI = 2.0 * math.pi


@dataclass
class SteadyCycle:
    """The periodic motion over one turn from phi0, sampled at ``phi1`` (rad)."""

    phi1: np.ndarray
    omega1: np.ndarray     # rad/s
    epsilon1: np.ndarray   # rad/s2
    time: np.ndarray       # s from phi0
    period: float          # s
    J_flywheel: float      # kg.m2

    @property
    def omega_mean(self) -> float:
        return TWO_PI / self.period

    @property
    def delta(self) -> float:
        return float((self.omega1.max() - self.omega1.min()) / self.omega_mean)


def _crank_angle_rhs(model):
    reduced, motor, tau = model.reduced, model.motor, model.equation.tau_ext

    def rhs(phi, y):
        omega = y[0]
        if not omega > 0.0:
            raise SchemeError(f"the crank stops (omega1 = {omega:.4g} rad/s at phi1 = {math.degrees(phi):.2f} deg): "
                              "no steady forward cycle for this design")
        J, half_dJ, Q, kin = reduced.coefficients(np.array([phi]))
        q = Q[0] + (reduced.velocity_load(kin, omega)[0] if reduced.velocity_dependent else 0.0)
        M = float(motor.torque_at(omega))
        return np.array([(M + q + tau - half_dJ[0] * omega * omega) / (J[0] * omega), 1.0 / omega])
    return rhs


def _one_turn(model, phi0, omega0, pieces, rtol, samples=None):
    rhs = _crank_angle_rhs(model)
    y = np.array([omega0, 0.0])
    dense = []
    for a, b in pieces:
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=rtol, atol=rtol * 1e-2, dense_output=samples is not None)
        if sol.status != 0:
            raise SchemeError(f"steady cycle: {sol.message}")
        y = sol.y[:, -1]
        dense.append((a, b, sol.sol))
    return y, dense


def steady_cycle(model, phi0: float = 0.0, rtol: float = 1e-11, n_samples: int = 3601,
                 omega_guess: float | None = None) -> SteadyCycle:
    """The periodic solution over one turn starting at crank angle ``phi0`` (rad)."""
    breaks = np.array(cycle_breaks(model))
    rel = np.unique(np.concatenate([[0.0, TWO_PI], (breaks - phi0) % TWO_PI]))
    pieces = [(phi0 + a, phi0 + b) for a, b in zip(rel[:-1], rel[1:]) if b - a > 1e-12]
    w = float(model.y0[1] if omega_guess is None else omega_guess)
    if not w > 0:
        raise ParameterError(f"the steady cycle needs a forward start speed, got omega1 = {w:g} rad/s", "omega1_start")
    # two fixed-point passes, then secant steps on g(w) = omega(2 pi; w) - w
    w1 = _one_turn(model, phi0, w, pieces, rtol)[0][0]
    w2 = _one_turn(model, phi0, w1, pieces, rtol)[0][0]
    a, ga, b, gb = w, w1 - w, w1, w2 - w1
    for _ in range(30):
        if gb == 0.0 or abs(gb) <= 1e-13 * abs(b):
            break
        c = b - gb * (b - a) / (gb - ga) if gb != ga else b + gb
        gc = _one_turn(model, phi0, c, pieces, rtol)[0][0] - c
        a, ga, b, gb = b, gb, c, gc
    else:
        raise SchemeError(f"no periodic cycle found (omega1 mismatch {gb:.3g} rad/s after 30 iterations)")
    _, dense = _one_turn(model, phi0, b, pieces, rtol, samples=True)
    phis = phi0 + np.linspace(0.0, TWO_PI, n_samples)
    # add the piece ends so the extremes at a switch are seen
    phis = np.unique(np.concatenate([phis, [p for pc in pieces for p in pc]]))
    ys = np.empty((2, phis.size))
    for lo, hi, sol in dense:
        sel = (phis >= lo) & (phis <= hi)
        ys[:, sel] = sol(phis[sel])
    rhs = _crank_angle_rhs(model)
    eps = np.array([rhs(p, y)[0] * y[0] for p, y in zip(phis, ys.T)])
    return SteadyCycle(phi1=phis, omega1=ys[0], epsilon1=eps, time=ys[1], period=float(ys[1, -1]),
                       J_flywheel=model.reduced.J_flywheel)


def energy_swing(model, n: int = 20001) -> tuple[float, np.ndarray, np.ndarray]:
    """dW_max (J) of eqs. 16-17 and the curve dW(phi1): the loads' work against their mean."""
    breaks = cycle_breaks(model)
    x, wts = np.polynomial.legendre.leggauss(8)
    phis, cumulative = [0.0], [0.0]
    grid = np.unique(np.concatenate([np.linspace(0.0, TWO_PI, n), breaks]))
    lo, hi = grid[:-1], grid[1:]
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    nodes = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    J, half_dJ, Q, kin = model.reduced.coefficients(nodes)
    if model.reduced.velocity_dependent:
        Q = Q + model.reduced.velocity_load(kin, np.ones_like(nodes))   # the direction of forward motion
    work = np.sum(Q.reshape(-1, x.size) * wts[None, :], axis=1) * half
    phis = grid
    cumulative = np.concatenate([[0.0], np.cumsum(work)])
    mean = cumulative[-1] / TWO_PI
    swing = cumulative - mean * phis
    return float(swing.max() - swing.min()), phis, swing


def design_flywheel(scenario, delta: float, phi0: float | None = None, rtol: float = 1e-11) -> dict:
    """Everything flywheel.json holds for a target coefficient of speed fluctuation ``delta``."""
    scenario = load_scenario(scenario)
    try:
        delta = float(delta)
    except (TypeError, ValueError):
        raise ParameterError(f"delta must be a number, got {delta!r}", "delta") from None
    if not (math.isfinite(delta) and 0.0 < delta < 1.0):
        raise ParameterError(f"delta = {delta!r}: the target coefficient of speed fluctuation must lie in "
                             "(0, 1), e.g. 0.05", "delta")
    spec = scenario.data.get("flywheel", {})
    phi0 = float(spec.get("angle_offset", 0.0) if phi0 is None else phi0)
    base = scenario.with_params(J_flywheel=0.0)
    model = base.build()
    grid = np.linspace(0.0, TWO_PI, 3601)
    J_e = model.reduced.coefficients(grid)[0]
    free = steady_cycle(model, phi0, rtol)
    dW, _, _ = energy_swing(model)
    omega_m = free.omega_mean
    J_eq17 = dW / (omega_m ** 2 * delta)
    J_eq16 = J_eq17 - float(np.mean(J_e))

    cache = {0.0: free}

    def cycle(J_F):
        if J_F not in cache:
            cache[J_F] = steady_cycle(base.with_params(J_flywheel=J_F).build(), phi0, rtol,
                                      omega_guess=free.omega1[0])
        return cache[J_F]

    if free.delta <= delta:
        J_sim = 0.0
    else:
        hi = max(J_eq17, 1.0)
        while cycle(hi).delta > delta:
            hi *= 2.0
            if hi > 1e9:
                raise CrankfmuError(f"no flywheel up to 1e9 kg.m2 reaches delta = {delta:g}")
        J_sim = brentq(lambda J_F: cycle(J_F).delta - delta, 0.0, hi, xtol=1e-10, rtol=1e-12)
    fitted = cycle(J_sim)
    return {
        "scenario": scenario.name,
        "delta_target": delta,
        "J_e_min": float(J_e.min()),
        "J_e_max": float(J_e.max()),
        "J_e_mean": float(J_e.mean()),
        "J_e_min_at_deg": float(np.degrees(grid[np.argmin(J_e)] - phi0) % 360),
        "J_e_max_at_deg": float(np.degrees(grid[np.argmax(J_e)] - phi0) % 360),
        "dW_max": dW,
        "omega_m": omega_m,
        "J_F_eq17": J_eq17,
        "J_F_eq16": J_eq16,
        "J_F_simulated": float(J_sim),
        "delta_achieved": fitted.delta,
        "delta_without_flywheel": free.delta,
        "delta_with_J_F_eq17": cycle(J_eq17).delta,
        "omega_peak_without": float(free.omega1.max()),
        "omega_peak_with": float(fitted.omega1.max()),
        "omega_peak_reduction": float(1.0 - fitted.omega1.max() / free.omega1.max()),
        "epsilon_peak_without": float(np.max(np.abs(free.epsilon1))),
        "epsilon_peak_with": float(np.max(np.abs(fitted.epsilon1))),
        "epsilon_peak_reduction": float(1.0 - np.max(np.abs(fitted.epsilon1)) / np.max(np.abs(free.epsilon1))),
        "units": {"J_*": "kg.m2", "dW_max": "J", "omega_*": "rad/s", "epsilon_*": "rad/s2", "delta*": "1",
                  "*_reduction": "1 (fraction of the value without flywheel)", "*_at_deg": "deg (paper's phi)"},
        "_cycles": {"without": free, "with": fitted},
    }
