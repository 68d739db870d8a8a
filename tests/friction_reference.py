"""An independent reference for joint friction: the in-line slider-crank O-A-B of seed 002 written
by hand, body by body, with Coulomb friction in its three pins and its guide (issue 69).

Nothing here comes from crankfmu: the kinematics are the closed form of the slider-crank
(sin phi2 = -l1 sin phi1 / l2, B on the x axis), the accelerations are differentiated by hand,
the Newton-Euler equations are written per body (the crank about its fixed pin O, the rod about
its mass centre, the slider by its forces), and the frictions are found by fixed-point iteration
(crankfmu's engine eliminates the acceleration and runs Newton's method on them).

Unknowns (9): the pin forces O = (Ox, Oy) of the ground on the crank, A = (Ax, Ay) of the crank on
the rod, B = (Bx, By) of the rod on the slider, the guide's normal force N on the slider (along
+y), the guide's couple Mg on the slider, and the crank's acceleration eps1. Frictions:

    M_O = -mu r |O| sign(omega1)                 on the crank (ground -> crank)
    M_A = -mu r |A| sign(omega2 - omega1)        on the rod (crank -> rod), -M_A on the crank
    M_B = -mu r |B| sign(0 - omega2)             on the slider (rod -> slider), -M_B on the rod
    F_s = -mu_s |N| sign(v_B)                    on the slider along x
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp


class SliderCrankWithFriction:
    """The issue's machine: l1 = 0.25, l2 = 0.5 m, bars of 8 and 6 kg/m, a 4 kg slider, g, a
    flywheel J on the crank, the motor M = A - B omega1, a force F_work against the slider while
    it moves towards +x, friction mu_pin with pin radius r_pin in O, A, B and mu_guide in the guide."""

    def __init__(self, l1=0.25, l2=0.5, q1=8.0, q2=6.0, m3=4.0, g=9.81, J=5.0, A=100.0, B=4.0,
                 F_work=400.0, mu_pin=0.1, r_pin=0.01, mu_guide=0.1):
        self.l1, self.l2, self.g, self.J, self.A, self.B, self.F_work = l1, l2, g, J, A, B, F_work
        self.m1, self.m2, self.m3 = q1 * l1, q2 * l2, m3
        self.I1, self.I2 = self.m1 * l1 ** 2 / 12.0, self.m2 * l2 ** 2 / 12.0
        self.c_pin, self.mu_guide = mu_pin * r_pin, mu_guide

    def rod(self, phi, w):
        """phi2, omega2 and the parts of alpha2 = a0 + a1 eps1."""
        l1, l2 = self.l1, self.l2
        phi2 = -math.asin(l1 * math.sin(phi) / l2)
        c2, s2 = math.cos(phi2), math.sin(phi2)
        w2 = -l1 * math.cos(phi) * w / (l2 * c2)
        # y_B = l1 sin phi + l2 sin phi2 = 0, twice differentiated
        a0 = (l1 * math.sin(phi) * w * w + l2 * s2 * w2 * w2) / (l2 * c2)
        a1 = -l1 * math.cos(phi) / (l2 * c2)
        return phi2, w2, a0, a1

    def system(self, phi, w, signs, frictions):
        """The 9 x 9 Newton-Euler matrix and right-hand side at (phi, omega1), given the frictions'
        values (M_O, M_A, M_B, F_s) and the working force's state."""
        l1, l2, g = self.l1, self.l2, self.g
        m1, m2, m3 = self.m1, self.m2, self.m3
        phi2, w2, a0, a1 = self.rod(phi, w)
        c, s, c2, s2 = math.cos(phi), math.sin(phi), math.cos(phi2), math.sin(phi2)
        M_O, M_A, M_B, F_s = frictions
        # accelerations as (part without eps1, part per eps1)
        aA = ((-l1 * c * w * w, -l1 * s * w * w), (-l1 * s, l1 * c))
        aC1 = ((0.5 * aA[0][0], 0.5 * aA[0][1]), (0.5 * aA[1][0], 0.5 * aA[1][1]))
        rot = lambda h, a, ww: (-h * s2 * a - h * c2 * ww * ww, h * c2 * a - h * s2 * ww * ww)   # noqa: E731
        aC2 = ((aA[0][0] + rot(0.5 * l2, a0, w2)[0], aA[0][1] + rot(0.5 * l2, a0, w2)[1]),
               (aA[1][0] - 0.5 * l2 * s2 * a1, aA[1][1] + 0.5 * l2 * c2 * a1))
        aB = (aA[0][0] + rot(l2, a0, w2)[0], aA[1][0] - l2 * s2 * a1)        # x only: y_B = 0
        vB = -l1 * s * w - l2 * s2 * w2
        P = -self.F_work if signs["work"] > 0 else 0.0
        Ax_, Ay_ = l1 * c, l1 * s                     # A relative to O
        K = np.zeros((9, 9))
        rhs = np.zeros(9)
        OX, OY, AX, AY, BX, BY, N, MG, EPS = range(9)
        # crank: forces, moment about O
        K[0, OX], K[0, AX], K[0, EPS] = 1.0, -1.0, -m1 * aC1[1][0]
        rhs[0] = m1 * aC1[0][0]
        K[1, OY], K[1, AY], K[1, EPS] = 1.0, -1.0, -m1 * aC1[1][1]
        rhs[1] = m1 * aC1[0][1] + m1 * g
        I_O = self.I1 + m1 * (0.5 * l1) ** 2 + self.J
        K[2, AX], K[2, AY], K[2, EPS] = Ay_, -Ax_, -I_O          # r_OA x (-A)
        M = self.A - self.B * w
        rhs[2] = -(M + M_O - M_A) + 0.5 * l1 * c * m1 * g        # r_OC1 x (0, -m1 g) = -0.5 l1 c m1 g
        # rod: forces, moment about C2
        K[3, AX], K[3, BX], K[3, EPS] = 1.0, -1.0, -m2 * aC2[1][0]
        rhs[3] = m2 * aC2[0][0]
        K[4, AY], K[4, BY], K[4, EPS] = 1.0, -1.0, -m2 * aC2[1][1]
        rhs[4] = m2 * aC2[0][1] + m2 * g
        hx, hy = 0.5 * l2 * c2, 0.5 * l2 * s2                    # C2 -> B; A is at -(hx, hy)
        # (A - C2) x (Ax, Ay) + (B - C2) x (-Bx, -By) + M_A - M_B = I2 alpha2
        K[5, AX], K[5, AY] = hy, -hx
        K[5, BX], K[5, BY] = hy, -hx
        K[5, EPS] = -self.I2 * a1
        rhs[5] = self.I2 * a0 - M_A + M_B
        # slider: x, y, moment (it does not turn)
        K[6, BX], K[6, EPS] = 1.0, -m3 * aB[1]
        rhs[6] = m3 * aB[0] - F_s - P
        K[7, BY], K[7, N] = 1.0, 1.0
        rhs[7] = m3 * g
        K[8, MG] = 1.0
        rhs[8] = -M_B
        return K, rhs, (w, w2, vB)

    def solve(self, phi, w, signs):
        """(eps1, unknowns, frictions) at (phi, omega1): fixed-point iteration on the frictions."""
        f = np.zeros(4)
        for _ in range(200):
            K, rhs, _ = self.system(phi, w, signs, f)
            x = np.linalg.solve(K, rhs)
            new = np.array([-self.c_pin * math.hypot(x[0], x[1]) * signs["O"],
                            -self.c_pin * math.hypot(x[2], x[3]) * signs["A"],
                            -self.c_pin * math.hypot(x[4], x[5]) * signs["B"],
                            -self.mu_guide * abs(x[6]) * signs["slide"]])
            if np.all(np.abs(new - f) <= 1e-14 * (np.abs(new) + self.mu_guide * np.max(np.abs(x)))):
                f = new
                break
            f = new
        else:
            raise RuntimeError("friction fixed point did not converge")
        K, rhs, speeds = self.system(phi, w, signs, f)
        x = np.linalg.solve(K, rhs)
        return x[8], x, f, speeds

    @staticmethod
    def signs_on(phi):
        """The frictions' and the working force's signs between dead centres, turning forward:
        omega1 > 0; omega2 - omega1 < 0 (|omega2| < omega1 for l1 < l2); omega2 has the sign of
        -cos phi, so the slider's -omega2 that of cos phi; v_B that of -sin phi."""
        return {"O": 1.0, "A": -1.0, "B": math.copysign(1.0, math.cos(phi)), "slide": math.copysign(1.0, -math.sin(phi)),
                "work": math.copysign(1.0, -math.sin(phi))}

    def rhs(self, signs):
        """d/dt (phi1, omega1, W_motor, W_work, W_weights, W_friction)."""
        def f(t, y):
            phi, w = y[0], y[1]
            eps, x, fr, (w1, w2, vB) = self.solve(phi, w, signs)
            P = -self.F_work if signs["work"] > 0 else 0.0
            phi2, _, _, _ = self.rod(phi, w)
            # the weights' power: -m g times each mass centre's vertical speed
            vC1y = 0.5 * self.l1 * math.cos(phi) * w
            vC2y = self.l1 * math.cos(phi) * w + 0.5 * self.l2 * math.cos(phi2) * w2
            friction_power = fr[0] * w1 + fr[1] * (w2 - w1) + fr[2] * (0.0 - w2) + fr[3] * vB
            return [w, eps, (self.A - self.B * w) * w, P * vB,
                    -self.g * (self.m1 * vC1y + self.m2 * vC2y), friction_power]
        return f

    def run(self, t_end, times, phi0=0.0, w0=0.0, rtol=1e-12):
        """omega1 and the works at ``times`` from (phi0, w0), crank turning forward (the motor's
        100 N.m at rest overcomes the friction at once), every dead centre (phi1 a multiple of
        pi/2) located as an event where a sign changes."""
        y = np.array([phi0, w0, 0.0, 0.0, 0.0, 0.0])
        t = 0.0
        out = np.empty((6, len(times)))
        times = np.asarray(times, dtype=float)
        while t < t_end:
            k = math.floor(y[0] / (0.5 * math.pi) + 1e-12)
            nxt = (k + 1) * 0.5 * math.pi
            signs = self.signs_on(0.5 * (k * 0.5 * math.pi + nxt))
            event = lambda tt, yy: yy[0] - nxt     # noqa: E731
            event.terminal, event.direction = True, 1.0
            sol = solve_ivp(self.rhs(signs), (t, t_end), y, method="DOP853", rtol=rtol, atol=rtol,
                            dense_output=True, events=[event])
            t_stop = sol.t[-1]
            sel = (times >= t) & (times <= t_stop)
            out[:, sel] = sol.sol(times[sel])
            y = sol.y[:, -1].copy()
            if sol.status == 1:
                y[0] = nxt
            t = t_stop
        return out

    def turn(self, w0, rtol=1e-12):
        """The state after one turn from (0, w0), and the works over it, crank-angle domain."""
        y = np.array([w0, 0.0, 0.0, 0.0, 0.0, 0.0])
        for k in range(4):
            a, b = k * 0.5 * math.pi, (k + 1) * 0.5 * math.pi
            signs = self.signs_on(0.5 * (a + b))
            f = self.rhs(signs)

            def by_angle(phi, z, f=f):
                d = f(0.0, np.array([phi, *z[:1], *z[2:]]))
                w = z[0]
                return [d[1] / w, 1.0 / w, d[2] / w, d[3] / w, d[4] / w, d[5] / w]
            y = solve_ivp(by_angle, (a, b), y, method="DOP853", rtol=rtol, atol=rtol).y[:, -1]
        return y

    def steady_turn(self, w_guess, rtol=1e-12):
        """(omega1 at phi1 = 0 of the periodic motion, the works over its turn) by secant steps."""
        a, ga = w_guess, self.turn(w_guess, rtol)[0] - w_guess
        b = a + ga
        for _ in range(40):
            gb = self.turn(b, rtol)[0] - b
            if gb == ga or abs(gb) < 1e-13 * b:
                break
            a, ga, b = b, gb, b - gb * (b - a) / (gb - ga)
        y = self.turn(b, rtol)
        return b, {"W_motor": y[2], "W_work": y[3], "W_weights": y[4], "W_friction": y[5]}
