"""Dynamics: reduced inertia, loads, motor and the equation of motion."""

from .equation import MovementEquation
from .loads import AppliedLoad, DeadPointMoment, SliderForce, ViscousForce, Weights, rocker_extremes
from .motor import MotorLine
from .reduced import LinkInertia, ReducedModel

__all__ = ["AppliedLoad", "DeadPointMoment", "LinkInertia", "MotorLine", "MovementEquation", "ReducedModel",
           "SliderForce", "ViscousForce", "Weights", "rocker_extremes"]
