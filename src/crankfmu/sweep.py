"""Parameter sweeps of a kinematic study: ``crankfmu sweep SCENARIO --param NAME=START:STOP:COUNT ...``.

The grid is every combination of the swept values. Each design is range-checked and assembled
over the whole turn; one that fails is recorded with its reason and the sweep goes on. Rows of
``peaks.csv`` are written (and flushed) as each design finishes; a design already in the file is
not computed again, so an interrupted sweep resumes where it stopped.
"""

from __future__ import annotations

import csv
import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import CrankfmuError
from .kinematic_study import _study, cycle


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
    rows: list[dict] = field(default_factory=list)
    failed: list[dict] = field(default_factory=list)
    series: dict = field(default_factory=dict)       # design tuple -> {quantity: array over phi1}
    phi1: np.ndarray | None = None
    skipped: int = 0                                  # designs found in peaks.csv (resume)


def _key(values) -> tuple:
    return tuple(round(float(v), 12) for v in values)


def run_sweep(scenario, axes: list[SweepAxis], out: Path, progress=None, resume: bool = True) -> SweepResult:
    ks = _study(scenario)
    quantities = list(ks.get("sweep_quantities", []))
    if not quantities:
        raise CrankfmuError(f"scenario {scenario.name}: [kinematics] sweep_quantities is empty: nothing to sweep")
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise CrankfmuError(f"each --param may appear once, got {names}")
    columns = names + [f"max_abs_{q}" for q in quantities]
    if ks.get("stroke_of"):
        columns += ["time_ratio", "stroke"]
    out.mkdir(parents=True, exist_ok=True)
    peaks_path, failed_path = out / "peaks.csv", out / "failed.csv"
    result = SweepResult(axes, columns)
    done = set()
    if resume and peaks_path.exists():
        with peaks_path.open() as f:
            reader = csv.DictReader(f)
            if reader.fieldnames == columns:
                for row in reader:
                    done.add(_key(row[n] for n in names))
    if not done:
        with peaks_path.open("w", newline="") as f:
            csv.writer(f).writerow(columns)
    failed_rows = []
    grid = list(itertools.product(*(a.values for a in axes)))
    with peaks_path.open("a", newline="") as f:
        writer = csv.writer(f)
        for i, design in enumerate(grid):
            if progress:
                progress(i / len(grid))
            params = dict(zip(names, design))
            try:
                c = cycle(scenario.with_params(**params), quantities)
            except CrankfmuError as exc:
                failed_rows.append({**params, "reason": str(exc)})
                continue
            result.phi1 = c["phi1"]
            result.series[_key(design)] = c["series"]
            row = {**params, **c["peaks"]}
            if ks.get("stroke_of"):
                row.update(time_ratio=c["time_ratio"], stroke=c["stroke"])
            result.rows.append(row)
            if _key(design) in done:
                result.skipped += 1
                continue
            writer.writerow([f"{row[col]:.15g}" for col in columns])
            f.flush()
    if progress:
        progress(1.0)
    result.failed = failed_rows
    with failed_path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names + ["reason"])
        for row in failed_rows:
            w.writerow([f"{row[n]:.15g}" for n in names] + [row["reason"]])
    return result


def check_claims(scenario, result: SweepResult) -> list[dict]:
    """Each of the paper's ``[[kinematics.claims]]``: does |quantity| grow as the claim says, at the
    peaks (each family of the other parameters fixed) and over what share of the cycle pointwise?"""
    ks = _study(scenario)
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
                keys = [_key(tuple({**fixed_map, p: v}[n] for n in names)) for v in order]
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
