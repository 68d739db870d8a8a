"""Joint friction's cost in the kernel (issue 69): issue 69's slider-crank (validation/data/
slidercrank_friction_scenario.toml: friction in its three pins and its guide) against the same
machine with mu = 0 (no friction: the kernel's frictionless path), each run 3 s from rest on the
fast path at its default rtol. The cost per accepted step and per right-hand side, the fastest of
several runs of the integration alone (the model and its tables built beforehand), measured in this
run; and the Python and native FMUs' step loops at 1 ms through fmpy, both ways. Target: a step
with friction at most 1.5x the frictionless step."""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "validation" / "data" / "slidercrank_friction_scenario.toml"
BOUND = 1.5


def _kernel_costs(scenario, repeats: int) -> dict:
    """us per accepted step and per right-hand side of the fast path over 3 s from rest, the fastest
    of ``repeats`` runs of the kernel alone (the model and its tables built beforehand)."""
    from crankfmu.dynamics.tabulated import table_of
    from crankfmu.integrators.fast import TABLE_TOLERANCE, FastIntegrator

    model = scenario.build(table=TABLE_TOLERANCE)
    table_of(model.reduced, TABLE_TOLERANCE)
    best = None
    for _ in range(repeats):
        started = time.perf_counter()
        run = FastIntegrator().run(model.equation, 0.0, model.y0, 3.0)
        elapsed = time.perf_counter() - started
        if best is None or elapsed < best[0]:
            best = (elapsed, run)
    elapsed, run = best
    return {"us_per_step": 1e6 * elapsed / run.n_steps, "us_per_rhs": 1e6 * elapsed / run.n_rhs,
            "steps": run.n_steps, "rhs": run.n_rhs}


def measure(repeats: int = 5) -> dict:
    import crankfmu
    from crankfmu.cli import main
    from crankfmu.fmi.python.build import build
    from fmu_step import step_loop

    with_friction = crankfmu.load_scenario(SCENARIO)
    without = with_friction.with_params(mu_pin=0.0, mu_guide=0.0)
    out = {"with": _kernel_costs(with_friction, repeats), "without": _kernel_costs(without, repeats)}
    with tempfile.TemporaryDirectory() as tmp:
        # the frictionless twin: the same file with its mu at 0
        twin = Path(tmp) / "slidercrank_no_friction_scenario.toml"
        text = SCENARIO.read_text().replace('mu_pin = { value = 0.1,', 'mu_pin = { value = 0.0,')
        twin.write_text(text.replace('mu_guide = { value = 0.1,', 'mu_guide = { value = 0.0,'))
        for what, path in (("with", SCENARIO), ("without", twin)):
            fmu = build("scenario", str(path), Path(tmp) / what, name="SliderFriction")
            out[what]["fmu_us_per_step"] = 1e6 * min(step_loop(fmu, 1e-3, 1.0)[0] for _ in range(repeats))
            with contextlib.redirect_stdout(io.StringIO()):            # (its "built ..." line)
                status = main(["fmu", str(path), "--native", "--out", str(Path(tmp) / what / "native")])
            if status != 0:
                raise SystemExit("the native FMU's build failed")
            native = next((Path(tmp) / what / "native").glob("*.fmu"))
            out[what]["native_us_per_step"] = 1e6 * min(step_loop(native, 1e-3, 1.0)[0] for _ in range(repeats))
    return out


def targets(measured: dict) -> list[tuple[str, str, bool]]:
    w, wo = measured["with"], measured["without"]
    ratio = w["us_per_step"] / wo["us_per_step"]
    fmu = w["fmu_us_per_step"] / wo["fmu_us_per_step"]
    return [(f"a fast-path step of issue 69's slider-crank with friction in its 4 joints <= {BOUND:g}x its "
             "frictionless step (mu = 0)",
             f"{w['us_per_step']:.2f} vs {wo['us_per_step']:.2f} us/step ({w['us_per_rhs']:.2f} vs "
             f"{wo['us_per_rhs']:.2f} us per right-hand side), ratio {ratio:.2f}", ratio <= BOUND),
            ("the Python FMU's 1 ms step with friction against mu = 0 (reported)",
             f"{w['fmu_us_per_step']:.2f} vs {wo['fmu_us_per_step']:.2f} us/step, ratio {fmu:.2f}", None),
            ("the native FMU's 1 ms step with friction against mu = 0 (reported)",
             f"{w['native_us_per_step']:.2f} vs {wo['native_us_per_step']:.2f} us/step, ratio "
             f"{w['native_us_per_step'] / wo['native_us_per_step']:.2f}", None)]


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    for target, figure, met in targets(measure()):
        print(f"| {target} | {figure} | {'-' if met is None else 'MET' if met else 'NOT MET'} |")
