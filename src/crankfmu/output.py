"""Writing results: timeseries.csv, summary.json and the PNG plots (paper Figs. 3 and 4)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .plots import plot_cycles
from .simulation import COLUMNS, Result


def write_timeseries(result: Result, path: Path) -> Path:
    """Plain CSV, one header line; the units are listed in summary.json ("columns")."""
    data = np.column_stack([getattr(result, c) for c in COLUMNS])
    np.savetxt(path, data, delimiter=",", header=",".join(COLUMNS), comments="", fmt="%.15g")
    return path


def write_summary(summary: dict, path: Path) -> Path:
    path.write_text(json.dumps(summary, indent=2, default=_json_default) + "\n")
    return path


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {obj!r}")


def write_run(result: Result, out_dir: str | Path) -> dict:
    """Everything `crankfmu simulate` writes; returns the summary."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    exp = result.scenario.experiment
    summary = result.summary()
    summary["columns"] = dict(COLUMNS)
    write_timeseries(result, out / "timeseries.csv")
    write_summary(summary, out / "summary.json")
    plot_cycles(result, out, exp.cycles, exp.summary_cycle)
    return summary
