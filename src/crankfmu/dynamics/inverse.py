"""Inverse dynamics: the equilibrium moment M_e(phi1) a drive must apply to the crank to impose a
prescribed motion (seed 001 eq. 1, the balance of instantaneous powers):

    M_e omega1 + sum G_j . v_Cj + sum (F_ij . v_Cj + M_ij . omega_j) + sum F_tech . v = 0

with the inertia forces F_ij = -m_j a_Cj and moments M_ij = -I_Cj eps_j. Velocities and
accelerations come from the transfer functions (eqs. 12-14)::

    v_C = omega1 (t, p)            a_C = eps1 (t, p) + omega1^2 (tt, pp)
    omega_j = omega1 q_j           eps_j = eps1 q_j + omega1^2 qq_j

The powers are summed link by link and load by load, each split into weights, technological
loads and inertia, so M_e = M_weights + M_technological + M_inertia. At constant omega1 the
inertia part is 0.5 J'(phi1) omega1^2: exactly proportional to omega1^2.

The joint reactions (:mod:`.reactions`) give the same M_e by Newton-Euler, an independent check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .loads import TECHNOLOGICAL, WEIGHTS
from .reduced import ReducedModel


@dataclass
class EquilibriumMoment:
    """M_e and its parts at an array of crank angles, N.m (positive: the drive turns the crank
    forward).

    phi1 rad, omega1 rad/s, epsilon1 rad/s2: the prescribed motion.
    weights, technological, inertia: the parts of M_e that balance each category's power.
    """

    phi1: np.ndarray
    omega1: np.ndarray
    epsilon1: np.ndarray
    weights: np.ndarray
    technological: np.ndarray
    inertia: np.ndarray

    @property
    def total(self) -> np.ndarray:
        """M_e with inertia, N.m."""
        return self.weights + self.technological + self.inertia

    @property
    def static(self) -> np.ndarray:
        """M_e with the inertia forces and moments neglected, N.m."""
        return self.weights + self.technological


def prescribed_motion(phi1, omega1, epsilon1=0.0, forward: bool = True):
    """Arrays (phi1 rad, omega1 rad/s, epsilon1 rad/s2) of a prescribed crank motion.

    ``omega1`` is a constant or an array over phi1 (any omega1(phi1)); for a law omega1(phi1)
    the acceleration is eps1 = omega1 domega1/dphi1. With ``forward`` omega1 must be > 0: eq. 1
    divides the powers by it, and the technological forces' direction follows the motion
    (Newton-Euler, which divides by nothing, takes any finite omega1: forward False).
    """
    phi1 = np.atleast_1d(np.asarray(phi1, dtype=float))
    omega1 = np.broadcast_to(np.asarray(omega1, dtype=float), phi1.shape).copy()
    epsilon1 = np.broadcast_to(np.asarray(epsilon1, dtype=float), phi1.shape).copy()
    if not np.all(np.isfinite(omega1)):
        raise ParameterError("omega1 must be finite (rad/s)", "omega1")
    if forward and np.any(omega1 <= 0.0):
        bad = omega1[~(omega1 > 0.0)]
        raise ParameterError(
            f"omega1 must be > 0 rad/s (the crank turning forward) for the equilibrium moment, "
            f"got {float(bad[0]) if bad.size else float('nan'):g} rad/s", "omega1")
    if not np.all(np.isfinite(epsilon1)):
        raise ParameterError("epsilon1 must be finite (rad/s2)", "epsilon1")
    return phi1, omega1, epsilon1


def equilibrium_moment(reduced: ReducedModel, phi1, omega1, epsilon1=0.0) -> EquilibriumMoment:
    """M_e(phi1) by eq. 1 for the mechanism, links and loads of ``reduced`` (flywheel included)."""
    phi1, omega1, epsilon1 = prescribed_motion(phi1, omega1, epsilon1)
    kin = reduced.mechanism.kinematics(phi1)
    power = {WEIGHTS: np.zeros_like(phi1), TECHNOLOGICAL: np.zeros_like(phi1)}
    for load in reduced.loads:
        part = power[load.category]
        for f in load.applied(kin, omega1):
            if f.point is not None:
                _, _, dx, dy, _, _ = kin.point(f.point)
                part += (f.fx * dx + f.fy * dy) * omega1
            if np.any(f.moment != 0.0):
                part += f.moment * kin.link_angle(f.link)[1] * omega1
    inertia_power = -reduced.J_flywheel * epsilon1 * omega1
    w2 = omega1 * omega1
    for link in reduced.links:
        _, _, t, p, tt, pp = kin.point(link.centre)
        _, q, qq = kin.link_angle(link.name)
        ax, ay = epsilon1 * t + w2 * tt, epsilon1 * p + w2 * pp
        eps = epsilon1 * q + w2 * qq
        inertia_power -= link.mass * (ax * t + ay * p) * omega1 + link.inertia * eps * q * omega1
    return EquilibriumMoment(
        phi1=phi1, omega1=omega1, epsilon1=epsilon1,
        weights=-power[WEIGHTS] / omega1,
        technological=-power[TECHNOLOGICAL] / omega1,
        inertia=-inertia_power / omega1,
    )
