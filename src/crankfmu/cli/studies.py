"""The study commands: ``crankfmu simulate``, ``schemes``, ``kinematics``, ``sweep``,
``equilibrium``, ``flywheel`` and ``well``; each reads its files, runs its study and writes its
reports into --out."""

from __future__ import annotations

import math
from pathlib import Path

from ..atomic import write_text
from ..errors import CrankfmuError
from .arguments import parse_sets, with_friction


def settings_text(settings: dict) -> str:
    """A run's settings as a reader reads them: "fast: Dormand-Prince 5(4) on the tabulated model
    (C kernel), rtol 1e-11, table of 4096 intervals checked to 2.2e-12", not a Python dict."""
    parts = [f"{settings.get('method', '?')}: {settings['solver']}" if settings.get("solver") else
             str(settings.get("method", "?"))]
    if settings.get("rtol") is not None:
        parts.append(f"rtol {settings['rtol']:g}")
    if settings.get("angle_step") is not None:
        parts.append(f"angle step {settings['angle_step']:g} rad")
    if settings.get("table_intervals"):
        parts.append(f"table of {settings['table_intervals']} intervals checked to {settings.get('table_error', 0):.2g}")
    return ", ".join(parts)


def cmd_simulate(args) -> int:
    from ..output import write_run
    from ..progress import ProgressBar
    from ..scenario import load_scenario
    from ..simulation import simulate

    scenario = with_friction(load_scenario(args.scenario), args.friction).with_params(**parse_sets(args.set))
    t_end = args.t_end if args.t_end is not None else scenario.experiment.stop_time
    bar = ProgressBar(t_end, label=f"{scenario.name} {args.method}", start=scenario.experiment.start_time)
    try:
        result = simulate(scenario, t_end=t_end, method=args.method, rtol=args.rtol,
                          angle_step=None if args.angle_step_deg is None else math.radians(args.angle_step_deg),
                          progress=bar)
    finally:
        bar.close()
    summary = write_run(result, args.out)
    k = scenario.experiment.summary_cycle
    c = summary[f"cycle_{k}"]
    e = summary["energy_balance"]
    print(f"{scenario.name} ({settings_text(result.settings)}), cycle {k} "
          f"(t = {c['t_start']:.4f}..{c['t_end']:.4f} s):")
    print(f"  omega1 min  {c['omega1_min']:.6f} rad/s")
    print(f"  omega1 max  {c['omega1_max']:.6f} rad/s")
    print(f"  omega1 mean {c['omega1_mean']:.6f} rad/s (time mean, 2*pi/T)")
    print(f"  delta       {c['delta']:.6f} (max - min)/mean")
    print(f"  J_red       {summary['J_red_min']:.6f} .. {summary['J_red_max']:.6f} kg.m2")
    print(f"  energy      W_motor {e['W_motor']:.4f} J, W_load {e['W_load']:.4f} J, dE_kin {e['dE_kin']:.4f} J "
          f"over {e['over']}: residual {e['residual']:.2e}")
    if "friction" in summary:
        f = summary["friction"]
        efficiency = "" if f["efficiency"] is None else f", efficiency {f['efficiency']:.4f} (-W_load/W_motor)"
        print(f"  friction    W_friction {e['W_friction']:.4f} J over {e['over']}; cycle {k}: "
              f"{100 * (f['friction_share'] or 0.0):.2f} % of the motor's work{efficiency}, dE_kin {f['dE_kin']:.4f} J")
    print(f"  wrote {args.out}/timeseries.csv, summary.json, {', '.join(summary['figures'])}")
    return 0


def cmd_schemes(args) -> int:
    import json
    from pathlib import Path

    from ..scenario import load_scenario
    from ..simulation import simulate
    from ..plots import plot_startup
    from ..studies.schemes import format_table, scheme_study

    scenario = load_scenario(args.scenario).with_params(**parse_sets(args.set))
    steps = [float(s) for s in args.steps_deg.split(",")]
    if any(not s > 0 for s in steps):
        raise CrankfmuError(f"--steps-deg must be positive angles in deg, got {args.steps_deg!r}")
    reference = simulate(scenario)
    rows, runs = scheme_study(scenario, reference, steps_deg=steps)
    print(format_table(rows, scenario.experiment.summary_cycle))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "schemes.json", json.dumps(rows, indent=2) + "\n")
    plot_startup(reference, runs, out / "startup.png")
    print(f"wrote {out}/schemes.json, startup.png")
    return 0


def cmd_kinematics(args) -> int:
    import json
    from pathlib import Path

    from ..pictures.velocity_plan import plot_velocity_plan
    from ..plots import plot_time_series
    from ..studies.kinematics import compare_with_paper, time_series, values_at
    from ..scenario import load_scenario

    scenario = load_scenario(args.scenario).with_params(**parse_sets(args.set))
    values, detail = values_at(scenario, args.at, args.omega)
    rows = compare_with_paper(scenario, values)
    ts = time_series(scenario, args.omega)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "values.json", json.dumps(values, indent=2) + "\n")
    detail.update(paper_comparison=rows, approximation=ts.get("approx_name"),
                  approximation_max_errors=ts.get("approx_errors"))
    write_text(out / "values_detail.json", json.dumps(detail, indent=2) + "\n")
    units = detail["units"]
    print(f"{scenario.name} at phi1 = {args.at:g} deg, omega1 = {detail['omega1']:g} rad/s (exact kinematics):")
    paper = {r["name"]: r for r in rows}
    print(f"  {'quantity':8s} {'exact':>14s} {'unit':6s} {'paper':>8s} {'difference':>10s}")
    for name, v in values.items():
        r = paper.get(name)
        extra = f"{r['paper']:8.4g} {100 * r['rel_diff']:+9.2f} %" if r else ""
        print(f"  {name:8s} {v:14.8g} {units[name]:6s} {extra}")
    plots = plot_time_series(ts, out, scenario.name)
    ks = scenario.kinematics_study
    plots.append(plot_velocity_plan(detail, ks.get("relative", []), out / "velocity_plan.png",
                                    f"{scenario.name}: velocity plan at {args.at:g} deg"
                                    + (f" (the paper's {ks['figures']['velocity_plan']})"
                                       if "velocity_plan" in ks.get("figures", {}) else ""), scenario.name))
    if ts.get("approx_errors"):
        print(f"  the paper's approximation ({ts['approx_name']}) over {ts['time'][-1]:g} s, largest errors: "
              + ", ".join(f"{k} {v:.4g} {ts['units'].get(k, 'm')}" for k, v in ts["approx_errors"].items()))
    print(f"  wrote {out}/values.json, values_detail.json, " + ", ".join(p.name for p in plots))
    return 0


def cmd_sweep(args) -> int:
    import json
    from pathlib import Path

    import numpy as np

    from ..plots import plot_families, plot_steady
    from ..progress import ProgressBar
    from ..scenario import load_scenario
    from ..studies.sweep import SweepAxis, check_claims, run_sweep

    scenario = load_scenario(args.scenario).with_params(**parse_sets(args.set))
    if not args.param:
        raise CrankfmuError("give at least one --param NAME=START:STOP:COUNT")
    axes = [SweepAxis.parse(p, scenario) for p in args.param]
    out = Path(args.out)
    bar = ProgressBar(1.0, label=f"{scenario.name} sweep")
    try:
        result = run_sweep(scenario, axes, out, progress=bar, resume=not args.restart, study=args.study,
                           scheduler=args.scheduler, chunk_size=args.chunk)
    finally:
        bar.close()
    names = [a.name for a in axes]
    total = len(result.rows) + len(result.failed)
    print(f"{scenario.name}: {result.study} sweep, {total} designs: {len(result.rows)} computed"
          + (f" ({result.skipped} already in {result.path.name})" if result.skipped else "")
          + f", {len(result.failed)} failed")
    # an earlier sweep's figures in this folder (another parameter, another study) would read as this one's
    for stale in (*out.glob("*_vs_*.png"), out / "delta.png"):
        stale.unlink(missing_ok=True)
    if result.study == "kinematic":
        definition = scenario.mechanism_definition()
        units = {q.name: q.unit(definition) for q in scenario.quantities}
        plots = plot_families(result, scenario, units, out)
        claims = check_claims(scenario, result)
        write_text(out / "claims.json", json.dumps(claims, indent=2) + "\n")
        print("  " + " ".join(f"{c:>14s}" for c in result.columns))
        for row in result.rows:
            print("  " + " ".join(f"{row[c]:14.6g}" for c in result.columns))
        for c in claims:
            print(f"  claim: {c['claim']} [{c['quantity']}]: peaks increase in {c['peaks_hold_in']} of "
                  f"{c['families']} families; |{c['quantity']}| increases pointwise over "
                  f"{100 * c['share_of_cycle_min']:.0f}-{100 * c['share_of_cycle_mean']:.0f} % (min-mean) of the cycle, "
                  f"{100 * c['share_of_second_half_mean']:.0f} % of its second half")
        written = f"peaks.csv, failed.csv, claims.json and {len(plots)} PNG"
    else:
        plots = plot_steady(result, out, {n: scenario.parameters[n].unit for n in names}, scenario.name)
        if result.rows:
            deltas = np.array([r["delta"] for r in result.rows])
            best = result.rows[int(np.argmin(deltas))]
            print(f"  delta from {deltas.min():.6g} to {deltas.max():.6g}; smallest at "
                  + ", ".join(f"{n} = {best[n]:g}" for n in names)
                  + f" (omega1 mean {best['omega1_mean']:.6g} rad/s)")
        written = f"steady.csv, failed.csv and {len(plots)} PNG"
    for row in result.failed[:20]:
        print("  FAILED " + ", ".join(f"{n} = {row[n]:g}" for n in names) + f": {row['reason']}")
    if len(result.failed) > 20:
        print(f"  ... {len(result.failed) - 20} more failed designs in failed.csv")
    print(f"  wrote {out}/{written}")
    if not result.rows:
        raise CrankfmuError(f"no design of the sweep could be computed ({len(result.failed)} failed; see {out}/failed.csv)")
    return 0


def cmd_equilibrium(args) -> int:
    from ..output import write_equilibrium
    from ..studies.equilibrium import equilibrium_study, startup_torque
    from ..scenario import load_scenario

    scenario = with_friction(load_scenario(args.scenario), args.friction).with_params(**parse_sets(args.set))
    results = equilibrium_study(scenario, args.omega, args.angles)
    startup = startup_torque(scenario.build()) if results[0].with_friction is not None else None
    summary = write_equilibrium(scenario, results, args.out, startup)
    print(f"{scenario.name}: equilibrium moment at constant crank speed ({results[0].moment.phi1.size} angles)")
    print(f"  {'omega1':>6s} {'Me_min':>9s} {'Me_max':>9s} {'Me_mean':>9s} {'min stat':>9s} {'max stat':>9s} "
          f"{'inertia':>8s}  [N.m; inertia ratio = max|Me - Me_static| / max|Me|]")
    for r in results:
        s = summary[f"{r.omega1:g}"]
        print(f"  {r.omega1:6g} {s['Me_min']:9.3f} {s['Me_max']:9.3f} {s['Me_mean']:9.4f} {s['Me_min_static']:9.3f} "
              f"{s['Me_max_static']:9.3f} {s['inertia_ratio']:8.4f}")
    if results[0].with_friction is not None:
        print("  with the joints' friction (Newton-Euler) [N.m]:")
        print(f"  {'omega1':>6s} {'Me_min':>9s} {'Me_max':>9s} {'Me_mean':>9s} {'efficiency':>10s}")
        for r in results:
            s = summary[f"{r.omega1:g}"]
            eff = "" if s["efficiency"] is None else f"{s['efficiency']:10.4f}"
            print(f"  {r.omega1:6g} {s['Me_min_with_friction']:9.3f} {s['Me_max_with_friction']:9.3f} "
                  f"{s['Me_mean_with_friction']:9.4f} {eff}")
        up = summary["startup"]
        print(f"  start from rest: {up['startup_torque']:.3f} N.m at {up['at_deg']:.1f} deg with friction, "
              f"{up['startup_torque_without_friction']:.3f} N.m at {up['without_friction_at_deg']:.1f} deg without")
    tech, angle = results[0].tech_work, results[0].cycle_angle
    per = "turn" if scenario.cycle_turns == 1 else f"machine cycle ({scenario.cycle_turns} turns)"
    print(f"  technological work per {per} {tech:.4f} J: over its {math.degrees(angle):.0f} deg {-tech / angle:.4f} N.m "
          "(= Me_mean)")
    peaks = summary[f"{results[0].omega1:g}"]["joint_reaction_peaks"]
    print(f"  joint reaction peaks at {results[0].omega1:g} rad/s: "
          + ", ".join(f"{j} {v['max_force_N']:.0f} N" for j, v in peaks.items()))
    print(f"  wrote {args.out}/summary.json, {', '.join(summary['files'])}")
    return 0


def cmd_flywheel(args) -> int:
    from ..output import write_flywheel
    from ..studies.flywheel import STUDY_STAGES, flywheel_study
    from ..progress import ProgressBar
    from ..scenario import load_scenario

    scenario = load_scenario(args.scenario).with_params(**parse_sets(args.set))
    steps = None if args.steps_deg is None else [float(s) for s in args.steps_deg.split(",")]
    if steps is not None and any(not s > 0 for s in steps):
        raise CrankfmuError(f"--steps-deg must be positive angles in deg, got {args.steps_deg!r}")
    bar = ProgressBar(STUDY_STAGES, label=f"{scenario.name} flywheel study")
    try:
        study = flywheel_study(scenario, args.delta, steps, progress=bar)
        plots = write_flywheel(study, args.out)
        bar(STUDY_STAGES)
    finally:
        bar.close()
    d, st = study.design, study.stability
    print(f"{scenario.name}: flywheel for delta = {d.delta_target:g}")
    print(f"  J_e            {d.J_e_min:.6g} .. {d.J_e_max:.6g} kg.m2, the mechanism's own (min at "
          f"{d.J_e_min_at_deg:.1f} deg, max at {d.J_e_max_at_deg:.1f} deg)")
    start = "no flywheel" if d.baseline_J_flywheel == 0.0 else f"the file's flywheel {d.baseline_J_flywheel:g} kg.m2"
    print(f"  dW_max         {d.dW_max:.3f} J, omega_m {d.omega_m:.6f} rad/s (steady, {start}: "
          f"delta {d.without.delta:.5f})")
    if d.baseline_reason:
        print(f"                 ({d.baseline_reason})")
    print(f"  J_F eq. 17     {d.J_F_eq17:.3f} kg.m2 (gives delta {d.delta_with_J_F_eq17:.5f} when simulated)")
    if abs(d.J_F_eq17 - d.J_F_simulated) > 0.1 * d.J_F_simulated:
        print(f"                 {100 * (d.J_F_eq17 / d.J_F_simulated - 1):+.0f} % from the simulated: eq. 17 takes J "
              "constant and the torques independent of the speed; here " + "; ".join(d.eq17_departures or ["no more"]))
    print(f"  J_F eq. 16     {d.J_F_eq16:.3f} kg.m2")
    print(f"  J_F simulated  {d.J_F_simulated:.3f} kg.m2: delta {d.delta_achieved:.6f}")
    print(f"  peaks with it  omega1 -{100 * d.omega_peak_reduction:.2f} %, |epsilon1| "
          f"-{100 * d.epsilon_peak_reduction:.2f} %")
    estimate = (f"linear estimate {st.linear_estimate_deg:.3f} deg" if math.isfinite(st.linear_estimate_deg)
                else "no linear estimate: the motor line has no slope, B = 0")
    if st.skipped:
        print(f"  eq. 3: not run: {st.skipped}")
    elif st.limit:
        print(f"  eq. 3 stable up to {st.limit['largest_stable_deg']:.3f} deg, unstable from "
              f"{st.limit['smallest_unstable_deg']:.3f} deg ({estimate})")
    else:
        print(f"  eq. 3: no stability limit within the steps tried ({estimate})")
    print(f"  wrote {args.out}/flywheel.json, " + ", ".join(p.name for p in plots))
    return 0


def cmd_well(args) -> int:
    import json

    from ..atomic import replacing
    from ..pictures.together import both
    from ..pictures.well import animation_gif, cards_png, torque_png
    from ..progress import ProgressBar
    from ..studies import well as study

    well, cw, strokes = study.run(args.well, max_strokes=args.max_strokes, in_c=not args.reference_loop)
    stroke = strokes[-1]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    result = study.summary(well, cw, stroke)
    result["strokes_run"] = len(strokes)
    result["card_change_last_stroke"] = study.card_change(strokes[-2], stroke) if len(strokes) > 1 else None
    with replacing(out / "summary.json") as partial:
        partial.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    parts = study.torque_parts(cw, stroke)
    title = f"{well.title}\n{60 / stroke.period:.2f} strokes/min, stroke {len(strokes)} (steady)"
    api = study.api_rod_torque(cw, stroke, parts)

    def figures():
        cards_png(stroke, cw.string.design, out, title, well.name)
        torque_png(stroke, parts, api, out, title, well.name)

    def animation():
        bar = ProgressBar(args.frames, "animation")
        animation_gif(cw, stroke, out, frames=args.frames, progress=bar, scenario=well.name)
        bar.close()

    if args.no_animation:
        figures()
    else:
        both(figures, animation)                 # on two cores at once
    f = result["field_units"]
    print(f"{well.name}: steady after {len(strokes)} strokes at {result['strokes_per_minute']:.3f} strokes/min "
          f"(the last two cards differ by {result['card_change_last_stroke']:.1e} of the peak load)")
    print(f"  PPRL {result['PPRL']:.0f} N ({f['PPRL_lb']:.0f} lb)   MPRL {result['MPRL']:.0f} N ({f['MPRL_lb']:.0f} lb)   "
          f"peak torque {result['peak_torque']:.0f} N.m ({f['peak_torque_in_lb']:.0f} in-lb)")
    print(f"  PRHP {result['PRHP']:.0f} W = hydraulic {result['hydraulic_power']:.0f} + damping "
          f"{result['damping_power']:.0f} + friction {result['friction_power']:.0f} + plunger stops "
          f"{result['plunger_stop_power']:.2f} W; motor {result['motor_power']:.0f} W, cyclic load factor "
          f"{result['cyclic_load_factor']:.2f}")
    print(f"  surface stroke {result['surface_stroke']:.4f} m, plunger stroke {result['plunger_stroke']:.4f} m "
          f"({f['plunger_stroke_in']:.2f} in)")
    if "reference" in result:
        print(f"  {'against the published design':34s} {'published':>10s} {'crankfmu':>10s} {'difference':>10s}  verdict")
        for key, row in result["reference"].items():
            bar = f" within {100 * row['tolerance']:g} %" if "tolerance" in row else ""
            why = f" ({row['why']})" if row.get("why") else ""
            print(f"  {key:34s} {row['published']:10.2f} {row['crankfmu']:10.2f} {100 * row['relative']:+9.1f} %  "
                  f"{row['verdict']}{bar}{why}")
    print(f"  wrote {out}/summary.json, cards.png, torque.png" + ("" if args.no_animation else ", well.gif"))
    return 0
