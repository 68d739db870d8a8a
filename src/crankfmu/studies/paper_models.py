"""The papers' own approximate models, kept to measure how far they are from the exact kinematics.

A scenario's ``[kinematics] approximation`` names one of ``APPROXIMATIONS``; each takes the
scenario's parameter values and crank angles (rad) at constant omega1 (rad/s) and returns the
same quantities as the exact study (positions m, velocities m/s, accelerations m/s2).
"""

from __future__ import annotations

import numpy as np


def malcoci_mathcad(values: dict, phi, omega1: float) -> dict:
    """Seed 002 eqs. 4-9: psi = atan(Y_A/b) in place of asin(r sin(phi)/b), C at b/2 in place of AC.

    X_B = r cos(phi) + b cos(psi); V_B, a_B its time derivatives (eqs. 7-8) taken analytically at
    constant omega1; C = (r cos(phi) + b/2 cos(psi), b/2 sin(psi)) (eq. 9, as printed).
    """
    r, b = values["l1"], values["l2"]
    phi = np.asarray(phi, dtype=float)
    k = r / b
    s, c = np.sin(phi), np.cos(phi)
    den = 1.0 + (k * s) ** 2
    psi = np.arctan(k * s)
    dpsi = k * c / den                                           # dpsi/dphi
    ddpsi = (-k * s * den - k * c * 2.0 * k * k * s * c) / den ** 2
    x = r * c + b * np.cos(psi)
    dx = -r * s - b * np.sin(psi) * dpsi
    ddx = -r * c - b * np.cos(psi) * dpsi ** 2 - b * np.sin(psi) * ddpsi
    return {"x_B": x, "v_B": dx * omega1, "a_B": ddx * omega1 ** 2,
            "path": (r * c + 0.5 * b * np.cos(psi), 0.5 * b * np.sin(psi))}


APPROXIMATIONS = {"malcoci_mathcad": malcoci_mathcad}
