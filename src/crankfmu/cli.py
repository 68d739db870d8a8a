"""Command line: ``crankfmu simulate SCENARIO --out DIR [--method M] [--set NAME=VALUE ...]``,
``crankfmu schemes SCENARIO --out DIR``, ``crankfmu draw SCENARIO --at DEG --out FILE.png``,
``crankfmu animate SCENARIO --out FILE.gif [--result DIR]``,
``crankfmu validate [--fmu PATH ...] [--out DIR] [--quick]`` and the studies (``crankfmu --help``)."""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from .errors import CrankfmuError
from .integrators import METHODS
from .atomic import write_text


def _parse_sets(items: list[str]) -> dict[str, float]:
    values = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise CrankfmuError(f"--set expects NAME=VALUE, got {item!r}")
        try:
            values[name.strip()] = float(value)
        except ValueError:
            raise CrankfmuError(f"--set {name.strip()}: {value!r} is not a number") from None
    return values


def cmd_simulate(args) -> int:
    from .output import write_run
    from .progress import ProgressBar
    from .scenario import load_scenario
    from .simulation import simulate

    scenario = load_scenario(args.scenario).with_params(**_parse_sets(args.set))
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
    print(f"{scenario.name} ({summary['method']}, {result.settings}), cycle {k} "
          f"(t = {c['t_start']:.4f}..{c['t_end']:.4f} s):")
    print(f"  omega1 min  {c['omega1_min']:.6f} rad/s")
    print(f"  omega1 max  {c['omega1_max']:.6f} rad/s")
    print(f"  omega1 mean {c['omega1_mean']:.6f} rad/s (time mean, 2*pi/T)")
    print(f"  delta       {c['delta']:.6f} (max - min)/mean")
    print(f"  J_red       {summary['J_red_min']:.6f} .. {summary['J_red_max']:.6f} kg.m2")
    print(f"  energy      W_motor {e['W_motor']:.4f} J, W_load {e['W_load']:.4f} J, dE_kin {e['dE_kin']:.4f} J "
          f"over {e['over']}: residual {e['residual']:.2e}")
    print(f"  wrote {args.out}/timeseries.csv, summary.json, omega1_cycles.png, omega1_cycle{k}.png")
    return 0


def cmd_schemes(args) -> int:
    import json
    from pathlib import Path

    from .scenario import load_scenario
    from .simulation import simulate
    from .plots import plot_startup
    from .studies.schemes import format_table, scheme_study

    scenario = load_scenario(args.scenario).with_params(**_parse_sets(args.set))
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

    from .pictures.velocity_plan import plot_velocity_plan
    from .plots import plot_time_series
    from .studies.kinematics import compare_with_paper, time_series, values_at
    from .scenario import load_scenario

    scenario = load_scenario(args.scenario).with_params(**_parse_sets(args.set))
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

    from .plots import plot_families, plot_steady
    from .progress import ProgressBar
    from .scenario import load_scenario
    from .studies.sweep import SweepAxis, check_claims, run_sweep

    scenario = load_scenario(args.scenario).with_params(**_parse_sets(args.set))
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
    from .output import write_equilibrium
    from .studies.equilibrium import equilibrium_study
    from .scenario import load_scenario

    scenario = load_scenario(args.scenario).with_params(**_parse_sets(args.set))
    results = equilibrium_study(scenario, args.omega, args.angles)
    summary = write_equilibrium(scenario, results, args.out)
    print(f"{scenario.name}: equilibrium moment at constant crank speed ({results[0].moment.phi1.size} angles)")
    print(f"  {'omega1':>6s} {'Me_min':>9s} {'Me_max':>9s} {'Me_mean':>9s} {'min stat':>9s} {'max stat':>9s} "
          f"{'inertia':>8s}  [N.m; inertia ratio = max|Me - Me_static| / max|Me|]")
    for r in results:
        s = summary[f"{r.omega1:g}"]
        print(f"  {r.omega1:6g} {s['Me_min']:9.3f} {s['Me_max']:9.3f} {s['Me_mean']:9.4f} {s['Me_min_static']:9.3f} "
              f"{s['Me_max_static']:9.3f} {s['inertia_ratio']:8.4f}")
    tech = results[0].tech_work
    print(f"  technological work per turn {tech:.4f} J: over 2 pi {-tech / (2 * math.pi):.4f} N.m (= Me_mean)")
    peaks = summary[f"{results[0].omega1:g}"]["joint_reaction_peaks"]
    print(f"  joint reaction peaks at {results[0].omega1:g} rad/s: "
          + ", ".join(f"{j} {v['max_force_N']:.0f} N" for j, v in peaks.items()))
    print(f"  wrote {args.out}/summary.json, equilibrium_<omega>.csv, Me_omega<omega>.png, reactions_*.png")
    return 0


def cmd_flywheel(args) -> int:
    from .output import write_flywheel
    from .studies.flywheel import STUDY_STAGES, flywheel_study
    from .progress import ProgressBar
    from .scenario import load_scenario

    scenario = load_scenario(args.scenario).with_params(**_parse_sets(args.set))
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
    print(f"  J_e            {d.J_e_min:.4f} .. {d.J_e_max:.4f} kg.m2 (min at {d.J_e_min_at_deg:.1f} deg, "
          f"max at {d.J_e_max_at_deg:.1f} deg)")
    print(f"  dW_max         {d.dW_max:.3f} J, omega_m {d.omega_m:.6f} rad/s (steady, no flywheel: "
          f"delta {d.delta_without_flywheel:.5f})")
    print(f"  J_F eq. 17     {d.J_F_eq17:.3f} kg.m2 (gives delta {d.delta_with_J_F_eq17:.5f} when simulated)")
    print(f"  J_F eq. 16     {d.J_F_eq16:.3f} kg.m2")
    print(f"  J_F simulated  {d.J_F_simulated:.3f} kg.m2: delta {d.delta_achieved:.6f}")
    print(f"  peaks with it  omega1 -{100 * d.omega_peak_reduction:.2f} %, |epsilon1| "
          f"-{100 * d.epsilon_peak_reduction:.2f} %")
    if st.limit:
        print(f"  eq. 3 stable up to {st.limit['largest_stable_deg']:.3f} deg, unstable from "
              f"{st.limit['smallest_unstable_deg']:.3f} deg (linear estimate {st.linear_estimate_deg:.3f} deg)")
    else:
        print(f"  eq. 3: no stability limit within the steps tried (estimate {st.linear_estimate_deg:.3f} deg)")
    print(f"  wrote {args.out}/flywheel.json, " + ", ".join(p.name for p in plots))
    return 0


def _points(text: str | None):
    return None if text is None else [p.strip() for p in text.split(",") if p.strip()]


def cmd_draw(args) -> int:
    from .pictures.draw import OVERLAYS, draw_figure, drawing_section, save
    from .scenario import load_scenario

    scenario = load_scenario(args.scenario).with_params(**_parse_sets(args.set))
    section = drawing_section(scenario)
    at = args.at if args.at is not None else float(section.get("at_deg", 0.0))
    chosen = [o for o in OVERLAYS if getattr(args, o)]
    show = chosen or ([] if args.plain else list(section.get("show", [])))
    trace = _points(args.trace) if args.trace is not None else section.get("trace", [])
    out = Path(args.out)
    if out.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise CrankfmuError(f"--out {out}: a drawing is written as .png, .svg or .pdf")
    fig = draw_figure(scenario, at, show, args.omega, trace, section.get("caption", ""))
    cite = section.get("caption", "")
    save(fig, out, scenario.name, (f"{cite}. " if cite else "") + f"{scenario.title}, drawn from its data files at phi1 = {at:g} deg"
         + (f" with {', '.join(show)}" if show else "") + (f"; traced: {', '.join(trace)}" if trace else "") + ".")
    print(f"{scenario.name}: the mechanism at phi1 = {at:g} deg" + (f" with {', '.join(show)}" if show else "")
          + f": wrote {out}")
    return 0


def cmd_animate(args) -> int:
    from .pictures.animate import animate
    from .progress import ProgressBar
    from .scenario import load_scenario

    scenario = load_scenario(args.scenario).with_params(**_parse_sets(args.set))
    bar = ProgressBar(args.frames, label=f"{scenario.name} animation")
    try:
        path = animate(scenario, args.out, args.result, _points(args.trace), args.frames, args.fps, args.omega,
                       progress=bar)
    finally:
        bar.close()
    print(f"{scenario.name}: {args.frames} frames at {args.fps} per s: wrote {path}")
    return 0


def cmd_check(args) -> int:
    from .check import check_scenario

    report = check_scenario(args.scenario)
    print(report.text())
    print({0: "check passed", 1: "check FAILED", 2: "the files cannot be read"}[report.status])
    return report.status


def cmd_fmu(args) -> int:
    if args.drive + args.cushion + args.well > 1:
        raise CrankfmuError("--drive, --cushion and --well: give one (what kind of file SCENARIO is)")
    kind = "drive" if args.drive else "cushion" if args.cushion else "well" if args.well else "scenario"
    values = _parse_sets(args.set)
    if values and not (args.native and kind == "scenario"):
        raise CrankfmuError("--set: a native mechanism FMU's values only (--native with a scenario); every parameter "
                            f"of a{' native' if args.native else ' Python'} {kind} FMU is set by its host")
    if args.fmi_version == "3" and not args.native:
        raise CrankfmuError("--fmi-version 3: native FMUs only (--native); the Python FMUs (pythonfmu) are FMI 2.0")
    from .fmi.stages import watching_stages
    from .progress import StageLine

    line = StageLine()
    try:
        with watching_stages(line):
            path = _build_fmu(args, kind, values)
    finally:
        line.close()
    print(f"built {path}")
    return 0


def _build_fmu(args, kind: str, values: dict) -> Path:
    """The FMU cmd_fmu asked for: native or Python, a mechanism's or a component's."""
    if args.native and kind != "scenario":
        from .fmi.native_components import build_native_component

        path = build_native_component(kind, args.source, Path(args.out), args.name, args.causality,
                                      fmi_version=f"{args.fmi_version}.0")
    elif args.native:
        from .fmi.native_build import build_native

        path = build_native(args.source, Path(args.out), args.name, causality=args.causality, values=values,
                            fmi_version=f"{args.fmi_version}.0")
    else:
        from .fmi.build import build

        path = build(kind, args.source, Path(args.out), args.name, args.causality)
    return path


def _parser_class():
    """Subcommands' parsers with the same help formatter (defaults shown)."""
    class Parser(argparse.ArgumentParser):
        def __init__(self, *args, **kwargs):
            kwargs.setdefault("formatter_class", _Help)
            super().__init__(*args, **kwargs)
    return Parser


def _scenario_command(sub, name: str, func, help: str):
    """A subcommand on one scenario: SCENARIO, --out DIR and --set NAME=VALUE (repeatable)."""
    p = sub.add_parser(name, help=help, description=help[0].upper() + help[1:] + ".")
    p.add_argument("scenario", help="packaged scenario name (e.g. seed000) or path to a .toml file")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a scenario parameter (SI units), repeatable")
    p.set_defaults(func=func)
    return p


DESCRIPTION = """Planar crank mechanisms with their motor, flywheel and loads, from first principles:
simulate them, study them as the papers do, and build FMI 2.0 FMUs of them (Python or native)
that the validation harness proves against an in-process reference. Each command takes a packaged
scenario name (seed000 ... seed004, pumpjack) or the path of your own scenario file;
crankfmu COMMAND --help tells more."""


class _Help(argparse.RawDescriptionHelpFormatter):
    """Every option's default in its help (unless the help says it already, or there is none to
    say: a flag, a required option, an empty list); descriptions kept as written."""

    def _get_help_string(self, action):
        text = action.help or ""
        if ("default" in text or action.required or action.default in (None, argparse.SUPPRESS, [])
                or isinstance(action.default, bool) or not action.option_strings):
            return text
        return text + " (default: %(default)s)"


def build_parser() -> argparse.ArgumentParser:
    from importlib.metadata import PackageNotFoundError, version

    parser = argparse.ArgumentParser(prog="crankfmu", description=DESCRIPTION, formatter_class=_Help)
    try:
        parser.add_argument("--version", action="version", version=f"crankfmu {version('crankfmu')}")
    except PackageNotFoundError:            # run from a source tree that was never installed
        parser.add_argument("--version", action="version", version="crankfmu (not installed)")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_parser_class())
    p = sub.add_parser("simulate", help="run a scenario and write timeseries.csv, summary.json and plots")
    p.add_argument("scenario", help="packaged scenario name (e.g. seed000) or path to a .toml file")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--method", default="reference", choices=METHODS,
                   help="reference: DOP853 at rtol 1e-12 on the contour engine, every switch located; fast: the C "
                        "kernel on the tabulated model (what the FMUs run); radau, dopri5: scipy on the engine; "
                        "badoiu-eq17, lv-eq3: the papers' crank-angle schemes")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a scenario parameter (SI units), repeatable")
    p.add_argument("--t-end", type=float, default=None, help="end time in s (default: the scenario's)")
    p.add_argument("--rtol", type=float, default=None,
                   help="relative (and absolute) tolerance of the time-domain methods (default: each method's "
                        "own: reference 1e-12, fast, radau and dopri5 1e-11)")
    p.add_argument("--angle-step-deg", type=float, default=None,
                   help="angle step of the crank-angle schemes in deg (default 0.1)")
    p.set_defaults(func=cmd_simulate)

    p = _scenario_command(sub, "schemes", cmd_schemes,
                          "the papers' crank-angle schemes against the reference: "
                          "convergence order and start-up")
    p.add_argument("--steps-deg", default="1,0.1,0.01", help="comma-separated angle steps in deg")
    p = _scenario_command(sub, "kinematics", cmd_kinematics,
                          "exact velocities, accelerations and instant centre at one crank "
                          "angle, time series beside the paper's approximation, velocity plan")
    p.add_argument("--at", type=float, required=True, help="crank angle in deg")
    p.add_argument("--omega", type=float, default=None, help="constant crank speed in rad/s (default: the paper's)")

    p = _scenario_command(sub, "sweep", cmd_sweep,
                          "parameter sweep on Dask: kinematic peaks (peaks.csv, the families' "
                          "plots, the paper's claims) or steady cycles (steady.csv)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=START:STOP:COUNT",
                   help="a swept parameter (repeatable; the grid is every combination)")
    p.add_argument("--restart", action="store_true", help="recompute every design (default: resume the results file)")
    p.add_argument("--study", choices=("kinematic", "steady"), default=None,
                   help="kinematic: peaks over a turn at constant speed (default with a [kinematics] section); "
                        "steady: each design's steady cycle and speed fluctuation (default otherwise)")
    p.add_argument("--scheduler", default="local", metavar="ADDRESS",
                   help="Dask scheduler: 'local' (default: a local cluster, one worker process per core), "
                        "an address such as tcp://host:8786 (an existing cluster), or 'serial' (this process)")
    p.add_argument("--chunk", type=int, default=None, help="designs per Dask task (default 4 kinematic, 500 steady)")

    p = _scenario_command(sub, "equilibrium", cmd_equilibrium,
                          "equilibrium moment over a cycle at constant crank speeds, with "
                          "and without inertia, and the joint reactions (seed 001 Figs. 2-5)")
    p.add_argument("--omega", default=None, help="comma-separated crank speeds in rad/s (default: the "
                                                 "scenario's [equilibrium] omega1)")
    p.add_argument("--angles", type=int, default=None, help="crank angles per cycle (default 360)")

    p = _scenario_command(sub, "flywheel", cmd_flywheel,
                          "flywheel for a target speed fluctuation: eqs. 16-17 and by simulation "
                          "of the steady cycle; J_e, the movement from the start, eq. 3 stability")
    p.add_argument("--delta", type=float, required=True, help="target coefficient of speed fluctuation, in (0, 1)")
    p.add_argument("--steps-deg", default=None, help="comma-separated eq. 3 angle steps in deg (default: the "
                                                     "scenario's [flywheel] eq3_steps_deg)")

    p = sub.add_parser("draw", help="the mechanism at one crank angle (PNG/SVG): links, joints, ground, mass "
                                     "centres; optionally velocities, instant centres, joint reactions")
    p.add_argument("scenario", help="packaged scenario name or path to a .toml file")
    p.add_argument("--at", type=float, default=None, help="crank angle in deg (default: the scenario's [drawing] at_deg, else 0)")
    p.add_argument("--out", required=True, help="FILE.png, .svg or .pdf")
    p.add_argument("--velocities", action="store_true", help="velocity vectors of the points (at --omega)")
    p.add_argument("--instant-centres", dest="instant_centres", action="store_true",
                   help="the instant centres of the turning links")
    p.add_argument("--reactions", action="store_true", help="the joint reactions of crankfmu equilibrium "
                                                             "at this angle (constant crank speed --omega)")
    p.add_argument("--plain", action="store_true", help="no overlays, even those of the scenario's [drawing] show")
    p.add_argument("--omega", type=float, default=None, help="crank speed in rad/s for velocities and reactions "
                   "(default: the scenario's [drawing], [kinematics] or [equilibrium] speed, else omega1_start)")
    p.add_argument("--trace", default=None, metavar="P,Q", help="points whose path over a turn is drawn")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.set_defaults(func=cmd_draw)

    p = sub.add_parser("animate", help="the mechanism moving (GIF, or MP4 with ffmpeg): a crank turn at constant "
                                        "speed or a simulated run, traced points, omega1 with a cursor")
    p.add_argument("scenario", help="packaged scenario name or path to a .toml file")
    p.add_argument("--out", required=True, help="FILE.gif or FILE.mp4")
    p.add_argument("--result", default=None, metavar="DIR", help="a run of crankfmu simulate (DIR/timeseries.csv) "
                                                                   "to animate instead of a constant-speed turn")
    p.add_argument("--trace", default=None, metavar="P,Q", help="points whose paths are traced (default: the "
                                                                  "scenario's [drawing] trace)")
    p.add_argument("--frames", type=int, default=120, help="frames, spread evenly over the motion (default 120)")
    p.add_argument("--fps", type=int, default=20, help="frames per second (default 20)")
    p.add_argument("--omega", type=float, default=None, help="constant crank speed in rad/s without --result")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    p.set_defaults(func=cmd_animate)

    p = sub.add_parser("check", help="check a scenario and its mechanism file before building anything: names, "
                                      "degree of freedom, Grashof, assembly, dead points, masses, J_red (exit 0/1/2)")
    p.add_argument("scenario", help="packaged scenario name or path to a .toml scenario file")
    p.set_defaults(func=cmd_check)

    p = sub.add_parser("fmu", help="build the FMU (FMI 2.0 co-simulation) of a scenario: packaged, or your own "
                                    "scenario file with its mechanism file beside it")
    p.add_argument("source", metavar="SCENARIO", help="packaged scenario name (seed000) or path to a .toml scenario "
                                                      "file (with --drive: a drive file)")
    p.add_argument("--out", required=True, help="folder for NAME.fmu and its cross-check files NAME_ref.csv/.opt")
    p.add_argument("--name", default=None, help="the FMU's model identifier (default: the file's fmu key)")
    p.add_argument("--drive", action="store_true", help="SCENARIO is a drive file (Drive.fmu: drives/dc_pi.toml)")
    p.add_argument("--well", action="store_true",
                   help="SCENARIO is a well file (RodString.fmu: wells/rp11l_guo.toml)")
    p.add_argument("--cushion", action="store_true",
                   help="SCENARIO is a cushion file (DieCushion.fmu: elements/die_cushion.toml)")
    p.add_argument("--native", action="store_true",
                   help="a native FMU (C, linux64 and win64 binaries, no Python needed on the host); a mechanism's "
                        "geometry, masses and loads are fixed at build time, a component's parameters are all settable")
    p.add_argument("--fmi-version", choices=("2", "3"), default="2",
                   help="with --native: FMI 2.0, or FMI 3.0 (binaries for x86_64 Linux and Windows and aarch64 Linux; "
                        "a mechanism's with event mode and early return, terminals and icon)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="with --native and a scenario: a parameter's value the FMU is built for (SI units, "
                        "repeatable); its geometry, masses, loads and gravity are fixed in a native FMU's tables")
    p.add_argument("--causality", choices=("torque", "speed"), default=None,
                   help="what the crank takes: a torque (tau_ext, the default) or the speed omega1 (the FMU then "
                        "outputs tau_drive, the torque the drive must apply); default: the file's [crank] causality")
    p.set_defaults(func=cmd_fmu)


    # validate and hosts parse their own options (crankfmu validate --help): building this parser
    # then imports neither harness, whose cases and references take 0.4 s to import
    p = sub.add_parser("validate", add_help=False, help="every FMU against the in-process reference and the "
                                                        "papers: PASS/FAIL lines and DIR/report.md")
    p.set_defaults(delegate="crankfmu.validation.harness")

    p = sub.add_parser("ssp", help="FourBarDrive.ssp (FourBar.fmu driven by Drive.fmu: DC motor, PI speed control) "
                                    "and FourBarDriveSpeed.ssp (the same in speed causality), for third-party masters")
    p.add_argument("--fmus", default=None, help="folder with the FMUs (make fmu; default build/fmus, or "
                                                "build/fmus/native with --native)")
    p.add_argument("--out", required=True)
    p.add_argument("--native", action="store_true",
                   help="native FMUs only (no Python on the host): each must be built for the values the SSP sets")
    p.add_argument("--system", action="append", choices=("FourBarDrive", "FourBarDriveSpeed", "PressCushion", "PumpingWell", "well"),
                   help="which SSP (default: FourBarDrive and FourBarDriveSpeed; PressCushion needs TogglePress.fmu, "
                        "built from tests/data/user/togglepress_scenario.toml, and DieCushion.fmu; PumpingWell, or well: PumpJack.fmu "
                        "and RodString.fmu)")
    p.set_defaults(func=cmd_ssp)

    p = sub.add_parser("well", help="a beam pumping well (wells/*.toml: rod string, pump, surface unit) run to "
                                     "steady state: cards.png, torque.png, summary.json, well.gif")
    p.add_argument("well", help="a packaged well (rp11l_guo) or a .toml well file")
    p.add_argument("--out", required=True)
    p.add_argument("--max-strokes", type=int, default=40, help="give up on steady state after this many strokes")
    p.add_argument("--frames", type=int, default=60, help="frames of the animation")
    p.add_argument("--no-animation", action="store_true")
    p.add_argument("--reference-loop", action="store_true",
                   help="step the unit and the string in Python (crankfmu.well.CoupledWell.step), the reference the C "
                        "loop is tested against: the same numbers, about five times slower")
    p.set_defaults(func=cmd_well)

    p = sub.add_parser("page", help="the results page: FOLDER/index.html shows every figure and animation under "
                                     "FOLDER by data file, with captions, the paper's figures they reproduce, the "
                                     "published numbers beside ours and the validation report")
    p.add_argument("folder", help="a folder of results (make demo's build/demo)")
    p.add_argument("--validation", default=None, metavar="DIR",
                   help="a crankfmu validate --out folder (its checks.json and report.html) to show with them")
    p.add_argument("--out", default=None, help="the page's file (default: FOLDER/index.html)")
    p.set_defaults(func=cmd_page)

    p = sub.add_parser("hosts", add_help=False, help="the drop-in check: third-party masters (fmpy, ecos, "
                                                     "ecospy, libcosim) on FourBar.fmu and FourBarDrive.ssp; "
                                                     "PASS/FAIL lines")
    p.set_defaults(delegate="crankfmu.validation.hosts")
    return parser


def cmd_page(args) -> int:
    from .pages.results import write_page

    out = write_page(args.folder, args.validation, args.out)
    print(f"wrote {out}: open it in a browser")
    return 0


def cmd_well(args) -> int:
    import json

    from .atomic import replacing
    from .pictures.together import both
    from .pictures.well import animation_gif, cards_png, torque_png
    from .progress import ProgressBar
    from .studies import well as study

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
        print(f"  {'against the published design':34s} {'published':>10s} {'crankfmu':>10s} {'difference':>10s}")
        for key, row in result["reference"].items():
            print(f"  {key:34s} {row['published']:10.2f} {row['crankfmu']:10.2f} {100 * row['relative']:+9.1f} %")
    print(f"  wrote {out}/summary.json, cards.png, torque.png" + ("" if args.no_animation else ", well.gif"))
    return 0


def cmd_ssp(args) -> int:
    from .fmi.ssp import write_ssp

    fmus = Path(args.fmus or ("build/fmus/native" if args.native else "build/fmus"))
    for system in args.system or ("FourBarDrive", "FourBarDriveSpeed"):
        system = "PumpingWell" if system == "well" else system
        path = write_ssp(fmus, Path(args.out), system=system, native=args.native)
        print(f"wrote {path}")
    return 0


#: the commands whose --out is a file (its folder must be writable), not a folder
_OUT_IS_FILE = ("draw", "animate", "page")


def check_output(path, is_file: bool = False) -> Path:
    """CrankfmuError, before anything is computed, when ``path`` (a folder, or a file's folder)
    cannot be created or written: an existing file where a folder must be, or no write permission
    on the nearest existing folder. Nothing is created."""
    path = Path(path)
    folder = path.parent if is_file else path
    if is_file and path.is_dir():
        raise CrankfmuError(f"--out {path}: is a folder; give a file name ({path / 'out.png'}, say)")
    probe = folder
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise CrankfmuError(f"--out {path}: {probe} is a file, not a folder: it cannot hold the output")
    if probe.exists() and not os.access(probe, os.W_OK | os.X_OK):
        raise CrankfmuError(f"--out {path}: no permission to write in {probe}")
    return path


def main(argv=None) -> int:
    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    delegate = getattr(args, "delegate", None)  # validate, hosts: their module parses the rest
    if rest and not delegate:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    try:
        if getattr(args, "out", None) is not None:
            check_output(args.out, is_file=args.command in _OUT_IS_FILE)
        if delegate:
            import importlib

            return importlib.import_module(delegate).main(rest)
        return args.func(args)
    except CrankfmuError as exc:
        show_traceback()
        print(f"crankfmu: error: {_one_line(exc)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("crankfmu: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:     # a bug or the machine (disk full, permissions): one line, not a traceback
        if show_traceback():
            raise
        print(f"crankfmu: error: {type(exc).__name__}: {_one_line(exc)} (CRANKFMU_TRACEBACK=1 shows where)",
              file=sys.stderr)
        return 1


def show_traceback() -> bool:
    """With CRANKFMU_TRACEBACK=1, the traceback of the failure being handled goes to stderr before
    its one line (for a bug report); every command that turns a failure into one line calls it."""
    if not os.environ.get("CRANKFMU_TRACEBACK"):
        return False
    import traceback

    traceback.print_exc(file=sys.stderr)
    return True


def _one_line(exc) -> str:
    """An error's message on one line (a compiler's output, a multi-line cause)."""
    return " | ".join(line.strip() for line in str(exc).splitlines() if line.strip()) or type(exc).__name__


if __name__ == "__main__":
    sys.exit(main())
