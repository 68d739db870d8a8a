"""Integrators of the movement equation, all behind ``Integrator.run``.

  fast         Dormand-Prince 5(4) on the tabulated model (the C kernel, ``crankfmu.native``), every switch
               located: the FMUs' integrator and ``simulate``'s default
  time_domain  scipy's solve_ivp, a segment per mode (the engine-based ``reference`` DOP853,
               ``radau``, ``dopri5``: scipy's RK45): the independent checks
  crank_angle  the papers' own schemes in the crank angle (seed 000 eq. 17, seed 003 eq. 3)

The submodules are imported on first use: the FMUs ship the fast path only (``base``, ``fast``:
numpy and the C kernel), the others need scipy.
"""

from __future__ import annotations

import importlib
import math

from ..errors import ParameterError
from .base import Integrator, Trajectory

METHODS = ("fast", "reference", "radau", "dopri5", "badoiu-eq17", "lv-eq3")

_WHERE = {
    "BadoiuEq17": "crank_angle", "CrankAngleScheme": "crank_angle", "LvEq3": "crank_angle",
    "FastIntegrator": "fast", "FastStepper": "fast",
    "SolveIvpIntegrator": "time_domain", "dopri5": "time_domain", "radau": "time_domain",
    "reference": "time_domain",
}


def __getattr__(name):
    if name in _WHERE:
        return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def make_integrator(method: str, rtol: float | None = None, angle_step: float | None = None) -> Integrator:
    """The integrator called ``method`` (one of METHODS).

    rtol applies to the time-domain methods; angle_step (rad, default 0.1 deg) to the
    crank-angle schemes.
    """
    from .crank_angle import BadoiuEq17, LvEq3
    from .fast import FastIntegrator
    from .time_domain import dopri5, radau, reference

    if method == "fast":
        return FastIntegrator(rtol)
    if method == "reference":
        return reference(rtol)
    if method == "radau":
        return radau(rtol)
    if method == "dopri5":
        return dopri5(rtol)
    step = math.radians(0.1) if angle_step is None else angle_step
    if method == "badoiu-eq17":
        return BadoiuEq17(step)
    if method == "lv-eq3":
        return LvEq3(step)
    raise ParameterError(f"unknown method {method!r}; valid methods: {', '.join(METHODS)}", "method")


__all__ = ["METHODS", "BadoiuEq17", "CrankAngleScheme", "FastIntegrator", "FastStepper", "Integrator", "LvEq3",
           "SolveIvpIntegrator", "Trajectory", "dopri5", "make_integrator", "radau", "reference"]
