"""The sucker-rod string: Gibbs' damped wave equation for a tapered string of rods, the pump at
its bottom, and buoyancy; one discretisation shared by RodString.fmu and the in-process well.

The steps with a valve pump run in C (crank_components.c, ``cc_string_step``), what RodString.fmu
and the in-process well use; this module's numpy step is the same scheme in the same order, kept
as their reference (tests/test_rodstring_c.py) and for the linear foot.

The equation (Gibbs 1963; Everitt & Jennings 1992) for the rods' displacement u(x, t), downward
positive, x the depth from the polished rod:

    rho A u_tt = (E A u_x)_x - c rho A u_t + w_b,      w_b = rho A g (1 - rho_fluid / rho_steel)

with the buoyant weight w_b distributed along the string (the effective-force convention: the
fluid pressure's resultant on a rod is its displaced weight, exact at the surface, where the
polished rod load is measured, and what RP 11L's Wrf = W (1 - 0.128 G) states). The damping
coefficient is Gibbs' viscous one, c = pi nu a / (2 L) (1/s), with nu the dimensionless damping
factor of the well file and a the wave speed: the rod-fluid drag that damps the string's first
mode (a / (4 L) Hz) by the fraction nu of critical.

Discretisation: the string is cut in segments of about ``segment`` m within each taper (each
taper's length is a whole number of segments, so a joint between tapers is a node), each segment
a spring E A / dx between two nodes, each node carrying half of the adjoining segments' masses
and buoyant weights (lumped mass: the second-order finite-difference scheme of the wave equation
on a non-uniform grid). Time is stepped by the explicit central difference (leapfrog), velocities
at half steps, the damping taken at the step's mid-point; it is stable for the Courant number
a dt / dx <= 1 in every segment (``courant`` of the well file, checked at build). Second order
in dx and dt, as tests/test_rodstring.py shows against the analytic solution of a damped string
with harmonic top motion and a spring-dashpot at its foot.

The pump at the foot (the valve pump, or the linear foot the tests use) is dynamics/pumps.py.

Energy (discrete, exact to round-off): the work of the polished rod equals the change of the
string's kinetic, strain and gravitational energy, plus the damping loss, plus the pump's work,
split into hydraulic work (Fo times the loaded plunger travel), friction, and the loss of the
plunger node stopping at the ends of the stroke (the lumped half-segment's kinetic energy; it
vanishes with the segment).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import DefinitionError, format_value
from .pumps import ValvePump


@dataclass(frozen=True)
class Taper:
    """One section of the string, top first."""

    length: float            # m
    diameter: float          # m
    E: float                 # Pa, Young's modulus
    mass_per_length: float   # kg/m, the rods with their couplings (API RP 11L's Wr / g)

    @property
    def area(self) -> float:
        return math.pi * self.diameter ** 2 / 4

    @property
    def wave_speed(self) -> float:
        """a = sqrt(E / rho) with rho the mass per length over the area (m/s)."""
        return math.sqrt(self.E * self.area / self.mass_per_length)


@dataclass(frozen=True)
class StringDesign:
    """Everything the string and the pump need, in SI."""

    tapers: tuple
    rho_fluid: float          # kg/m3
    rho_steel: float          # kg/m3, the rods' material (buoyancy by displaced volume)
    plunger_diameter: float   # m
    fluid_level: float        # m, depth of the working fluid level in the annulus
    p_tubing: float = 0.0     # Pa, at the wellhead
    p_casing: float = 0.0     # Pa, at the wellhead
    damping: float = 0.0      # Gibbs' dimensionless factor nu
    friction: float = 0.0     # N, plunger friction
    fillage: float = 1.0      # the barrel's liquid fraction on each downstroke
    g: float = 9.81
    segment: float = 10.0     # m, target segment length
    courant: float = 1.0      # a dt / dx at the largest step

    @property
    def depth(self) -> float:
        return sum(t.length for t in self.tapers)

    @property
    def plunger_area(self) -> float:
        return math.pi * self.plunger_diameter ** 2 / 4

    @property
    def fluid_load(self) -> float:
        """Fo = (p_discharge - p_intake) A_p (N): the tubing's liquid column over the plunger
        against the annulus' liquid column above the pump."""
        p_discharge = self.p_tubing + self.rho_fluid * self.g * self.depth
        p_intake = self.p_casing + self.rho_fluid * self.g * max(self.depth - self.fluid_level, 0.0)
        return (p_discharge - p_intake) * self.plunger_area

    @property
    def buoyancy_factor(self) -> float:
        return 1.0 - self.rho_fluid / self.rho_steel

    @property
    def weight_in_air(self) -> float:
        return sum(t.mass_per_length * t.length for t in self.tapers) * self.g

    @property
    def buoyant_weight(self) -> float:
        """Wrf (N): the string's weight in the fluid."""
        return self.weight_in_air * self.buoyancy_factor

    @property
    def wave_travel_time(self) -> float:
        """s: from the polished rod to the pump."""
        return sum(t.length / t.wave_speed for t in self.tapers)

    @property
    def damping_coefficient(self) -> float:
        """Gibbs' c = pi nu a / (2 L) (1/s), a the string's mean wave speed L / travel time."""
        a = self.depth / self.wave_travel_time
        return math.pi * self.damping * a / (2 * self.depth)

    def check(self, where: str = "rod string"):
        if not self.tapers:
            raise DefinitionError(f"{where}: the string needs at least one taper")
        for i, t in enumerate(self.tapers, 1):
            for name in ("length", "diameter", "E", "mass_per_length"):
                value = getattr(t, name)
                if not (math.isfinite(value) and value > 0):
                    raise DefinitionError(f"{where}: taper {i} {name} = {value!r} must be > 0 (valid range (0, inf))")
        if not 0.0 < self.fillage <= 1.0:
            raise DefinitionError(f"{where}: fillage = {self.fillage!r} is out of range: valid range (0, 1]")
        if not 0.0 < self.courant <= 1.0:
            raise DefinitionError(f"{where}: courant = {self.courant!r} is out of range: valid range (0, 1] "
                                  "(the explicit scheme is unstable above 1)")
        if not self.segment > 0:
            raise DefinitionError(f"{where}: segment = {self.segment!r} must be > 0 m")
        self._check_bounded(where)
        if self.fluid_load < 0:
            raise DefinitionError(f"{where}: the fluid load is negative ({self.fluid_load:g} N): the intake pressure "
                                  "exceeds the discharge pressure")


    def _check_bounded(self, where: str):
        """Refuse what would make a step unbounded in time or memory: more than MAX_SEGMENTS
        segments, or an internal step (the Courant limit: courant x segment / wave speed) below
        MIN_STEP, naming the value and its valid range with the other values as given."""
        n = sum(_segments(t, self.segment) for t in self.tapers)
        if n > MAX_SEGMENTS:
            shortest = self.depth / MAX_SEGMENTS
            raise DefinitionError(f"{where}: segment = {format_value(self.segment)} m cuts the {self.depth:.6g} m string "
                                  f"into {n} segments, more than {MAX_SEGMENTS}: valid range "
                                  f"[{shortest:.4g}, inf) m with these tapers")
        for i, t in enumerate(self.tapers, 1):
            dx = t.length / _segments(t, self.segment)
            dt = self.courant * dx / t.wave_speed
            if dt < MIN_STEP:
                # dt = courant dx sqrt(m / (E A)): the stiffest E, the lightest rods, the smallest
                # courant that keep dt at MIN_STEP
                E_max = t.mass_per_length * (self.courant * dx / MIN_STEP) ** 2 / t.area
                courant_min = MIN_STEP * t.wave_speed / dx
                fix = f"taper {i} E must be at most {E_max:.4g} Pa (valid range (0, {E_max:.4g}])"
                if courant_min <= 1.0:
                    fix += f", or courant at least {courant_min:.4g} (valid range [{courant_min:.4g}, 1])"
                raise DefinitionError(
                    f"{where}: courant = {format_value(self.courant)} and taper {i} E = {format_value(t.E)} Pa (wave "
                    f"speed {t.wave_speed:.3g} m/s over {dx:.4g} m segments) make the string's internal step "
                    f"{dt:.3g} s, below {format_value(MIN_STEP)} s, and a second's steps would not end: with the "
                    f"other values as given, {fix}")


#: a string of at most this many segments (memory and time per step stay bounded)
MAX_SEGMENTS = 100_000
#: the shortest internal step (s): a second of simulated time in at most a million steps
MIN_STEP = 1e-6


@dataclass
class Grid:
    """Nodes 0 (polished rod) .. N (plunger): node masses, buoyant weights, segment stiffnesses."""

    x: np.ndarray          # m, node depths
    mass: np.ndarray       # kg, per node
    weight: np.ndarray     # N, buoyant weight per node (downward)
    stiffness: np.ndarray  # N/m, per segment
    dt_max: float          # s, the Courant limit times ``courant``


def _segments(taper: Taper, segment: float) -> int:
    """How many equal segments a taper is cut into: the fewest no longer than ``segment``."""
    return max(1, math.ceil(taper.length / segment - 1e-9))


def grid(design: StringDesign) -> Grid:
    xs, mass_seg, weight_seg, k_seg, dt_max = [0.0], [], [], [], math.inf
    for t in design.tapers:
        n = _segments(t, design.segment)
        dx = t.length / n
        for _ in range(n):
            xs.append(xs[-1] + dx)
            mass_seg.append(t.mass_per_length * dx)
            weight_seg.append(t.mass_per_length * dx * design.g * design.buoyancy_factor)
            k_seg.append(t.E * t.area / dx)
        dt_max = min(dt_max, design.courant * dx / t.wave_speed)
    mass_seg, weight_seg = np.array(mass_seg), np.array(weight_seg)
    node_mass, node_weight = np.zeros(len(xs)), np.zeros(len(xs))
    node_mass[:-1] += mass_seg / 2
    node_mass[1:] += mass_seg / 2
    node_weight[:-1] += weight_seg / 2
    node_weight[1:] += weight_seg / 2
    return Grid(np.array(xs), node_mass, node_weight, np.array(k_seg), dt_max)


# ----------------------------------------------------------------------------------- the string
@dataclass
class RodString:
    """The discretised string stepped on its own time grid; the top follows the polished rod.

    State: node positions ``u`` at time ``t`` (downward, m, from the unstretched string hanging
    from the polished rod's reference), node velocities ``v`` half a step before. ``load`` is the
    polished rod load at ``t`` (N, up on the rods), ``work`` the polished rod's work (J)."""

    design: StringDesign
    pump: object = None
    dt: float = 0.0
    grid: Grid = None
    t: float = 0.0
    u: np.ndarray = None
    v: np.ndarray = None
    load: float = 0.0
    work: float = 0.0
    damping_loss: float = 0.0
    energy_start: float = 0.0
    in_c: bool = True               # step by the components' C (a valve pump); False: this module's numpy
    _last_u: np.ndarray = field(default=None, repr=False)

    def __post_init__(self):
        self.design.check()
        self.grid = grid(self.design)
        if self.pump is None:
            self.pump = ValvePump(self.design.fluid_load, self.design.friction, self.design.fillage)
        if not self.dt:
            self.dt = self.grid.dt_max
        c = self.design.damping_coefficient
        self._c = c
        self.u = np.zeros_like(self.grid.x)
        self.v = np.zeros_like(self.grid.x)
        # the C steps (crank_components.c) for a valve pump, what RodString.fmu and the in-process
        # well run; this module's numpy step stays as their reference (and for the linear foot)
        self._kernel = None
        if self.in_c and isinstance(self.pump, ValvePump):
            from ..native.physics import StringSteps

            g = self.grid
            self._kernel = StringSteps(g.mass, g.weight, g.stiffness, c,
                                       (self.pump.Fo, self.pump.friction, self.pump.fillage))
            self._x = np.zeros(11)

    # ---------------------------------------------------------------- set-up
    def hang(self, t: float, top: float, pump_force: float = 0.0):
        """At rest at time t in static equilibrium, the polished rod at ``top`` (m, downward) and
        the pump holding ``pump_force`` (N, down on the plunger): the downstroke's rest, 0."""
        g = self.grid
        below = np.cumsum(g.weight[::-1])[::-1]          # weight of nodes j..N
        tension = below[1:] + pump_force                 # segment j carries the nodes below it
        self.u = top + np.concatenate(([0.0], np.cumsum(tension / g.stiffness)))
        self.v = np.zeros_like(self.u)
        self.t = t
        self.load = tension[0] + g.weight[0]
        self.work = self.damping_loss = 0.0
        self.energy_start = self.stored_energy(self.u)
        return self

    def stored_energy(self, u_next: np.ndarray) -> float:
        """Kinetic, strain and gravitational energy at the half step between u and u_next (J),
        the discrete energy the leapfrog conserves."""
        g = self.grid
        e, e_next = np.diff(self.u), np.diff(u_next)
        return float(0.5 * np.dot(g.mass, self.v * self.v) + 0.5 * np.dot(g.stiffness, e * e_next)
                     - np.dot(g.weight, (self.u + u_next) / 2))

    def energy(self) -> float:
        """The stored energy now (J): kinetic at the last half step, strain and weight at the
        mid-point of the last step."""
        return self.stored_energy(self._last_u) if self._last_u is not None else self.energy_start

    # ---------------------------------------------------------------- stepping
    @property
    def kernel(self):
        """The C steps (native.physics.StringSteps), or None when this string steps in numpy."""
        return self._kernel

    @property
    def c(self) -> float:
        """Gibbs' damping coefficient (1/s)."""
        return self._c

    def to_kernel(self):
        """The state as the C steps take it: (u, v, last_u, the scalars x), the scalars written from
        this object's fields; the C changes them in place, ``from_kernel`` reads them back."""
        p, x = self.pump, self._x
        x[:] = (self.t, self.load, self.work, self.damping_loss, p.motion, p.u_top, p.u_bottom, p.hydraulic,
                p.friction_loss, p.stop_loss, p._gas)
        if self._last_u is None:
            self._last_u = np.zeros_like(self.u)
        return self.u, self.v, self._last_u, x

    def from_kernel(self):
        p, x = self.pump, self._x.tolist()
        self.t, self.load, self.work, self.damping_loss = x[0], x[1], x[2], x[3]
        p.motion, p.u_top, p.u_bottom, p.hydraulic, p.friction_loss, p.stop_loss = int(x[4]), *x[5:10]
        p._gas = bool(x[10])

    def advance(self, top_end: float, h: float):
        """A communication step of h s: as many equal internal steps as keep the Courant number at
        or below the design's, the polished rod moving linearly from where it is to ``top_end``."""
        if self._kernel is not None:
            self.to_kernel()
            self._kernel.advance(self.u, self.v, self._last_u, self._x, float(top_end), float(h), self.grid.dt_max)
            self.from_kernel()
            return
        n = max(1, math.ceil(h / self.grid.dt_max - 1e-9))
        start = float(self.u[0])
        for k in range(1, n + 1):
            self.step(start + (top_end - start) * k / n, h / n)

    def step(self, top_next: float, dt: float | None = None):
        """One step of length dt (default self.dt): the polished rod moves to ``top_next``."""
        dt = self.dt if dt is None else dt
        if self._kernel is not None:
            self.to_kernel()
            self._kernel.step(self.u, self.v, self._last_u, self._x, float(top_next), float(dt))
            self.from_kernel()
            return
        g, u, v, c = self.grid, self.u, self.v, self._c
        T = g.stiffness * (u[1:] - u[:-1])
        f = g.weight.copy()
        f[:-1] += T
        f[1:] -= T
        scale = 1.0 / (1.0 + c * dt / 2)
        b = dt * scale / g.mass
        v_new = (1.0 - c * dt / 2) * scale * v + b * f
        P, v_new[-1] = self.pump.solve(float(v_new[-1]), float(b[-1]), float(u[-1]), float(v[-1]))
        v_new[0] = (top_next - u[0]) / dt
        mid = (v_new + v) / 2
        # the polished rod: segment 0's tension, the top half-segment's weight, inertia and drag
        self.load = float(T[0] + g.weight[0] - g.mass[0] * ((v_new[0] - v[0]) / dt + c * mid[0]))
        travel = dt * mid
        self.work -= self.load * travel[0]
        self.damping_loss += c * dt * float(np.dot(g.mass, mid * mid))
        self.pump.account(P, float(travel[-1]))
        u_next = u + dt * v_new
        u_next[0] = top_next
        self.v = v_new
        self._last_u = u
        self.u = u_next
        self.t += dt

    def balance(self) -> float:
        """work - (stored energy change + damping + pump work): zero to round-off (J)."""
        return self.work - (self.energy() - self.energy_start + self.damping_loss + self.pump.work)

    # ---------------------------------------------------------------- readings
    @property
    def pump_position(self) -> float:
        return float(self.u[-1])

    @property
    def static_load(self) -> float:
        """The polished rod load at the state now without the top half-segment's inertia and drag
        (N): the first segment's tension plus that half-segment's buoyant weight. What a coupled
        unit feels at a step's end, before the next step says how the top moves."""
        return float(self.grid.stiffness[0] * (self.u[1] - self.u[0]) + self.grid.weight[0])

    @property
    def pump_load(self) -> float:
        """The rods' tension at the pump (N): the last segment's."""
        return float(self.grid.stiffness[-1] * (self.u[-1] - self.u[-2]))

    def state(self) -> list:
        """Everything the continuation depends on, as copies (an FMU's state; a step to redo)."""
        last = None if self._last_u is None else self._last_u.copy()
        return [self.t, self.u.copy(), self.v.copy(), last, self.load, self.work, self.damping_loss,
                self.energy_start, self.pump.state()]

    def restore(self, s):
        (self.t, u, v, last, self.load, self.work, self.damping_loss, self.energy_start, pump) = s
        # into the arrays in use where they fit (the C steps keep their addresses), else new ones
        for name, value in (("u", u), ("v", v), ("_last_u", last)):
            here = getattr(self, name)
            if value is None:
                setattr(self, name, None)
            elif here is not None and here.shape == np.shape(value):
                here[:] = value
            else:
                setattr(self, name, np.array(value, dtype=float))
        self.pump.restore(pump)


# --------------------------------------------------------------------------- the closed form
def harmonic_solution(design: StringDesign, omega: float, amplitude: float, foot_k: float, foot_c: float):
    """The steady harmonic response of a uniform string (one taper) without gravity, its top
    moving as amplitude sin(omega t) and its foot on a spring-dashpot (LinearFoot): returns
    (u(x, t), tension(x, t)) as functions. U'' + kappa^2 U = 0, kappa^2 = (omega^2 - i c omega)/a^2,
    U(0) = -i amplitude, E A U'(L) = -(k + i omega c_foot) U(L)."""
    (taper,) = design.tapers
    a, L, EA = taper.wave_speed, taper.length, taper.E * taper.area
    c = design.damping_coefficient
    kappa = np.sqrt((omega ** 2 - 1j * c * omega) / a ** 2 + 0j)
    Z = foot_k + 1j * omega * foot_c
    A = -1j * amplitude
    B = A * (EA * kappa * np.sin(kappa * L) - Z * np.cos(kappa * L)) / (EA * kappa * np.cos(kappa * L)
                                                                        + Z * np.sin(kappa * L))

    def u(x, t):
        return np.real((A * np.cos(kappa * x) + B * np.sin(kappa * x)) * np.exp(1j * omega * t))

    def tension(x, t):
        return np.real(EA * kappa * (-A * np.sin(kappa * x) + B * np.cos(kappa * x)) * np.exp(1j * omega * t))

    return u, tension
