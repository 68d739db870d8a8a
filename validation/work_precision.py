"""Speed against error for one scenario (seed 000): every method's error and median wall time,
measured in one run on one machine, so the ratios between them mean something.

Error: max |omega1 error| (rad/s) on the scenario's 1 ms output grid over its 2 s, and
|phi1(2 s) error| (rad), against a truth run (in-process DOP853 with the motor kink located,
rtol = atol = 1e-13; it agrees with the reference at 1e-12 to about 1e-11 rad/s). Time: the
median wall time, over at least ``REPEATS`` runs (fewer only for a run over 1 s, and the report
says so), of the whole call that produces the answer (for the FMU the whole
``fmpy.simulate_fmu`` call: instantiate, initialise, step, free), with its spread (the fastest
and slowest run). An FMU's point also carries its initialisation (to the first communication
point) and its cost per communication step apart. Only points that deliver the stated output
grid (communication steps no coarser than it) enter the verdicts and the ratio table: a 20-step
run costs little because it answers less, not because it is fast. A method is called the fastest
only where its slowest run beats the next method's fastest.

Methods: the FMU through fmpy (communication steps 1e-4..1e-1 s at its default rtol, and rtol
1e-4..1e-10 at 1 ms steps); crankfmu in process (reference, dopri5); the papers' crank-angle
schemes (seed 000 eq. 17, seed 003 eq. 3) at 1, 0.1, 0.01 deg; scipy ``solve_ivp`` RK45, DOP853,
LSODA and Radau at rtol 1e-3..1e-10 on the same right-hand side with the motor line chosen by
omega1 at each call (no event location: what a user of solve_ivp gets).
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from crankfmu.dynamics.equation import OMEGA, PHI

from .reference import reference_run

FMU_STEPS = (1e-4, 1e-3, 1e-2, 1e-1)
FMU_RTOLS = (1e-4, 1e-6, 1e-8, 1e-10)
SCHEME_STEPS_DEG = (1.0, 0.1, 0.01)
SCIPY_METHODS = ("RK45", "DOP853", "LSODA", "Radau")
SCIPY_RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
QUICK = {"fmu_steps": (1e-3, 1e-1), "fmu_rtols": (1e-6, 1e-10), "scheme_steps_deg": (1.0, 0.1),
         "scipy_methods": ("RK45", "DOP853"), "scipy_rtols": (1e-4, 1e-7, 1e-10)}
#: runs per timed point: the median of 5 with its spread (a run over 1 s is repeated less, said so)
REPEATS = 5
TARGETS = (1e-3, 1e-6, 1e-9)        # rad/s: the error levels of the ratio table


@dataclass
class Point:
    family: str
    setting: str
    omega1_error: float     # rad/s, max over the 1 ms grid
    phi1_error: float       # rad at the end
    time_s: float           # median wall time
    repeats: int
    note: str = ""
    time_min: float = math.nan      # the fastest run, s
    time_max: float = math.nan      # the slowest run, s
    on_grid: bool = True            # delivers the stated output grid (else: not in the verdicts)
    init_s: float = math.nan        # an FMU's: median time to its first communication point, s
    per_step_s: float = math.nan    # an FMU's: median time per communication step after it, s


def _timed(run, repeats: int = REPEATS):
    """(the last output, every run's wall time, every output) over ``repeats`` calls; fewer when
    the calls so far add up to over 2 s and each took over 1 s."""
    outs, times = [], []
    while len(times) < repeats and not (times and min(times) > 1.0 and sum(times) > 2.0):
        started = time.perf_counter()
        outs.append(run())
        times.append(time.perf_counter() - started)
    return outs[-1], times, outs


def _errors(t, omega, phi, grid, truth):
    """Errors at the points of ``t`` that lie on the 1 ms grid (all of them for steps >= 1 ms)."""
    idx = np.searchsorted(grid, t)
    idx = np.clip(idx, 0, grid.size - 1)
    on = np.abs(grid[idx] - t) < 1e-9
    e_w = float(np.max(np.abs(np.asarray(omega)[on] - truth["omega1"][idx[on]])))
    e_p = abs(float(np.asarray(phi)[-1] - truth["phi1"][-1]))
    return e_w, e_p


def solve_ivp_peer(model, grid, method, rtol):
    """scipy solve_ivp on the movement equation, the mode read off the state at each call (the
    switches stepped across, as a user calling solve_ivp on the equation would)."""
    eq = model.equation

    def f(t, y):
        return eq.rhs(t, y, eq.mode_of_state(y))

    sol = solve_ivp(f, (grid[0], grid[-1]), model.y0, method=method, rtol=rtol, atol=rtol, dense_output=True)
    if sol.status != 0:
        raise RuntimeError(f"solve_ivp {method} rtol={rtol:g}: {sol.message}")
    y = sol.sol(grid)
    return y[OMEGA], y[PHI]


def run_study(fmus, scenario, quick: bool = False, progress=None) -> tuple[list[Point], dict]:
    """Every method's points on ``scenario``: each FMU of ``fmus`` ((label, FmuUnderTest) pairs, the
    Python and native builds of the scenario) in Co-Simulation (steps and rtols swept) and, where
    it has Model Exchange, through fmpy's CVode (rtols swept), beside the in-process methods and
    scipy's, all timed in this one run."""
    exp = scenario.experiment
    n = int(round((exp.stop_time - exp.start_time) / exp.output_interval))
    grid = exp.start_time + exp.output_interval * np.arange(n + 1)
    truth = reference_run(scenario, grid, method="reference", rtol=1e-13)
    q = QUICK if quick else {"fmu_steps": FMU_STEPS, "fmu_rtols": FMU_RTOLS, "scheme_steps_deg": SCHEME_STEPS_DEG,
                             "scipy_methods": SCIPY_METHODS, "scipy_rtols": SCIPY_RTOLS}
    jobs = []
    for name, fmu in fmus:
        default_rtol = fmu.variables["rtol"].start if "rtol" in fmu.variables else None
        for step in q["fmu_steps"]:
            jobs.append((f"{name}, rtol {float(default_rtol):g}, step sweep", f"step {step:g} s",
                         lambda s=step, f=fmu: f.run(exp.stop_time, s, show_progress=False)))
        for rtol in q["fmu_rtols"]:
            jobs.append((f"{name}, 1 ms steps, rtol sweep", f"rtol {rtol:g}",
                         lambda r=rtol, f=fmu: f.run(exp.stop_time, 1e-3, {"rtol": r}, show_progress=False)))
        if "ModelExchange" in fmu.kind.interfaces:
            for rtol in q["fmu_rtols"]:
                jobs.append((f"{name} as Model Exchange (fmpy CVode), 1 ms output", f"rtol {rtol:g}",
                             lambda r=rtol, f=fmu: f.run(exp.stop_time, 1e-3, show_progress=False,
                                                         interface="ModelExchange", rtol=r)))
    jobs.append(("crankfmu reference (DOP853 + kink events)", "rtol 1e-12",
                 lambda: reference_run(scenario, grid, "reference")))
    for rtol in (1e-6, 1e-8, 1e-10):
        jobs.append(("crankfmu dopri5 (in process)", f"rtol {rtol:g}",
                     lambda r=rtol: reference_run(scenario, grid, "dopri5", rtol=r)))
    for label, method in (("paper eq. 17 (seed 000)", "badoiu-eq17"), ("paper eq. 3 (seed 003)", "lv-eq3")):
        for deg in q["scheme_steps_deg"]:
            jobs.append((label, f"{deg:g} deg",
                         lambda m=method, d=deg: reference_run(scenario, grid, m, angle_step=math.radians(d))))
    model = scenario.build()
    for method in q["scipy_methods"]:
        for rtol in q["scipy_rtols"]:
            jobs.append((f"solve_ivp {method}", f"rtol {rtol:g}",
                         lambda m=method, r=rtol: solve_ivp_peer(model, grid, m, r)))

    points = []
    for i, (family, setting, job) in enumerate(jobs):
        if progress:
            progress(i / len(jobs))
        try:
            out, times, outs = _timed(job)
        except Exception as exc:     # a peer that fails is a point with a note, not a lost study
            points.append(Point(family, setting, float("nan"), float("nan"), float("nan"), 0, str(exc)[:160]))
            continue
        spread = {"time_min": min(times), "time_max": max(times)}
        note = "" if len(times) >= REPEATS else f"{len(times)} runs: each over 1 s"
        if hasattr(out, "error"):             # an FMU run
            if out.error:
                points.append(Point(family, setting, float("nan"), float("nan"), statistics.median(times),
                                    len(times), out.error[:160], **spread))
                continue
            e_w, e_p = _errors(out.time, out["omega1"], out["phi1"], grid, truth)
            step = float(out.settings["step"])
            points.append(Point(family, setting, e_w, e_p, statistics.median(times), len(times), note, **spread,
                                on_grid=step <= exp.output_interval * (1 + 1e-9),
                                init_s=statistics.median(o.init_wall for o in outs),
                                per_step_s=statistics.median(o.per_step for o in outs)))
            continue
        if isinstance(out, tuple):          # solve_ivp peer
            e_w, e_p = _errors(grid, out[0], out[1], grid, truth)
        else:
            e_w, e_p = _errors(grid, out["omega1"], out["phi1"], grid, truth)
        points.append(Point(family, setting, e_w, e_p, statistics.median(times), len(times), note, **spread))
    if progress:
        progress(1.0)
    return points, {"truth": "DOP853 + kink events, rtol = atol = 1e-13", "grid_s": exp.output_interval,
                    "span_s": exp.stop_time - exp.start_time, "repeats": REPEATS,
                    "fewest_runs": min((p.repeats for p in points if p.repeats), default=0)}


def _reaches(p: Point, target: float) -> bool:
    return p.on_grid and math.isfinite(p.omega1_error) and p.omega1_error <= target


def ratio_table(points: list[Point], targets=TARGETS) -> list[dict]:
    """For each family and target error: its fastest point reaching the target, and that time
    relative to the fastest family at the same target."""
    families = list(dict.fromkeys(p.family for p in points))
    rows = []
    best = {}
    for target in targets:
        ok = [p for p in points if _reaches(p, target)]
        best[target] = min((p.time_s for p in ok), default=math.nan)
    for fam in families:
        row = {"family": fam}
        for target in targets:
            ok = [p for p in points if p.family == fam and _reaches(p, target)]
            if ok:
                p = min(ok, key=lambda p: p.time_s)
                row[target] = {"setting": p.setting, "time_s": p.time_s, "ratio": p.time_s / best[target],
                               "spread": (p.time_min, p.time_max)}
            else:
                row[target] = None
        rows.append(row)
    return rows


def method_of(family: str) -> str:
    """The method a family sweeps (its name before the first comma): one FMU's rtol and step sweeps
    are one method, its Model Exchange runs another, each scipy method its own."""
    return family.split(",")[0]


def ranked_methods(points: list[Point], target: float) -> list[Point]:
    """Each method's fastest point reaching ``target`` on the output grid, the fastest method first."""
    best_of: dict[str, Point] = {}
    for p in sorted((p for p in points if _reaches(p, target)), key=lambda p: p.time_s):
        best_of.setdefault(method_of(p.family), p)
    return list(best_of.values())


def fastest(points: list[Point], target: float) -> tuple[Point | None, Point | None]:
    """The fastest point at ``target`` on the output grid and the fastest of another method (the runner-up)."""
    ranked = ranked_methods(points, target)
    return (ranked[0] if ranked else None), (ranked[1] if len(ranked) > 1 else None)


def verdict(points: list[Point], target: float) -> str:
    """What this run says of the fastest method at ``target`` rad/s on the output grid: a method is
    ahead of another only where its slowest run beats the other's fastest (the spread of both
    measured here); methods whose runs overlap the fastest one's are named as tied with it."""
    ranked = ranked_methods(points, target)
    if not ranked:
        return f"At {target:g} rad/s: no method reached it on the output grid in this run."

    def said(p):
        return (f"{method_of(p.family)} ({p.setting}, {p.time_s * 1e3:.3g} ms, runs {p.time_min * 1e3:.3g} to "
                f"{p.time_max * 1e3:.3g} ms)")
    best, others = ranked[0], ranked[1:]
    if not others:
        return f"At {target:g} rad/s: only {said(best)} reached it."
    tied = [p for p in others if p.time_min <= best.time_max]
    ahead = [p for p in others if p.time_min > best.time_max]
    if tied:
        text = (f"At {target:g} rad/s the fastest are **{' and '.join(method_of(p.family) for p in [best, *tied])}**, "
                f"whose runs overlap: " + "; ".join(said(p) for p in [best, *tied]) + ".")
    else:
        text = f"At {target:g} rad/s the fastest is **{method_of(best.family)}**: {said(best)}."
    if ahead:
        nxt = ahead[0]
        text += (f" The next method, {said(nxt)}, takes {nxt.time_s / best.time_s:.3g} times as long, beyond the "
                 "spread of both.")
    return text
