"""The C kernel against the numba kernel it replaces, before the numba code goes (issue 27): every
packaged scenario and every hard case of validation/cases (each gravity), run by the fast path
with each kernel, compared output by output (relative to the output's largest magnitude), plus
the steady cycles of the batch. Prints a table and the largest difference; exits 1 above 1e-12.

    python benchmarks/c_against_numba.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
import types

import numpy as np

from crankfmu import native, simulate
from crankfmu.integrators import fast
from crankfmu.integrators.kernel import COMPILED, drivers as numba_drivers
from crankfmu.scenario import available_scenarios, load_scenario
from crankfmu.validation.cases import load_cases

FIELDS = ("phi1", "omega1", "epsilon1", "M_motor", "M_load", "J_red", "W_motor", "W_load", "W_ext")


def c_drivers():
    """The numba drivers' calling convention on the C kernel (tables tuple, scratch tuple)."""
    cache = {}

    def tables_of(tables):
        key = tuple(id(a) for a in tables)
        if key not in cache:
            cache[key] = (native.Tables(*tables), tables)    # keep the arrays alive
        return cache[key][0]

    return types.SimpleNamespace(
        begin=lambda S, t, y, tables, P, ws, row: native.begin(S, t, y, tables_of(tables), P, row),
        advance=lambda S, tt, tl, tables, P, ws, row: native.advance(S, tt, tl, tables_of(tables), P, row),
        run_chunk=lambda S, t_end, times, i_out, rows, store, n_store, ev, n_ev, md, n_md, tables, P, ws:
            native.run_chunk(S, t_end, times, i_out, rows, store, n_store, ev, n_ev, md, n_md, tables_of(tables), P),
        dense_many=native.dense_many,
        steady_batch=lambda params, phi, guess, tol, turns, tables, out, ws:
            native.steady_batch(params, phi, guess, tol, turns, tables_of(tables), out))


def runs(quick: bool):
    from pathlib import Path

    for path in sorted((Path(__file__).resolve().parents[1] / "tests" / "data" / "user").glob("*_scenario.toml")):
        scenario = load_scenario(str(path))
        yield path.stem, "user's files", scenario, scenario.experiment.stop_time
    for name in available_scenarios():
        scenario = load_scenario(name)
        yield name, "default", scenario, scenario.experiment.stop_time
        cases = load_cases(name)
        for g in cases.gravity:
            for case in cases.cases:
                try:
                    s = scenario.with_params(g=g, **case.set)
                except Exception:
                    continue
                yield name, f"{case.name} g={g:g}", s, case.span(quick)


def compare(quick: bool) -> float:
    worst = 0.0
    rows = []
    for name, case, scenario, t_end in runs(quick):
        times = np.linspace(scenario.experiment.start_time, t_end, 2001)
        results = []
        for drivers in (numba_drivers, c_drivers()):
            fast.drivers = drivers
            try:
                results.append(simulate(scenario, method="fast", t_end=t_end, output_times=times))
            except Exception as exc:          # both kernels must refuse alike
                results.append(type(exc).__name__ + ": " + str(exc))
        fast.drivers = numba_drivers
        a, b = results
        if isinstance(a, str) or isinstance(b, str):
            same = a == b
            rows.append((name, case, "refused alike" if same else f"DIFFERENT: {a!r} vs {b!r}", 0.0 if same else 1.0))
            worst = max(worst, 0.0 if same else 1.0)
            continue
        diff = max(float(np.max(np.abs(getattr(a, f) - getattr(b, f))) / max(np.max(np.abs(getattr(a, f))), 1e-300))
                   for f in FIELDS)
        worst = max(worst, diff)
        rows.append((name, case, f"{a.trajectory.n_steps} steps, {len(a.trajectory.events)} events", diff))
    for name, case, what, diff in rows:
        print(f"{name:10s} {case:34s} {what:34s} {diff:.3e}")
    return worst


def compare_batch() -> float:
    """The steady cycles of many flywheels and motor lines (sweeps, flywheel sizing) by each kernel."""
    import crankfmu.studies.batch as batch

    worst = 0.0
    for name, designs in (("seed000", [{"J_flywheel": j, "B": b} for j in (0.2, 1.0, 5.0, 20.0) for b in (10.0, 30.0)]),
                          ("seed003", [{"J_flywheel": j} for j in (0.0, 10.0, 100.0, 250.0)]),
                          ("pumpjack", [{"J_flywheel": j} for j in (0.0, 50.0)])):
        out = []
        for drivers in (numba_drivers, c_drivers()):
            batch.drivers = drivers
            result = batch.steady_cycles(name, designs)
            out.append((np.array([[r[c] for c in batch.STEADY_COLUMNS] for r in result.rows]),
                        [f["reason"] for f in result.failed]))
        batch.drivers = numba_drivers
        (a, fa), (b, fb) = out
        d = float(np.max(np.abs(a - b) / np.maximum(np.abs(a), 1e-300))) if a.size else 0.0
        if fa != fb or a.shape != b.shape:
            d = 1.0
        print(f"{name:10s} {'steady batch':34s} {f'{len(designs)} designs, {len(fa)} failed':34s} {d:.3e}")
        worst = max(worst, d)
    return worst


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    if not COMPILED:
        print("numba is not installed: nothing to compare against")
        return 1
    worst = max(compare(args.quick), compare_batch())
    print(f"largest relative difference, C kernel against numba: {worst:.3e} (target <= 1e-12)")
    return 0 if worst <= 1e-12 else 1


if __name__ == "__main__":
    sys.exit(main())
