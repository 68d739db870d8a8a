"""A beam pumping well (a well file, ``dynamics.well``) as a surface unit and its rod string, and
the two as one model: the reference of PumpingWell.ssp and what ``crankfmu well`` runs.

The unit is a pumping-unit scenario with a rope port ``rod`` at its horsehead; its own data-file
rod loads (W_rods, W_rods_buoyant, W_fluid) are set to zero, the string hanging from the rope port
instead, its polished rod load the port's input (N, downward).

One model (``CoupledWell``): the unit's movement equation (the C kernel, through FastStepper) and
the discretised string advance together on the string's time grid. Over each step the polished
rod load is linear in time between its values at the step's ends (the kernel takes time-linear
port inputs); the string's step needs the polished rod's position at the step's end, which needs
the unit's step, which needs the load at the end: the step is iterated to its fixed point (two
passes: the load's sensitivity to the unit's step over one string step is about 1e-4), so there
is no communication step and no lag between the two.

The load the unit feels is the string's static load at the step's ends (the first segment's
tension and the top half-segment's buoyant weight, ``RodString.static_load``), the output of
RodString.fmu: the top half-segment's inertia (16 kg at 10 m segments, vanishing with the grid)
is carried by the prescribed motion in both, so the one model and the co-simulated system are
the same physics and differ only by the communication step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import native as kernel
from .dynamics.loads import Weights
from .dynamics.motor import MotorLine
from .dynamics.rodstring import RodString, StringDesign
from .dynamics.tabulated import table_of
from .dynamics.well import WellFile
from .errors import DefinitionError
from .numerics import bracketed_roots
from .integrators.fast import TABLE_TOLERANCE, FastStepper, refused

#: the unit scenario's data-file rod loads, replaced by the string on the rope port
ROD_LOADS_OFF = {"W_rods": 0.0, "W_rods_buoyant": 0.0, "W_fluid": 0.0}
PORT = "rod"


def rope_port(scenario):
    ports = [p for p in scenario.ports if p.name == PORT]
    if not ports or ports[0].kind != "rope":
        raise DefinitionError(f"{scenario.where}: a well's unit needs a rope port named {PORT!r} at its horsehead "
                              f"(see scenarios/pumpjack.toml)")
    return ports[0]


def rp11l_counterbalance(design: StringDesign) -> float:
    """RP 11L's counterbalance effect (N): 1.06 (Wrf + Fo/2)."""
    return 1.06 * (design.buoyant_weight + design.fluid_load / 2)


def counterbalance_spec(well: WellFile):
    """The [unit] table's counterbalance: "balanced", "rp11l" or a counterbalance effect (N)."""
    spec = well.unit.get("counterbalance", "balanced")
    if spec in ("balanced", "rp11l"):
        return spec
    if isinstance(spec, (int, float)) and not isinstance(spec, bool) and spec >= 0:
        return float(spec)
    raise DefinitionError(f"{well.where}: [unit] counterbalance = {spec!r}: give \"balanced\", \"rp11l\" or a "
                          "counterbalance effect in N (>= 0)")


def counterbalance_of(scenario) -> float:
    """The counterbalance effect (N) of the scenario's counterweights (API 11E's definition): the
    polished rod load that balances the unit's weights with the crank horizontal on the upstroke
    (phi1 = pi, the counterweights' torque largest and helping the rods up). The rod load's torque
    is its rope's transfer function times the load."""
    port = rope_port(scenario)
    phi = np.array([math.pi])
    model = scenario.build()
    kin = model.mechanism.kinematics(phi)
    gravity = sum(float(np.asarray(load.torque(kin, 0.0)).ravel()[0]) for load in model.reduced.loads
                  if isinstance(load, Weights))
    return -gravity / float(port.transfer(kin)[1][0])


def counterweight_mass(scenario, cbe: float) -> float:
    """m_cw (kg) whose counterbalance effect is ``cbe``: the effect is linear in m_cw."""
    c0 = counterbalance_of(scenario.with_params(m_cw=0.0))
    c1 = (counterbalance_of(scenario.with_params(m_cw=1000.0)) - c0) / 1000.0
    m = (cbe - c0) / c1
    if not m >= 0:
        raise DefinitionError(f"counterbalance effect {cbe:g} N needs a negative counterweight ({m:g} kg)")
    return m


def line_through(omega_sync: float, B: float) -> MotorLine:
    """The crank-side induction motor line M = B (omega_sync - omega1): one line, no start-up line."""
    return MotorLine(B * omega_sync, B, B * omega_sync, B, 0.0)


def motor_line(rated_power: float, rated_slip: float, omega_sync: float) -> MotorLine:
    """The line through the rated point: (1 - s) omega_sync, rated_power / that speed."""
    omega_rated = (1 - rated_slip) * omega_sync
    return line_through(omega_sync, rated_power / omega_rated / (rated_slip * omega_sync))


def unit_scenario(well: WellFile, design: StringDesign | None = None, m_cw: float | None = None,
                  progress: bool = False, in_c: bool = True):
    """The unit's scenario for this well: its [unit.parameters], the data-file rod loads off, the
    counterweights (``m_cw`` in kg, or from the [unit] counterbalance: balanced by runs of the
    well, ``balanced_counterweight``, or the counterweights of a counterbalance effect), and the
    motor line for the synchronous speed at the crank: the line's no-load speed at the target
    strokes/min plus half the rated slip, the starting guess the sheave (``run_to_steady``)
    corrects."""
    from .scenario import load_scenario

    design = design or well.design()
    unit = well.unit
    scenario = load_scenario(unit.get("scenario", "pumpjack"))
    values = {**dict(unit.get("parameters", {})), **ROD_LOADS_OFF, "g": design.g}
    scenario = scenario.with_params(**values)
    rope_port(scenario)
    motor = unit.get("motor", {})
    try:
        power, slip = float(motor["rated_power"]), float(motor["rated_slip"])
    except (KeyError, TypeError, ValueError):
        raise DefinitionError(f"{well.where}: [unit.motor] needs rated_power (W) and rated_slip (1)") from None
    if not (power > 0 and 0 < slip < 1):
        raise DefinitionError(f"{well.where}: [unit.motor] rated_power = {power!r} must be > 0 W and rated_slip = "
                              f"{slip!r} in (0, 1)")
    line = motor_line(power, slip, target_speed(well) * (1 + slip / 2))
    scenario = scenario.with_params(A=line.A, B=line.B, A_low=line.A_low, B_low=line.B_low,
                                    omega_switch=line.omega_switch, omega1_start=target_speed(well))
    if m_cw is None:
        spec = counterbalance_spec(well)
        if spec == "balanced":
            m_cw = balanced_counterweight(well, scenario, design, progress=progress, in_c=in_c)
        else:
            m_cw = counterweight_mass(scenario, rp11l_counterbalance(design) if spec == "rp11l" else spec)
    scenario = scenario.with_params(m_cw=m_cw)
    if unit.get("title"):          # the unit as the well changes it (a scaled geometry), for its figures' words
        scenario.title = str(unit["title"])
    return scenario


def target_speed(well: WellFile) -> float:
    spm = well.unit.get("strokes_per_minute")
    if not isinstance(spm, (int, float)) or isinstance(spm, bool) or not spm > 0:
        raise DefinitionError(f"{well.where}: [unit] strokes_per_minute = {spm!r} must be > 0")
    return 2 * math.pi * spm / 60


# ------------------------------------------------------------------------------- one model
class CoupledWell:
    """The unit and the string as one model (module docstring). ``step()`` advances one string
    step, ``run_until`` many (in C unless ``in_c`` is False: crank_well.c states step() again, and
    tests/test_well_c.py holds the two equal to the bit); ``t``, ``y`` (the unit's state), ``row``
    (the kernel's output row) and ``load_end`` (the polished rod load) are the state after it."""

    def __init__(self, scenario, design: StringDesign, dt: float | None = None, rtol: float = 1e-10,
                 in_c: bool = True):
        self.scenario = scenario
        self.in_c = in_c                 # run_until steps in C (crank_well.c); False: step() here, its reference
        self._c_steps = self._c_bound = None
        self.model = scenario.build()
        self.port = rope_port(scenario)
        self.i_port = [p.name for p in scenario.ports].index(PORT)
        self.n_ports = len(scenario.ports)
        v = scenario.values
        table = table_of(self.model.reduced, TABLE_TOLERANCE)
        self.motor = MotorLine(v["A"], v["B"], v["A_low"], v["B_low"], v["omega_switch"])
        self.stepper = FastStepper(table, self.motor, self.model.reduced.J_flywheel, rtol)
        self.rope = RopeMotion.of(scenario, self.model, self.port)
        self.string = RodString(design, dt=dt or 0.0)
        self.dt = self.string.dt
        self.t = 0.0
        self.y = kernel.state_vector(self.model.y0)       # (the kernel's N_Y: crank_well.c writes them all)
        self.y[0], self.y[1] = v["phi1_start"], v["omega1_start"]
        s0 = self.rope.position(self.y[0])
        self.string.hang(0.0, s0)
        self.load_end = self.string.load
        self.row = self._start_unit(self.string.load, 0.0).copy()

    def set_motor(self, motor):
        """A new motor line from the next step on (a sheave change)."""
        self.motor = motor
        self.stepper.set_motor(motor)

    def _start_unit(self, load, rate):
        inputs = [0.0] * self.n_ports
        rates = [0.0] * self.n_ports
        inputs[self.i_port], rates[self.i_port] = load, rate
        self.stepper.set_port_inputs(inputs, rates, self.t)
        return self.stepper.start(self.t, self.y)

    def step(self):
        dt, t = self.dt, self.t
        saved_string = self.string.state()
        load_a = load_b = self.load_end
        for n_pass in range(2):
            self._start_unit(load_a, (load_b - load_a) / dt)
            row = self.stepper.advance(t + dt, t + dt)
            phi = float(row[0])
            if n_pass:
                self.string.restore(saved_string)
            self.string.step(self.rope.position(phi), dt)
            load_b = self.string.static_load
        # the unit's state at t + dt from the last pass
        y = np.zeros_like(self.y)
        kernel.dense(self.stepper.state, t + dt, y)
        self.y = y
        self.row = row.copy()
        self.load_end = load_b
        self.t = t + dt

    def run_until(self, phi_stop: float, record: bool = False) -> np.ndarray | None:
        """Steps until the crank angle reaches ``phi_stop`` (rad); with ``record``, the samples after
        each step (rows of FIELDS)."""
        if not self.in_c:
            rows = []
            while self.y[0] < phi_stop:
                self.step()
                if record:
                    rows.append(_sample(self))
            return np.array(rows, dtype=float).reshape(-1, len(FIELDS)) if record else None
        steps = self._bind_c()
        chunks, capacity = [], 4096
        while True:
            samples = np.empty((capacity, len(FIELDS))) if record else None
            k, self.t, self.load_end, status = steps.run(self.t, self.load_end, phi_stop, capacity, samples)
            if record:
                chunks.append(samples[:k])
            if status or k < capacity:
                break
        self.string.from_kernel()
        self.row = self.stepper.row.copy()
        if status:
            refused(status, self.stepper.state)
        return np.concatenate(chunks) if record else None

    def _bind_c(self):
        """The C steps on this model's arrays (bound again when step() has replaced one)."""
        u, v, last_u, x = self.string.to_kernel()
        arrays = (self.y, u, v, last_u, x)
        if self._c_bound is None or any(a is not b for a, b in zip(arrays, self._c_bound)):
            if not (self.y.dtype == np.float64 and self.y.flags.c_contiguous):
                self.y = np.array(self.y, dtype=float)
                arrays = (self.y, *arrays[1:])
            from .native.physics import WellSteps

            self._c_steps = WellSteps(self.stepper, self.y, self.i_port, self.n_ports, self.rope.breakpoints,
                                             self.rope.cubic_array, self.rope.h, self.string.kernel, self.string.c,
                                             u, v, last_u, x, self.dt)
            self._c_bound = arrays
        return self._c_steps


class RopeMotion:
    """The rope port's coordinate s(phi1) (m) and s'(phi1), as periodic cubics on 4096 angles from
    the mechanism's kinematics: the one model asks for it every string step."""

    #: by the unit's geometry and port: the balancing runs change the counterweights only
    _CACHE: dict = {}

    @classmethod
    def of(cls, scenario, model, port) -> "RopeMotion":
        """The rope's motion of this unit, shared by units of the same geometry."""
        # everything but the masses and the loads moves the rope, or may
        still = set(scenario.mechanism_definition().mass_parameters) | set(scenario.load_parameters())
        key = (str(scenario.mechanism_name), repr(port),
               tuple(sorted((name, value) for name, value in scenario.values.items() if name not in still)))
        if key not in cls._CACHE:
            if len(cls._CACHE) > 64:
                cls._CACHE.clear()
            cls._CACHE[key] = cls(model, port)
        return cls._CACHE[key]

    def __init__(self, model, port, n: int = 4096):
        from scipy.interpolate import CubicHermiteSpline

        phi = np.linspace(0.0, 2 * math.pi, n + 1)
        kin = model.mechanism.kinematics(phi[:-1])
        s, ds, _ = port.transfer(kin)
        s, ds = np.append(s, s[0]), np.append(ds, ds[0])
        self.s = CubicHermiteSpline(phi, s, ds, extrapolate="periodic")
        self.ds = self.s.derivative()
        # the same cubics as plain floats: the coupled model asks for a position twice per string
        # step, where scipy's call costs ten times the arithmetic
        self.h = 2 * math.pi / n
        self._cubics = [tuple(float(c) for c in self.s.c[:, i]) for i in range(n)]
        # the same as arrays for the C steps (crank_well.c): breakpoints, and (c3, c2, c1, c0) per interval
        self.breakpoints = np.ascontiguousarray(self.s.x[:-1], dtype=float)
        self.cubic_array = np.ascontiguousarray(self.s.c.T, dtype=float)

    def position(self, phi: float) -> float:
        x = phi % (2 * math.pi)
        i = min(int(x / self.h), len(self._cubics) - 1)
        c3, c2, c1, c0 = self._cubics[i]
        u = x - self.s.x[i]
        return ((c3 * u + c2) * u + c1) * u + c0

    def velocity(self, phi: float, omega: float) -> float:
        return float(self.ds(phi % (2 * math.pi))) * omega


# ------------------------------------------------------------------------------- steady state
#: a stroke's samples, one per string step
FIELDS = ("t", "phi1", "omega1", "epsilon1", "M_motor", "s", "F", "u_pump", "F_pump", "work", "hydraulic",
          "damping", "friction", "stops")
ROW = {name: i for i, name in enumerate(kernel.ROW_FIELDS)}


@dataclass
class Stroke:
    """One stroke's samples, one per string step (arrays by FIELDS), and its energies (J)."""

    data: dict

    def __getitem__(self, key):
        return self.data[key]

    @property
    def period(self) -> float:
        return float(self["t"][-1] - self["t"][0])

    def delta(self, key) -> float:
        return float(self[key][-1] - self[key][0])


def _sample(cw: CoupledWell) -> list[float]:
    s, pump = cw.string, cw.string.pump
    r = cw.row
    # the load at the sample's time: the string's load is that of the start of its last step
    return [cw.t, r[ROW["phi1"]], r[ROW["omega1"]], r[ROW["epsilon1"]], r[ROW["M_motor"]], s.u[0], cw.load_end,
            s.pump_position, s.pump_load, s.work, pump.hydraulic, s.damping_loss, pump.friction_loss, pump.stop_loss]


def bottom_angle(cw: CoupledWell) -> float:
    """The crank angle (rad, in [0, 2 pi)) of the polished rod's lowest point."""
    phi = np.linspace(0.0, 2 * math.pi, 3601)[:-1]
    i = int(np.argmax(cw.rope.s(phi)))
    # refine on the cubic: s'(phi) = 0 near phi[i]
    ends = np.array([phi[i] - 2 * math.pi / 3600, phi[i] + 2 * math.pi / 3600])
    rate = lambda p: cw.rope.ds(np.mod(p, 2 * math.pi))  # noqa: E731
    fa, fb = rate(ends)
    return float(bracketed_roots(rate, ends[:1], ends[1:], [fa], [fb])[0]) % (2 * math.pi)


def card_change(a: Stroke, b: Stroke) -> float:
    """The largest difference of the surface load at the same crank angle between two strokes,
    over the peak load."""
    grid = np.linspace(0.0, 1.0, 721)
    fa = np.interp(grid, (a["phi1"] - a["phi1"][0]) / (2 * math.pi), a["F"])
    fb = np.interp(grid, (b["phi1"] - b["phi1"][0]) / (2 * math.pi), b["F"])
    return float(np.max(np.abs(fa - fb)) / np.max(np.abs(fb)))


def run_to_steady(well: WellFile, scenario, design: StringDesign, max_strokes: int = 40, tolerance: float = 5e-4,
                  dt: float | None = None, bar=None, in_c: bool = True):
    """(the coupled model, its strokes) run to steady state. Each stroke is cut at the bottom of
    the polished rod's travel.
    - the sheave: the motor line's synchronous speed is corrected after each stroke until the
      mean crank speed is the well file's strokes/min (to 5e-4), then held;
    - steady state: strokes are run until two successive surface cards agree to ``tolerance`` of
      the peak load at every crank angle, or ``max_strokes``."""
    cw = CoupledWell(scenario, design, dt=dt, in_c=in_c)
    target = target_speed(well)
    slope = cw.motor.B
    omega_sync = cw.motor.A / slope
    phi_b = bottom_angle(cw)
    # run to the first bottom of stroke
    next_bottom = phi_b + 2 * math.pi * math.ceil((cw.y[0] - phi_b) / (2 * math.pi) + 1e-9)
    cw.run_until(next_bottom)
    strokes: list[Stroke] = []
    last = np.array([_sample(cw)])
    tuned = False
    while len(strokes) < max_strokes:
        next_bottom += 2 * math.pi
        samples = np.concatenate([last, cw.run_until(next_bottom, record=True)])
        stroke = Stroke({k: samples[:, i].copy() for i, k in enumerate(FIELDS)})
        last = samples[-1:]
        strokes.append(stroke)
        if bar:
            bar(len(strokes))
        if not tuned:
            # the sheave: move the synchronous speed by the speed error (the line's slope is steep,
            # so the mean torque hardly changes with it)
            error = target - 2 * math.pi / stroke.period
            if abs(error) < 5e-4 * target:
                tuned = True
            else:
                omega_sync += error
                cw.set_motor(line_through(omega_sync, slope))
                continue
        if len(strokes) >= 2 and card_change(strokes[-2], strokes[-1]) < tolerance:
            break
    return cw, strokes


def gearbox_torque(cw: CoupledWell, stroke: Stroke) -> np.ndarray:
    """The net gearbox torque (N.m) over a stroke, from the drive's side: M_motor - J_flywheel
    epsilon1 (the rotor and sheaves are on the motor's side of the reducer)."""
    return stroke["M_motor"] - cw.model.reduced.J_flywheel * stroke["epsilon1"]


def stroke_halves(stroke: Stroke) -> np.ndarray:
    """True where the polished rod rises (its position s, positive downward, falls)."""
    return np.gradient(stroke["s"]) < 0


def _peak_gap(net: np.ndarray, up: np.ndarray) -> float:
    """The upstroke's peak of ``net`` less the downstroke's."""
    return float(net[up].max() - net[~up].max())


def torque_peaks(cw: CoupledWell, stroke: Stroke) -> tuple[float, float]:
    """The peak net gearbox torque (N.m) on the upstroke and on the downstroke."""
    net, up = gearbox_torque(cw, stroke), stroke_halves(stroke)
    return float(net[up].max()), float(net[~up].max())


_BALANCED: dict = {}


def balanced_counterweight(well: WellFile, scenario, design: StringDesign, tolerance: float = 1e-3,
                           max_runs: int = 8, progress: bool = False, in_c: bool = True) -> float:
    """m_cw (kg) for which the unit is balanced: the peak net gearbox torque of the upstroke
    equals the downstroke's, at steady state. This is the balance RP 11L's peak torque assumes
    and the one a crew sets in the field, moving the counterweights until the motor's peaks on
    both strokes are equal; RP 11L's CBE, 1.06 (Wrf + Fo/2), is its estimate of it.

    Newton's method on the counterweight: a run to steady state gives the net torque over the
    stroke; the counterweights' part of it is linear in m_cw (their gravity torque per kg), so the
    m_cw that equalises the two peaks with the rest of that stroke held is found by bisection, and
    the next run takes it; it stops when the two peaks agree to ``tolerance`` of the peak. Each
    run starts from RP 11L's CBE's counterweights only the first time."""
    key = (repr(sorted(scenario.values.items())), repr(design), in_c)
    if key in _BALANCED:
        return _BALANCED[key]
    from .progress import ProgressBar

    m = counterweight_mass(scenario, rp11l_counterbalance(design))
    # the counterweights' gravity torque is linear in m_cw: its part per kg from two models, built once
    reduced = [scenario.with_params(m_cw=mass).build().reduced for mass in (0.0, 1.0)]
    bar = ProgressBar(max_runs, f"well {well.name}: balancing the counterweights") if progress else None
    for run in range(max_runs):
        cw, strokes = run_to_steady(well, scenario.with_params(m_cw=m), design, in_c=in_c)
        stroke = strokes[-1]
        net, up = gearbox_torque(cw, stroke), stroke_halves(stroke)
        if bar:
            bar(run + 1)
        gap = _peak_gap(net, up)
        if abs(gap) < tolerance * np.abs(net).max():
            break
        # the counterweights' torque per kg at the stroke's crank angles (their weights' torque is
        # Q; the net torque carries -Q)
        phi = np.mod(stroke["phi1"], 2 * math.pi)
        per_kg = -(reduced[1].coefficients(phi)[2] - reduced[0].coefficients(phi)[2])
        gaps = lambda dms: np.array([_peak_gap(net + dm * per_kg, up) for dm in dms])  # noqa: E731
        at_ends = gaps([-m, m])
        if at_ends[0] * at_ends[1] > 0:
            raise DefinitionError(f"{well.where}: no counterweight between 0 and {2 * m:g} kg balances the unit's "
                                  "peak torques; give [unit] counterbalance as a number (N)")
        m += float(bracketed_roots(gaps, [-m], [m], at_ends[:1], at_ends[1:], xtol=1e-12)[0])
    else:
        raise DefinitionError(f"{well.where}: the counterweights did not balance in {max_runs} runs (peak gap "
                              f"{gap:g} N.m); give [unit] counterbalance as a number (N)")
    if bar:
        bar.close()
    _BALANCED[key] = m
    return m
