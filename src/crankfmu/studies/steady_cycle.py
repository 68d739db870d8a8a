"""The steady cycle of a machine: the periodic solution omega1(phi1) of the movement equation
written in the crank angle, domega1/dphi1 = (M_motor(omega1) + Q - 0.5 J' omega1^2) / (J omega1),
with the time dt/dphi1 = 1/omega1 carried along (the flywheel study's, studies/flywheel.py, and the
works and efficiency over one cycle).

Each smooth piece between two load switches is integrated by DOP853 (the switches end a piece, they
are not stepped over); the start speed is found by a secant iteration on omega1(phi0 + Phi) =
omega1(phi0), Phi the machine's cycle (2 pi cycle_turns: one turn, a four-stroke engine's two).
delta = (omega_max - omega_min) / omega_m with omega_m = Phi / T, the cycle's time mean (the
definition `crankfmu simulate` uses).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from .equilibrium import cycle_breaks
from ..errors import SchemeError

TWO_PI = 2.0 * math.pi
#: a steady cycle's shooting is near its root where the mismatch g(w) = omega(end) - w is within
#: this fraction of w: there a secant step on the smooth g shrinks |g| unless the integration's
#: own error has the last word (steady_cycle stops on the first step that does not)
NEAR_ROOT = 1e-6
#: the shooting stops where the secant's next correction of w is within this many rtol of w: the
#: integration's own error over a cycle moves g by about that much (engine4 at rtol 1e-11 without a
#: flywheel: g wanders within 1e-7 rad/s at 291 rad/s, and the secant's w within 3e-9 of itself, from
#: one step to the next), so steps below it move w by that error, not towards the root. The secant's
#: correction, not |g|: with a heavy flywheel g is nearly flat in w, and a small g is no small error.
#: The cycle from that w closes to within that floor, and delta's check against the fast kernel's
#: with it (engine4's flywheel for delta 0.005: 6e-8 of delta; the 5 more steps it took before,
#: keeping the smallest |g| they met, gave 5e-9)
SHOOTING_RTOLS = 1000.0


@dataclass
class SteadyCycle:
    """The periodic motion over one machine cycle from phi0, sampled at ``phi1`` (rad)."""

    phi1: np.ndarray
    omega1: np.ndarray     # rad/s
    epsilon1: np.ndarray   # rad/s2
    time: np.ndarray       # s from phi0
    period: float          # s
    J_flywheel: float      # kg.m2
    angle: float = TWO_PI  # rad: the cycle (2 pi cycle_turns)

    @property
    def omega_mean(self) -> float:
        return self.angle / self.period

    @property
    def delta(self) -> float:
        return float((self.omega1.max() - self.omega1.min()) / self.omega_mean)


#: the torques whose work over the cycle ``_one_cycle(works=True)`` integrates (dW/dphi1 = torque)
WORK_TORQUES = ("M_motor", "M_load", "M_friction")


def _crank_angle_rhs(model, works: bool = False):
    """d(omega1, t)/dphi1 = (epsilon1 / omega1, 1 / omega1), the motor branch by omega1. Each piece
    lies between two switches, so the loads' side and band follow from (phi1, omega1). ``works``:
    also the works of WORK_TORQUES (J), dW/dphi1 = the torque (M_friction with joint friction)."""
    outputs = model.equation.outputs
    torques = WORK_TORQUES if model.reduced.friction is not None else WORK_TORQUES[:2]

    def rhs(phi, y):
        omega = y[0]
        if not omega > 0.0:
            raise SchemeError(f"the crank stops (omega1 = {omega:.4g} rad/s at phi1 = {math.degrees(phi):.2f} deg): "
                              "no steady forward cycle for this design")
        out = outputs(np.array([phi]), np.array([omega]))
        eps = float(out["epsilon1"][0])
        if not works:
            return np.array([eps / omega, 1.0 / omega])
        return np.array([eps / omega, 1.0 / omega, *(float(out[name][0]) for name in torques)])
    return rhs


def cycle_works(model, cycle: "SteadyCycle", rtol: float = 1e-11) -> dict:
    """The works (J) over the steady ``cycle`` of WORK_TORQUES: W_motor, W_load and, with joint
    friction, W_friction; and the mechanism's efficiency, the work the loads take over the motor's
    (-W_load / W_motor: the weights' work is zero over a cycle)."""
    breaks = np.array(cycle_breaks(model))
    phi0 = float(cycle.phi1[0])
    rel = np.unique(np.concatenate([[0.0, cycle.angle], (breaks - phi0) % cycle.angle]))
    pieces = [(phi0 + a, phi0 + b) for a, b in zip(rel[:-1], rel[1:]) if b - a > 1e-12]
    y, _ = _one_cycle(model, phi0, float(cycle.omega1[0]), pieces, rtol, works=True)
    names = ["W_motor", "W_load", "W_friction"][:y.size - 2]
    out = {name: float(value) for name, value in zip(names, y[2:])}
    out["efficiency"] = -out["W_load"] / out["W_motor"] if out["W_motor"] > 0.0 else float("nan")
    return out


def _one_cycle(model, phi0, omega0, pieces, rtol, samples=None, works: bool = False):
    rhs = _crank_angle_rhs(model, works)
    y = np.zeros(2 + (len(WORK_TORQUES) - (model.reduced.friction is None) if works else 0))
    y[0] = omega0
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
    """The periodic solution over one machine cycle starting at crank angle ``phi0`` (rad)."""
    breaks = np.array(cycle_breaks(model))
    cycle = model.reduced.period
    rel = np.unique(np.concatenate([[0.0, cycle], (breaks - phi0) % cycle]))
    pieces = [(phi0 + a, phi0 + b) for a, b in zip(rel[:-1], rel[1:]) if b - a > 1e-12]
    w = float(model.y0[1] if omega_guess is None else omega_guess)
    if not w > 0:
        raise ParameterError(f"the steady cycle needs a forward start speed, got omega1 = {w:g} rad/s", "omega1_start")
    # two fixed-point passes, then secant steps on g(w) = omega(phi0 + cycle; w) - w
    w1 = _one_cycle(model, phi0, w, pieces, rtol)[0][0]
    w2 = _one_cycle(model, phi0, w1, pieces, rtol)[0][0]
    a, ga, b, gb = w, w1 - w, w1, w2 - w1
    best, g_best = (a, ga) if abs(ga) < abs(gb) else (b, gb)
    for _ in range(30):
        step = gb * (b - a) / (gb - ga) if gb != ga else -gb        # the secant's correction of b
        if gb == 0.0 or (gb != ga and abs(step) <= SHOOTING_RTOLS * rtol * abs(b)):
            best = b
            break
        c = b - step
        gc = _one_cycle(model, phi0, c, pieces, rtol)[0][0] - c
        a, ga, b, gb = b, gb, c, gc
        # the integration's own error (rtol per step, summed over a cycle) bounds how small g gets:
        # near the root g is linear to far below that error, so a secant step that does not shrink
        # |g| there has reached that floor, and more steps only wander in it (engine4's cycle: 17
        # integrations of which the last 11 moved w by 1e-9 of itself at random). Likewise where a
        # heavy flywheel makes g nearly flat in w: stop where the secant no longer moves w.
        if abs(gc) < abs(g_best):
            best, g_best = c, gc
        elif abs(g_best) <= NEAR_ROOT * abs(best):
            break
        if abs(b - a) <= 1e-12 * abs(b):
            break
    else:
        raise SchemeError(f"no periodic cycle found (omega1 mismatch {gb:.3g} rad/s after 30 iterations)")
    b = best
    _, dense = _one_cycle(model, phi0, b, pieces, rtol, samples=True)
    rhs = _crank_angle_rhs(model)
    phis = phi0 + np.linspace(0.0, cycle, (n_samples - 1) * model.reduced.cycle_turns + 1)
    # add the piece ends so the extremes at a switch are seen
    phis = np.unique(np.concatenate([phis, [p for pc in pieces for p in pc]]))
    ys = np.empty((2, phis.size))
    for lo, hi, sol in dense:
        sel = (phis >= lo) & (phis <= hi)
        ys[:, sel] = sol(phis[sel])
    # a smooth extreme lies between two samples (the sampled one is off by O(dphi^2), about 1e-7
    # of delta at 0.1 deg): add it where the slope domega1/dphi1 changes sign. The piece ends are
    # samples, so two neighbours always lie in one piece.
    extra = []
    for i in {int(np.argmin(ys[0])), int(np.argmax(ys[0]))}:
        for a, b in ((i - 1, i), (i, i + 1)):
            if a < 0 or b >= phis.size:
                continue
            sol = next(sol for lo, hi, sol in dense if lo <= phis[a] and phis[b] <= hi)
            slope = lambda p, sol=sol: rhs(p, sol(p))[0]      # noqa: E731
            inset = 1e-9 * (phis[b] - phis[a])                  # off the switch angles themselves
            pa, pb = phis[a] + inset, phis[b] - inset
            if slope(pa) * slope(pb) < 0.0:
                p = brentq(slope, pa, pb, xtol=1e-15)
                extra.append((p, sol(p)))
    if extra:
        phis = np.concatenate([phis, [p for p, _ in extra]])
        ys = np.concatenate([ys, np.column_stack([y for _, y in extra])], axis=1)
        order = np.argsort(phis)
        phis, ys = phis[order], ys[:, order]
    eps = model.equation.outputs(phis, ys[0])["epsilon1"]
    return SteadyCycle(phi1=phis, omega1=ys[0], epsilon1=eps, time=ys[1], period=float(ys[1, -1]),
                       J_flywheel=model.reduced.J_flywheel, angle=cycle)
