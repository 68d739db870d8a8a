"""Motor characteristic reduced to the crank."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class MotorLine:
    """Piecewise-linear motor line (seed 000): torque in N.m on the crank.

    ``A - B*omega1`` for omega1 > omega_switch (the working line) and
    ``A_low - B_low*omega1`` for omega1 <= omega_switch (start-up line). Both lines are
    extended linearly beyond their ranges, so the torque stays defined at and below
    omega1 = 0 (start from rest, stall, reversal).

    A, A_low in N.m; B, B_low in N.m.s/rad; omega_switch in rad/s.
    """

    A: float
    B: float
    A_low: float
    B_low: float
    omega_switch: float

    def torque(self, omega1, high: bool):
        """Torque (N.m) on the given branch; the caller decides the branch (see ``is_high``)."""
        if high:
            return self.A - self.B * omega1
        return self.A_low - self.B_low * omega1

    def is_high(self, omega1) -> bool:
        return omega1 > self.omega_switch

    def torque_at(self, omega1):
        """Torque (N.m) with the branch chosen by omega1 itself (for outputs, arrays welcome)."""
        import numpy as np

        omega1 = np.asarray(omega1, dtype=float)
        return np.where(omega1 > self.omega_switch,
                        self.A - self.B * omega1, self.A_low - self.B_low * omega1)
