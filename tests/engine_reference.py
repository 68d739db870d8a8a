"""A hand-written reference of tests/data/user/engine4s_scenario.toml, the single-cylinder
four-stroke engine: the slider-crank's kinematics in closed form, its own J, J' and generalized
force, and scipy's DOP853 at 1e-13. It uses no crankfmu code (only the file's numbers, read here
with tomllib), so it checks the engine, the tables over a cycle of two turns, the kernel and the
FMUs from outside.

    phi2 = -asin(l1 sin phi1 / l2),  xB = l1 cos phi1 + l2 cos phi2       (B on the x axis)
    J(phi1) = J_F + m1 |v_C1|^2 + I1 + m2 |v_C2|^2 + I2 phi2'^2 + m3 xB'^2   (per omega1^2)
    Q(phi1) = F_x(phi1) xB',  F_x = -F_gas exp(k (cos((phi1 - phi_peak)/2) - 1))   (once per 2 turns)
    J omega1' = -B omega1 + Q - 0.5 J' omega1^2                          (the brake: A = 0)
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

FILE = Path(__file__).resolve().parent / "data" / "user" / "engine4s_scenario.toml"


class Engine:
    def __init__(self, path=FILE, **overrides):
        data = tomllib.loads(Path(path).read_text())
        p = {k: float(v["value"]) for k, v in data["parameters"].items()}
        p.update(overrides)
        self.p = p
        self.l1, self.l2 = p["l1"], p["l2"]
        self.m1, self.I1 = p["q1"] * p["l1"], p["q1"] * p["l1"] ** 3 / 12
        self.m2, self.I2 = p["q2"] * p["l2"], p["q2"] * p["l2"] ** 3 / 12
        self.m3 = p["m3"]
        self.cycle = 4.0 * math.pi            # rad: the machine's cycle, two crank turns

    def coefficients(self, phi):
        """(J, 0.5 J', Q) at crank angle phi (rad)."""
        l1, l2, p = self.l1, self.l2, self.p
        s, c = math.sin(phi), math.cos(phi)
        phi2 = -math.asin(l1 * s / l2)
        s2, c2 = math.sin(phi2), math.cos(phi2)
        d2 = -l1 * c / (l2 * c2)                                     # phi2'
        dd2 = (l1 * s + l2 * s2 * d2 * d2) / (l2 * c2)               # phi2''
        dx = -l1 * s - l2 * s2 * d2                                  # xB'
        ddx = -l1 * c - l2 * (c2 * d2 * d2 + s2 * dd2)               # xB''
        t1, p1, tt1, pp1 = -0.5 * l1 * s, 0.5 * l1 * c, -0.5 * l1 * c, -0.5 * l1 * s
        t2 = -l1 * s - 0.5 * l2 * s2 * d2
        p2 = l1 * c + 0.5 * l2 * c2 * d2
        tt2 = -l1 * c - 0.5 * l2 * (c2 * d2 * d2 + s2 * dd2)
        pp2 = -l1 * s + 0.5 * l2 * (-s2 * d2 * d2 + c2 * dd2)
        J = (p["J_flywheel"] + self.m1 * (t1 * t1 + p1 * p1) + self.I1 + self.m2 * (t2 * t2 + p2 * p2)
             + self.I2 * d2 * d2 + self.m3 * dx * dx)
        half = (self.m1 * (t1 * tt1 + p1 * pp1) + self.m2 * (t2 * tt2 + p2 * pp2) + self.I2 * d2 * dd2
                + self.m3 * dx * ddx)
        F = -p["F_gas"] * math.exp(p["k_peak"] * (math.cos(0.5 * (phi - p["phi_peak"])) - 1.0))
        return J, half, F * dx

    def torque(self, omega):
        return self.p["A"] - self.p["B"] * omega

    def rhs(self, t, y):
        J, half, Q = self.coefficients(y[0])
        return [y[1], (self.torque(y[1]) + Q - half * y[1] ** 2) / J]

    def run(self, times, rtol=1e-13):
        """omega1 at ``times`` (s) from the file's start. At 1e-13: scipy 1.17's DOP853 at 1e-12 was
        2e-7 of omega1 off over the fan engine's 1 s (its gas peak is 0.1 rad wide), at 1e-13 within
        6e-12 of 1e-14's."""
        y0 = [self.p["phi1_start"], self.p["omega1_start"]]
        sol = solve_ivp(self.rhs, (times[0], times[-1]), y0, method="DOP853", rtol=rtol, atol=rtol,
                        t_eval=times)
        return sol.y[1]

    # ---- the steady cycle, in the crank angle: d(omega1, t)/dphi1 = (epsilon1 / omega1, 1 / omega1)
    def _cycle(self, omega0, rtol=1e-12, dense=False):
        def rhs(phi, y):
            J, half, Q = self.coefficients(phi)
            return [(self.torque(y[0]) + Q - half * y[0] ** 2) / (J * y[0]), 1.0 / y[0]]
        return solve_ivp(rhs, (0.0, self.cycle), [omega0, 0.0], method="DOP853", rtol=rtol, atol=rtol * 1e-2,
                         dense_output=dense)

    def steady(self, omega_guess=300.0):
        """(omega1 at phi1 = 0, delta, period s) of the periodic motion over the two-turn cycle:
        the secant method on omega1(4 pi) = omega1(0); delta = (max - min) / (4 pi / period), the
        extremes located on the dense output."""
        g = lambda w: self._cycle(w).y[0, -1] - w                                  # noqa: E731
        a, b = omega_guess, self._cycle(omega_guess).y[0, -1]
        ga, gb = g(a), g(b)
        for _ in range(40):
            if abs(gb) <= 1e-13 * b:
                break
            a, ga, b = b, gb, b - gb * (b - a) / (gb - ga)
            gb = g(b)
        sol = self._cycle(b, dense=True)
        phi = np.linspace(0.0, self.cycle, 40001)
        w = sol.sol(phi)[0]
        period = sol.y[1, -1]

        def polish(sign, i):
            from scipy.optimize import minimize_scalar
            lo, hi = phi[max(i - 1, 0)], phi[min(i + 1, phi.size - 1)]
            res = minimize_scalar(lambda x: sign * sol.sol(x)[0], bounds=(lo, hi), method="bounded",
                                  options={"xatol": 1e-13})
            return sign * min(sign * w[i], res.fun)
        w_max, w_min = polish(-1.0, int(np.argmax(w))), polish(1.0, int(np.argmin(w)))
        return b, (w_max - w_min) / (self.cycle / period), period


def flywheel_for(delta, path=FILE, **overrides):
    """J_flywheel (kg.m2) whose steady cycle has the coefficient of speed fluctuation ``delta``."""
    def gap(J):
        return Engine(path, J_flywheel=J, **overrides).steady()[1] - delta
    return brentq(gap, 1e-3, 2.0, xtol=1e-12, rtol=1e-12)
