"""The joint reactions tabulated for the FMUs (dynamics.reactions' Newton-Euler, term by term): a
reaction is linear in the crank's acceleration, omega1^2, omega1, the switched loads' values, the
ports' inputs and, with joint friction, each friction's value, with coefficients that are functions
of phi1 alone; the FMUs weigh the tabulated terms (the kernel's ck_reaction_values). The joints'
friction table (friction_table.py) takes its reaction components' terms from here too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cubics import build_cubics
from .reduced import ReducedModel

TWO_PI = 2.0 * np.pi

#: the terms a joint reaction is linear in, before the switched loads' and the ports' values
REACTION_TERMS = ("1", "epsilon1", "omega1^2", "omega1")


@dataclass
class ReactionTable:
    """The joint reactions (dynamics.reactions, Newton-Euler) tabulated for the native FMU.

    A reaction is linear in the crank's acceleration, in omega1^2 (the centripetal terms), in the
    loads linear in omega1 (dampers), in each switched load's value (a slider force's signed
    magnitude, a user load's direction selector) and in each port's input, with coefficients
    that are functions of phi1 alone: R = R_1 + epsilon1 R_eps + omega1^2 R_w2 + omega1 R_w
    + sum_s value_s R_s + sum_p input_p R_p.

    coefficients  (n_components n_terms, n, 4): component-major, terms in the order REACTION_TERMS,
                  the switched loads' columns (the reduced table's order), the ports
    names         the components' output names (dynamics.reactions.reaction_outputs' order)
    n_terms       4 + switched columns + ports (+ one per joint friction: its value)
    error_bound   the checked largest relative difference from the Newton-Euler solve
    """

    coefficients: np.ndarray
    names: tuple[str, ...]
    n_terms: int
    error_bound: float
    construction: str
    period: float = TWO_PI       # rad: the machine's cycle (the loads' terms repeat over it)


def reaction_terms(reduced: ReducedModel):
    """(names, n_terms, terms, solve): the joint reactions' outputs, their number of terms (the
    kernel's reaction weights: REACTION_TERMS, the switched columns, the ports, and with joint
    friction one per friction, its value: ck_reaction_values), ``terms(phi1)`` (components, terms,
    angles) by one Newton-Euler solve per term with that part of the loads alone, and
    ``solve(phi1, extra=...)`` (components, angles) for other applied loads alone."""
    from .reactions import joint_reactions, reaction_arrays, reaction_outputs

    n_f = 0 if reduced.friction is None else len(reduced.friction)

    names = tuple(name for name, _, _ in reaction_outputs(reduced.mechanism.definition))
    fixed = [load for load in reduced.loads if load.position_only]
    viscous = [load for load in reduced.loads if getattr(load, "linear_in_omega1", False)]
    # a load of the speeds beyond affine (speed_loads.PolynomialSpeedLoad) gives its parts at rest and
    # per omega1 as forces of its own; its other parts are columns
    polynomial = [load for load in viscous if hasattr(load, "applied_parts")]
    viscous = [load for load in viscous if load not in polynomial]
    with_rest = [load for load in viscous if hasattr(load, "parts")]       # user_loads.SpeedLoad
    columns = [(load, j) for load in reduced.sliders for j in range(len(load.column_names))]

    def solve(phi1, omega1=0.0, epsilon1=0.0, inertia=False, loads=(), extra=None):
        kin = reduced.mechanism.kinematics(phi1)
        arrays = reaction_arrays(joint_reactions(reduced, phi1, omega1, epsilon1, inertia=inertia, loads=list(loads),
                                                 extra=extra, kin=kin))
        return np.array([np.broadcast_to(arrays[name], phi1.shape) for name in names])

    def terms(phi1):
        phi1 = np.asarray(phi1, dtype=float)
        # a user's load of the speeds may have a part at rest (a generator's a + b omega1): it joins
        # the fixed term, and the term per omega1 is the rest (the dampers have none: no solve)
        at_rest = solve(phi1, loads=with_rest) if with_rest else 0.0
        out = [solve(phi1, loads=fixed) + at_rest,
               solve(phi1, epsilon1=1.0, inertia=True),
               solve(phi1, omega1=1.0, inertia=True),
               solve(phi1, omega1=1.0, loads=viscous) - at_rest]
        for k, term in ((0, 0), (1, 3)):            # the polynomial loads' parts at rest and per omega1
            if polynomial:
                out[term] = out[term] + solve(phi1, extra=lambda kin, k=k: [
                    part for load in polynomial for part in load.applied_parts(kin)[k]])
        for load, j in columns:
            out.append(solve(phi1, extra=lambda kin, load=load, j=j: load.column_applied(kin, j)))
        for port in reduced.ports:
            out.append(solve(phi1, extra=lambda kin, port=port: port.applied(kin, 1.0)))
        for i in range(n_f):                        # each joint friction at value 1 alone
            out.append(solve(phi1, extra=lambda kin, i=i: reduced.friction.unit_loads(kin, i)))
        return np.stack(out, axis=1)                # (components, terms, angles)

    return names, len(REACTION_TERMS) + len(columns) + len(reduced.ports) + n_f, terms, solve


def zero_terms(terms, period: float, cycle_turns: int) -> np.ndarray:
    """(components, terms) whether each term of ``terms(phi1)`` is kept: a term a component does
    not have (a damper's on a pin it does not load, a port's on a joint it bypasses) is zero up to
    the solve's round-off, and exactly zero in the table, so that round-off is not tabulated to a
    relative tolerance (a probe of 96 angles per turn)."""
    probe = terms(np.linspace(0.0, period, 97 * cycle_turns)[:-1])
    return np.max(np.abs(probe), axis=2) > 1e-12 * np.max(np.abs(probe), axis=(0, 2))[None, :]


def tabulate_reactions(reduced: ReducedModel, tolerance: float = 1e-11, n_max: int = 1 << 16,
                       loosest: float = 1e-8) -> ReactionTable:
    """The coefficients of every joint reaction (ReactionTable) as periodic cubics, to
    ``tolerance`` relative to each function's largest magnitude, by the reduced table's
    constructions. Each term is one Newton-Euler solve with that part of the loads alone."""
    names, n_terms, terms, _ = reaction_terms(reduced)
    keep = zero_terms(terms, reduced.period, reduced.cycle_turns)

    def engine(phi1):
        return (terms(phi1) * keep[:, :, None]).reshape(len(names) * n_terms, -1)

    named = ("the joint reactions", [f"{name} ({term} term)" for name in names
                                     for term in (*REACTION_TERMS, *(f"column {k}" for k in range(n_terms - 4)))])
    coefficients, error, construction = build_cubics(engine, tolerance, 256, n_max, loosest, named,
                                                     reduced.cycle_turns)
    return ReactionTable(coefficients, names, n_terms, error, construction, reduced.period)
