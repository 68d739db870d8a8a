"""``crankfmu validate [--fmu PATH ...] [--out DIR] [--quick]``: every FMU against the in-process
reference and the papers. One line per check, ``N passed, M failed``, exit status 1 on any
failure, ``DIR/report.md`` with tables and plots."""

from __future__ import annotations

import argparse
import math
import sys
import time
import zipfile
from pathlib import Path

import numpy as np

from crankfmu.errors import CrankfmuError
from crankfmu.progress import ProgressBar
from crankfmu.scenario import load_scenario

from . import cases as hard_cases
from . import work_precision
from .checks import CheckList
from .compare import cycles, energy_residual, max_abs_error, phi_quadrature_residual, relative_error
from .fmu_runner import FmuUnderTest, scenario_of
from .paper import check_paper
from .reference import reference_run
from .report import plot_overlay, plot_work_precision, write_report

DEFAULT_FMUS = Path("build") / "fmus"
OUTPUT_TOLERANCE = 1e-6        # relative: the FMU's rtol (1e-10) leaves ~1e-9; 1e-6 is the contract's bound
LS_REF = "extra/org.fmi-standard.fmi-ls-ref"


def _carried_reference(fmu: FmuUnderTest):
    """The result the FMU carries (fmi-ls-ref), as {column: array}, or None."""
    with zipfile.ZipFile(fmu.path) as z:
        name = f"{LS_REF}/{fmu.name}_out.csv"
        if name not in z.namelist():
            return None
        text = z.read(name).decode()
    header, *rows = text.strip().splitlines()
    cols = [c.strip('"') for c in header.split(",")]
    data = np.array([[float(x) for x in r.split(",")] for r in rows])
    return {c: data[:, i] for i, c in enumerate(cols)}


def check_default(fmu: FmuUnderTest, scenario, checks, out: Path) -> dict:
    """The default experiment through fmpy against the reference at the same points."""
    exp = scenario.experiment
    prefix = f"{fmu.name}.default"
    run = fmu.run(exp.stop_time, exp.output_interval, label="default")
    if run.error:
        checks.holds(f"{prefix}.ran", False, note=run.error)
        return {}
    ref = reference_run(scenario, run.time)
    rows = []
    for name in fmu.outputs:
        if name not in ref.values:
            continue
        a, r = max_abs_error(run[name], ref[name]), relative_error(run[name], ref[name])
        checks.at_most(f"{prefix}.{name}_rel_error", r, OUTPUT_TOLERANCE)
        rows.append({"output": name, "unit": fmu.units.get(name) or "1", "abs": a, "rel": r, "tol": OUTPUT_TOLERANCE})
    checks.at_most(f"{prefix}.energy_residual", energy_residual(run.values), 1e-8)
    floor = phi_quadrature_residual(ref.time, ref["phi1"], ref["omega1"], ref["epsilon1"])
    checks.at_most(f"{prefix}.phi1_is_integral_of_omega1",
                   phi_quadrature_residual(run.time, run["phi1"], run["omega1"], run["epsilon1"]),
                   2.0 * floor + 1e-8, "rad", note=f"Hermite-rule floor on the reference {floor:.2e} rad")
    # the same for each mechanism-specific position with its velocity and acceleration outputs
    by_of = {}
    for q in scenario.quantities:
        by_of.setdefault(q.of, {})[q.order] = q.name
    for of, names in by_of.items():
        if {0, 1, 2} <= set(names) and all(names[o] in run.values for o in (0, 1, 2)):
            x, v, a = names[0], names[1], names[2]
            floor = phi_quadrature_residual(ref.time, ref[x], ref[v], ref[a])
            checks.at_most(f"{prefix}.{x}_is_integral_of_{v}", phi_quadrature_residual(run.time, run[x], run[v], run[a]),
                           2.0 * floor + 1e-8, note=f"Hermite-rule floor on the reference {floor:.2e}")
    fc, rc = cycles(run.time, run["phi1"], run["omega1"]), cycles(ref.time, ref["phi1"], ref["omega1"])
    k = min(exp.summary_cycle, len(fc), len(rc))
    if k:
        for key in ("omega1_min", "omega1_max", "omega1_mean"):
            checks.at_most(f"{prefix}.cycle{k}_{key}_error", fc[k - 1][key] - rc[k - 1][key], 1e-6, "rad/s")
    carried = _carried_reference(fmu)
    if carried is not None and carried["time"].shape == run.time.shape:
        checks.at_most(f"{prefix}.omega1_vs_carried_fmi_ls_ref", relative_error(run["omega1"], carried["omega1"]),
                       OUTPUT_TOLERANCE)
    from fmpy.validation import validate_fmu
    problems = validate_fmu(str(fmu.path))
    checks.holds(f"{fmu.name}.fmpy_validate", not problems, note="; ".join(map(str, problems))[:300])
    plot = plot_overlay(run, ref, out / f"{fmu.name}_default.png",
                        f"{fmu.name}.fmu, default experiment ({scenario.name})")
    model = ref.result.model
    n_paper = len(checks.items)
    check_paper(scenario, model, run, checks, fmu.name)
    return {"default": {"span": exp.stop_time - exp.start_time, "step": exp.output_interval, "fmu_wall": run.wall,
                        "ref_wall": ref.wall, "rows": rows, "plot": plot.name},
            "paper": checks.items[n_paper:]}


def check_work_precision(fmu, scenario, checks, out: Path, quick: bool) -> dict:
    bar = ProgressBar(1.0, label=f"{fmu.name} work-precision", stream=sys.stderr)
    try:
        points, meta = work_precision.run_study(fmu, scenario, quick, progress=bar)
    finally:
        bar.close()
    prefix = f"{fmu.name}.work_precision"
    for p in points:
        if p.family.startswith("FMU") and "rtol 1e-10" in (p.family + p.setting):
            checks.at_most(f"{prefix}.fmu_{p.setting.replace(' ', '_')}_omega1_error", p.omega1_error, 1e-6, "rad/s")
    for family in ("paper eq. 17 (seed 000)", "paper eq. 3 (seed 003)"):
        pts = [p for p in points if p.family == family and math.isfinite(p.omega1_error)]
        if len(pts) >= 2:
            a, b = pts[-2], pts[-1]          # two finest steps, a factor 10 apart
            order = math.log10(a.omega1_error / b.omega1_error)
            checks.close(f"{prefix}.{family.split()[2]}_convergence_order", order, 1.0, 0.15,
                         note=f"{a.setting} -> {b.setting}")
    ratios = work_precision.ratio_table(points)
    verdict = []
    for target in (1e-6, 1e-9):
        best, second = work_precision.fastest(points, target)
        if best is None:
            verdict.append(f"- At {target:g} rad/s: no method reached it in this run.")
        elif second is None:
            verdict.append(f"- At {target:g} rad/s: only {best.family} ({best.setting}) reached it, "
                           f"in {best.time_s * 1e3:.3g} ms.")
        else:
            verdict.append(f"- At {target:g} rad/s the fastest is **{best.family}** ({best.setting}, "
                           f"{best.time_s * 1e3:.3g} ms), {second.time_s / best.time_s:.3g} times faster than the "
                           f"next method, {second.family} ({second.setting}, {second.time_s * 1e3:.3g} ms).")
    plot = plot_work_precision(points, out / f"{fmu.name}_work_precision.png",
                               f"{scenario.name}: speed against error (one run, one machine)")
    for line in verdict:
        print(line.replace("**", ""))
    return {"points": points, "meta": meta, "ratios": ratios, "targets": work_precision.TARGETS,
            "verdict": verdict, "plot": plot.name}


def validate(fmu_paths, out, quick: bool = False, echo=print) -> tuple[CheckList, Path]:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    checks = CheckList(echo)
    sections = []
    started = time.perf_counter()
    for path in fmu_paths:
        try:
            fmu = FmuUnderTest(path)
        except CrankfmuError as exc:
            checks.holds(f"{Path(path).stem}.loads", False, note=str(exc))
            continue
        try:
            scenario = load_scenario(fmu.scenario_source)
            section = {"name": fmu.name, "scenario": scenario.name,
                       "intro": [f"`{fmu.path}`; scenario file `{scenario.where}`.", ""]}
            section.update(check_default(fmu, scenario, checks, out))
            case_file = hard_cases.load_cases(scenario.name)
            if case_file.work_precision:
                section["work_precision"] = check_work_precision(fmu, scenario, checks, out, quick)
            rows = []
            for case in case_file.cases:
                if quick and not case.quick:
                    continue
                for g in case_file.gravity:
                    row = hard_cases.run_case(fmu, scenario, case, g, quick, checks)
                    if "fmu" in row:
                        row["plot"] = plot_overlay(row.pop("fmu"), row.pop("ref"),
                                                   out / f"{fmu.name}_{case.name}_g{g:g}.png",
                                                   f"{fmu.name}.fmu, {case.name}, g = {g:g} m/s2").name
                    rows.append(row)
            section["hard"] = rows
            sections.append(section)
        finally:
            fmu.close()
    report = write_report(out, sections, checks, quick, time.perf_counter() - started)
    return checks, report


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    parser = parser or argparse.ArgumentParser(prog="crankfmu validate", description=__doc__)
    parser.add_argument("--fmu", action="append", default=[], metavar="PATH",
                        help=f"an FMU to validate (repeatable; default: every FMU in {DEFAULT_FMUS}/)")
    parser.add_argument("--out", default="build/validation", help="directory for report.md and the plots")
    parser.add_argument("--quick", action="store_true", help="the CI subset: shorter hard cases, fewer "
                                                             "work-precision points")
    return parser


def run_from_args(args) -> int:
    # the mechanism FMUs (each names its scenario); Drive.fmu is checked by `crankfmu hosts`
    paths = args.fmu or sorted(str(p) for p in DEFAULT_FMUS.glob("*.fmu") if scenario_of(p) is not None)
    if not paths:
        raise CrankfmuError(f"no FMUs in {DEFAULT_FMUS}/: build them with `make fmu`, or give --fmu PATH")
    checks, report = validate(paths, args.out, args.quick)
    print(checks.summary())
    print(f"wrote {report}")
    return 0 if checks.failed == 0 else 1


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return run_from_args(args)
    except CrankfmuError as exc:
        print(f"crankfmu validate: error: {exc}", file=sys.stderr)
        return 2
