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
"""

from __future__ import annotations

import math

import numpy as np

from . import native as kernel
from .dynamics.loads import Weights
from .dynamics.motor import MotorLine
from .dynamics.rodstring import RodString, StringDesign
from .dynamics.tabulated import table_of
from .dynamics.well import WellFile
from .errors import DefinitionError
from .integrators.fast import TABLE_TOLERANCE, FastStepper

#: the unit scenario's data-file rod loads, replaced by the string on the rope port
ROD_LOADS_OFF = {"W_rods": 0.0, "W_rods_buoyant": 0.0, "W_fluid": 0.0}
PORT = "rod"


def rope_port(scenario):
    ports = [p for p in scenario.ports if p.name == PORT]
    if not ports or ports[0].kind != "rope":
        raise DefinitionError(f"{scenario.where}: a well's unit needs a rope port named {PORT!r} at its horsehead "
                              f"(see scenarios/pumpjack.toml)")
    return ports[0]


def counterbalance_effect(well: WellFile, design: StringDesign) -> float:
    """CBE (N) of the [unit] table: RP 11L's 1.06 (Wrf + Fo/2), or a number."""
    spec = well.unit.get("counterbalance", "rp11l")
    if spec == "rp11l":
        return 1.06 * (design.buoyant_weight + design.fluid_load / 2)
    if isinstance(spec, (int, float)) and not isinstance(spec, bool) and spec >= 0:
        return float(spec)
    raise DefinitionError(f"{well.where}: [unit] counterbalance = {spec!r}: give \"rp11l\" or a counterbalance "
                          "effect in N (>= 0)")


def counterweight_mass(scenario, cbe: float) -> float:
    """m_cw (kg) whose counterbalance effect is ``cbe``: with the crank horizontal on the upstroke
    (phi1 = pi, the counterweights' torque largest and helping the rods up), a polished rod load
    of ``cbe`` balances the unit's weights (API 11E's definition). The rod load's torque is its
    rope's transfer function times the load; the weights' torque is linear in m_cw."""
    port = rope_port(scenario)
    phi = np.array([math.pi])

    def static_torque(m_cw):
        model = scenario.with_params(m_cw=m_cw).build()
        kin = model.mechanism.kinematics(phi)
        gravity = sum(float(np.asarray(load.torque(kin, 0.0)).ravel()[0]) for load in model.reduced.loads
                      if isinstance(load, Weights))
        return gravity + cbe * float(port.transfer(kin)[1][0])

    t0, t1 = static_torque(0.0), static_torque(1000.0)
    m = -t0 * 1000.0 / (t1 - t0)
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


def unit_scenario(well: WellFile, omega_sync: float | None = None, design: StringDesign | None = None):
    """The unit's scenario for this well: its [unit.parameters], the data-file rod loads off, the
    counterweights for the counterbalance effect, and the motor line for the synchronous speed at
    the crank ``omega_sync`` (default: the line's no-load speed at the target strokes/min plus
    the rated slip, the starting guess ``steady_unit`` refines)."""
    from .scenario import load_scenario

    design = design or well.design()
    unit = well.unit
    scenario = load_scenario(unit.get("scenario", "pumpjack"))
    values = {**dict(unit.get("parameters", {})), **ROD_LOADS_OFF, "g": design.g}
    scenario = scenario.with_params(**values)
    rope_port(scenario)
    scenario = scenario.with_params(m_cw=counterweight_mass(scenario, counterbalance_effect(well, design)))
    motor = unit.get("motor", {})
    try:
        power, slip = float(motor["rated_power"]), float(motor["rated_slip"])
    except (KeyError, TypeError, ValueError):
        raise DefinitionError(f"{well.where}: [unit.motor] needs rated_power (W) and rated_slip (1)") from None
    if not (power > 0 and 0 < slip < 1):
        raise DefinitionError(f"{well.where}: [unit.motor] rated_power = {power!r} must be > 0 W and rated_slip = "
                              f"{slip!r} in (0, 1)")
    if omega_sync is None:
        omega_sync = target_speed(well) * (1 + slip / 2)
    line = motor_line(power, slip, omega_sync)
    return scenario.with_params(A=line.A, B=line.B, A_low=line.A_low, B_low=line.B_low,
                                omega_switch=line.omega_switch, omega1_start=target_speed(well))


def target_speed(well: WellFile) -> float:
    spm = well.unit.get("strokes_per_minute")
    if not isinstance(spm, (int, float)) or isinstance(spm, bool) or not spm > 0:
        raise DefinitionError(f"{well.where}: [unit] strokes_per_minute = {spm!r} must be > 0")
    return 2 * math.pi * spm / 60


# ------------------------------------------------------------------------------- one model
class CoupledWell:
    """The unit and the string as one model (module docstring). ``step()`` advances one string
    step; ``t``, ``y`` (the unit's state), ``row`` (the kernel's output row) and ``load_end`` (the
    polished rod load) are the state after it."""

    def __init__(self, scenario, design: StringDesign, dt: float | None = None, rtol: float = 1e-10):
        self.scenario = scenario
        self.model = scenario.build()
        self.port = rope_port(scenario)
        self.i_port = [p.name for p in scenario.ports].index(PORT)
        self.n_ports = len(scenario.ports)
        v = scenario.values
        table = table_of(self.model.reduced, TABLE_TOLERANCE)
        self.motor = MotorLine(v["A"], v["B"], v["A_low"], v["B_low"], v["omega_switch"])
        self.stepper = FastStepper(table, self.motor, self.model.reduced.J_flywheel, rtol)
        self.rope = RopeMotion(self.model, self.port)
        self.string = RodString(design, dt=dt or 0.0)
        self.dt = self.string.dt
        self.t = 0.0
        self.y = np.array(self.model.y0, dtype=float)
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
        load_a, load_b = self.string.load, self.load_end
        for n_pass in range(2):
            self._start_unit(load_a, (load_b - load_a) / dt)
            row = self.stepper.advance(t + dt, t + dt)
            phi = float(row[0])
            if n_pass:
                self.string.restore(saved_string)
            self.string.step(self.rope.position(phi), dt)
            load_a = self.string.load
            load_b = self.string.static_load
        # the unit's state at t + dt from the last pass
        y = np.zeros_like(self.y)
        kernel.dense(self.stepper.state, t + dt, y)
        self.y = y
        self.row = row.copy()
        self.load_end = load_b
        self.t = t + dt


class RopeMotion:
    """The rope port's coordinate s(phi1) (m) and s'(phi1), as periodic cubics on 4096 angles from
    the mechanism's kinematics: the one model asks for it every string step."""

    def __init__(self, model, port, n: int = 4096):
        from scipy.interpolate import CubicHermiteSpline

        phi = np.linspace(0.0, 2 * math.pi, n + 1)
        kin = model.mechanism.kinematics(phi[:-1])
        s, ds, _ = port.transfer(kin)
        s, ds = np.append(s, s[0]), np.append(ds, ds[0])
        self.s = CubicHermiteSpline(phi, s, ds, extrapolate="periodic")
        self.ds = self.s.derivative()

    def position(self, phi: float) -> float:
        return float(self.s(phi % (2 * math.pi)))

    def velocity(self, phi: float, omega: float) -> float:
        return float(self.ds(phi % (2 * math.pi))) * omega
