"""Dynamics: the reduced model (inertia J, 0.5 J', loads reduced to the crank), the motor line, the
hybrid rules of the movement equation (``modes``, stated again in the C kernel and compared with it), the movement
equation on the contour engine (``equation``), its tabulation for the fast path (``tabulated``),
inverse dynamics and joint reactions, and the DC drive."""

from .equation import MovementEquation
from .loads import AppliedLoad, DeadPointMoment, SliderForce, ViscousForce, Weights, rocker_extremes
from .motor import MotorLine
from .reduced import LinkInertia, ReducedModel

__all__ = ["AppliedLoad", "DeadPointMoment", "LinkInertia", "MotorLine", "MovementEquation", "ReducedModel",
           "SliderForce", "ViscousForce", "Weights", "rocker_extremes"]
