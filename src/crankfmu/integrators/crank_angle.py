"""Crank-angle schemes: the movement equation stepped in phi1 instead of t.

Both papers integrate d(omega1)/d(phi1) on a fixed angle grid phi_i = phi_0 + i*dphi:

* ``badoiu-eq17`` (seed 000 eq. 17), explicit Euler in phi1::

      omega_{i+1} = omega_i + dphi/(omega_i S2_i) (-A + B omega_i - S1_i - omega_i^2 S3_i)

  with S2 = -J, S3 = -0.5 J', S1 = Q and the motor branch chosen by omega_i, as published.

* ``lv-eq3`` (seed 003 eq. 3), the same balance with J' replaced by the difference of J over the
  step::

      omega_{t+1} = M_e(phi_t, omega_t) dphi / (J_t omega_t) + (3 J_t - J_{t+1}) / (2 J_t) omega_t

The time axis is rebuilt from the angle steps assuming a constant angular acceleration over
each step (dphi = (omega_i + omega_{i+1})/2 dt), so both schemes can be compared with the
time-domain integrators on the same footing. Both divide by omega1: a case that reaches
omega1 <= 0 (start from rest, stall, reversal) raises SchemeError instead of returning garbage.
"""

from __future__ import annotations

import math

import numpy as np

from ..dynamics.equation import STATE_SIZE
from ..errors import ParameterError, SchemeError
from .base import Integrator, Trajectory


class CrankAngleScheme(Integrator):
    time_domain = False
    formula = "?"

    def __init__(self, angle_step: float = math.radians(0.1)):
        if not (angle_step > 0 and math.isfinite(angle_step)):
            raise ParameterError(
                f"angle_step must be a positive angle in rad (e.g. {math.radians(0.1):.6g} for 0.1 deg), "
                f"got {angle_step!r}", "angle_step")
        self.angle_step = float(angle_step)

    def next_omega(self, omega, Me, J, J_next, half_dJ, h):
        raise NotImplementedError  # each scheme defines its own recursion

    def _fail(self, t, phi, omega):
        return SchemeError(
            f"{self.name} cannot run this case: omega1 = {omega:.6g} rad/s <= 0 at t = {t:.6g} s, "
            f"phi1 = {math.degrees(phi):.3f} deg. The crank-angle form divides by omega1, so it "
            "cannot start from rest, stall or reverse; use method='reference' (time domain)."
        )

    def run(self, equation, t0, y0, t_end, progress=None, output_times=None):
        reduced, motor, tau = equation.reduced, equation.motor, equation.tau_ext
        if any(callable(u) or u != 0.0 for u in equation.port_inputs):
            raise SchemeError(f"{self.name}: the crank-angle schemes take no port inputs (the paper's eq. 17 "
                              "has none); use method 'fast' or 'reference'")
        if equation.friction is not None:
            raise SchemeError(f"{self.name}: the crank-angle schemes take no joint friction (the paper's eq. 17 "
                              "has none); use method 'reference'")
        h = self.angle_step
        phi0, omega = float(y0[0]), float(y0[1])
        t = float(t0)
        if not omega > 0.0:
            raise self._fail(t, phi0, omega)
        chunk = max(16, int(math.ceil(2 * math.pi / h)))
        ts, ws, eps, Wm, Wl, We = [t], [omega], [], [0.0], [0.0], [0.0]
        wm = wl = we = 0.0
        i_global = 0
        n_rhs = 0
        done = False
        while len(eps) < len(ts):     # every node, the last included, gets its eq.-10 acceleration
            # position-dependent coefficients for the next chunk of the grid, in one vectorised call
            phis = phi0 + h * (i_global + np.arange(chunk + 1))
            J, half_dJ, Qp, kin = reduced.coefficients(phis)
            n_rhs += chunk
            for i in range(chunk):
                Q = Qp[i]
                if reduced.velocity_dependent:
                    Q += float(reduced.velocity_load(kin.subset(i), omega)[0])
                M = motor.torque(omega, omega > motor.omega_switch)
                Me = M + Q + tau
                omega_next = self.next_omega(omega, Me, J[i], J[i + 1], half_dJ[i], h)
                eps.append((omega_next - omega) / h * omega)   # eq. 10
                if done:
                    break
                if not (omega_next > 0.0 and math.isfinite(omega_next)):
                    raise self._fail(t, phis[i + 1], omega_next)
                t += 2.0 * h / (omega + omega_next)
                wm += M * h
                wl += Q * h
                we += tau * h
                omega = omega_next
                ts.append(t)
                ws.append(omega)
                Wm.append(wm)
                Wl.append(wl)
                We.append(we)
                # one more pass through the loop gives the last node its eq.-10 acceleration
                done = t >= t_end
            i_global += chunk
            if progress is not None:
                progress(t)
        n = len(ts)
        y = np.empty((STATE_SIZE, n))
        y[0] = phi0 + h * np.arange(n)
        y[1] = ws
        y[2], y[3], y[4] = Wm, Wl, We
        return Trajectory(t=np.array(ts), y=y, epsilon=np.array(eps[:n]), n_rhs=n_rhs, n_steps=n - 1)


class BadoiuEq17(CrankAngleScheme):
    """Seed 000 eq. 17: explicit Euler in phi1, J' from the analytic transfer functions."""

    name = "badoiu-eq17"

    def next_omega(self, omega, Me, J, J_next, half_dJ, h):
        return omega + h * (Me - half_dJ * omega * omega) / (J * omega)


class LvEq3(CrankAngleScheme):
    """Seed 003 eq. 3: J' replaced by the forward difference of J over the angle step."""

    name = "lv-eq3"

    def next_omega(self, omega, Me, J, J_next, half_dJ, h):
        return Me * h / (J * omega) + (3.0 * J - J_next) / (2.0 * J) * omega
