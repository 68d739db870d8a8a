"""What a user waits for, end to end (issue 17): ``speed.py`` reports these beside its table.

* ``simulate()`` from the scenario file to the Result in a warm process (imports done, kernel
  compiled), with its breakdown (loading the files, building the model, tabulating, the kernel,
  the outputs), against the peer the issue names: scipy's DOP853 on a right-hand side written here
  by hand from the four-bar's closed-form geometry (seed 000 only), at the same error.
* The C RK4 limit (``c_rk4.c``): the same hand-written four-bar in C, RK4 at a fixed step with the
  kink located, at the coarsest step reaching the same error.
* The imports alone, in a fresh process.
* The first run on a fresh machine: a new HOME (so no crankfmu cache),
  a fresh copy of the package (nothing of it compiled yet, not even its bytecode): the CLI's
  ``crankfmu simulate seed000 --method fast`` and fmpy's first ``simulate_fmu`` of FourBar.fmu.
* FourBar.fmu through fmpy, instantiate to free, beside a do-nothing FMU's whole run, and the
  reset + initialisation of a changed design.

Nothing here is asserted on seconds: ``speed.py`` judges ratios measured in the same run.
"""

from __future__ import annotations

import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def median_time(run, repeats: int, once_over: float = math.inf):
    """(result of the last call, median seconds) of ``repeats`` calls; one call only when it takes
    more than ``once_over`` seconds."""
    times, out = [], None
    for _ in range(repeats):
        started = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - started)
        if times[0] > once_over:
            break
    return out, statistics.median(times)


# ------------------------------------------------------------------ the peer: hand-written four-bar
def fourbar_rhs(values: dict):
    """d(phi1, omega1)/dt of seed 000 written out by hand: B from two circles (above the x axis),
    the velocity ratios and their derivatives from the loop's derivatives, J and 0.5 J' summed over
    the three bars (m = q l, I = m l^2 / 12, mass centres at mid-link), eq. 18 on the rocker with its
    extremes from the collinear positions, the motor line by branch. Returns (rhs(t, y, high), ws)."""
    l0, l1, l2, l3 = (values[k] for k in ("l0", "l1", "l2", "l3"))
    m1, m2, m3 = values["q1"] * l1, values["q2"] * l2, values["q3"] * l3
    I1, I2, I3 = m1 * l1 ** 2 / 12, m2 * l2 ** 2 / 12, m3 * l3 ** 2 / 12
    Mr, J_F = values["Mr"], values["J_flywheel"]
    A, B, A_low, B_low, ws = (values[k] for k in ("A", "B", "A_low", "B_low", "omega_switch"))
    if values["g"] != 0.0:
        raise SystemExit("the hand-written peer covers seed 000 with g = 0")

    def B_at_distance(r):            # B at distance r from O on the rocker's circle, above the axis
        return math.acos((r * r + l0 * l0 - l3 * l3) / (2 * l0 * r))
    phi1d = B_at_distance(l1 + l2)                  # AB in the prolongation of OA
    phi1a = B_at_distance(l2 - l1) + math.pi        # AB folded back over OA

    def rhs(t, y, high):
        phi1, w = y
        s1, c1 = math.sin(phi1), math.cos(phi1)
        ax, ay = l1 * c1, l1 * s1
        dx, dy = l0 - ax, -ay                       # A -> C
        d = math.hypot(dx, dy)
        alpha = math.atan2(dy, dx)
        beta = math.acos((l2 * l2 + d * d - l3 * l3) / (2 * l2 * d))
        phi2 = alpha + beta                         # B above the line AC
        bx, by = ax + l2 * math.cos(phi2), ay + l2 * math.sin(phi2)
        phi3 = math.atan2(-by, l0 - bx)
        s2, c2, s3, c3 = math.sin(phi2), math.cos(phi2), math.sin(phi3), math.cos(phi3)
        # l1 u'(phi1) + l2 q2 u'(phi2) + l3 q3 u'(phi3) = 0, u' = (-sin, cos)
        det = l2 * l3 * (-s2 * c3 + c2 * s3)
        rx, ry = l1 * s1, -l1 * c1
        q2 = (rx * l3 * c3 + l3 * s3 * ry) / det
        q3 = (-l2 * s2 * ry - l2 * c2 * rx) / det
        # second derivatives: the same matrix, right-hand side from u'' = -u
        rx2 = l1 * c1 + l2 * c2 * q2 * q2 + l3 * c3 * q3 * q3
        ry2 = l1 * s1 + l2 * s2 * q2 * q2 + l3 * s3 * q3 * q3
        qq2 = (rx2 * l3 * c3 + l3 * s3 * ry2) / det
        qq3 = (-l2 * s2 * ry2 - l2 * c2 * rx2) / det
        # mass centres: (t, p) = d/dphi1, (tt, pp) = d2/dphi1^2
        t1, p1, tt1, pp1 = -0.5 * l1 * s1, 0.5 * l1 * c1, -0.5 * l1 * c1, -0.5 * l1 * s1
        t2 = -l1 * s1 - 0.5 * l2 * s2 * q2
        p2 = l1 * c1 + 0.5 * l2 * c2 * q2
        tt2 = -l1 * c1 - 0.5 * l2 * (c2 * q2 * q2 + s2 * qq2)
        pp2 = -l1 * s1 + 0.5 * l2 * (-s2 * q2 * q2 + c2 * qq2)
        t3, p3 = 0.5 * l3 * s3 * q3, -0.5 * l3 * c3 * q3
        tt3 = 0.5 * l3 * (c3 * q3 * q3 + s3 * qq3)
        pp3 = 0.5 * l3 * (s3 * q3 * q3 - c3 * qq3)
        J = (J_F + m1 * (t1 * t1 + p1 * p1) + I1 + m2 * (t2 * t2 + p2 * p2) + I2 * q2 * q2
             + m3 * (t3 * t3 + p3 * p3) + I3 * q3 * q3)
        half_dJ = (m1 * (t1 * tt1 + p1 * pp1) + m2 * (t2 * tt2 + p2 * pp2) + I2 * q2 * qq2
                   + m3 * (t3 * tt3 + p3 * pp3) + I3 * q3 * qq3)
        Q = Mr * math.sin(0.5 * (phi1 - phi1d)) * math.sin(0.5 * (phi1 - phi1a)) * q3
        M = A - B * w if high else A_low - B_low * w
        return [w, (M + Q - half_dJ * w * w) / J]
    return rhs, ws


def peer_run(values: dict, y0, t_end: float, grid, rtol: float):
    """omega1 on ``grid`` by scipy's DOP853 on the hand-written right-hand side, the motor kink
    located as an event: a segment on the start-up line up to omega_switch, then the working line
    (seed 000 crosses the kink once, upwards)."""
    from scipy.integrate import solve_ivp

    rhs, ws = fourbar_rhs(values)
    kink = lambda t, y, high: y[1] - ws  # noqa: E731
    kink.terminal, kink.direction = True, 1.0
    first = solve_ivp(rhs, (0.0, t_end), list(y0), method="DOP853", rtol=rtol, atol=rtol, dense_output=True,
                      events=kink, args=(False,))
    if first.status != 1:
        return first.sol(grid)[1]
    t_kink = float(first.t_events[0][0])
    second = solve_ivp(rhs, (t_kink, t_end), [first.y_events[0][0][0], ws], method="DOP853", rtol=rtol, atol=rtol,
                       dense_output=True, args=(True,))
    return np.where(grid < t_kink, first.sol(np.minimum(grid, t_kink))[1], second.sol(np.maximum(grid, t_kink))[1])


def fastest_peer(values: dict, y0, grid, truth, target: float, repeats: int):
    """The fastest rtol of the peer that reaches ``target`` (rad/s): (rtol, error, seconds)."""
    found = None
    for rtol in (1e-8, 1e-9, 1e-10, 1e-11, 1e-12):
        omega, seconds = median_time(lambda r=rtol: peer_run(values, y0, float(grid[-1]), grid, r), repeats)
        error = float(np.max(np.abs(omega - truth)))
        if error <= target and (found is None or seconds < found[2]):
            found = (rtol, error, seconds)
    return found


def c_rk4_limit(values: dict, y0, grid, truth, target: float, repeats: int = 20):
    """The C RK4 limit (``c_rk4.c``, gcc -O2): (steps per output interval, max omega1 error, fastest
    of ``repeats`` runs in seconds) at the coarsest step that reaches ``target`` rad/s, or None."""
    keys = ("l0", "l1", "l2", "l3", "q1", "q2", "q3", "Mr", "J_flywheel", "A", "B", "A_low", "B_low", "omega_switch")
    args = [repr(float(values[k])) for k in keys] + [repr(float(y0[0])), repr(float(y0[1])),
                                                     repr(float(grid[-1])), repr(float(grid[1] - grid[0]))]
    with tempfile.TemporaryDirectory() as tmp:
        exe = Path(tmp) / "c_rk4"
        subprocess.run(["gcc", "-O2", "-o", str(exe), str(ROOT / "benchmarks" / "c_rk4.c"), "-lm"], check=True,
                       capture_output=True)
        for substeps in (1, 2, 4, 8, 16, 32, 64):
            done = subprocess.run([str(exe), *args, str(substeps), str(repeats)], capture_output=True, text=True,
                                  check=True)
            numbers = np.array(done.stdout.split(), dtype=float)
            error = float(np.max(np.abs(numbers[1:] - truth[1:])))
            if error <= target:
                return substeps, error, float(numbers[0])
    return None


# ------------------------------------------------------------------ simulate() and its breakdown
def simulate_breakdown(name: str, repeats: int) -> dict:
    """simulate(load_scenario(name), method="fast") end to end in this (warm) process, and the
    median time of each stage run alone: files, model (the fast path's Scenario.build(table=...)
    without its table), table (the C model's: assembly check, searches, tabulation), kernel; the
    outputs are the rest."""
    import crankfmu
    from crankfmu.dynamics.tabulated import c_table
    from crankfmu.integrators.fast import TABLE_TOLERANCE, FastIntegrator
    from crankfmu.scenario import load_scenario

    crankfmu.simulate(load_scenario(name), method="fast")                  # compile and warm up
    result, total = median_time(lambda: crankfmu.simulate(load_scenario(name), method="fast"), repeats)
    scenario, files = median_time(lambda: load_scenario(name), repeats)
    model, built = median_time(lambda: scenario.build(table=TABLE_TOLERANCE), repeats)
    _, table = median_time(lambda: c_table(scenario, scenario.values, TABLE_TOLERANCE), repeats)
    build = max(built - table, 0.0)
    times = result.time
    integrator = FastIntegrator()
    _, kernel = median_time(lambda: integrator.run(model.equation, float(times[0]), model.y0, float(times[-1]),
                                                   output_times=times), repeats)    # table cached by now
    return {"total": total, "files": files, "model": build, "table": table, "kernel": kernel,
            "outputs": max(total - files - build - table - kernel, 0.0), "omega1": result.omega1, "time": times}


def import_time() -> float:
    """Seconds to import crankfmu with simulate() and the fast path in a fresh process."""
    code = ("import time; t = time.perf_counter(); import crankfmu, crankfmu.simulation, "
            "crankfmu.integrators.fast; print(time.perf_counter() - t)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(done.stdout.split()[-1])


# ------------------------------------------------------------------ a fresh machine
def fresh_environment(tmp: Path) -> dict:
    """The environment of a first run: a new HOME and cache (nothing of crankfmu cached), and
    a fresh copy of the package first on the path (its bytecode not yet compiled, as after an
    installation; the dependencies keep the bytecode their installation compiled)."""
    import shutil

    import crankfmu

    env = {k: v for k, v in os.environ.items() if not k.startswith("CRANKFMU_")}
    (tmp / "home").mkdir(exist_ok=True)
    shutil.copytree(Path(crankfmu.__file__).parent, tmp / "site" / "crankfmu", ignore=shutil.ignore_patterns("__pycache__"))
    env.update(HOME=str(tmp / "home"), XDG_CACHE_HOME=str(tmp / "home" / ".cache"), PYTHONPATH=str(tmp / "site"))
    return env


def first_runs(fmu: Path | None) -> dict:
    """Wall seconds of the CLI's first fast run and fmpy's first simulate_fmu on a fresh machine."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = fresh_environment(Path(tmp))
        cli = [sys.executable, "-m", "crankfmu.cli", "simulate", "seed000", "--method", "fast", "--out", str(Path(tmp) / "run")]
        started = time.perf_counter()
        subprocess.run(cli, env=env, capture_output=True, check=True)
        out["cli"] = time.perf_counter() - started
    if fmu is not None:
        with tempfile.TemporaryDirectory() as tmp:
            env = fresh_environment(Path(tmp))
            code = f"import fmpy; fmpy.simulate_fmu({str(fmu)!r}, output=['omega1'])"
            started = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, check=True)
            out["fmu"] = time.perf_counter() - started
    return out


# ------------------------------------------------------------------ the FMU in fmpy
def fmu_reset_and_initialise(fmu: Path, repeats: int) -> float:
    """Median seconds of fmi2Reset, a changed design (the coupler's length: new tables) and the
    initialisation, in one instance."""
    from fmu_step import initialised

    with tempfile.TemporaryDirectory() as tmp:
        slave, vr = initialised(fmu, tmp)
        times = []
        for k in range(repeats):
            started = time.perf_counter()
            slave.reset()
            slave.setReal([vr["l2"]], [0.5 + 0.001 * (k + 1)])
            slave.setupExperiment(startTime=0.0)
            slave.enterInitializationMode()
            slave.exitInitializationMode()
            times.append(time.perf_counter() - started)
        slave.terminate()
        slave.freeInstance()
    return statistics.median(times)
