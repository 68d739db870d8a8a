"""Parameter sweeps: ``crankfmu sweep SCENARIO --param NAME=START:STOP:COUNT ...``.

The grid is every combination of the swept values. Two studies:

- ``kinematic`` (scenarios with a ``[kinematics]`` section, seed 004): each design's quantities
  over one turn at constant crank speed, their peaks in ``peaks.csv``;
- ``steady`` (any scenario with a motor): each design's steady cycle (omega1 mean, min, max and
  the coefficient of speed fluctuation delta) in ``steady.csv``, computed many designs per call
  by ``crankfmu.studies.batch.steady_cycles`` on the C kernel.

The designs are cut into chunks and run on Dask: a local cluster of worker processes (one per
core) by default, or an existing cluster with ``scheduler="tcp://host:8786"`` (its workers need
crankfmu installed); ``scheduler="serial"`` runs them in this process. Rows are written (and
flushed) as each chunk finishes, in the order they finish. A design that fails (out of range,
cannot be assembled, stalls) is listed with its reason in ``failed.csv`` and the sweep goes on;
a chunk whose worker dies is listed the same way. A design already in the results file is not
computed again, so an interrupted sweep resumes where it stopped.
"""

from __future__ import annotations

import csv
import itertools
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import CrankfmuError
from .kinematics import cycle, study_settings

STUDIES = ("kinematic", "steady")


@dataclass
class SweepAxis:
    name: str
    values: list[float]

    @classmethod
    def parse(cls, text: str, scenario) -> "SweepAxis":
        name, sep, spec = text.partition("=")
        name = name.strip()
        parts = spec.split(":")
        if not sep or len(parts) != 3:
            raise CrankfmuError(f"--param expects NAME=START:STOP:COUNT, got {text!r}")
        scenario._param(name)               # an unknown name is named with the valid ones
        try:
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise CrankfmuError(f"--param {name}: START and STOP must be numbers and COUNT an integer, "
                                f"got {spec!r}") from None
        if count < 1 or not (math.isfinite(start) and math.isfinite(stop)):
            raise CrankfmuError(f"--param {name}: COUNT must be >= 1 and START, STOP finite, got {spec!r}")
        return cls(name, [float(v) for v in np.linspace(start, stop, count)])


@dataclass
class SweepResult:
    axes: list[SweepAxis]
    columns: list[str]
    study: str = "kinematic"
    rows: list[dict] = field(default_factory=list)
    failed: list[dict] = field(default_factory=list)
    series: dict = field(default_factory=dict)       # design tuple -> {quantity: array over phi1}
    phi1: np.ndarray | None = None
    skipped: int = 0                                  # designs found in the results file (resume)
    path: Path | None = None                          # the results file

    def _design(self, values: dict) -> tuple:
        return design_key(values[a.name] for a in self.axes)

    def row_at(self, values: dict) -> dict | None:
        """The results row of the design with these swept values (name -> value), None if it failed."""
        if getattr(self, "_rows", (None, -1))[1] != len(self.rows):       # built once per row count
            self._rows = ({design_key(r[a.name] for a in self.axes): r for r in self.rows}, len(self.rows))
        return self._rows[0].get(self._design(values))

    def series_at(self, values: dict) -> dict | None:
        """{quantity: values over phi1} of the design with these swept values, None if it failed."""
        return self.series.get(self._design(values))


def design_key(values) -> tuple:
    """A design's swept values as a dictionary key: rounded, so that a value read back from the
    results file (resume) finds the design of the grid."""
    return tuple(round(float(v), 12) for v in values)


# ---------------------------------------------------------------------- work done by a worker
def _kinematic_chunk(scenario, names, designs, quantities, stroke: bool):
    """[(design, row or None, series, phi1, reason)] for a chunk of designs."""
    out = []
    for design in designs:
        params = dict(zip(names, design))
        try:
            c = cycle(scenario.with_params(**params), quantities)
        except CrankfmuError as exc:
            out.append((design, None, None, None, str(exc)))
            continue
        row = {**params, **c["peaks"]}
        if stroke:
            row.update(time_ratio=c["time_ratio"], stroke=c["stroke"])
        out.append((design, row, c["series"], c["phi1"], ""))
    return out


def _steady_chunk(scenario, names, designs):
    from .batch import steady_cycles

    result = steady_cycles(scenario, [dict(zip(names, d)) for d in designs])
    out = [(tuple(r[n] for n in names), r, None, None, "") for r in result.rows]
    out += [(tuple(r[n] for n in names), None, None, None, r["reason"]) for r in result.failed]
    return out


# ---------------------------------------------------------------------- running the chunks
def run_chunks(function, chunks: list, args: tuple, scheduler: str | None = None):
    """Yield (chunk, result or exception) as each chunk finishes, on Dask (see module doc).

    ``function(args[0], args[1], chunk, *args[2:])`` computes one chunk (scenario, names first)."""
    if scheduler == "serial" or not chunks:
        for chunk in chunks:
            try:
                yield chunk, function(args[0], args[1], chunk, *args[2:])
            except Exception as exc:        # noqa: BLE001 - a failed chunk is reported, not fatal
                yield chunk, exc
        return
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise CrankfmuError("crankfmu sweep runs on Dask: pip install 'dask[distributed]' "
                            "(or --scheduler serial to run in this process)") from None
    import logging

    logging.getLogger("distributed").setLevel(logging.ERROR)
    if scheduler in (None, "", "local"):
        import dask

        # Dask starts its workers with MALLOC_TRIM_THRESHOLD_=65536 (to hand memory back in long-lived
        # clusters). Setting it fixes glibc's mmap threshold at 128 kB, so each design's table
        # (0.5 MB of cubics, freed when the design has run) is mapped and unmapped again: 128 page
        # faults and two system calls per design, a quarter of a seed 000 design's time. These
        # workers live for one sweep: glibc's own thresholds reuse the freed table's memory.
        with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
            cluster = LocalCluster(n_workers=min(os.cpu_count() or 1, len(chunks)), threads_per_worker=1,
                                   processes=True, dashboard_address=None, silence_logs=logging.ERROR)
        client = Client(cluster)
    else:
        cluster = None
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, ValueError) as exc:
            raise CrankfmuError(f"--scheduler {scheduler}: cannot reach the Dask scheduler ({exc})") from None
    try:
        futures = {client.submit(function, args[0], args[1], chunk, *args[2:], pure=False): i
                   for i, chunk in enumerate(chunks)}
        for future in as_completed(futures):
            chunk = chunks[futures[future]]
            try:
                yield chunk, future.result()
            except Exception as exc:        # noqa: BLE001 - a worker's failure is reported per chunk
                yield chunk, exc
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def default_study(scenario) -> str:
    return "kinematic" if scenario.kinematics_study.get("sweep_quantities") else "steady"


def run_sweep(scenario, axes: list[SweepAxis], out: Path, progress=None, resume: bool = True,
              study: str | None = None, scheduler: str | None = "serial", chunk_size: int | None = None
              ) -> SweepResult:
    """Run the sweep (see the module doc); ``progress(fraction)`` is called as chunks finish."""
    study = study or default_study(scenario)
    if study not in STUDIES:
        raise CrankfmuError(f"unknown study {study!r}; valid studies: {', '.join(STUDIES)}")
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise CrankfmuError(f"each --param may appear once, got {names}")
    if study == "kinematic":
        ks = study_settings(scenario)
        quantities = list(ks.get("sweep_quantities", []))
        if not quantities:
            raise CrankfmuError(f"scenario {scenario.name}: [kinematics] sweep_quantities is empty: nothing to sweep")
        stroke = bool(ks.get("stroke_of"))
        columns = names + [f"max_abs_{q}" for q in quantities] + (["time_ratio", "stroke"] if stroke else [])
        results_path = out / "peaks.csv"
        function, extra = _kinematic_chunk, (quantities, stroke)
        chunk_size = chunk_size or 4
    else:
        from .batch import STEADY_COLUMNS

        columns = names + list(STEADY_COLUMNS)
        results_path = out / "steady.csv"
        function, extra = _steady_chunk, ()
        chunk_size = chunk_size or 500
    out.mkdir(parents=True, exist_ok=True)
    failed_path = out / "failed.csv"
    result = SweepResult(axes, columns, study, path=results_path)
    done: dict[tuple, dict] = {}
    if resume and results_path.exists():
        with results_path.open() as f:
            reader = csv.DictReader(f)
            if reader.fieldnames == columns:
                for row in reader:
                    done[design_key(row[n] for n in names)] = {k: float(v) for k, v in row.items()}
    if not done:
        with results_path.open("w", newline="") as f:
            csv.writer(f).writerow(columns)
    grid = list(itertools.product(*(a.values for a in axes)))
    if study == "steady":
        # a steady design in the file is finished; a kinematic one is recomputed for the plots
        result.rows += [done[design_key(d)] for d in grid if design_key(d) in done]
        result.skipped = len(result.rows)
        todo = [d for d in grid if design_key(d) not in done]
    else:
        todo = grid
    chunks = [todo[i:i + chunk_size] for i in range(0, len(todo), chunk_size)]
    finished = result.skipped
    with results_path.open("a", newline="") as f, failed_path.open("w", newline="") as ff:
        writer, failed_writer = csv.writer(f), csv.writer(ff)
        failed_writer.writerow(names + ["reason"])
        for chunk, outcome in run_chunks(function, chunks, (scenario, names, *extra), scheduler):
            if isinstance(outcome, Exception):
                outcome = [(d, None, None, None, f"the worker failed: {type(outcome).__name__}: {outcome}")
                           for d in chunk]
            for design, row, series, phi1, reason in outcome:
                params = dict(zip(names, design))
                if row is None:
                    result.failed.append({**params, "reason": reason})
                    failed_writer.writerow([f"{v:.15g}" for v in design] + [reason])
                    continue
                if series is not None:
                    result.series[design_key(design)] = series
                    result.phi1 = phi1
                result.rows.append(row)
                if design_key(design) in done:
                    result.skipped += 1
                    continue
                writer.writerow([f"{row[col]:.15g}" for col in columns])
            f.flush()
            ff.flush()
            finished += len(chunk)
            if progress:
                progress(finished / max(len(grid), 1))
    if progress:
        progress(1.0)
    _in_grid_order(result, grid, names, columns, results_path, failed_path)
    return result


def _in_grid_order(result: SweepResult, grid, names, columns, results_path, failed_path):
    """The rows, in memory and in the CSV files, in the order of the grid (the parameters' values
    ascending, the first --param slowest), not in the order the workers finished them: the files
    are written as the designs finish (so --resume keeps them), then rewritten whole, sorted."""
    from ..atomic import write_text

    order = {design_key(d): i for i, d in enumerate(grid)}
    last = len(order)
    result.rows.sort(key=lambda r: order.get(design_key(r[n] for n in names), last))
    result.failed.sort(key=lambda r: order.get(design_key(r[n] for n in names), last))

    def text(header, rows):
        lines = [",".join(header)] + [",".join(cells) for cells in rows]
        return "\n".join(lines) + "\n"
    write_text(results_path, text(columns, ([f"{row[c]:.15g}" for c in columns] for row in result.rows)))
    write_text(failed_path, text(names + ["reason"], ([f"{row[n]:.15g}" for n in names] + [_csv_cell(row["reason"])]
                                                      for row in result.failed)))


def _csv_cell(text: str) -> str:
    """A CSV field as the csv module writes it: quoted where it holds a comma, a quote or a newline."""
    import io

    buffer = io.StringIO()
    csv.writer(buffer).writerow([text])
    return buffer.getvalue().rstrip("\r\n")


def check_claims(scenario, result: SweepResult) -> list[dict]:
    """Each of the paper's ``[[kinematics.claims]]``: does |quantity| grow as the claim says, at the
    peaks (each family of the other parameters fixed) and over what share of the cycle pointwise?"""
    ks = study_settings(scenario)
    names = [a.name for a in result.axes]
    out = []
    for claim in ks.get("claims", []):
        p = claim["param"]
        if p not in names:
            continue
        axis = next(a for a in result.axes if a.name == p)
        order = axis.values if claim["direction"] == "increase" else axis.values[::-1]
        others = [a for a in result.axes if a.name != p]
        for quantity in claim["quantities"]:
            peak_ok, peak_n, shares, second = 0, 0, [], []
            for fixed in itertools.product(*(a.values for a in others)):
                fixed_map = dict(zip([a.name for a in others], fixed))
                keys = [design_key(tuple({**fixed_map, p: v}[n] for n in names)) for v in order]
                if any(k not in result.series for k in keys):
                    continue                   # a design of this family failed: no verdict
                curves = np.array([np.abs(result.series[k][quantity]) for k in keys])
                peaks = curves.max(axis=1)
                peak_n += 1
                peak_ok += bool(np.all(np.diff(peaks) > 0))
                grows = np.all(np.diff(curves, axis=0) > 0, axis=0)
                shares.append(float(np.mean(grows)))
                second.append(float(np.mean(grows[result.phi1 >= math.pi])))
            out.append({"claim": claim["text"], "param": p, "direction": claim["direction"], "quantity": quantity,
                        "families": peak_n, "peaks_hold_in": peak_ok,
                        "share_of_cycle_min": min(shares) if shares else float("nan"),
                        "share_of_cycle_mean": float(np.mean(shares)) if shares else float("nan"),
                        "share_of_second_half_mean": float(np.mean(second)) if second else float("nan")})
    return out
