"""``crankfmu well WELL.toml --out DIR``: the pumping well run to steady state as one model
(crankfmu.well.CoupledWell), read the way a production engineer reads it.

- the run: crankfmu.well.run_to_steady (the sheave set to the file's strokes/min, then strokes
  until two successive surface cards agree to ``tolerance`` of the peak load at every crank
  angle), after balancing the counterweights if the file asks for it (``counterbalance =
  "balanced"``: equal peak torques on the upstroke and the downstroke);
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
  mean motor torque), strokes/min, surface and plunger strokes (m), the counterweights and their
  counterbalance effect beside RP 11L's, the upstroke's and downstroke's peak torques; with the well file's
  [reference] (a published design's numbers) side by side.
"""

from __future__ import annotations

import math

import numpy as np

from ..dynamics.well import load_well
from ..progress import ProgressBar
from ..well import (CoupledWell, Stroke, card_change, counterbalance_of, counterbalance_spec, gearbox_torque,
                    rp11l_counterbalance, run_to_steady, torque_peaks, unit_scenario)

__all__ = ["run", "card_change", "torque_parts", "api_rod_torque", "summary", "comparison"]

LB, INCH, IN_LB, HP = 4.4482216152605, 0.0254, 0.1129848290276167, 745.69987158227


def run(well_name, max_strokes: int = 40, tolerance: float = 5e-4, dt: float | None = None, progress=True,
        in_c: bool = True):
    """(well file, coupled model, the strokes run): the well's unit (its counterweights balanced
    first if the file asks for it) and string run to steady state (crankfmu.well.run_to_steady);
    ``in_c`` False: every step by the Python reference (CoupledWell.step), the same numbers."""
    well = load_well(well_name)
    design = well.design()
    scenario = unit_scenario(well, design=design, progress=progress, in_c=in_c)
    bar = ProgressBar(max_strokes, f"well {well.name}: strokes") if progress else None
    cw, strokes = run_to_steady(well, scenario, design, max_strokes=max_strokes, tolerance=tolerance, dt=dt, bar=bar,
                                in_c=in_c)
    if bar:
        bar.close()
    return well, cw, strokes


def torque_parts(cw: CoupledWell, stroke: Stroke) -> dict:
    """The net gearbox torque (N.m) from the drive's side and its parts from the unit's side."""
    reduced = cw.model.reduced
    phi, omega, eps = stroke["phi1"], stroke["omega1"], stroke["epsilon1"]
    J, half_dJ, Q_weights, kin = reduced.coefficients(np.mod(phi, 2 * math.pi))
    s_prime = cw.port.transfer(kin)[1]
    net = gearbox_torque(cw, stroke)
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
    up_peak, down_peak = torque_peaks(cw, stroke)
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
        "counterbalance": counterbalance_spec(well),
        "counterbalance_effect": counterbalance_of(cw.scenario),
        "rp11l_counterbalance_effect": rp11l_counterbalance(cw.string.design),
        "peak_torque_upstroke": up_peak, "peak_torque_downstroke": down_peak,
        "units": {"PPRL": "N", "MPRL": "N", "peak_torque": "N.m", "PRHP": "W", "hydraulic_power": "W",
                  "damping_power": "W", "friction_power": "W", "plunger_stop_power": "W", "motor_power": "W",
                  "cyclic_load_factor": "1", "strokes_per_minute": "1/min", "surface_stroke": "m",
                  "plunger_stroke": "m", "torque_closure": "1", "api_torque_difference": "1", "fluid_load": "N", "buoyant_rod_weight": "N",
                  "counterweight_mass": "kg", "counterbalance_effect": "N",
                  "rp11l_counterbalance_effect": "N", "peak_torque_upstroke": "N.m", "peak_torque_downstroke": "N.m"},
    }
    out["field_units"] = {"PPRL_lb": out["PPRL"] / LB, "MPRL_lb": out["MPRL"] / LB,
                          "peak_torque_in_lb": out["peak_torque"] / IN_LB, "PRHP_hp": out["PRHP"] / HP,
                          "plunger_stroke_in": out["plunger_stroke"] / INCH, "surface_stroke_in": out["surface_stroke"] / INCH}
    reference = well.unit.get("reference") or {}
    if reference:
        out["reference"] = comparison(out, reference, well.unit.get("reference_accuracy") or {})
    return out


#: the [unit.reference] keys a well file may give (field units, as published) -> (ours, scale)
REFERENCE = {"PPRL_lb": ("PPRL", LB), "MPRL_lb": ("MPRL", LB), "peak_torque_in_lb": ("peak_torque", IN_LB),
             "plunger_stroke_in": ("plunger_stroke", INCH), "strokes_per_minute": ("strokes_per_minute", 1.0)}


def comparison(out: dict, reference: dict, accuracy: dict | None = None) -> dict:
    """Each published number beside ours, with its verdict as the papers' numbers have one: the
    well file's [unit.reference_accuracy] gives the method's stated accuracy (relative: agrees
    within it, else disagrees), or says in words why a number is no evidence ("fitted: ...") or
    cannot be judged ("not comparable: ...")."""
    rows = {}
    for key, published in reference.items():
        if key not in REFERENCE:
            continue
        ours, scale = REFERENCE[key]
        value = out[ours] / scale
        relative = value / published - 1.0
        row = {"published": published, "crankfmu": value, "relative": relative}
        said = (accuracy or {}).get(key)
        if isinstance(said, (int, float)):
            row.update(tolerance=float(said), verdict="agrees" if abs(relative) <= said else "disagrees")
        elif isinstance(said, str) and ":" in said:
            verdict, why = (part.strip() for part in said.split(":", 1))
            row.update(verdict=verdict, why=why)
        else:
            row.update(verdict="not comparable", why="no stated accuracy")
        rows[key] = row
    return rows
