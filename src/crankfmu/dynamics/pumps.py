"""The sucker-rod string's foot: the force the pump exerts on the bottom node, solved exactly at
each step of the string (dynamics/rodstring.py; crank_components.c states the valve pump again in
C, tests/test_rodstring_c.py compares them).

The pump (``ValvePump``): the plunger is the bottom node. The force P the pump exerts on the
rods (downward positive) is set-valued, like dry friction:

- moving up: the travelling valve is closed and the plunger lifts the fluid: P = Fo + Ff;
- moving down through liquid: the travelling valve is open: P = -Ff;
- moving down through gas (partial fillage: the first (1 - fillage) of the downstroke below the
  top of the stroke): the valve stays closed: P = Fo - Ff, until the plunger strikes the liquid
  (fluid pound) and the load drops;
- at rest: P anywhere between the two, the rods stretching or relaxing while the load transfers
  between the tubing and the rods.

Fo = (p_discharge - p_intake) x plunger area, Ff the plunger friction. Each step solves for P
exactly (a projection: the unique P and velocity satisfying the law after the step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

UP, DOWN, REST = 1, -1, 0


@dataclass
class ValvePump:
    """The pump's set-valued force on the plunger node (module docstring)."""

    Fo: float
    friction: float = 0.0
    fillage: float = 1.0
    motion: int = REST
    u_top: float = math.nan       # plunger position (downward) where the last upstroke ended
    u_bottom: float = math.nan    # ... where it began
    # the pump's work, split (J): hydraulic, friction, the plunger node's stops
    hydraulic: float = 0.0
    friction_loss: float = 0.0
    stop_loss: float = 0.0
    _gas: bool = False

    def loaded_going_down(self, u: float) -> bool:
        """True while the plunger descends through the barrel's gas (the valve stays closed)."""
        if self.fillage >= 1.0 or math.isnan(self.u_top) or math.isnan(self.u_bottom):
            return False
        return u < self.u_top + (1.0 - self.fillage) * (self.u_bottom - self.u_top)

    def solve(self, v_free: float, b: float, u: float, v_old: float) -> tuple[float, float]:
        """(P, v_new) with v_new = v_free + b P and P in the pump's law."""
        gas = self.loaded_going_down(u)
        p_hi = self.Fo + self.friction
        p_lo = (self.Fo if gas else 0.0) - self.friction
        p_rest = -v_free / b
        if p_rest > p_hi:
            P, motion = p_hi, UP
        elif p_rest < p_lo:
            P, motion = p_lo, DOWN
        else:
            P, motion = p_rest, REST
        if motion == UP and self.motion != UP:
            self.u_bottom = u
        elif motion != UP and self.motion == UP:
            self.u_top = u
        self.motion = motion
        self._gas = gas
        return P, v_free + b * P

    def account(self, P: float, travel: float):
        """Split the pump's work -P x travel (travel downward, m) over the step just solved."""
        if self.motion == REST:
            self.stop_loss -= P * travel
            return
        fluid = self.Fo if (self.motion == UP or self._gas) else 0.0
        self.hydraulic -= fluid * travel
        self.friction_loss -= (P - fluid) * travel

    @property
    def work(self) -> float:
        return self.hydraulic + self.friction_loss + self.stop_loss

    def state(self) -> list:
        return [self.motion, self.u_top, self.u_bottom, self.hydraulic, self.friction_loss, self.stop_loss]

    def restore(self, s):
        self.motion, self.u_top, self.u_bottom, self.hydraulic, self.friction_loss, self.stop_loss = s
        self.motion = int(self.motion)


@dataclass
class LinearFoot:
    """A spring-dashpot at the string's foot, P = -k u - c v: the linear boundary whose
    harmonic response is known in closed form (rodstring.harmonic_solution)."""

    k: float
    c: float
    hydraulic: float = 0.0
    friction_loss: float = 0.0
    stop_loss: float = 0.0

    def solve(self, v_free, b, u, v_old):
        v_new = (v_free - b * self.k * u - b * self.c * v_old / 2) / (1 + b * self.c / 2)
        return -self.k * u - self.c * (v_new + v_old) / 2, v_new

    def account(self, P, travel):
        self.friction_loss -= P * travel

    @property
    def work(self):
        return self.friction_loss

    def state(self):
        return [self.friction_loss]

    def restore(self, s):
        (self.friction_loss,) = s
