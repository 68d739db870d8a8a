"""Hard cases: data files ``cases/<scenario>.toml``, each case run through the FMU and in process.

Every case is run once per gravity value of its file, and checked for the generic invariants
(omega1 and phi1 against the reference, the energy balance on the FMU's own outputs, phi1 as the
integral of omega1, the last full cycle's delta) plus its own stated expectation:
``omega1_below`` (the crank reverses), ``schemes_refuse`` (the crank-angle schemes raise
SchemeError rather than return numbers), ``transmission_below_deg`` (the geometry really is near
singular), ``refused_parameter`` (the FMU refuses with fmi2Error and a log that names it).
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from crankfmu.errors import CrankfmuError, DefinitionError, SchemeError
from crankfmu.simulation import simulate

from .compare import cycles, energy_residual, phi_quadrature_residual, relative_error
from .model_exchange import START_RTOL, tightened_run
from .reference import cached_reference

CASES_DIR = Path(__file__).resolve().parent / "cases"
SCHEMES = ("badoiu-eq17", "lv-eq3")


@dataclass
class HardCase:
    name: str
    expect: str
    set: dict
    stop_time: float
    step: float
    quick_stop_time: float | None = None
    quick: bool = True
    reference: str = "reference"           # or "radau", or "periodic" (long runs)
    omega1_tolerance: float = 1e-6         # relative to max |omega1|
    phase_tolerance: float | None = None   # rad at the end; default omega1_tolerance*max|omega1|*stop_time
    energy_tolerance: float = 1e-8
    omega1_below: float | None = None
    schemes_refuse: bool = False
    refused_parameter: str | None = None
    transmission_below_deg: float | None = None
    transmission_links: list = field(default_factory=list)

    @classmethod
    def from_dict(cls, data: dict, where: str) -> "HardCase":
        known = set(cls.__dataclass_fields__)
        unknown = sorted(set(data) - known)
        if unknown:
            raise DefinitionError(f"{where}: unknown key(s) {', '.join(unknown)} in case "
                                  f"{data.get('name')!r} (known: {', '.join(sorted(known))})")
        try:
            case = cls(**data)
        except TypeError as exc:
            raise DefinitionError(f"{where}: case {data.get('name')!r}: {exc}") from None
        for key in ("stop_time", "step"):
            if not getattr(case, key) > 0:
                raise DefinitionError(f"{where}: case {case.name!r}: {key} must be > 0 s")
        return case

    def span(self, quick: bool) -> float:
        return self.quick_stop_time if quick and self.quick_stop_time else self.stop_time


@dataclass
class CaseFile:
    gravity: list[float]
    cases: list[HardCase]
    work_precision: bool          # run the speed-against-error study on this scenario


def load_cases(scenario_name: str) -> CaseFile:
    """The scenario's case file; no file means no hard cases and no study."""
    path = CASES_DIR / f"{scenario_name}.toml"
    if not path.is_file():
        return CaseFile([], [], False)
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    return CaseFile([float(g) for g in data.get("gravity", [0.0])],
                    [HardCase.from_dict(c, str(path)) for c in data.get("case", [])],
                    bool(data.get("work_precision", False)))


def min_transmission_deg(model, links) -> float:
    """Smallest angle (deg) between two links over a crank turn: 0 at a change point."""
    grid = np.linspace(0.0, 2 * math.pi, 3601)
    kin = model.mechanism.kinematics(grid)
    a, b = (kin.q[name] for name in links)
    return float(np.degrees(np.min(np.arcsin(np.clip(np.abs(np.sin(a - b)), 0.0, 1.0)))))


def _names(text: str, parameter: str) -> bool:
    return re.search(rf"(?<![A-Za-z0-9_]){re.escape(parameter)}(?![A-Za-z0-9_])", text) is not None


def run_case(fmu, scenario, case: HardCase, g: float, quick: bool, checks, interface: str = "CoSimulation") -> dict:
    """Run one case at one gravity through one interface; record its checks; return a row of the
    report's table. In Model Exchange the FMU's own rtol does not act: CVode steps it, from
    model_exchange.START_RTOL (or the case's rtol if tighter), tightened until the case's bars hold
    or the floor is reached (model_exchange.py); the bars are the case's, at least 1e-6 on omega1
    and 1e-7 on the energy balance (what CVode leaves at 1e-10, measured on seed 000)."""
    me = interface == "ModelExchange"
    prefix = f"{fmu.name}.{fmu.kind.build}.{'me' if me else 'cs'}.hard.{case.name}.g{g:g}"
    stop = case.span(quick)
    fmu_values = {**case.set, "g": g}
    if me:
        fmu_values.pop("rtol", None)
    model_values = {k: v for k, v in fmu_values.items() if k in scenario.parameters}
    n_before = len(checks.items)
    row = {"case": case.name, "g": g, "stop_time": stop, "step": case.step, "expect": case.expect,
           "interface": interface}
    omega_tol = max(case.omega1_tolerance, 1e-6) if me else case.omega1_tolerance
    energy_tol = max(case.energy_tolerance, 1e-7) if me else case.energy_tolerance
    tightened, case_scenario = None, None
    if me and not case.refused_parameter:
        case_scenario = scenario.with_params(**model_values)

        def worst_of(attempt):
            ref = cached_reference(case_scenario, attempt.time, case.reference)
            return max(relative_error(attempt["omega1"], ref["omega1"]) / omega_tol,
                       energy_residual(attempt.values) / energy_tol)

        tightened = tightened_run(lambda r: fmu.run(stop, case.step, fmu_values, label=case.name,
                                                    interface=interface, rtol=r),
                                  worst_of, start=case.set.get("rtol", START_RTOL))
        run = tightened.run
        row["rtol"] = tightened.rtol
    else:
        run = fmu.run(stop, case.step, fmu_values, label=case.name, interface=interface,
                      rtol=START_RTOL if me else None)
    rtol_note = tightened.note() if tightened else ""
    row["fmu_wall"] = run.wall

    if case.refused_parameter:
        p = case.refused_parameter
        log = "\n".join(run.log)
        checks.holds(f"{prefix}.refused_with_fmi2Error", run.error is not None, note=run.error or "it ran")
        checks.holds(f"{prefix}.log_names_{p}", _names(log, p), note=log[-300:])
        try:
            scenario.with_params(**model_values).build()
            in_process = ""
        except CrankfmuError as exc:
            in_process = str(exc)
        checks.holds(f"{prefix}.in_process_error_names_{p}", _names(in_process, p), note=in_process[-300:])
        last = (log.splitlines()[-1] if log else run.error or "")
        row["note"] = "refused: ..." + last[-150:] if len(last) > 150 else "refused: " + last
        row["checks"] = checks.items[n_before:]
        return row

    if run.error is not None:
        checks.holds(f"{prefix}.ran", False, note=f"{run.error}; log: {' | '.join(run.log[-3:])}")
        row["checks"] = checks.items[n_before:]
        return row

    case_scenario = case_scenario or scenario.with_params(**model_values)
    ref = cached_reference(case_scenario, run.time, case.reference)
    row["ref_wall"] = ref.wall
    row["fmu"], row["ref"] = run, ref

    w_scale = float(np.max(np.abs(ref["omega1"])))
    e_omega = relative_error(run["omega1"], ref["omega1"])
    checks.at_most(f"{prefix}.omega1_rel_error", e_omega, omega_tol,
                   note=_bar_note(case, me, ref, rtol_note))
    e_phi = abs(float(run["phi1"][-1] - ref["phi1"][-1]))
    phase_tol = case.phase_tolerance or omega_tol * w_scale * stop + 1e-9
    checks.at_most(f"{prefix}.phi1_end_error", e_phi, phase_tol, "rad")
    residual = energy_residual(run.values)
    checks.at_most(f"{prefix}.energy_residual", residual, energy_tol,
                   note="the works are integrated with the state" + (f"; {rtol_note}" if rtol_note else ""))
    row.update(omega1_rel_error=e_omega, phi1_end_error=e_phi, energy_residual=residual)
    if case.reference == "periodic":
        row["note"] = (f"{ref.settings['cycles_extended']:.0f} turns on the settled cycle "
                       f"(T = {ref.settings['period']:.9f} s, reference phase uncertainty "
                       f"{ref.settings['phase_uncertainty']:.1e} rad)")
    if case.step <= 1e-3 + 1e-15:
        floor = phi_quadrature_residual(ref.time, ref["phi1"], ref["omega1"], ref["epsilon1"])
        measured = phi_quadrature_residual(run.time, run["phi1"], run["omega1"], run["epsilon1"])
        checks.at_most(f"{prefix}.phi1_is_integral_of_omega1", measured, 2.0 * floor + (1e-6 if me else 1e-8), "rad",
                       note=f"Hermite-rule floor on the exact reference {floor:.2e} rad")
    fc, rc = cycles(run.time, run["phi1"], run["omega1"]), cycles(ref.time, ref["phi1"], ref["omega1"])
    if fc and rc and len(fc) == len(rc) and case.step <= 1e-2:
        checks.at_most(f"{prefix}.last_cycle_delta_error", fc[-1]["delta"] - rc[-1]["delta"], omega_tol * 10)
        row["delta_last_cycle"] = fc[-1]["delta"]

    if case.omega1_below is not None:
        w_min = float(np.min(run["omega1"]))
        checks.below(f"{prefix}.omega1_min", w_min, case.omega1_below, "rad/s")
        row["note"] = f"omega1 from {w_min:.3f} to {float(np.max(run['omega1'])):.3f} rad/s"
    if case.schemes_refuse and not me:
        for method in SCHEMES:
            try:
                simulate(case_scenario, t_end=stop, method=method)
                refused, why = False, "returned numbers"
            except SchemeError as exc:
                refused, why = True, str(exc)
            checks.holds(f"{prefix}.{method}_refuses", refused, note=why[:200])
    if case.transmission_below_deg is not None:
        mu = min_transmission_deg(ref.model, case.transmission_links)
        checks.below(f"{prefix}.min_transmission_angle", mu, case.transmission_below_deg, "deg")
        row["note"] = (f"min transmission angle {mu:.2f} deg, Jacobian conditioning "
                       f"{ref.model.conditioning:.3f}")
    row["checks"] = checks.items[n_before:]
    return row


def _bar_note(case: HardCase, me: bool, ref, rtol_note: str) -> str:
    """Why omega1's bar is what it is: the case's stated bar, the reference's own error, the grid."""
    why = (f"bar: the case's {case.omega1_tolerance:g} of max |omega1|" + (" (at least 1e-6 in Model Exchange)" if me else "")
           + f"; the in-process reference ({ref.settings.get('method', case.reference)}, "
             f"rtol {ref.settings.get('rtol', '-')}) on the {case.step:g} s output grid")
    return why + (f"; {rtol_note}" if rtol_note else "")
