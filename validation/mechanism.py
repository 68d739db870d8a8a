"""A mechanism FMU in torque causality (Python or native) against the in-process reference.

Each interface the FMU offers is checked on its own: Co-Simulation (the FMU's own stepper) and
Model Exchange (fmpy's CVode on the FMU's derivatives and event indicators). Every output the FMU
declares is compared with the reference at the same communication points: the contract's, the
scenario's ``[[outputs]]``, the ports' s, v, a and the joint reactions (Newton-Euler at the
reference's states). The paper's numbers and the hard cases (cases.py) follow, and, when both
builds of one scenario are validated, the native FMU against the Python one.
"""

from __future__ import annotations

import math
import zipfile

import numpy as np

from . import cases as hard_cases
from .compare import (compare_builds, cycles, energy_residual, max_abs_error, phi_quadrature_residual,
                      relative_error)
from .model_exchange import tightened_run
from .paper import check_paper
from .reference import cached_reference, second_method_gap
from .figures import plot_outputs

#: Co-Simulation: the FMU's stepper at its default rtol (1e-10 or 1e-11) leaves about 1e-9 of each
#: output's scale; 1e-6 is the contract's bound
OUTPUT_TOLERANCE = 1e-6
#: Model Exchange: fmpy's CVode (BDF) at rtol 1e-10 leaves about 1e-8 of omega1's scale and 6e-9 of
#: the work in the energy balance over seed 000's 2 s (measured); the checks keep the contract's
#: 1e-6 on the outputs and 1e-7 on the energy balance, and the rtol is tightened where a case needs
#: it (model_exchange.py)
ME_ENERGY_TOLERANCE = 1e-7
#: ... except epsilon1 and the joint reactions (algebraic in epsilon1 and in a switched force's
#: value): fmpy's CVode locates a slider force's switch to its root-finding tolerance, and those
#: outputs carry what that leaves (1.8e-6 measured on the Whitworth shaper at rtol 1e-10 and
#: 8.8e-7 at 1e-12: not an integration error)
ME_ALGEBRAIC_TOLERANCE = 1e-5
#: the native FMU against the Python one of the same file, both in Co-Simulation: one C kernel
#: steps both, and both read their [[outputs]] and reactions from the same tables (checked to 1e-11
#: and 1e-8, fmi.python.slave.REACTION_TOLERANCE, of each term's scale) by the same C rules; the bars
#: leave room for the native tables' decimal text
NATIVE_PYTHON_TOLERANCE = {"contract": 1e-9, "quantity": 1e-9, "reaction": 1e-7}
LS_REF = "extra/org.fmi-standard.fmi-ls-ref"
INTERFACE_TAG = {"CoSimulation": "cs", "ModelExchange": "me"}


def interfaces(fmu) -> list[str]:
    """The interfaces the harness drives: each one the FMU declares."""
    return list(fmu.kind.interfaces)


def carried_reference(fmu):
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


def output_group(name: str, reactions, quantities) -> str:
    """contract, quantity ([[outputs]], ports) or reaction: what an output's tolerance depends on."""
    return "reaction" if name in reactions else "quantity" if name in quantities else "contract"


def output_bars(fmu, scenario, model, run, ref, me: bool) -> tuple[dict, dict, dict]:
    """({output: bar}, the model at the FMU's states, their groups) for the default experiment: the
    one home of each output's bar, which the Model Exchange tightening and the checks both read.

    The bar is the contract's 1e-6 of the output's largest value (Model Exchange: 1e-5 for epsilon1
    and the joint reactions, ME_ALGEBRAIC_TOLERANCE), plus, for an output that is a function of the
    state (epsilon1, M_load, the reactions, ...), what the states' own difference from the
    reference carries through it: a steep load turns 1e-8 rad into 1e-6 of its value. That part is
    measured, the model at the FMU's states against the model at the reference's, plus the
    at-own-states bar; the FMU's own share is bounded by the at-own-states checks."""
    at_state, groups = model_at_states(scenario, model, run["phi1"], run["omega1"], run["epsilon1"])
    bars = {}
    for name in fmu.outputs:
        if name not in ref.values:
            continue
        tol = OUTPUT_TOLERANCE
        if me and (name == "epsilon1" or name in ref.reaction_names):
            tol = ME_ALGEBRAIC_TOLERANCE
        if name in at_state:
            carried = relative_error(at_state[name], ref[name])
            if math.isfinite(carried):
                tol = float(f"{tol + carried + AT_STATE_TOLERANCE[groups[name]]:.2g}")
        bars[name] = tol
    return bars, at_state, groups


def compare_outputs(prefix, fmu, run, ref, checks, bars: dict, note="") -> list[dict]:
    """One check per output the FMU declares: its largest error relative to the output's scale
    against its bar (``bars``, output_bars). An output the reference cannot give is a failed check,
    not a silent skip."""
    rows = []
    for name in fmu.outputs:
        if name not in ref.values:
            checks.holds(f"{prefix}.{name}_compared", False, note="the reference has no such output")
            continue
        tol = bars[name]
        a, r = max_abs_error(run[name], ref[name]), relative_error(run[name], ref[name])
        checks.at_most(f"{prefix}.{name}_rel_error", r, tol, note=note)
        rows.append({"output": name, "unit": fmu.units.get(name) or "1", "abs": a, "rel": r, "tol": tol,
                     "group": output_group(name, ref.reaction_names, ref.quantity_names)})
    return rows



#: the FMU's outputs as functions of its own states, against the in-process model at those states:
#: no integration error enters, only the model. One C rule set tabulates the native model (its
#: tables checked to 1e-11 of each term's scale, fmi.python.slave); a sum of terms of opposite signs can
#: lose up to three digits against its own peak, so 1e-8 of the output's largest value. The joint
#: reactions come from tables checked to 1e-8 (fmi.python.slave.REACTION_TOLERANCE): 1e-7.
AT_STATE_TOLERANCE = {"model": 1e-8, "quantity": 1e-8, "reaction": 1e-7}


def expected_units(scenario) -> dict[str, str]:
    """The unit each output of a mechanism FMU of ``scenario`` must declare: the contract's, the
    [[outputs]]' and the ports' (from their coordinates), the joint reactions'."""
    from crankfmu.contract import OUTPUTS, SPEED_OUTPUTS
    from crankfmu.fmi.variables import friction_variables, output_quantities, reaction_variables

    definition = scenario.mechanism_definition()
    units = {v.name: v.unit for v in (*SPEED_OUTPUTS, *OUTPUTS)}
    units.update({q.name: q.unit(definition) for q in output_quantities(scenario)})
    units.update({v.name: v.unit for v in (*reaction_variables(scenario), *friction_variables(scenario))})
    return units


def check_units(fmu, scenario, checks, prefix: str):
    """Every output's unit as the modelDescription declares it against the unit the model gives it:
    a host converts by the declared unit, so a wrong one is a wrong number in the host."""
    wanted = expected_units(scenario)
    wrong = [f"{n}: declares {fmu.units.get(n) or 'none'}, is {wanted[n]}" for n in fmu.outputs
             if n in wanted and (fmu.units.get(n) or "1") != wanted[n]]
    unknown = [n for n in fmu.outputs if n not in wanted]
    checks.holds(f"{prefix}.output_units", not wrong and not unknown,
                 note="; ".join(wrong + [f"{n}: not an output of the data file" for n in unknown])
                 or f"{len(fmu.outputs)} outputs, each in its unit")


def model_at_states(scenario, model, phi1, omega1, epsilon1) -> tuple[dict, dict]:
    """The in-process model of ``scenario`` (``model``, built) at given states: ({output: array}, {output: group}) for
    M_load, J_red, E_kin and epsilon1 ("model"), the [[outputs]] and ports ("quantity") and the
    joint reactions and frictions ("reaction"). epsilon1 is the free motion's (a crank held on the motor's switch
    or stuck at rest has another)."""
    from crankfmu.fmi.variables import output_quantities, reaction_variables
    from crankfmu.mechanisms.quantities import evaluate_all

    outputs = model.equation.outputs(phi1, omega1)
    values = {k: v for k, v in outputs.items() if k in ("M_load", "J_red", "E_kin", "epsilon1")}
    groups = dict.fromkeys(values, "model")
    # joint friction's outputs (not its work, a state): the free motion's frictions, Newton-Euler at the
    # FMU's states, as the reactions (they are their part)
    friction = {k: v for k, v in outputs.items() if k in model.equation.friction_names and k != "W_friction"}
    values.update(friction)
    groups.update(dict.fromkeys(friction, "reaction"))
    quantities = output_quantities(scenario)
    reactions = reaction_variables(scenario)
    kin = model.mechanism.kinematics(phi1) if quantities or reactions else None
    if quantities:
        found = evaluate_all(quantities, kin, omega1, epsilon1)
        values.update(found)
        groups.update(dict.fromkeys(found, "quantity"))
    if reactions:
        from crankfmu.dynamics.reactions import joint_reactions, reaction_arrays

        found = reaction_arrays(joint_reactions(model.reduced, phi1, omega1, epsilon1, kin=kin))
        values.update(found)
        groups.update(dict.fromkeys(found, "reaction"))
    return {k: np.asarray(v, dtype=float) for k, v in values.items()}, groups


def check_at_own_states(prefix, run, at_state: dict, groups: dict, checks) -> list[dict]:
    """M_load, J_red, E_kin, the [[outputs]], the ports and the joint reactions the FMU reports,
    against the in-process model of its data file evaluated at the FMU's own phi1, omega1 and
    epsilon1 (model_at_states; bars AT_STATE_TOLERANCE): a model that differs from its data file (a
    load off by 1e-6, a port of the wrong sign, a carried file that is not the binary's) fails here
    whatever the integrator's error."""
    rows = []
    for name, expected in at_state.items():
        if name not in run.values or name == "epsilon1":       # epsilon1: the free motion's only
            continue
        tol = AT_STATE_TOLERANCE[groups[name]]
        r = relative_error(run[name], expected)
        checks.at_most(f"{prefix}.{name}_at_own_states", r, tol,
                       note="the in-process model of the data file at the FMU's own states: no integration error; "
                            f"bar from the tables' checked accuracy ({groups[name]})")
        rows.append({"output": name, "rel": r, "tol": tol})
    return rows


def check_default(fmu, scenario, checks, out, interface: str) -> dict:
    """The default experiment through fmpy against the reference at the same points."""
    exp = scenario.experiment
    tag = INTERFACE_TAG[interface]
    prefix = f"{fmu.name}.{fmu.kind.build}.{tag}.default"
    me = interface == "ModelExchange"

    def run_at(rtol):
        return fmu.run(exp.stop_time, exp.output_interval, label=f"default ({tag})", interface=interface, rtol=rtol)

    model = scenario.build()
    judged = [None, None]  # the last run judged and its bars: the run the tightening ends with is not judged again

    def bars_of(attempt):
        if judged[0] is not attempt:
            judged[:] = attempt, output_bars(fmu, scenario, model, attempt,
                                             cached_reference(scenario, attempt.time, model=model), me)
        return judged[1]

    rtol_note = ""
    if me:
        def worst_of(attempt):
            ref = cached_reference(scenario, attempt.time, model=model)
            return max([energy_residual(attempt.values) / ME_ENERGY_TOLERANCE,
                        *(relative_error(attempt[n], ref[n]) / bar for n, bar in bars_of(attempt)[0].items())])

        tightened = tightened_run(run_at, worst_of)
        run, rtol_note = tightened.run, tightened.note()
    else:
        run = run_at(None)
    if run.error:
        checks.holds(f"{prefix}.ran", False, note=run.error)
        return {"interface": interface}
    ref = cached_reference(scenario, run.time, model=model)
    bars, at_state, groups = bars_of(run)
    gap = second_method_gap(scenario, run.time)
    rows = compare_outputs(prefix, fmu, run, ref, checks, bars,
                           note=f"bar: the contract's 1e-6 of the output's largest value, plus what the states' "
                                f"difference carries through a function of the state; the reference (DOP853 with "
                                f"its kinks located, rtol {ref.settings.get('rtol', 1e-12):g}) and a second method "
                                f"(the fast path at rtol 1e-13) differ by {gap:.1e} of omega1, on the "
                                f"{exp.output_interval:g} s output grid" + (f"; {rtol_note}" if me else ""))
    check_at_own_states(prefix, run, at_state, groups, checks)
    checks.at_most(f"{prefix}.energy_residual", energy_residual(run.values), ME_ENERGY_TOLERANCE if me else 1e-8,
                   note="the works are integrated with the state" + (f"; {rtol_note}" if me else ""))
    floor = phi_quadrature_residual(ref.time, ref["phi1"], ref["omega1"], ref["epsilon1"])
    checks.at_most(f"{prefix}.phi1_is_integral_of_omega1",
                   phi_quadrature_residual(run.time, run["phi1"], run["omega1"], run["epsilon1"]),
                   2.0 * floor + (1e-6 if me else 1e-8), "rad",
                   note=f"Hermite-rule floor on the reference {floor:.2e} rad")
    by_of = {}
    for q in scenario.quantities:
        by_of.setdefault(q.of, {})[q.order] = q.name
    for names in by_of.values():
        if {0, 1, 2} <= set(names) and all(names[o] in run.values for o in (0, 1, 2)):
            x, v, a = names[0], names[1], names[2]
            floor = phi_quadrature_residual(ref.time, ref[x], ref[v], ref[a])
            checks.at_most(f"{prefix}.{x}_is_integral_of_{v}", phi_quadrature_residual(run.time, run[x], run[v], run[a]),
                           2.0 * floor + (1e-6 if me else 1e-8), note=f"Hermite-rule floor on the reference {floor:.2e}")
    fc, rc = cycles(run.time, run["phi1"], run["omega1"]), cycles(ref.time, ref["phi1"], ref["omega1"])
    k = min(exp.summary_cycle, len(fc), len(rc))
    if k:
        # a cycle's min, max and mean are read from the output points omega1 is compared on: they are
        # off by at most omega1's largest error, whose bar is omega1's
        cycle_bar = bars["omega1"] * float(np.max(np.abs(ref["omega1"])))
        for key in ("omega1_min", "omega1_max", "omega1_mean"):
            checks.at_most(f"{prefix}.cycle{k}_{key}_error", fc[k - 1][key] - rc[k - 1][key], cycle_bar, "rad/s",
                           note="bar: omega1's, in rad/s (the cycle's values are read from the same output points)")
    carried = carried_reference(fmu)
    if carried is not None and carried["time"].shape == run.time.shape:
        checks.at_most(f"{prefix}.omega1_vs_carried_fmi_ls_ref", relative_error(run["omega1"], carried["omega1"]),
                       OUTPUT_TOLERANCE)
    plot = plot_outputs(run, ref, [r["output"] for r in rows], {r["output"]: r["tol"] for r in rows},
                        out / f"{fmu.name}_{fmu.kind.build}_{tag}_default.png",
                        f"{fmu.title}, {interface}, default experiment ({scenario.name})")
    section = {"interface": interface, "span": exp.stop_time - exp.start_time, "step": exp.output_interval,
               "fmu_wall": run.wall, "ref_wall": ref.wall, "rows": rows, "plot": plot.name, "run": run}
    return section


def check_model(fmu, scenario, checks, out, subset: str) -> dict:
    """Everything a torque-causal mechanism FMU gets: fmpy's validation, the default experiment in
    each interface, the paper's numbers (on the Co-Simulation run) and every hard case in each
    interface (not in the ``demo`` subset; the quick ones over their quick spans in ``quick``).
    Returns the report's section."""
    from fmpy.validation import validate_fmu

    from .report import shortened

    quick = shortened(subset)
    problems = validate_fmu(str(fmu.path))
    checks.holds(f"{fmu.name}.{fmu.kind.build}.fmpy_validate", not problems, note="; ".join(map(str, problems))[:300])
    check_units(fmu, scenario, checks, f"{fmu.name}.{fmu.kind.build}")
    section = {"default": [], "hard": [], "paper": []}
    for interface in interfaces(fmu):
        default = check_default(fmu, scenario, checks, out, interface)
        section["default"].append(default)
        if interface == "CoSimulation" and "run" in default:
            n_paper = len(checks.items)
            check_paper(scenario, scenario.build(), default["run"], checks, f"{fmu.name}.{fmu.kind.build}")
            section["paper"] = checks.items[n_paper:]
    case_file = hard_cases.load_cases(scenario.name)
    for interface in interfaces(fmu) if subset != "demo" else ():
        for case in case_file.cases:
            if quick and not case.quick:
                continue
            for g in case_file.gravity:
                unsettable = unsettable_values(fmu, {**case.set, "g": g})
                if unsettable and not case.refused_parameter:
                    name = f"{fmu.name}.{fmu.kind.build}.{INTERFACE_TAG[interface]}.hard.{case.name}.g{g:g}"
                    checks.skip(name, f"the FMU cannot take {unsettable}")
                    section["hard"].append({"case": case.name, "g": g, "stop_time": case.span(quick),
                                            "step": case.step, "expect": case.expect, "interface": interface,
                                            "note": f"not run: the FMU cannot take {unsettable}",
                                            "checks": checks.items[-1:]})
                    continue
                row = hard_cases.run_case(fmu, scenario, case, g, quick, checks, interface)
                if "fmu" in row:
                    run, ref = row.pop("fmu"), row.pop("ref")
                    names = [n for n in ("omega1", "phi1", "E_kin") if n in run.values]
                    row["plot"] = plot_outputs(
                        run, ref, names, {"omega1": case.omega1_tolerance},
                        out / f"{fmu.name}_{fmu.kind.build}_{INTERFACE_TAG[interface]}_{case.name}_g{g:g}.png",
                        f"{fmu.title}, {interface}, {case.name}, g = {g:g} m/s2").name
                section["hard"].append(row)
    return section


#: what a host may set before initialisation, by the FMI standard: a parameter (fixed or tunable)
#: or an input; a constant, a calculated parameter, an output or a local cannot be set
SETTABLE_CAUSALITIES = ("parameter", "input")


def unsettable_values(fmu, values: dict) -> str:
    """The values a case sets that the FMU cannot take, as its modelDescription declares (the
    variable is absent, or its causality or variability forbids setting it); "" when it takes them
    all. No rule about builds: a native FMU takes whatever parameters it declares."""
    refused = []
    for name in values:
        v = fmu.variables.get(name)
        if v is None:
            refused.append(f"{name} (it declares no such variable)")
        elif v.causality not in SETTABLE_CAUSALITIES or v.variability == "constant":
            refused.append(f"{name} (declared causality {v.causality}, variability {v.variability}: "
                           "not settable before initialisation)")
    return ", ".join(refused)


def check_native_against_python(native, python, scenario, checks, native_run, python_run) -> dict:
    """The two builds of one scenario file (either causality), both in Co-Simulation on the same
    run: every output they share, to NATIVE_PYTHON_TOLERANCE of its scale by kind of output (the
    kinds from the scenario file: its joint reactions, its [[outputs]] and ports)."""
    from crankfmu.fmi.variables import output_quantities, reaction_variables

    reactions = {v.name for v in reaction_variables(scenario)}
    quantities = {q.name for q in output_quantities(scenario)}

    def tolerance_of(name):
        group = output_group(name, reactions, quantities)
        return NATIVE_PYTHON_TOLERANCE[group], group
    return compare_builds(native, python, checks, native_run, python_run, tolerance_of)
