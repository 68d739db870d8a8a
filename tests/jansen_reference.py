"""An independent reference of Jansen's leg on the ground (the packaged scenario jansen): its
positions by circle intersections (no contour, no Newton), the points' velocities per omega1 by
complex-step differentiation of those positions (exact to rounding), J(phi1) from the links' mass
centres and angular velocities, J' by an 8th-order central difference of J, the Lagrange equation
J epsilon + J'/2 omega^2 = M(omega) + Q(phi1) integrated by DOP853 and restarted wherever the foot
touches or leaves the ground, so that no step straddles the contact's kink."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

STEP = 1e-30                       # the complex step
FD = 2e-3                          # rad: the central difference of J
FD_WEIGHTS = (4 / 5, -1 / 5, 4 / 105, -1 / 280)     # 8th order, offsets 1..4


def _circles(P, r1, Q, r2, sign):
    """An intersection of circles (P, r1), (Q, r2): sign +1 left of P->Q, -1 right."""
    dx, dy = Q[0] - P[0], Q[1] - P[1]
    d = np.sqrt(dx * dx + dy * dy)
    x = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    y = np.sqrt(r1 * r1 - x * x)
    ex, ey = dx / d, dy / d
    return (P[0] + x * ex - sign * y * ey, P[1] + x * ey + sign * y * ex)


def positions(phi, p):
    """Every point at crank angle phi (real or complex)."""
    O = (0.0 * phi, 0.0 * phi)
    Q = (-p["la"] + 0.0 * phi, -p["ll"] + 0.0 * phi)
    A = (p["lm"] * np.cos(phi), p["lm"] * np.sin(phi))
    C = _circles(A, p["lj"], Q, p["lb"], -1.0)        # above the line A-Q (A is to the right of Q)
    D = _circles(A, p["lk"], Q, p["lc"], +1.0)        # below it
    E = _circles(Q, p["ld"], C, p["le"], +1.0)        # left of Q->C
    F = _circles(E, p["lf"], D, p["lg"], -1.0)        # right of E->D
    G = _circles(D, p["li"], F, p["lh"], +1.0)        # the foot, left of D->F: below
    mid = lambda P1, P2, s: (P1[0] + s * (P2[0] - P1[0]), P1[1] + s * (P2[1] - P1[1]))   # noqa: E731
    centroid = lambda a, b, c: ((a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3)       # noqa: E731
    return {"O": O, "Q": Q, "A": A, "C": C, "D": D, "E": E, "F": F, "G": G,
            "G1": mid(O, A, 0.5), "Gj": mid(A, C, 0.5), "Gk": mid(A, D, 0.5), "Gc": mid(Q, D, 0.5),
            "Gf": mid(E, F, 0.5), "Gu": centroid(Q, C, E), "Gl": centroid(D, F, G)}


def links(p):
    """(centre, mass, inertia about it, the two points giving its angle) of each link."""
    q = p["q"]

    def bar(length):
        return q * length, q * length ** 3 / 12

    def plate(a, b, c):
        return q * (a + b + c), q * (a + b + c) * (a * a + b * b + c * c) / 36
    return [("G1", *bar(p["lm"]), ("O", "A")), ("Gj", *bar(p["lj"]), ("A", "C")),
            ("Gu", *plate(p["lb"], p["ld"], p["le"]), ("Q", "C")), ("Gk", *bar(p["lk"]), ("A", "D")),
            ("Gc", *bar(p["lc"]), ("Q", "D")), ("Gf", *bar(p["lf"]), ("E", "F")),
            ("Gl", *plate(p["lg"], p["lh"], p["li"]), ("D", "F"))]


def rates(phi, p):
    """(positions, d/dphi1 of every point's coordinates) at a real phi, by the complex step."""
    z = positions(phi + 1j * STEP, p)
    return ({k: (v[0].real, v[1].real) for k, v in z.items()},
            {k: (v[0].imag / STEP, v[1].imag / STEP) for k, v in z.items()})


def inertia(phi, p):
    """J(phi1) kg.m2: the flywheel and every link's m |v|^2 + I w^2 per omega1^2."""
    x, dx = rates(phi, p)
    J = p["J_flywheel"]
    for centre, mass, I, (a, b) in links(p):
        ux, uy = x[b][0] - x[a][0], x[b][1] - x[a][1]
        dux, duy = dx[b][0] - dx[a][0], dx[b][1] - dx[a][1]
        w = (ux * duy - uy * dux) / (ux * ux + uy * uy)        # the link's angle's rate per omega1
        J += mass * (dx[centre][0] ** 2 + dx[centre][1] ** 2) + I * w * w
    return J


def contact_gap(phi, p):
    return p["y_ground"] - positions(phi, p)["G"][1]


def generalized_force(phi, p):
    """Q(phi1) N.m: the weights and the ground's push on the foot, each times its point's dy/dphi1."""
    x, dx = rates(phi, p)
    Q = sum(-mass * p["g"] * dx[centre][1] for centre, mass, _, _ in links(p))
    return Q + p["k_g"] * max(0.0, p["y_ground"] - x["G"][1]) * dx["G"][1]


def omega1(p, stop: float):
    """omega1 (rad/s) from 0 to ``stop`` s: a function of an array of times."""
    def motor(w):
        return p["A"] - p["B"] * w if w > p["omega_switch"] else p["A_low"] - p["B_low"] * w

    def rhs(t, y):
        phi, w = y
        J = inertia(phi, p)
        half_dJ = 0.5 * sum(c * (inertia(phi + k * FD, p) - inertia(phi - k * FD, p))
                            for k, c in enumerate(FD_WEIGHTS, start=1)) / FD
        return [w, (motor(w) + generalized_force(phi, p) - half_dJ * w * w) / J]

    def touch(t, y):
        return contact_gap(y[0], p)
    pieces, t, y = [], 0.0, [p["phi1_start"], p["omega1_start"]]
    while t < stop:
        run = solve_ivp(rhs, (t, stop), y, method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True, events=touch)
        crossed = [e for e in run.t_events[0] if e > t + 1e-12]
        end = crossed[0] if crossed else stop
        if not crossed and run.status == 1:
            run = solve_ivp(rhs, (t, stop), y, method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True)
        pieces.append((t, end, run.sol))
        t, y = end, run.sol(end)
    return lambda times: np.array([next(sol(x)[1] for a, b, sol in pieces if a <= x <= b) for x in times])
