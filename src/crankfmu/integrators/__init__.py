"""Integrators of the movement equation, all behind ``Integrator.run``."""

from __future__ import annotations

import math

from ..errors import ParameterError
from .base import Integrator, Trajectory
from .crank_angle import BadoiuEq17, CrankAngleScheme, LvEq3
from .fast import FastIntegrator, FastStepper
from .stepper import DormandPrinceIntegrator, DormandPrinceStepper, StepperState
from .time_domain import SolveIvpIntegrator, radau, reference

METHODS = ("fast", "reference", "radau", "dopri5", "badoiu-eq17", "lv-eq3")


def make_integrator(method: str, rtol: float | None = None, angle_step: float | None = None) -> Integrator:
    """The integrator called ``method`` (one of METHODS).

    rtol applies to the time-domain methods; angle_step (rad, default 0.1 deg) to the
    crank-angle schemes.
    """
    if method == "fast":
        return FastIntegrator(rtol)
    if method == "reference":
        return reference(rtol)
    if method == "radau":
        return radau(rtol)
    if method == "dopri5":
        return DormandPrinceIntegrator(1e-10 if rtol is None else rtol)
    step = math.radians(0.1) if angle_step is None else angle_step
    if method == "badoiu-eq17":
        return BadoiuEq17(step)
    if method == "lv-eq3":
        return LvEq3(step)
    raise ParameterError(f"unknown method {method!r}; valid methods: {', '.join(METHODS)}", "method")


__all__ = ["METHODS", "BadoiuEq17", "CrankAngleScheme", "DormandPrinceIntegrator", "DormandPrinceStepper", "FastIntegrator", "FastStepper",
           "Integrator", "LvEq3", "SolveIvpIntegrator", "StepperState", "Trajectory", "make_integrator",
           "radau", "reference"]
