"""Speed at a given error, one command, one run: ``python benchmarks/speed.py [--quick] [--out DIR]``.

Every figure is measured in this run on this machine, so the ratios mean something (the machine is
shared: compare ratios, not seconds). The problem is seed 000 from 0 to 2 s; the error is
max |omega1 error| (rad/s) on the 1 ms output grid against a truth run (the contour engine,
DOP853, rtol = atol = 1e-13, the motor kink located). Times are medians over repeated runs of the
integration alone, the model built beforehand (its build and tabulation are reported apart).

Rows:
  crankfmu fast          the C kernel on the tabulated model (method "fast"), rtol sweep
  crankfmu reference     DOP853 on the contour engine, rtol 1e-12
  solve_ivp RK45 / DOP853 / LSODA   scipy on the same tabulated model with a plain-Python
                         right-hand side (a few us a call) and the kink located as an event,
                         rtol = atol swept: the peer at matched tolerance
  paper eq. 17           seed 000's crank-angle scheme at 1, 0.1, 0.01 deg
  FourBar.fmu            fmi2DoStep at 1 ms beside a do-nothing FMU (benchmarks/fmu_step.py)

Then the issue-6 targets, each with its measured figure: fast vs DOP853 at 1e-8 rad/s, the FMU's
error and per-step ratio, a 10,000-design steady-cycle sweep on Dask, the seven-link table's build
time. Then issue 17's, end to end (``end_to_end.py``): simulate() from the scenario file against
scipy's DOP853 on a hand-written right-hand side at the same error, with the breakdown of where
the time goes (seed 000, the seven-link seed 001, the shaper seed 003); FourBar.fmu's whole run
through fmpy against a do-nothing FMU's, and its reset + initialisation of a changed design; the
first run on a fresh machine (the CLI and the FMU; not with --quick); and issue 38's: FourBar.fmu,
Python and native, with every variable read at every 1 ms step, through fmpy and in the ecos
master (``all_outputs.py``); and issue 39's (``well.py``): RodString.fmu's step, native against
Python, and `crankfmu well rp11l_guo` end to end against the code the issue started from; and issue
40's (``fmi3_step.py``): the FMI 3.0 FMU's step against the FMI 2.0 one's in the C hosts, and event
mode's cost on seed 001; and issues 58 and 68's (``speed_loads.py``): the four-stroke engine's FMU
step with its brake as a couple of omega1, and as a fan, against the brake on the motor line. Writes speed.md and speed.json in --out (default build/bench).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

FAST_RTOLS = (1e-6, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
PEER_RTOLS = (1e-6, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
PEERS = ("RK45", "DOP853", "LSODA")
SCHEME_DEG = (1.0, 0.1, 0.01)
TARGET_ERROR = 1e-8


def timed(run, repeats: int):
    """(result, median seconds) of ``repeats`` calls (one call when it takes over 2 s)."""
    from end_to_end import median_time

    return median_time(run, repeats, once_over=2.0)


def python_rhs_equation(model, table):
    """The movement equation on the tabulated model with a plain-Python right-hand side."""
    from crankfmu.dynamics.equation import MovementEquation

    coef = table.coefficients.tolist()               # functions x intervals x 4, Python floats
    n = table.n_intervals
    h = 2.0 * math.pi / n
    two_pi = 2.0 * math.pi
    J_flywheel = model.reduced.J_flywheel
    if table.forces.shape[2]:
        raise SystemExit("the peer right-hand side here covers seed 000's loads only")

    class PythonTabulated(MovementEquation):
        def coefficients(self, phi1, omega1, mode, t=0.0):
            w = phi1 % two_pi
            i = min(int(w / h), n - 1)
            u = w - i * h
            a, b, c, v = coef[0][i], coef[1][i], coef[2][i], coef[3][i]
            J = a[0] + u * (a[1] + u * (a[2] + u * a[3])) + J_flywheel
            half_dJ = b[0] + u * (b[1] + u * (b[2] + u * b[3]))
            Q = c[0] + u * (c[1] + u * (c[2] + u * c[3])) + (v[0] + u * (v[1] + u * (v[2] + u * v[3]))) * omega1
            return J, half_dJ, Q, self.tau_ext          # seed 000 has no ports

    return PythonTabulated(model.reduced, model.motor)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="fewer settings and repeats (a smoke run)")
    parser.add_argument("--out", default=str(ROOT / "build" / "bench"))
    parser.add_argument("--fmu", default=str(ROOT / "build" / "fmus" / "FourBar.fmu"))
    parser.add_argument("--native", default=str(ROOT / "build" / "fmus" / "native" / "FourBar.fmu"),
                        help="the native FMU of seed 000 (crankfmu fmu seed000 --native)")
    parser.add_argument("--designs", type=int, default=10000, help="designs of the steady-cycle sweep")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    repeats = 2 if args.quick else 7

    import crankfmu
    from crankfmu.integrators import SolveIvpIntegrator, make_integrator
    from crankfmu.dynamics.tabulated import table_of
    from crankfmu.integrators.fast import FastIntegrator
    from crankfmu.progress import ProgressBar
    from crankfmu.scenario import load_scenario

    scenario = load_scenario("seed000")
    grid = np.linspace(0.0, 2.0, 2001)
    truth = crankfmu.simulate(scenario, method="reference", rtol=1e-13, output_times=grid).omega1
    model = scenario.build()
    started = time.perf_counter()
    table = table_of(model.reduced)
    table_time = time.perf_counter() - started
    rows = []

    def add(family, setting, omega, seconds, n_rhs=None, note=""):
        error = float(np.max(np.abs(np.asarray(omega) - truth)))
        rows.append({"family": family, "setting": setting, "omega1_error": error, "time_s": seconds,
                     "n_rhs": n_rhs, "note": note})

    jobs = []
    fast_rtols = (1e-8, 1e-11) if args.quick else FAST_RTOLS
    for rtol in fast_rtols:
        jobs.append(("crankfmu fast (C kernel)", rtol))
    peer_rtols = (1e-8, 1e-11) if args.quick else PEER_RTOLS
    for method in PEERS:
        for rtol in peer_rtols:
            jobs.append((f"solve_ivp {method}", rtol))
    bar = ProgressBar(len(jobs) + 8, label="speed benchmark")
    peer_eq = python_rhs_equation(model, table)
    for i, (family, rtol) in enumerate(jobs):
        bar(i)
        if family.startswith("crankfmu fast"):
            integrator = FastIntegrator(rtol)
            integrator.run(model.equation, 0.0, model.y0, 2.0, output_times=grid)        # compile/warm up
            tr, seconds = timed(lambda: integrator.run(model.equation, 0.0, model.y0, 2.0, output_times=grid),
                                repeats)
            add(family, f"rtol {rtol:g}", tr.outputs["state"][1], seconds, tr.n_rhs)
        else:
            integrator = SolveIvpIntegrator(family.split()[1], rtol)

            def peer(integrator=integrator):
                peer_eq.n_rhs = 0
                tr = integrator.run(peer_eq, 0.0, model.y0, 2.0)
                return tr, tr.dense(grid)[1]
            (tr, omega), seconds = timed(peer, max(2, repeats // 2))
            add(family, f"rtol {rtol:g}", omega, seconds, tr.n_rhs)
    bar(len(jobs))
    bar(len(jobs) + 1)
    ref, seconds = timed(lambda: make_integrator("reference").run(model.equation, 0.0, model.y0, 2.0), 1)
    add("crankfmu reference (engine)", "rtol 1e-12", ref.dense(grid)[1], seconds, ref.n_rhs)
    for deg in (SCHEME_DEG[:2] if args.quick else SCHEME_DEG):
        result, seconds = timed(lambda d=deg: crankfmu.simulate(scenario, method="badoiu-eq17",
                                                                angle_step=math.radians(d), output_times=grid), 1)
        add("paper eq. 17 (crank angle)", f"{deg:g} deg", result.omega1, seconds)
    bar(len(jobs) + 2)

    # the FMU beside a do-nothing FMU
    import end_to_end

    fmu = {}
    if Path(args.fmu).exists():
        import fmu_step

        native = {"native FourBar.fmu": Path(args.native)} if Path(args.native).exists() else {}
        m = fmu_step.measure(Path(args.fmu), 1e-3, 2.0, 2 if args.quick else 5, extra=native)
        fb = statistics.median(m["per_step"]["FourBar.fmu"])
        nop = statistics.median(m["per_step"]["do-nothing FMU"])
        if native:
            import native_step

            nat = statistics.median(m["per_step"]["native FourBar.fmu"])
            in_c = native_step.c_driver_per_step(Path(args.native), 1e-3, 2.0, 3 if args.quick else 11)
            fmu["native"] = {"fmpy_us_per_step": 1e6 * nat, "fmpy_omega1_error": m["errors"]["native FourBar.fmu"],
                             "c_driver_us_per_step": in_c["us_per_step"],
                             "c_driver_omega1_error": abs(in_c["omega1"] - float(truth[-1]))}
            rows.append({"family": "native FourBar.fmu via fmpy, 1 ms steps", "setting": "rtol 1e-11 (default)",
                         "omega1_error": m["errors"]["native FourBar.fmu"], "time_s": nat * 2000, "n_rhs": None,
                         "note": f"{1e6 * nat:.2f} us/step; in the C driver {in_c['us_per_step']:.3f} us/step"})
        fmu.update({"us_per_step": 1e6 * fb, "noop_us_per_step": 1e6 * nop, "ratio": fb / nop, "omega1_error": m["error"],
               "whole_s": statistics.median(m["whole"]["FourBar.fmu"]),
               "noop_whole_s": statistics.median(m["whole"]["do-nothing FMU"]),
               "reset_init_s": end_to_end.fmu_reset_and_initialise(Path(args.fmu), 3 if args.quick else 7)})
        # speed causality: the native and the Python FourBarSpeed.fmu run the same kernel step, so the
        # same numbers; what the native one saves is the Python around it
        speed_fmus = {"FourBarSpeed.fmu": Path(args.fmu).parent / "FourBarSpeed.fmu",
                      "native FourBarSpeed.fmu": Path(args.native).parent / "FourBarSpeed.fmu"}
        if all(path.exists() for path in speed_fmus.values()):
            sm = fmu_step.measure_speed_causal(speed_fmus, 1e-3, 2.0, 2 if args.quick else 5)
            py_s, nat_s = (statistics.median(sm["per_step"][label]) for label in speed_fmus)
            difference = float(np.max(np.abs(sm["tau_drive"]["FourBarSpeed.fmu"]
                                             - sm["tau_drive"]["native FourBarSpeed.fmu"])))
            fmu["speed"] = {"python_us_per_step": 1e6 * py_s, "native_us_per_step": 1e6 * nat_s,
                            "tau_drive_difference": difference}
        rows.append({"family": "FourBar.fmu via fmpy, 1 ms steps", "setting": "rtol 1e-11 (default)",
                     "omega1_error": m["error"], "time_s": fb * 2000, "n_rhs": None,
                     "note": f"{1e6 * fb:.1f} us/step; do-nothing FMU {1e6 * nop:.1f} us/step"})
    # every output read at every step (issue 38): through fmpy and in the ecos command
    every = {}
    if Path(args.fmu).exists() and Path(args.native).exists():
        import all_outputs

        # the run, 10 s, with --quick too: under a second in ecos, while a shorter run's
        # real-time factor would mostly be the Python FMU's start (about 0.4 s), not its steps
        every = all_outputs.measure({"python": Path(args.fmu), "native": Path(args.native)}, 1e-3, 10.0,
                                    2 if args.quick else 3)
    bar(len(jobs) + 3)

    # the steady-cycle sweep on Dask, and the seven-link model
    from crankfmu.studies.sweep import SweepAxis, run_sweep

    side = int(round(math.sqrt(args.designs)))
    axes = [SweepAxis("J_flywheel", list(np.linspace(0.0, 20.0, side))), SweepAxis("B", list(np.linspace(10.0, 30.0, side)))]
    with tempfile.TemporaryDirectory() as tmp:
        started = time.perf_counter()
        sweep = run_sweep(scenario, axes, Path(tmp), resume=False, study="steady", scheduler="local")
        sweep_time = time.perf_counter() - started
    bar(len(jobs) + 4)
    started = time.perf_counter()
    seven = load_scenario("seed001").build()
    seven_table = table_of(seven.reduced)
    seven_time = time.perf_counter() - started
    bar(len(jobs) + 5)

    # end to end (issue 17): simulate() from the file, the hand-written peer, a fresh machine
    e2e_repeats = 5 if args.quick else 31         # a run is ~5 ms: a median of 31 is cheap and steady
    breakdowns = {name: end_to_end.simulate_breakdown(name, e2e_repeats) for name in ("seed000", "seed001", "seed003")}
    e2e_error = float(np.max(np.abs(np.interp(grid, breakdowns["seed000"]["time"], breakdowns["seed000"]["omega1"]) - truth)))
    peer = end_to_end.fastest_peer(dict(scenario.values), model.y0[:2], grid, truth, TARGET_ERROR, max(2, repeats // 2))
    c_limit = end_to_end.c_rk4_limit(dict(scenario.values), model.y0[:2], grid, truth, TARGET_ERROR)
    imports = end_to_end.import_time()
    first = {} if args.quick else end_to_end.first_runs(Path(args.fmu) if Path(args.fmu).exists() else None)
    bar(len(jobs) + 6)
    # the pumping well (issue 39): RodString.fmu's step, native against Python; crankfmu well end to end
    import well as well_bench

    wells = well_bench.measure(Path(args.native).parent / "RodString.fmu", Path(args.fmu).parent / "RodString.fmu",
                               args.quick)
    bar(len(jobs) + 7)
    # FMI 3.0 (issue 40): a step against FMI 2.0's in the C hosts; event mode's cost on seed 001
    import fmi3_step

    fmi3 = fmi3_step.measure(args.quick)
    bar(len(jobs) + 8)
    # a load of the speed (issues 58, 68): the brake as a couple of omega1, and as a fan, against the
    # motor line's
    import speed_loads

    loads = speed_loads.measure(3 if args.quick else 7)
    bar.close()

    # ------------------------------------------------------------------ report
    def best(prefix):
        ok = [r for r in rows if r["family"].startswith(prefix) and r["omega1_error"] <= TARGET_ERROR]
        return min(ok, key=lambda r: r["time_s"]) if ok else None

    fast_best, dop_best = best("crankfmu fast (C kernel)"), best("solve_ivp DOP853")
    ratio = fast_best["time_s"] / dop_best["time_s"] if fast_best and dop_best else math.nan
    lines = ["# Speed at a given error (seed 000, 0-2 s, max |omega1 error| on the 1 ms grid)", "",
             f"Measured in one run; times are medians of the integration alone. Tabulating seed 000: "
             f"{1e3 * table_time:.1f} ms, {table.n_intervals} intervals, checked error {table.error_bound:.1e}.", "",
             "| method | setting | max omega1 error (rad/s) | time (ms) | RHS calls | note |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['family']} | {r['setting']} | {r['omega1_error']:.2e} | {1e3 * r['time_s']:.2f} | "
                     f"{r['n_rhs'] if r['n_rhs'] is not None else ''} | {r['note']} |")
    targets = [
        ("in process, error <= 1e-8 rad/s in <= 1/15 of DOP853's time",
         (f"fast {fast_best['setting']}: {fast_best['omega1_error']:.1e} rad/s in {1e3 * fast_best['time_s']:.2f} ms; "
          f"DOP853 {dop_best['setting']}: {dop_best['omega1_error']:.1e} in {1e3 * dop_best['time_s']:.1f} ms; "
          f"ratio 1/{1 / ratio:.0f}") if fast_best and dop_best else "a method did not reach 1e-8",
         bool(ratio <= 1 / 15)),
    ]
    if fmu:
        targets.append(("FourBar.fmu at 1 ms: error <= 1e-8 rad/s and per step <= 2x a do-nothing FMU",
                        f"{fmu['omega1_error']:.1e} rad/s; {fmu['us_per_step']:.1f} vs {fmu['noop_us_per_step']:.1f} "
                        f"us/step, ratio {fmu['ratio']:.2f}",
                        fmu["omega1_error"] <= 1e-8 and fmu["ratio"] <= 2.0))
    targets.append((f"{len(sweep.rows) + len(sweep.failed)} flywheel/motor designs (steady delta each) in < 60 s",
                    f"{sweep_time:.1f} s on Dask (local, {os.cpu_count()} workers), {len(sweep.failed)} failed",
                    sweep_time < 60 and not sweep.failed))
    targets.append(("seven-link reduced model built in < 1 s",
                    f"{seven_time:.3f} s (build {seven_time - seven_table.build_time:.3f} s + tabulation "
                    f"{seven_table.build_time:.3f} s, {seven_table.n_intervals} intervals, error "
                    f"{seven_table.error_bound:.1e})", seven_time < 1.0))
    lines += ["", "## Targets (issue 6)", "", "| target | measured | met |", "|---|---|---|"]
    lines += [f"| {t} | {m} | {'yes' if ok else 'NO'} |" for t, m, ok in targets]

    # ---- issue 17: end to end
    lines += ["", "## Where the time of simulate() goes (warm process, method fast, median ms)", "",
              f"Imports in a fresh process (crankfmu, simulate, the fast path): {1e3 * imports:.0f} ms.", "",
              "| scenario | files | model | table | kernel | outputs | total |", "|---|---|---|---|---|---|---|"]
    for name, b in breakdowns.items():
        lines.append(f"| {name} | " + " | ".join(f"{1e3 * b[k]:.1f}" for k in ("files", "model", "table", "kernel", "outputs", "total"))
                     + " |")
    e2e = breakdowns["seed000"]["total"]
    targets17 = []
    if peer is not None:
        targets17.append((
            "simulate() end to end (seed 000, 0-2 s, error <= 1e-8 rad/s) <= 1/8 of scipy DOP853 on a hand-written "
            "right-hand side at the same error",
            f"{1e3 * e2e:.1f} ms at {e2e_error:.1e} rad/s; peer rtol {peer[0]:g}: {1e3 * peer[2]:.1f} ms at "
            f"{peer[1]:.1e} rad/s; simulate / peer = {e2e / peer[2]:.3f}, target <= 0.125 (the C RK4 limit: "
            + (f"{1e3 * c_limit[2]:.2f} ms at {c_limit[1]:.1e} rad/s, {c_limit[0]} step(s) per ms)" if c_limit
               else "did not reach the error)"),
            bool(e2e <= peer[2] / 8 and e2e_error <= TARGET_ERROR)))
    if fmu:
        targets17.append(("FourBar.fmu's default experiment through fmpy (instantiate to free) <= 2x a do-nothing FMU's",
                          f"{1e3 * fmu['whole_s']:.0f} ms vs {1e3 * fmu['noop_whole_s']:.0f} ms, ratio "
                          f"{fmu['whole_s'] / fmu['noop_whole_s']:.1f}", fmu["whole_s"] <= 2 * fmu["noop_whole_s"]))
        targets17.append(("FourBar.fmu reset + initialisation of a changed design <= 10 ms",
                          f"{1e3 * fmu['reset_init_s']:.1f} ms", fmu["reset_init_s"] <= 0.010))
    for key, what in (("fmu", "FourBar.fmu's first simulate_fmu on a fresh machine <= 3 s"),
                      ("cli", "`crankfmu simulate seed000 --method fast` on a fresh machine <= 3 s")):
        if key in first:
            targets17.append((what, f"{first[key]:.1f} s", first[key] <= 3.0))
        else:
            lines_note = "not measured with --quick" if args.quick else "no FMU to run"
            targets17.append((what, lines_note, None))
    if fmu.get("native") and c_limit:
        nat = fmu["native"]
        c_limit_us = 1e6 * c_limit[2] / 2000
        targets17.append(("native FourBar.fmu per 1 ms step in the C driver <= 3x the hand-written C RK4 limit "
                          "(issue 27)",
                          f"{nat['c_driver_us_per_step']:.3f} us/step (omega1 at 2 s off by "
                          f"{nat['c_driver_omega1_error']:.1e} rad/s) vs C RK4 {c_limit_us:.3f} us per 1 ms at "
                          f"{c_limit[1]:.1e} rad/s; ratio {nat['c_driver_us_per_step'] / c_limit_us:.2f}",
                          nat["c_driver_us_per_step"] <= 3 * c_limit_us))
        targets17.append(("native FourBar.fmu per 1 ms step through fmpy, against the do-nothing pythonfmu FMU "
                          "(issue 27: reported)",
                          f"{nat['fmpy_us_per_step']:.2f} vs {fmu['noop_us_per_step']:.2f} us/step, ratio "
                          f"{nat['fmpy_us_per_step'] / fmu['noop_us_per_step']:.2f}; omega1 error "
                          f"{nat['fmpy_omega1_error']:.1e} rad/s", nat["fmpy_omega1_error"] <= TARGET_ERROR))
    if fmu.get("speed"):
        sp = fmu["speed"]
        targets17.append(("native FourBarSpeed.fmu per 1 ms step through fmpy, against the Python FourBarSpeed.fmu, "
                          "omega1 set every step (issue 28: reported; the same kernel step, so the same tau_drive)",
                          f"{sp['native_us_per_step']:.2f} vs {sp['python_us_per_step']:.2f} us/step, ratio "
                          f"{sp['native_us_per_step'] / sp['python_us_per_step']:.3f}; tau_drive differs by "
                          f"{sp['tau_drive_difference']:.1e} N.m", sp["tau_drive_difference"] == 0.0))
    if every:
        py, nat = every["python"], every["native"]
        targets17.append(("FourBar.fmu (Python) in the ecos master, 10 s with every variable read at every 1 ms step: "
                          "real-time factor >= 10 (issue 38; 0.93 when each step's reactions were a Newton-Euler solve)",
                          f"{py['ecos_real_time_factor']:.1f} ({py['ecos_wall_s']:.2f} s wall); through fmpy "
                          f"{py['fmpy_us_per_step']:.1f} us/step", py["ecos_real_time_factor"] >= 10))
        targets17.append(("native FourBar.fmu in the ecos master, the same run: real-time factor >= 25 (issue 38)",
                          f"{nat['ecos_real_time_factor']:.1f} ({nat['ecos_wall_s']:.2f} s wall); through fmpy "
                          f"{nat['fmpy_us_per_step']:.1f} us/step, {py['fmpy_us_per_step'] / nat['fmpy_us_per_step']:.1f}x "
                          "faster than the Python FMU", nat["ecos_real_time_factor"] >= 25))
    lines += ["", "## Targets (issue 17)", "", "| target | measured | met |", "|---|---|---|"]
    lines += [f"| {t} | {m} | {'MET' if ok else ('NOT MET' if ok is not None else 'not measured')} |"
              for t, m, ok in targets17]
    lines += ["", "## Targets (issue 39)", "", "| target | measured | met |", "|---|---|---|"]
    lines += [f"| {t} | {m} | {'MET' if ok else ('NOT MET' if ok is not None else 'reported')} |"
              for t, m, ok in well_bench.targets(wells)]
    lines += ["", "## Targets (issue 40)", "", "| target | measured | met |", "|---|---|---|"]
    lines += [f"| {t} | {m} | {'MET' if ok else ('NOT MET' if ok is not None else 'reported')} |"
              for t, m, ok in fmi3_step.targets(fmi3)]
    lines += ["", "## Targets (issues 58 and 68: loads of the speed)", "", "| target | measured | met |", "|---|---|---|"]
    lines += [f"| {t} | {m} | {'MET' if ok else 'NOT MET'} |" for t, m, ok in speed_loads.targets(loads)]
    import friction
    frictions = friction.measure(3 if args.quick else 7)
    lines += ["", "## Targets (issue 69: joint friction)", "", "| target | measured | met |", "|---|---|---|"]
    lines += [f"| {t} | {m} | {'-' if ok is None else 'MET' if ok else 'NOT MET'} |"
              for t, m, ok in friction.targets(frictions)]
    text = "\n".join(lines) + "\n"
    print(text)
    (out / "speed.md").write_text(text)
    (out / "speed.json").write_text(json.dumps({"rows": rows, "fmu": fmu, "sweep_s": sweep_time,
                                                "seven_link_s": seven_time, "fast_over_dop853": ratio,
                                                "end_to_end_ms": {n: {k: 1e3 * v for k, v in b.items() if isinstance(v, float)}
                                                                  for n, b in breakdowns.items()},
                                                "imports_s": imports, "first_run_s": first, "c_rk4_limit": c_limit,
                                                "every_output": every, "well": wells, "fmi3": fmi3,
                                                "speed_loads_us_per_step": loads, "friction": frictions,
                                                "targets_issue_17": [{"target": t, "measured": m, "met": ok}
                                                                     for t, m, ok in targets17],
                                                "targets": [{"target": t, "measured": m, "met": ok}
                                                            for t, m, ok in targets]}, indent=2) + "\n")
    print(f"wrote {out}/speed.md and speed.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
