"""The reduced model tabulated once per design: what the fast integrators evaluate.

J(phi1), 0.5 J'(phi1) and the position-dependent loads are periodic in phi1 and, for a mechanism
that assembles over the whole turn, smooth. They are sampled from the contour engine on a
uniform grid over one turn and held as periodic cubic splines, one local cubic per interval, so
an evaluation costs one index computation and a few multiply-adds whatever the mechanism.

The grid is refined (doubled) until the splines agree with the engine at the points where a
spline's error is largest (the interval midpoints) and at a second, staggered set of angles, to
``tolerance`` relative to each function's largest magnitude. That checked bound is kept in
``error_bound`` and reported with every fast result.

Velocity-dependent loads stay exact:

- a viscous force is linear in omega1: Q = c_lin(phi1) * omega1, with c_lin tabulated;
- a switched load is a sum of columns, functions of phi1, each times a value constant on each
  interval between the load's switch angles and for each direction of the crank: a slider force
  (seed 001's F3/F7, seed 003's cutting force) is its magnitude times dx/dphi1 between the
  slider's reversals (and its band's ends); a user's direction-dependent force or couple is its two
  directions' torques, each switched on (1) or off (0) by the sign of the chosen velocity. The
  columns are tabulated; the interval and the direction are part of the integrator's discrete
  state, and the switch angles and omega1 = 0 are located as events.

The motor line (a kink at omega_switch) is evaluated exactly by the integrators.
"""

from __future__ import annotations

import math
import os
import time
import weakref
from dataclasses import dataclass

import numpy as np

from ..errors import DefinitionError
from . import modes
from .cubics import build_cubics, evaluate_cubics
from .reaction_table import ReactionTable
from .reduced import ReducedModel
from .speed_laws import LAW, ColumnLaws, column_laws

TWO_PI = 2.0 * math.pi
#: the table's functions, in order; slider transfer functions dx/dphi1 follow
J_LINKS, HALF_DJ, Q_POSITION, Q_VISCOUS = range(4)
FIRST_SLIDER = 4


@dataclass
class ReducedTable:
    """Periodic cubic splines of the reduced model on ``n`` intervals of 2 pi / n.

    coefficients  (n_functions, n, 4): local cubic c0 + u (c1 + u (c2 + u c3)), u = phi1 - phi1_i
                  functions: J of the links (kg.m2, the flywheel is a parameter), 0.5 J' (kg.m2/rad),
                  Q of the position-only loads (N.m), viscous coefficient (N.m.s/rad), then each
                  switched load's columns (a slider force's dx/dphi1 in m/rad, a user load's torques),
                  then each port's transfer function ds/dphi1 (m/rad or rad/rad): the last n_ports
    switch_angles (m,) rad in [0, 2 pi): where a slider force changes; empty without slider forces
    forces        (max(m, 1), 2, n_sliders) N: each slider force's signed value on interval k
                  (from switch_angles[k] to the next) with omega1 > 0 (index 0) and < 0 (index 1)
    error_bound   largest relative difference from the engine found at the check angles
    """

    coefficients: np.ndarray
    switch_angles: np.ndarray
    forces: np.ndarray
    error_bound: float
    tolerance: float
    build_time: float            # s
    slider_names: tuple[str, ...] = ()
    construction: str = ""       # how the cubics were made (a Fourier series, or a spline of samples)
    n_ports: int = 0
    period: float = TWO_PI       # rad: the machine's cycle (cycle_turns turns) the functions repeat over
    #: (n_sliders,) the power of omega1 each switched column's value is multiplied by (0; a load of
    #: the speeds' parts 1 and 2: a fan's -c omega1 |omega1|); None: every column 0
    powers: np.ndarray | None = None
    #: the laws g(omega1) of the columns of power LAW (speed_laws.ColumnLaws), None where none has one
    laws: object = None
    #: the joints' friction (friction_table.FrictionTable), None without any
    friction: object = None

    def arrays(self) -> tuple:
        """(coefficients, switch_angles, forces, n_ports, period, powers, laws, friction): the table
        as the C kernel takes it (native.Tables)."""
        return (self.coefficients, self.switch_angles, self.forces, self.n_ports, self.period, self.powers, self.laws,
                self.friction)

    @property
    def n_intervals(self) -> int:
        return self.coefficients.shape[1]

    def evaluate(self, phi1) -> np.ndarray:
        """All functions at an array of crank angles: shape (n_functions, len(phi1))."""
        return evaluate_cubics(self.coefficients, phi1, self.period)

    def interval_of(self, phi1) -> np.ndarray:
        """Index of the switch interval holding each crank angle (0 without switch angles). The
        switch angles are the kinematics' (a slider's reversals, a velocity's sign): one turn's."""
        if self.switch_angles.size == 0:
            return np.zeros(np.shape(phi1), dtype=np.int64)
        wrapped = np.asarray(phi1) % TWO_PI
        return (np.searchsorted(self.switch_angles, wrapped, side="right") - 1) % self.switch_angles.size

    def coefficients_at(self, phi1, omega1, J_flywheel: float, values=None):
        """(J, 0.5 J', Q) at arrays of states, the slider forces' direction from omega1's sign;
        ``values``: the functions at phi1 (``evaluate``), where the caller has them already."""
        values = self.evaluate(phi1) if values is None else values
        omega1 = np.asarray(omega1, dtype=float)
        J = values[J_LINKS] + J_flywheel
        Q = values[Q_POSITION] + values[Q_VISCOUS] * omega1
        if self.forces.shape[2]:
            k = self.interval_of(phi1)
            direction = modes.direction_imposed(omega1)
            for s in range(self.forces.shape[2]):
                # a law of the speed's column has the value 1 both ways: it acts in either direction
                # and at rest (modes.column_factor), its law in place of a power of omega1
                power = 0 if self.powers is None else int(self.powers[s])
                speed = self.laws(s, omega1) if power == LAW else omega1 ** power
                force = modes.column_factor(self.forces[k, 0, s], self.forces[k, 1, s], direction)
                Q = Q + force * speed * values[FIRST_SLIDER + s]
        return J, values[HALF_DJ], Q



def _engine_values(reduced: ReducedModel, sliders, viscous, phi1) -> np.ndarray:
    J, half_dJ, Q, kin = reduced.coefficients(phi1)
    rows = [J - reduced.J_flywheel, half_dJ, Q, np.zeros_like(phi1)]
    for load in viscous:
        if hasattr(load, "parts"):           # a user's load of the speeds: Q0 + omega1 Q1 (user_loads.SpeedLoad)
            at_rest, per_omega = load.parts(kin)
            rows[Q_POSITION] = rows[Q_POSITION] + at_rest
            rows[Q_VISCOUS] = rows[Q_VISCOUS] + per_omega
        else:
            rows[Q_VISCOUS] = rows[Q_VISCOUS] + load.torque(kin, 1.0)
    for load in sliders:
        rows += load.columns(kin)
    for port in reduced.ports:
        rows.append(port.transfer(kin)[1])
    return np.array(rows)


def tabulate(reduced: ReducedModel, tolerance: float = 1e-11, n_start: int = 256,
             n_max: int = 1 << 16, loosest: float = 1e-8) -> ReducedTable:
    """Tabulate ``reduced`` to ``tolerance`` (relative to each function's largest magnitude).

    First as a Fourier series (:func:`from_series`: a few hundred samples of the engine for a
    mechanism away from its dead points), else as a cubic spline of the engine's samples
    (:func:`from_samples`). A mechanism close to a dead point has steep transfer functions: when
    2**16 spline intervals do not reach ``tolerance`` the table is kept if its checked error is
    within ``loosest`` (its ``error_bound`` then exceeds ``tolerance``, and users of the table
    report it); beyond that SchemeError is raised (use the engine, method "reference").
    """
    started = time.perf_counter()
    sliders = reduced.sliders
    viscous = [load for load in reduced.loads if getattr(load, "linear_in_omega1", False)]
    for load in reduced.loads:
        if not load.position_only and load not in sliders and load not in viscous:
            raise DefinitionError(f"the fast model cannot tabulate a {type(load).__name__} load "
                                  "(velocity-dependent loads it knows: linear in omega1, or switched by a "
                                  "velocity's direction)")
    engine = lambda phi1: _engine_values(reduced, sliders, viscous, phi1)  # noqa: E731
    names = (["the reduced inertia J_red", "0.5 dJ_red/dphi1", "the loads' generalized force",
              "the dampers' generalized force per omega1"]
             + [f"slider force column {name}" for load in sliders for name in load.column_names]
             + [f"port {port.name}'s transfer function" for port in reduced.ports])
    # J, 0.5 J' and the ports' transfer functions are the kinematics alone: steep there means a dead
    # point; a load steep where they are not is a steep load
    kinematic = (J_LINKS, HALF_DJ, *range(len(names) - len(reduced.ports), len(names)))
    coefficients, error, construction = build_cubics(engine, tolerance, n_start, n_max, loosest,
                                                     ("the reduced model", names, kinematic), reduced.cycle_turns)
    switch, forces = reduced.slider_schedule()
    powers = np.array([p for load in sliders for p in getattr(load, "column_powers", (0,) * len(load.column_names))],
                      dtype=np.int32)
    return ReducedTable(coefficients, switch, forces, error, tolerance, time.perf_counter() - started,
                        tuple(name for load in sliders for name in load.column_names), construction,
                        len(reduced.ports), reduced.period, powers, column_laws(sliders, reduced.mechanism))


@dataclass
class QuantityTable:
    """A scenario's [[outputs]] (mechanism-specific quantities) tabulated for the native FMU.

    coefficients  (3 n_coordinates, n, 4): for each distinct coordinate (``Quantity.of``) the
                  periodic cubics of q - winding phi1, q' and q'' (derivatives in phi1), in that order
    coordinates   the coordinates, in the table's order
    winding       (n_coordinates,) whole turns a coordinate makes per crank turn (a link that turns
                  fully: its angle gains 2 pi winding per turn; 0 for every other coordinate)
    error_bound   the checked largest relative difference from the analytic kinematics
    """

    coefficients: np.ndarray
    coordinates: tuple[str, ...]
    winding: np.ndarray
    error_bound: float
    construction: str


def tabulate_quantities(mechanism, quantities, definition, tolerance: float = 1e-11, n_max: int = 1 << 16,
                        loosest: float = 1e-8) -> QuantityTable:
    """The transfer functions of ``quantities`` (mechanisms.quantities) as periodic cubics, to
    ``tolerance`` relative to each function's largest magnitude, by the same constructions as
    the reduced model's table."""
    coordinates = tuple(dict.fromkeys(q.of for q in quantities))
    first = {c: next(q for q in quantities if q.of == c) for c in coordinates}
    # whole turns per crank turn, from the angle's increments over one turn (each taken in
    # (-pi, pi], so a coordinate written modulo 2 pi is counted right)
    grid = np.linspace(0.0, TWO_PI, 513)
    kin = mechanism.kinematics(grid)
    winding = []
    for c in coordinates:
        if not first[c].is_angle(definition):
            winding.append(0.0)
            continue
        steps = np.diff(first[c].transfer(kin)[0])
        winding.append(float(round(np.sum(steps - TWO_PI * np.round(steps / TWO_PI)) / TWO_PI)))
    winding = np.array(winding)

    def engine(phi1):
        kin = mechanism.kinematics(np.asarray(phi1, dtype=float))
        rows = []
        for c, w in zip(coordinates, winding):
            q, dq, ddq = first[c].transfer(kin)
            rows += [q - w * phi1, dq, ddq]
        return np.array(rows, dtype=float)

    names = [f"[[outputs]] {first[c].name} ({c}{suffix})" for c in coordinates
             for suffix in ("", "'", "''")]
    coefficients, error, construction = build_cubics(engine, tolerance, 256, n_max, loosest,
                                                ("the scenario's [[outputs]]", names))
    return QuantityTable(coefficients, coordinates, winding, error, construction)


#: tables built in this process, per model and tolerance: they live as long as their model
_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def table_of(reduced: ReducedModel, tolerance: float = 1e-11) -> ReducedTable:
    """The table of ``reduced`` to ``tolerance``, built once per model and tolerance: by the C
    model where the scenario compiles to it (c_table), else by the Python engine (tabulate).

    The flywheel is not in it (a parameter of the fast integrators), so designs that differ only
    in the flywheel or the motor share one table.
    """
    tables = _TABLES.setdefault(reduced, {})
    if tolerance not in tables:
        source = getattr(reduced, "source", None)
        table = c_table(*source, tolerance, getattr(reduced, "c_model", None)) if source is not None else None
        if table is None:
            table = tabulate(reduced, tolerance)
            if reduced.friction is not None:
                from .friction_table import tabulate_frictions
                table.friction = tabulate_frictions(reduced, tolerance)
                table.error_bound = max(table.error_bound, table.friction.error_bound)
        tables[tolerance] = table
    return tables[tolerance]


def keep_table(reduced: ReducedModel, table: ReducedTable) -> None:
    """Record ``table`` as the table of ``reduced`` at its tolerance (what table_of then returns)."""
    _TABLES.setdefault(reduced, {})[table.tolerance] = table


def c_model(scenario, values: dict):
    """The C model (native.mechanism.CModel) of a design, its assembly checked over the turn and
    its loads' switch angles found; None where the scenario does not compile to it, the C model
    refuses the values (the Python engine then says why) or CRANKFMU_TABLES=python."""
    if os.environ.get("CRANKFMU_TABLES") == "python":
        return None
    from ..native.mechanism import CModel, MechanismError
    from .program import parameter_values
    from .program_scenario import compile_scenario

    program = compile_scenario(scenario)
    if program is None:
        return None
    try:
        return CModel(program, parameter_values(program, values))
    except MechanismError:
        return None


def c_table(scenario, values: dict, tolerance: float = 1e-11, model=None) -> ReducedTable | None:
    """The reduced model's table built by the C model (native/mechanism/crank_mechanism.c; its tabulator
    native/mechanism/crank_tabulator.c) from the scenario's compiled program at ``values`` (or by ``model``, a
    c_model of them), with the same constructions and checked bound as :func:`tabulate`; None
    where the scenario does not compile to it or the C model refuses the values (the Python engine
    then builds the table, or says why it cannot). With the environment variable
    CRANKFMU_TABLES=python every table is the Python engine's (the reference path; make bench times
    a sweep both ways)."""
    from ..native.mechanism import MechanismError

    started = time.perf_counter()
    model = model or c_model(scenario, values)
    if model is None:
        return None
    try:
        coefficients, switches, forces, error, construction = model.table(tolerance)
        friction = c_friction_table(model, tolerance)
    except MechanismError:
        return None
    laws = None
    if any(law is not None for law in model.program.column_laws):
        constants = scenario.mechanism_definition().constant_values(values)
        laws = ColumnLaws(tuple(model.program.column_laws),
                          {k: float(v) for k, v in {**values, **constants}.items() if isinstance(v, (int, float, np.floating))})
    table = ReducedTable(coefficients, switches, forces, error, tolerance, time.perf_counter() - started,
                         model.program.column_names, construction, model.program.n_ports,
                         TWO_PI * model.program.cycle_turns, np.asarray(model.program.column_powers, dtype=np.int32),
                         laws)
    if friction is not None:
        table.friction = friction
        table.error_bound = max(table.error_bound, friction.error_bound)
    return table


def c_friction_table(model, tolerance: float):
    """The joints' friction table (friction_table.FrictionTable) of a C model, as tabulate_frictions
    builds it from the engine (tests/test_friction_kernel.py compares the two); None without any
    active friction."""
    from ..native.mechanism import FRICTION
    from .friction_table import FrictionTable

    found = model.friction()
    if found is None:
        return None
    components, c, signs = found
    coefficients, error, construction = model.cubics(FRICTION, tolerance)
    return FrictionTable(coefficients, components, c, signs, model.reaction_terms - len(c), error, construction)


def c_output_tables(scenario, values: dict, quantities, tolerance: float, reaction_tolerance: float, reactions: bool,
                    model=None):
    """(QuantityTable or None, ReactionTable or None) of a design built by the C model (``model``, a
    c_model of these values, or a new one), as tabulate_quantities and tabulate_reactions build them
    (the same constructions and bounds, tests/test_c_model.py); None where the scenario does not
    compile to it or the C model refuses."""
    from ..native.mechanism import QUANTITIES, REACTIONS, MechanismError

    model = model or c_model(scenario, values)
    if model is None:
        return None
    program = model.program
    if tuple(dict.fromkeys(q.of for q in quantities)) != program.coordinate_names:
        return None
    try:
        quantity_table = reaction_table = None
        if quantities:
            coefficients, error, construction = model.cubics(QUANTITIES, tolerance)
            quantity_table = QuantityTable(coefficients, program.coordinate_names, model.winding, error, construction)
        if reactions:
            coefficients, error, construction = model.cubics(REACTIONS, reaction_tolerance)
            reaction_table = ReactionTable(coefficients, program.reaction_names, model.reaction_terms, error,
                                           construction, TWO_PI * program.cycle_turns)
    except MechanismError:
        return None
    return quantity_table, reaction_table
