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


def coupled_reference(times, scenario: str = "seed000", drive: str = "dc_pi", rtol: float = 1e-12) -> dict:
    """omega1, phi1, tau, i at ``times`` (s) from the start values of both data files."""
    from scipy.integrate import solve_ivp

    model = load_scenario(scenario).with_params(**MOTOR_OFF).build()
    equation = model.equation
    drive_file = load_drive(drive)
    values = {n: p.value for n, p in {**drive_file.parameters, **drive_file.inputs}.items()}
    dc = drive_file.drive(values)
    omega_set = values["omega_set"]
    mode = equation.initial_mode(0.0, model.y0)

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
