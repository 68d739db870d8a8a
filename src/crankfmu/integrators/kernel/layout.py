"""The compiled kernel's memory layout: what each float of its state and parameter arrays holds.

The whole integrator state is one float array, so an FMU saves and restores it by copying, and a
run can stop and continue (progress, growing output buffers) without a trace. numpy only: the
compiled files read these numbers as constants, Python callers (the fast integrator, the FMU, the
batch of steady cycles) index and allocate with them.
"""

from __future__ import annotations

import math

import numpy as np

from ...dynamics.modes import N_SLOTS
from ..tableau import N_STAGES

# ---- state array
T, Y, F_, H = 0, 1, 6, 11                    # t s, y[5], f[5], proposed step s
MOTOR, DIRECTION, INTERVAL, PHI_LO, PHI_HI = 12, 13, 14, 15, 16    # the mode (dynamics.modes)
T_PREV, Y_PREV, K = 17, 18, 23               # last step: start, start state, 7x5 stages
N_RHS, STEP_MOTOR, STEP_DIRECTION, STEP_INTERVAL, N_STEPS = 58, 59, 60, 61, 62
STATE_SIZE = 63
N_Y = 5                                      # phi1, omega1, W_motor, W_load, W_ext

# ---- parameter array
A_, B_, A_LOW, B_LOW, OMEGA_SWITCH, TAU_EXT, J_FLYWHEEL, RTOL, ATOL, H_MAX = range(10)
PARAM_SIZE = 10

# ---- output row: the state, then the contract outputs the tables give (``method.output_row``)
ROW_FIELDS = ("phi1", "omega1", "W_motor", "W_load", "W_ext", "epsilon1", "M_motor", "M_load", "J_red")
OUT_SIZE = len(ROW_FIELDS)

# ---- steady cycles of many designs (``drivers.steady_batch``)
SLOPE_SAMPLES = 8    # the speed's slope is sampled at 9 points of each step to bracket its extremes
STEADY_SIZE = 7      # omega1_mean, omega1_min, omega1_max, delta, period, turns, status
STEADY_OK, STEADY_NOT_CONVERGED, STEADY_STALLS, STEADY_UNDERFLOW = 0.0, 1.0, 2.0, 3.0

#: what the stepping functions return besides an event slot
NO_EVENT, UNDERFLOW = -1, -2


def parameters(motor, J_flywheel: float, tau_ext: float, rtol: float, atol: float,
               h_max: float = math.inf) -> np.ndarray:
    """The parameter array of one design."""
    P = np.zeros(PARAM_SIZE)
    set_motor(P, motor)
    P[TAU_EXT], P[J_FLYWHEEL] = tau_ext, J_flywheel
    P[RTOL], P[ATOL], P[H_MAX] = rtol, atol, h_max
    return P


def set_motor(P: np.ndarray, motor):
    """Write a MotorLine into a parameter array."""
    P[A_], P[B_], P[A_LOW], P[B_LOW], P[OMEGA_SWITCH] = (
        motor.A, motor.B, motor.A_low, motor.B_low, motor.omega_switch)


class Workspace:
    """Scratch arrays of one integration (allocated once, reused by every call)."""

    def __init__(self, n_functions: int):
        self.work = np.zeros(max(n_functions, 4))
        self.Kst = np.zeros((N_STAGES + 1, N_Y))
        self.ynew = np.zeros(N_Y)
        self.tmp = np.zeros(N_Y)
        self.f = np.zeros(N_Y)
        self.g0 = np.zeros(N_SLOTS)
        self.g1 = np.zeros(N_SLOTS)
        self.y = np.zeros(N_Y)
        self.f0 = np.zeros(N_Y)

    def arrays(self):
        """The scratch arrays as one tuple, in the order the kernel's stepping functions take them."""
        return self.work, self.Kst, self.ynew, self.tmp, self.f, self.g0, self.g1, self.y, self.f0
