"""The papers' crank-angle schemes measured against the reference: convergence and start-up.

For each scheme and angle step: the largest |omega1 error| over the summary cycle as a function
of phi1 (the schemes step in phi1, so this is their natural error), the observed order between
successive steps, the start-up (omega1 after the first step, the peak of omega1 over the first
cycle, the largest error over the first cycle) and the time to complete the summary cycle.
"""

from __future__ import annotations

import math

import numpy as np

from ..dynamics.equation import OMEGA, PHI
from ..simulation import Result, simulate

TWO_PI = 2.0 * math.pi


def scheme_study(scenario, reference: Result, methods=("badoiu-eq17", "lv-eq3"),
                 steps_deg=(1.0, 0.1, 0.01)) -> tuple[list[dict], dict]:
    """Rows of the table, and the runs themselves keyed by (method, step in deg)."""
    rows, runs = [], {}
    k = scenario.experiment.summary_cycle
    phi0 = reference.phi1[0]
    t_cycle_ref = reference.cycle_bounds(k)[1]
    first_ref = phi0 + np.linspace(0.0, TWO_PI, 721)
    peak_ref = float(np.max(reference.omega_at_angle(first_ref)))
    for method in methods:
        previous = None
        for deg in steps_deg:
            r = simulate(scenario, method=method, angle_step=math.radians(deg), t_end=reference.time[-1])
            runs[method, deg] = r
            phi, omega = r.trajectory.y[PHI], r.trajectory.y[OMEGA]
            cycle = (phi >= phi0 + TWO_PI * (k - 1)) & (phi <= phi0 + TWO_PI * k)
            err = float(np.max(np.abs(omega[cycle] - reference.omega_at_angle(phi[cycle]))))
            first = phi <= phi0 + TWO_PI
            err_first = float(np.max(np.abs(omega[first] - reference.omega_at_angle(phi[first]))))
            row = {
                "method": method, "step_deg": deg, "steps": int(r.trajectory.n_steps),
                "cycle_error": err,
                "order": None if previous is None else math.log(previous[1] / err) / math.log(previous[0] / deg),
                "omega1_after_first_step": float(omega[1]),
                "omega1_first_step_reference": float(reference.omega_at_angle(phi[1])[0]),
                "first_cycle_peak": float(np.max(omega[first])),
                "first_cycle_peak_reference": peak_ref,
                "first_cycle_error": err_first,
                "cycle_end_time": r.cycle_bounds(k)[1],
                "cycle_end_time_error": r.cycle_bounds(k)[1] - t_cycle_ref,
                "wall_time_s": r.wall_time,
            }
            rows.append(row)
            previous = (deg, err)
    return rows, runs


def format_table(rows: list[dict], cycle: int) -> str:
    head = (f"{'method':12} {'step deg':>8} {'steps':>7} {'max|dw| c' + str(cycle):>12} {'order':>6} "
            f"{'w after 1st':>11} {'(ref)':>9} {'peak c1':>8} {'(ref)':>8} {'max|dw| c1':>11} "
            f"{'dt end c' + str(cycle):>11} {'wall s':>7}")
    lines = [head]
    for r in rows:
        order = "" if r["order"] is None else f"{r['order']:.3f}"
        lines.append(
            f"{r['method']:12} {r['step_deg']:8g} {r['steps']:7d} {r['cycle_error']:12.3e} {order:>6} "
            f"{r['omega1_after_first_step']:11.4f} {r['omega1_first_step_reference']:9.4f} "
            f"{r['first_cycle_peak']:8.4f} {r['first_cycle_peak_reference']:8.4f} {r['first_cycle_error']:11.3e} "
            f"{r['cycle_end_time_error']:11.3e} {r['wall_time_s']:7.3f}")
    return "\n".join(lines)


