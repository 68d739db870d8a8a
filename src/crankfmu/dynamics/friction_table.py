"""The joints' friction tabulated for the C kernel (crank_kernel.h, CkFriction; its solve:
native/kernel/crank_friction.c; the rule: dynamics.friction).

At each state the kernel solves the frictions and the crank's acceleration together. What it needs
of the mechanism is, per friction, its relative rate k_i (rad/rad or m/rad) and its joint's reaction
components (a pin's two, a slide's normal force) as linear combinations: the joint reactions'
terms (reaction_table.reaction_terms: 1, epsilon1, omega1^2, omega1, the switched columns, the ports),
then one term per unit friction (each friction at value 1 alone, dynamics.friction.unit_loads).
These are functions of phi1 alone, tabulated once per design as periodic cubics like the reduced
model; the kernel weighs them at each right-hand side and runs Newton's method on the n_f
frictions (a few operations per iteration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cubics import build_cubics
from .reduced import ReducedModel
from .reaction_table import REACTION_TERMS, reaction_terms, zero_terms


@dataclass
class FrictionTable:
    """coefficients (n_f + sum(components) (n_terms + n_f), n, 4): the rates k_i, then each
    friction's reaction components' terms (crank_kernel.h's CkFriction layout); components (n_f,)
    2 for a pin, 1 for a slide; c (n_f,) mu r (m) or mu; signs (max(m, 1), n_f) each friction's
    sign on each switch interval of the reduced table, forward; error_bound the checked largest
    relative difference from the Newton-Euler solve."""

    coefficients: np.ndarray
    components: np.ndarray
    c: np.ndarray
    signs: np.ndarray
    n_terms: int
    error_bound: float
    construction: str
    _interval_major: np.ndarray | None = None

    @property
    def interval_major(self) -> np.ndarray:
        """The coefficients as the kernel reads them, (n, functions, 4) contiguous (crank_kernel.h,
        CkFriction): copied once per table, not once per run."""
        if self._interval_major is None:
            self._interval_major = np.ascontiguousarray(np.asarray(self.coefficients, dtype=float).transpose(1, 0, 2))
        return self._interval_major

    def joint_outputs(self, friction, frictions, phi1, omega1, period: float) -> dict:
        """Each joint's friction and its power (dynamics.friction.joint_values) at crank angles
        ``phi1`` (rad) and speeds ``omega1`` (rad/s), from the kernel's ``frictions`` there: the
        relative rates are this table's first functions. ``friction``: the design's joint friction
        (dynamics.friction), ``period``: the reduced table's (rad)."""
        from .cubics import evaluate_cubics
        from .friction import joint_values

        rates = evaluate_cubics(self.coefficients[:len(friction)], phi1, period)
        return joint_values(friction.frictions, frictions, rates, omega1)


def tabulate_frictions(reduced: ReducedModel, tolerance: float = 1e-11, n_max: int = 1 << 16,
                       loosest: float = 1e-8) -> FrictionTable:
    """The friction table of ``reduced`` (which has joint friction), to ``tolerance`` relative to
    each function's largest magnitude, by the reduced table's constructions."""
    friction = reduced.friction
    frictions = friction.frictions
    n_f = len(frictions)
    _, n_all, terms, _ = reaction_terms(reduced)         # (its last n_f: the unit frictions)
    n_terms = n_all - n_f
    # each friction's components among the reactions' (reactions.reaction_outputs: two per joint,
    # a slide's normal force first)
    rows = [c for f in frictions for c in ((2 * f.index, 2 * f.index + 1) if f.joint.kind == "revolute"
                                           else (2 * f.index,))]

    def component_terms(phi1):
        return terms(np.asarray(phi1, dtype=float))[rows]       # (components, n_terms + n_f, angles)

    keep = zero_terms(component_terms, reduced.period, reduced.cycle_turns)

    def engine(phi1):
        phi1 = np.asarray(phi1, dtype=float)
        rates = friction.rates(reduced.mechanism.kinematics(phi1))
        return np.concatenate([rates, (component_terms(phi1) * keep[:, :, None]).reshape(-1, phi1.size)])

    names = ([f"joint {f.name}'s relative rate" for f in frictions]
             + [f"joint {frictions[i].name}'s reaction component {c} ({term} term)"
                for i, f in enumerate(frictions) for c in range(2 if f.joint.kind == "revolute" else 1)
                for term in (*REACTION_TERMS, *(f"column {k}" for k in range(n_terms - 4)),
                             *(f"unit friction {g.name}" for g in frictions))])
    coefficients, error, construction = build_cubics(engine, tolerance, 256, n_max, loosest,
                                                     ("the joints' friction", names), reduced.cycle_turns)
    components = np.array([2 if f.joint.kind == "revolute" else 1 for f in frictions], dtype=np.int32)
    signs = np.asarray(reduced.friction_signs(), dtype=float).reshape(-1, n_f)
    return FrictionTable(coefficients, components, friction.coefficients.copy(), signs, n_terms, error,
                         construction)
