"""``crankfmu well WELL.toml --out DIR``: the pumping well run to steady state as one model
(crankfmu.well.CoupledWell), read the way a production engineer reads it.

- the sheave: the motor line's synchronous speed is corrected after each stroke until the mean
  crank speed is the well file's strokes/min (to 1e-4), then held;
- steady state: strokes are run until two successive surface cards agree to 1e-4 of the peak load
  at every crank angle (``tolerance``), or ``max_strokes``;
- a stroke runs from the bottom of the polished rod's travel to the next (the crank angle where
  the rope's position is lowest);
- the cards: polished rod and pump load against their position, upward from the bottom of stroke;
- the net gearbox torque, from the drive's side M_motor - J_flywheel epsilon1 (the rotor and
  sheaves are on the motor's side of the reducer), split by the unit's reduced model into the rod
  load's part -F s'(phi1), the weights' part (counterweights, beam unbalance, pitman) and the
  inertia part (J - J_flywheel) epsilon1 + J'/2 omega1^2. The parts are computed from the unit's
  kinematics and the card, so their sum against the drive's torque is a check
  (``torque_closure``); and API 11E's torque factor applied to the card, TF F, is
  compared with the drive's torque less the weights and inertia (``api_torque_difference``);
- summary.json: PPRL, MPRL (N), PRHP (W), the hydraulic, damping, friction and plunger-stop powers
  (W), peak_torque (N.m), motor power (W, mean M_motor omega1), the cyclic load factor (RMS over
  mean motor torque), strokes/min, surface and plunger strokes (m); with the well file's
  [reference] (a published design's numbers) side by side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..dynamics.well import load_well
from ..well import CoupledWell, line_through, target_speed, unit_scenario
from ..native import ROW_FIELDS
from ..progress import ProgressBar

ROW = {name: i for i, name in enumerate(ROW_FIELDS)}
LB, INCH, IN_LB, HP = 4.4482216152605, 0.0254, 0.1129848290276167, 745.69987158227
FIELDS = ("t", "phi1", "omega1", "epsilon1", "M_motor", "s", "F", "u_pump", "F_pump", "work", "hydraulic",
          "damping", "friction", "stops")


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
    s = cw.rope.s(phi)
    i = int(np.argmax(s))
    # refine on the cubic: s'(phi) = 0 near phi[i]
    from scipy.optimize import brentq
    a, b = phi[i] - 2 * math.pi / 3600, phi[i] + 2 * math.pi / 3600
    return brentq(lambda p: cw.rope.velocity(p, 1.0), a, b) % (2 * math.pi)


def run(well_name, max_strokes: int = 40, tolerance: float = 5e-4, dt: float | None = None, progress=True):
    """(well file, coupled model, the last two strokes, the strokes run). Each stroke is cut at
    the bottom of the polished rod's travel."""
    well = load_well(well_name)
    design = well.design()
    scenario = unit_scenario(well, design=design)
    cw = CoupledWell(scenario, design, dt=dt)
    target = target_speed(well)
    slope = cw.motor.B
    omega_sync = cw.motor.A / slope
    phi_b = bottom_angle(cw)
    bar = ProgressBar(max_strokes, f"well {well.name}: strokes") if progress else None
    # run to the first bottom of stroke
    next_bottom = phi_b + 2 * math.pi * math.ceil((cw.y[0] - phi_b) / (2 * math.pi) + 1e-9)
    while cw.y[0] < next_bottom:
        cw.step()
    strokes: list[Stroke] = []
    samples = [_sample(cw)]
    tuned = False
    n = 0
    while n < max_strokes:
        next_bottom += 2 * math.pi
        while cw.y[0] < next_bottom:
            cw.step()
            samples.append(_sample(cw))
        stroke = Stroke({k: np.array(col) for k, col in zip(FIELDS, zip(*samples))})
        samples = [samples[-1]]
        strokes.append(stroke)
        n += 1
        if bar:
            bar(n)
        mean_speed = 2 * math.pi / stroke.period
        if not tuned:
            # the sheave: move the synchronous speed by the speed error (the line's slope is steep,
            # so the mean torque hardly changes with it)
            error = target - mean_speed
            if abs(error) < 5e-4 * target:
                tuned = True
            else:
                omega_sync += error
                cw.set_motor(line_through(omega_sync, slope))
                continue
        if len(strokes) >= 2 and tuned and card_change(strokes[-2], strokes[-1]) < tolerance:
            break
    if bar:
        bar.close()
    return well, cw, strokes


def card_change(a: Stroke, b: Stroke) -> float:
    """The largest difference of the surface load at the same crank angle between two strokes,
    over the peak load."""
    grid = np.linspace(0.0, 1.0, 721)
    fa = np.interp(grid, (a["phi1"] - a["phi1"][0]) / (2 * math.pi), a["F"])
    fb = np.interp(grid, (b["phi1"] - b["phi1"][0]) / (2 * math.pi), b["F"])
    return float(np.max(np.abs(fa - fb)) / np.max(np.abs(fb)))


def torque_parts(cw: CoupledWell, stroke: Stroke) -> dict:
    """The net gearbox torque (N.m) from the drive's side and its parts from the unit's side."""
    reduced = cw.model.reduced
    phi, omega, eps = stroke["phi1"], stroke["omega1"], stroke["epsilon1"]
    J, half_dJ, Q_weights, kin = reduced.coefficients(np.mod(phi, 2 * math.pi))
    s_prime = cw.port.transfer(kin)[1]
    net = stroke["M_motor"] - reduced.J_flywheel * eps
    rod = -stroke["F"] * s_prime
    weights = -Q_weights
    inertia = (J - reduced.J_flywheel) * eps + half_dJ * omega ** 2
    return {"net": net, "rod": rod, "weights": weights, "inertia": inertia, "s_prime": s_prime, "kin": kin}


def api_rod_torque(cw: CoupledWell, stroke: Stroke, parts: dict) -> np.ndarray:
    """API 11E's torque factor applied to the card (N.m): TF F, TF = (A R / C) sin(alpha) / sin(beta)
    in closed form from the unit's link angles (alpha between crank and pitman, beta between
    pitman and beam). The drive's net torque less the unit's weights and inertia must equal it."""
    v = cw.scenario.values
    kin = parts["kin"]
    phi1 = np.mod(stroke["phi1"], 2 * math.pi)
    phi_p, theta = kin.q["phi_p"], kin.q["theta"]
    TF = v["arm_A"] * v["crank_R"] / v["arm_C"] * np.sin(phi_p - phi1) / np.sin(theta - phi_p)
    return TF * stroke["F"]


def summary(well, cw: CoupledWell, stroke: Stroke) -> dict:
    T = stroke.period
    parts = torque_parts(cw, stroke)
    up = -(stroke["s"] - stroke["s"].max())             # polished rod position above the bottom
    pump_up = -(stroke["u_pump"] - stroke["u_pump"].max())
    motor_torque = stroke["M_motor"]
    mean_torque = float(np.mean(motor_torque))
    out = {
        "PPRL": float(stroke["F"].max()), "MPRL": float(stroke["F"].min()),
        "peak_torque": float(np.max(np.abs(parts["net"]))),
        "PRHP": stroke.delta("work") / T,
        "hydraulic_power": stroke.delta("hydraulic") / T,
        "damping_power": stroke.delta("damping") / T,
        "friction_power": stroke.delta("friction") / T,
        "plunger_stop_power": stroke.delta("stops") / T,
        "motor_power": float(np.mean(motor_torque * stroke["omega1"])),
        "cyclic_load_factor": float(np.sqrt(np.mean(motor_torque ** 2)) / mean_torque),
        "strokes_per_minute": 60.0 / T,
        "surface_stroke": float(up.max()), "plunger_stroke": float(pump_up.max()),
        "torque_closure": float(np.max(np.abs(parts["net"] - parts["rod"] - parts["weights"] - parts["inertia"]))
                                / np.max(np.abs(parts["net"]))),
        "api_torque_difference": float(np.max(np.abs(parts["net"] - parts["weights"] - parts["inertia"]
                                                     - api_rod_torque(cw, stroke, parts))) / np.max(np.abs(parts["net"]))),
        "fluid_load": cw.string.design.fluid_load, "buoyant_rod_weight": cw.string.design.buoyant_weight,
        "counterweight_mass": cw.scenario.values["m_cw"],
        "units": {"PPRL": "N", "MPRL": "N", "peak_torque": "N.m", "PRHP": "W", "hydraulic_power": "W",
                  "damping_power": "W", "friction_power": "W", "plunger_stop_power": "W", "motor_power": "W",
                  "cyclic_load_factor": "1", "strokes_per_minute": "1/min", "surface_stroke": "m",
                  "plunger_stroke": "m", "torque_closure": "1", "api_torque_difference": "1", "fluid_load": "N", "buoyant_rod_weight": "N",
                  "counterweight_mass": "kg"},
    }
    out["field_units"] = {"PPRL_lb": out["PPRL"] / LB, "MPRL_lb": out["MPRL"] / LB,
                          "peak_torque_in_lb": out["peak_torque"] / IN_LB, "PRHP_hp": out["PRHP"] / HP,
                          "plunger_stroke_in": out["plunger_stroke"] / INCH, "surface_stroke_in": out["surface_stroke"] / INCH}
    reference = well.unit.get("reference") or {}
    if reference:
        out["reference"] = comparison(out, reference)
    return out


#: the [unit.reference] keys a well file may give (field units, as published) -> (ours, scale)
REFERENCE = {"PPRL_lb": ("PPRL", LB), "MPRL_lb": ("MPRL", LB), "peak_torque_in_lb": ("peak_torque", IN_LB),
             "plunger_stroke_in": ("plunger_stroke", INCH), "strokes_per_minute": ("strokes_per_minute", 1.0)}


def comparison(out: dict, reference: dict) -> dict:
    rows = {}
    for key, published in reference.items():
        if key not in REFERENCE:
            continue
        ours, scale = REFERENCE[key]
        value = out[ours] / scale
        rows[key] = {"published": published, "crankfmu": value, "relative": value / published - 1.0}
    return rows
