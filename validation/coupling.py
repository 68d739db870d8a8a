"""The four-bar driven by the DC drive, simulated in process as one model: the reference the
co-simulation of FourBarDrive.ssp is measured against.

State (phi1, omega1, i, x): the reduced movement equation on the contour engine (the exact
J(phi1), 0.5 J'(phi1) and Q(phi1, omega1) of ``MovementEquation.coefficients``) with the four-bar's
own motor line off and tau_ext = n_gear k_t i, and the drive's equations of ``dynamics.drive``.
Integrated with scipy's DOP853 at rtol = atol = 1e-12: nothing here shares the FMUs' stepping (the
fast kernel, the drive's exact step) or the coupling's zero-order hold.

A co-simulation at communication step H holds each FMU's inputs over the step, an O(H) error for
this coupling: the error table is expected to fall about linearly with H.
"""

from __future__ import annotations

import time

import numpy as np

from crankfmu.dynamics.drive import load_drive
from crankfmu.fmi.ssp import MOTOR_OFF
from crankfmu.scenario import load_scenario
from crankfmu.atomic import save_figure

STEPS = (1e-2, 1e-3, 1e-4)


def _parts(scenario: str, drive: str, J_flywheel: float | None):
    """The four-bar (its motor line off; its flywheel J_flywheel where given) built, its movement
    equation and start mode, and the drive of the drive file with the file's values."""
    flywheel = {} if J_flywheel is None else {"J_flywheel": J_flywheel}
    model = load_scenario(scenario).with_params(**MOTOR_OFF, **flywheel).build()
    drive_file = load_drive(drive)
    values = {n: p.value for n, p in {**drive_file.parameters, **drive_file.inputs}.items()}
    return model, model.equation, model.equation.initial_mode(0.0, model.y0), drive_file.drive(values), values


def coupled_reference(times, scenario: str = "seed000", drive: str = "dc_pi", rtol: float = 1e-12,
                      J_flywheel: float | None = None) -> dict:
    """omega1, phi1, tau, i at ``times`` (s) from the start values of both data files (the four-bar's
    flywheel ``J_flywheel`` kg.m2 where given: the whole inertia on the crank, the drive's and the
    flywheel's, when the drive carries part of it in speed causality)."""
    from scipy.integrate import solve_ivp

    model, equation, mode, dc, values = _parts(scenario, drive, J_flywheel)
    omega_set = values["omega_set"]

    def rhs(t, y):
        phi1, omega1, i, x = y
        J, half_dJ, Q, _ = equation.coefficients(phi1, omega1, mode, t)
        eps = (Q + dc.torque(i) - half_dJ * omega1 * omega1) / J     # the motor line is off
        di, dx = dc.rhs(i, x, omega1, omega_set)
        return [omega1, eps, di, dx]

    y0 = [model.y0[0], model.y0[1], values["i_start"], values["x_start"]]
    times = np.asarray(times, dtype=float)
    started = time.perf_counter()
    sol = solve_ivp(rhs, (times[0], times[-1]), y0, method="DOP853", rtol=rtol, atol=rtol, t_eval=times)
    if not sol.success:
        raise RuntimeError(f"coupled reference: {sol.message}")
    phi1, omega1, i, _ = sol.y
    return {"time": sol.t, "phi1": phi1, "omega1": omega1, "i": i, "tau": dc.torque(i),
            "wall": time.perf_counter() - started}


def shaft_damping(k: float, zeta: float, J_drive: float, J_machine: float) -> float:
    """The damping (N.m.s/rad) of a shaft of stiffness ``k`` (N.m/rad) between two inertias (kg.m2)
    for the damping ratio ``zeta`` of its torsional mode: 2 zeta sqrt(k J_eff), J_eff their series
    inertia."""
    return 2.0 * zeta * float(np.sqrt(k * J_drive * J_machine / (J_drive + J_machine)))


def machine_inertia(scenario: str = "seed000", J_flywheel: float = 0.0) -> float:
    """The four-bar's reduced inertia (kg.m2) at its start angle, its motor line off."""
    model, equation, mode, _, _ = _parts(scenario, "dc_pi", J_flywheel)
    return float(equation.coefficients(model.y0[0], model.y0[1], mode, 0.0)[0])


def shaft_reference(times, k: float, c: float, J_drive: float, J_flywheel: float = 0.0, scenario: str = "seed000",
                    drive: str = "dc_pi", rtol: float = 1e-10) -> dict:
    """The four-bar (its flywheel ``J_flywheel``) on an elastic shaft (``k`` N.m/rad, ``c`` N.m.s/rad)
    from the drive carrying ``J_drive`` kg.m2, as one model: state (phi1, omega1, i, x, omega, twist),
    both sides starting at the four-bar's omega1_start, the shaft untwisted; the shaft's torque
    k twist + c (omega - omega1) drives the crank and loads the drive. DOP853: its steps follow the
    shaft's torsional mode."""
    from scipy.integrate import solve_ivp

    model, equation, mode, dc, values = _parts(scenario, drive, J_flywheel)
    omega_set = values["omega_set"]

    def rhs(t, y):
        phi1, omega1, i, x, omega, twist = y
        tau = k * twist + c * (omega - omega1)
        J, half_dJ, Q, _ = equation.coefficients(phi1, omega1, mode, t)
        di, dx = dc.rhs(i, x, omega, omega_set)
        return [omega1, (Q + tau - half_dJ * omega1 * omega1) / J, di, dx, (dc.torque(i) - tau) / J_drive,
                omega - omega1]

    y0 = [model.y0[0], model.y0[1], values["i_start"], values["x_start"], model.y0[1], 0.0]
    times = np.asarray(times, dtype=float)
    sol = solve_ivp(rhs, (times[0], times[-1]), y0, method="DOP853", rtol=rtol, atol=rtol, t_eval=times)
    if not sol.success:
        raise RuntimeError(f"shaft reference: {sol.message}")
    return {"time": sol.t, "phi1": sol.y[0], "omega1": sol.y[1], "omega": sol.y[4], "twist": sol.y[5]}


def cosim_errors(runs: dict, reference: dict, column: str = "FourBar.omega1") -> list[dict]:
    """One row per (master, step): max |omega1 - reference| (rad/s) over the communication points,
    and the same relative to max |omega1|; ``runs`` maps (master, step) to a MasterRun of the SSP,
    ``column`` is the crank speed's variable in it (Drive.omega in speed causality)."""
    rows = []
    for (master, step), run in sorted(runs.items()):
        if run.error:
            rows.append({"master": master, "step": step, "error": run.error})
            continue
        omega = run[column]
        ref = np.interp(run.time, reference["time"], reference["omega1"])
        abs_err = float(np.max(np.abs(omega - ref)))
        rows.append({"master": master, "step": step, "omega1_error": abs_err,
                     "relative": abs_err / float(np.max(np.abs(reference["omega1"]))),
                     "omega1_end": float(omega[-1]), "points": int(run.time.size)})
    return rows


def plot(rows: list[dict], reference: dict, runs: dict, out, column: str = "FourBar.omega1",
         system: str = "FourBarDrive") -> None:
    from crankfmu.plots import pyplot

    plt = pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax1.plot(reference["time"], reference["omega1"], "k-", lw=1.2, label="one model in process (DOP853, rtol 1e-12)")
    for (master, step), run in sorted(runs.items()):
        if not run.error and step == max(s for m, s in runs if m == master):
            ax1.plot(run.time, run[column], "--", lw=1, label=f"{master}, H = {step:g} s")
    ax1.set_xlabel("time t (s)")
    ax1.set_ylabel("crank speed omega1 (rad/s)")
    ax1.set_title(f"{system}: crank speed")
    ax1.legend(fontsize=8)
    styles = iter([dict(marker="s", ms=9, ls="-", mfc="none"), dict(marker="o", ms=4, ls="--")])
    for master in sorted({r["master"] for r in rows}):
        pts = sorted((r["step"], r["omega1_error"]) for r in rows if r["master"] == master and "omega1_error" in r)
        if pts:
            ax2.loglog(*zip(*pts), label=master, **next(styles, {}))
    hs = np.array(STEPS)
    first = next((r for r in rows if "omega1_error" in r and r["step"] == max(STEPS)), None)
    if first:
        ax2.loglog(hs, first["omega1_error"] * hs / max(STEPS), "k:", label="slope 1")
    ax2.set_xlabel("communication step H (s)")
    ax2.set_ylabel("max |omega1 - reference| (rad/s)")
    ax2.set_title("co-simulation error against the one-model reference")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, out, dpi=120)
    plt.close(fig)
