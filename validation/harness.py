"""``crankfmu validate [--fmu PATH ...] [--out DIR] [--quick | --demo] [--jobs N] [--junit FILE]``: every FMU
against the in-process reference, closed forms and the papers. One line per check, then ``N
passed, M failed`` with each other verdict counted (disagree, fitted, not comparable, skipped);
``DIR/report.md`` (and .html) with a summary and plots. Exit status: 0 when no check failed and
at least one passed; 1 on any failure (a published number that changed included) or when nothing
passed; 2 on bad input (an --fmu that is not an FMU crankfmu built).

Without ``--fmu`` it takes every FMU under build/fmus/ and its folders (make fmu's native/ and
native3/). Each FMU is checked as its kind asks (its crankfmu VendorAnnotation says what it is):

* a mechanism in torque causality, Python or native: the default experiment against the
  reference in each interface it has (Co-Simulation; Model Exchange through fmpy's CVode), every
  output, the paper's numbers, every hard case, speed against error, and the native FMU against
  the Python one of the same file (mechanism.py);
* a mechanism in speed causality: tau_drive at constant omega1 against the equilibrium moment, a
  torque-causal reference played back, the energy balance (speed.py);
* the drive, the die cushion, the rod string: their closed forms (components.py).

An FMU it cannot check is listed under "not validated" with the reason, and counted. The FMUs of
one data file form a group that one worker process runs, so they share its reference runs; the
groups run on ``--jobs`` processes (default: the machine's cores, at most 2 by default on CI).
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import os
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

from crankfmu.cli.arguments import described
from crankfmu.errors import CrankfmuError

from .checks import CheckList

DEFAULT_FMUS = Path("build") / "fmus"
#: the groups' relative cost (the long runs and the speed-against-error study): the dearest start first,
#: so that the two workers end together. seed000's study is the longest of make validate and make
#: test; in make demo's subset (measured one after the other, 2026-11-30) the slider-crank with
#: friction took 25 s, engine4 14 s, Jansen's leg 12 s, the three-loop 9 s: started last, as they
#: were, the friction's alone made the run's last 15 s
COST = {"seed000": 10, "slidercrank_friction": 9, "engine4": 7, "pumpjack": 6, "jansen": 6, "seed001": 5,
        "seed003": 5, "well:rp11l_guo": 4, "engine1": 4}


def discover(folder: Path = DEFAULT_FMUS) -> list[Path]:
    """Every FMU under ``folder``, its subfolders (native/) included."""
    return sorted(folder.rglob("*.fmu"))


def plan(paths) -> tuple[list[list[str]], list[tuple[str, str]]]:
    """(groups of FMU paths, one group per data file and causality; the FMUs not validated, with why)."""
    from .fmu_runner import kind_of

    groups: dict[tuple, list[str]] = {}
    not_validated = []
    for path in map(Path, paths):
        if not path.is_file():
            not_validated.append((str(path), "no such file"))
            continue
        try:
            kind = kind_of(path)
        except Exception as exc:                  # not a zip, no modelDescription: say so, go on
            not_validated.append((str(path), f"cannot be read as an FMU: {type(exc).__name__}: {exc}"))
            continue
        if kind is None:
            not_validated.append((str(path), "carries no crankfmu VendorAnnotation: not an FMU crankfmu built, "
                                             "so there is no data file to check it against"))
            continue
        groups.setdefault((kind.kind, kind.data, kind.causality, kind.file or ""), []).append(str(path))
    ordered = sorted(groups.items(), key=lambda item: -COST.get(
        item[0][1] if item[0][0] == "scenario" else f"{item[0][0]}:{item[0][1]}", 1))
    return [paths for _, paths in ordered], not_validated


# ------------------------------------------------------------------------------------ one group
def run_group(paths: list[str], out: str, subset: str) -> dict:
    """Validate the FMUs of one data file (in a worker process) in ``subset`` (report.SUBSETS):
    their sections, checks and the FMUs found not validatable inside."""
    from .fmu_runner import FmuUnderTest
    from .report import shortened

    out = Path(out)
    checks = CheckList(echo=None)
    sections, not_validated = [], []
    fmus = []
    for path in paths:
        try:
            fmus.append(FmuUnderTest(path))
        except CrankfmuError as exc:
            not_validated.append((path, str(exc)))
    try:
        by_build = {}
        for fmu in fmus:
            started, n_before = time.perf_counter(), len(checks.items)
            try:
                section = _validate_one(fmu, checks, out, subset)
            except Exception as exc:      # a bug in a check, or a crash of the FMU: a failed check, go on
                checks.holds(f"{fmu.name}.{fmu.kind.build}.harness_ran", False,
                             note=f"{type(exc).__name__}: {exc} | {traceback.format_exc(limit=3)[-400:]}")
                section = {}
            section.update(name=fmu.name, build=fmu.kind.build, kind=fmu.kind.label, data=fmu.kind.data,
                           interfaces=list(fmu.kind.interfaces), path=str(fmu.path))
            by_build[fmu.kind.build] = (fmu, section)
            section["wall"] = time.perf_counter() - started
            section["n_before"], section["n_end"] = n_before, len(checks.items)
            sections.append(section)
        for build in by_build:
            if build.startswith("native") and "python" in by_build:
                _native_against_python(by_build[build], by_build["python"], checks)
        if subset != "demo":        # speed against error: timed runs, make validate's and make test's
            _work_precision(fmus, sections, checks, out, shortened(subset))
    finally:
        for fmu in fmus:
            fmu.close()
        from .fmu_runner import report_progress
        report_progress("", 1.0)                  # this worker is free: off the status line
    # each section's checks: the items made while it ran, and the comparisons added to it after
    ends = [s["n_before"] for s in sections[1:]] + [sections[-1]["n_end"] if sections else 0]
    for section, end in zip(sections, ends):
        section["checks"] = checks.items[section.pop("n_before"):end] + section.pop("extra_checks", [])
        section.pop("n_end", None)
        for entry in section.get("default", []):
            entry.pop("run", None)               # the arrays stay in the worker
    return {"sections": sections, "not_validated": not_validated, "checks": checks.items}


def _validate_one(fmu, checks, out, subset: str) -> dict:
    from crankfmu.scenario import load_scenario

    from .report import shortened

    quick = shortened(subset)
    kind = fmu.kind
    if kind.kind == "scenario":
        scenario = load_scenario(fmu.scenario_source)
        if kind.causality == "speed":
            from .speed import check_speed_fmu
            return check_speed_fmu(fmu, scenario, checks, out, quick)
        from .mechanism import check_model
        return check_model(fmu, scenario, checks, out, subset)
    from . import components
    check = {"drive": components.check_drive, "cushion": components.check_cushion, "shaft": components.check_shaft,
             "well": components.check_rod_string}.get(kind.kind)
    if check is None:
        checks.skip(f"{fmu.name}.{kind.build}", f"no checks for an FMU of kind {kind.kind!r}")
        return {}
    return check(fmu, checks, out, quick)


def _native_against_python(native_build, python_build, checks):
    """A native FMU of a data file (FMI 2.0 or 3.0) against its Python FMU, on their Co-Simulation runs."""
    (native, n_section), (python, p_section) = native_build, python_build
    n_run = next((d.get("run") for d in n_section.get("default", []) if d.get("interface") == "CoSimulation"), None)
    p_run = next((d.get("run") for d in p_section.get("default", []) if d.get("interface") == "CoSimulation"), None)
    if n_run is None or p_run is None or n_run.time.shape != p_run.time.shape:
        item = checks.skip(f"{native.name}.{native.kind.build}_vs_python", "one of the two default runs did not complete")
        n_section.setdefault("extra_checks", []).append(item)
        return
    n_before = len(checks.items)
    if native.kind.kind == "scenario":
        from crankfmu.scenario import load_scenario

        from .mechanism import check_native_against_python
        result = check_native_against_python(native, python, load_scenario(native.scenario_source), checks, n_run,
                                             p_run)
    else:
        from .components import check_native_against_python
        result = check_native_against_python(native, python, checks, n_run, p_run)
    n_section["native_vs_python"] = result
    n_section.setdefault("extra_checks", []).extend(checks.items[n_before:])


def _work_precision(fmus, sections, checks, out, quick):
    """Speed against error on a scenario whose case file asks for it: every FMU of the group."""
    from crankfmu.scenario import load_scenario

    from . import cases as hard_cases
    from .work_precision import run_study

    mechanisms = [f for f in fmus if f.kind.kind == "scenario" and f.kind.causality == "torque"]
    if not mechanisms:
        return
    scenario = load_scenario(mechanisms[0].scenario_source)
    if not hard_cases.load_cases(scenario.name).work_precision:
        return
    n_before = len(checks.items)
    from .fmu_runner import report_progress
    labelled = [(f"{f.kind.build.capitalize()} FMU", f) for f in mechanisms]
    points, meta = run_study(labelled, scenario, quick,
                             progress=lambda x: report_progress(f"{scenario.name} speed against error", x))
    section = sections[0]
    section["work_precision"] = _work_precision_section(points, meta, scenario, checks, out)
    section.setdefault("extra_checks", []).extend(checks.items[n_before:])


def _work_precision_section(points, meta, scenario, checks, out) -> dict:
    from . import work_precision
    from .figures import plot_work_precision

    prefix = f"{scenario.name}.work_precision"
    for p in points:
        if "FMU" in p.family and "rtol sweep" in p.family and p.setting == "rtol 1e-10":
            tag = p.family.split(",")[0].replace(" ", "_")
            checks.at_most(f"{prefix}.{tag}_{'me_' if 'Model Exchange' in p.family else ''}rtol_1e-10_omega1_error",
                           p.omega1_error, 1e-6, "rad/s")
    for family in ("paper eq. 17 (seed 000)", "paper eq. 3 (seed 003)"):
        pts = [p for p in points if p.family == family and math.isfinite(p.omega1_error)]
        if len(pts) >= 2:
            a, b = pts[-2], pts[-1]          # two finest steps, a factor 10 apart
            order = math.log10(a.omega1_error / b.omega1_error)
            # named by the scheme: "paper eq. 17 (seed 000)" -> eq17_scheme_convergence_order (it read "17_...")
            checks.close(f"{prefix}.eq{family.split()[2]}_scheme_convergence_order", order, 1.0, 0.15,
                         note=f"the observed order of the paper's crank-angle scheme, {a.setting} -> {b.setting}")
    verdict = [f"- {work_precision.verdict(points, target)}" for target in (1e-6, 1e-9)]
    plot = plot_work_precision(points, out / f"{scenario.name}_work_precision.png",
                               f"{scenario.name}: speed against error (medians of {meta['repeats']} runs, one machine)")
    return {"points": points, "meta": meta, "ratios": work_precision.ratio_table(points),
            "targets": work_precision.TARGETS, "verdict": verdict, "plot": plot.name}


def run_coupled_group(built: dict, out: str, quick: bool) -> dict:
    """The coupled scenes (validation/coupled.py) on the scenes' native FMUs ``built``, as a group of
    its own (in a worker process)."""
    from . import coupled
    from .fmu_runner import report_progress

    checks = CheckList(echo=None)
    started = time.perf_counter()
    section = {"name": "coupled scenes", "build": "native", "kind": "coupled FMUs", "data": "coupled scenes",
               "interfaces": ["CoSimulation"], "path": ""}
    try:
        section["coupled"] = coupled.run({k: Path(v) for k, v in built.items()}, Path(out), quick, checks,
                                         progress=report_progress)
    except Exception as exc:      # a bug in the masters or a crash of an FMU: a failed check, go on
        checks.holds("coupled.harness_ran", False,
                     note=f"{type(exc).__name__}: {exc} | {traceback.format_exc(limit=3)[-400:]}")
    section["wall"] = time.perf_counter() - started
    section["checks"] = list(checks.items)
    return {"sections": [section], "not_validated": [], "checks": checks.items}


def coupled_group(fmu_paths) -> dict | None:
    """{scenes.BUILDS name: path} of the coupled scenes' FMUs among ``fmu_paths``, or None."""
    from . import coupled
    from .fmu_runner import kind_of

    kinds = {}
    for path in map(Path, fmu_paths):
        try:
            kind = kind_of(path) if path.is_file() else None
        except Exception:                 # plan() says why it is not validated
            kind = None
        if kind is not None:
            kinds[str(path)] = kind
    found = coupled.coupled_fmus(kinds)
    return None if found is None else {k: str(v) for k, v in found.items()}


# ------------------------------------------------------------------------------------ all groups
def _worker_init(queue):
    """In each worker: runs report how far they are to the parent (through ``queue``, at most twice a
    second), not to stderr; and the worker ends itself when the parent is gone (killed, say), not
    running its group on for nobody."""
    import threading

    from . import fmu_runner

    pid, parent = os.getpid(), os.getppid()
    last = {"label": None, "at": 0.0}

    def progress(label, fraction):
        now = time.monotonic()
        if label != last["label"] or now - last["at"] >= 0.5 or fraction >= 1.0:
            last.update(label=label, at=now)
            queue.put((pid, label, fraction))

    def watch():
        while True:
            time.sleep(1.0)
            if os.getppid() != parent:
                os._exit(3)

    fmu_runner.PROGRESS = progress
    threading.Thread(target=watch, daemon=True).start()


class StatusLine:
    """One line for every worker, redrawn each second on a terminal (a line every 15 s in a log):
    the groups done, what each worker runs and how far it is, and the time since the start, so
    the display moves even while a reference runs."""

    def __init__(self, total: int, stream=None):
        self.total, self.stream = total, stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()
        self.last = -math.inf

    def show(self, done: int, status: dict, force: bool = False):
        now = time.perf_counter()
        if not force and now - self.last < (1.0 if self.tty else 15.0):
            return
        self.last = now
        # a run at 100 % is over: what its worker does next (the checks on it) has no fraction, so it
        # reads as that, not as a bar stuck at 100 % while the next work goes on
        running = "; ".join((f"{label} {100 * fraction:3.0f}%" if fraction < 1.0 else f"{label} done, checking")
                            for label, fraction in list(status.values())[:4] if label)
        filled = int(round(30 * done / max(self.total, 1)))
        line = (f"validate [{'#' * filled}{'.' * (30 - filled)}] {done}/{self.total} groups, "
                f"{now - self.t0:5.0f} s" + (f" | {running}" if running and done < self.total else ""))
        width = 160
        self.stream.write(f"\r{line[:width]:<{width}}" if self.tty else f"{line[:width]}\n")
        self.stream.flush()

    def close(self):
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


def validate(fmu_paths, out, subset: str = "full", echo=print, jobs: int | None = None) -> tuple[CheckList, Path]:
    """Every FMU of ``fmu_paths`` in ``subset`` (report.SUBSETS says what each runs): "full", make
    validate's; "quick", the CI subset; "demo", make demo's, each FMU's own checks without the hard
    cases, the speed against error and the coupled scenes."""
    from .report import SUBSETS, shortened, write_report

    if subset not in SUBSETS:
        raise CrankfmuError(f"the harness's subset {subset!r} is none of {', '.join(SUBSETS)}")

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    checks = CheckList(echo)
    started = time.perf_counter()
    groups, not_validated = plan(fmu_paths)
    # the coupled scenes first: the longest group where their FMUs are validated
    tasks = [partial(run_coupled_group, built, str(out), shortened(subset))
             for built in [coupled_group(fmu_paths)] if built and subset != "demo"] \
        + [partial(run_group, group, str(out), subset) for group in groups]
    results = []
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(tasks) or 1))
    if jobs == 1:
        for task in tasks:
            results.append(task())
            checks.extend(results[-1]["checks"])
    else:
        context = multiprocessing.get_context("spawn")      # fmpy's and matplotlib's state stay per worker
        queue, status = context.Queue(), {}
        line = StatusLine(len(tasks))
        with ProcessPoolExecutor(jobs, mp_context=context, initializer=_worker_init, initargs=(queue,)) as pool:
            pending = {pool.submit(task) for task in tasks}
            done = 0
            while pending:
                finished = {f for f in pending if f.done()}
                for future in finished:
                    pending.discard(future)
                    done += 1
                    result = future.result()
                    results.append(result)
                    if line.tty:
                        line.stream.write("\r" + " " * 160 + "\r")
                    checks.extend(result["checks"])
                while not queue.empty():
                    pid, label, fraction = queue.get_nowait()
                    status[pid] = (label, fraction)
                line.show(done, status, force=bool(finished))
                if pending:
                    time.sleep(0.5)
        line.close()
    sections = [s for r in results for s in r["sections"]]
    for r in results:
        not_validated += r["not_validated"]
    for name, why in not_validated:
        checks.skip(f"{Path(name).name}.not_validated", why)
    report = write_report(out, sections, not_validated, checks, subset,
                          time.perf_counter() - started)
    return checks, report


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    parser = parser or argparse.ArgumentParser(prog="crankfmu validate", description=described(__doc__))
    parser.add_argument("--fmu", action="append", default=[], metavar="PATH",
                        help=f"an FMU to validate, repeatable; any FMU crankfmu built, from any folder (default: "
                             f"every FMU under {DEFAULT_FMUS}/ and its folders, make fmu's native/ and native3/)")
    parser.add_argument("--out", default="build/validation",
                        help="directory for report.md and the plots (default: build/validation)")
    parser.add_argument("--quick", action="store_true", help="the CI subset: shorter hard cases, fewer "
                                                             "speed-against-error points")
    parser.add_argument("--demo", action="store_true",
                        help="make demo's subset: every FMU's fmpy validation, units, default experiment in each "
                             "interface against the reference, published numbers and native-against-Python "
                             "checks, without the hard cases, the speed against error and the coupled scenes "
                             "(make validate runs them all)")
    parser.add_argument("--jobs", type=int, default=None, metavar="N",
                        help="worker processes, one data file's FMUs each (default: the machine's cores)")
    parser.add_argument("--junit", default=None, metavar="FILE",
                        help="also write the checks as JUnit XML (one test case per check) for a CI system "
                             "(default: none)")
    return parser


def readable_fmu(path) -> None:
    """CrankfmuError naming ``path`` unless it is an FMU crankfmu built: a zip with a
    modelDescription.xml that carries crankfmu's VendorAnnotation. Checked before any work, so a
    junk file never reads as validated."""
    import zipfile

    from .fmu_runner import kind_of

    path = Path(path)
    if not path.is_file():
        raise CrankfmuError(f"no FMU at {path}: build it (make fmu) or give the path of an .fmu file")
    try:
        kind = kind_of(path)
    except (zipfile.BadZipFile, KeyError, OSError, ValueError, SyntaxError) as exc:
        what = "not a zip file" if isinstance(exc, zipfile.BadZipFile) else \
            "no modelDescription.xml in it" if isinstance(exc, KeyError) else f"{type(exc).__name__}: {exc}"
        raise CrankfmuError(f"--fmu {path}: cannot be read as an FMU ({what})") from None
    if kind is None:
        raise CrankfmuError(f"--fmu {path}: not an FMU crankfmu built (its modelDescription.xml has no crankfmu "
                            "VendorAnnotation), so there is no data file to check it against")


def run_from_args(args) -> int:
    for path in args.fmu:
        readable_fmu(path)
    paths = args.fmu or [str(p) for p in discover()]
    if not paths:
        raise CrankfmuError(f"no FMUs under {DEFAULT_FMUS}/: build them with `make fmu`, or give --fmu PATH")
    if args.jobs is not None and args.jobs < 1:
        raise CrankfmuError(f"--jobs must be >= 1, got {args.jobs}")
    from crankfmu.cli import check_output

    out = check_output(args.out)
    if args.junit:
        check_output(args.junit, is_file=True)
    started = time.perf_counter()
    subset = "demo" if args.demo else "quick" if args.quick else "full"
    checks, report = validate(paths, out, subset, jobs=args.jobs)
    if args.junit:
        from .junit import write_junit
        write_junit(args.junit, checks.items, time.perf_counter() - started)
    print(checks.summary())
    print(f"wrote {report}" + (f" and {args.junit}" if args.junit else ""))
    if checks.passed == 0:
        print("crankfmu validate: error: no check passed: nothing was validated", file=sys.stderr)
        return 1
    return 0 if checks.failed == 0 else 1


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return run_from_args(args)
    except CrankfmuError as exc:
        from crankfmu.cli import show_traceback

        show_traceback()
        print(f"crankfmu validate: error: {exc}", file=sys.stderr)
        return 2
