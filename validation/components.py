"""The component FMUs (Drive, DriveSpeed, DieCushion, ElasticShaft, RodString) against their own
closed forms.

* the drive (torque causality): its step response from rest with the crank held, and at a held
  crank speed, against scipy's DOP853 at rtol 1e-12 on the drive's differential equations (the
  FMU steps the exact solution of the held-input linear system: another method);
* the drive in speed causality: the same with its rotor, a held load torque;
* the die cushion: its force at every communication point against the data file's law
  k (s - s_seat - L_free) + c v at the inputs of the step;
* the elastic shaft: two sides turning unevenly, its twist the sum of the held speed differences
  times the step and its torque k twist + c (omega_a - omega_b) at every communication point;
* the rod string: hanging at rest its load is the string's buoyant weight; a stroke of 600 s carries
  Wrf + Fo while the plunger rises and Wrf while it falls (the quasi-static closed form), and
  its every output equals the in-process string stepped with the same motion;
* a native component FMU against the Python FMU of the same file, on the same case.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from .compare import compare_builds, max_abs_error, relative_error
from .fmu_runner import input_signal
from .figures import plot_outputs
from .reference import ReferenceRun

#: the drive's FMU steps the exact solution; DOP853 at rtol 1e-12 is good to about 1e-11
DRIVE_TOLERANCE = 1e-9
#: the cushion is a law: the FMU evaluates it in double precision
CUSHION_TOLERANCE = 1e-13
#: the shaft's twist is a running sum of 1000 differences: rounding grows like its count
SHAFT_TOLERANCE = 1e-12
#: the quasi-static stroke (tests/test_rodstring.py): damping 3e-4, inertia 1e-6, the first mode's
#: ringing after pick-up 7e-4 of Wrf + Fo
QUASI_STATIC_TOLERANCE = 1e-3


def _values(fmu) -> dict:
    return {name: float(v.start) for name, v in fmu.variables.items()
            if v.causality in ("parameter", "input") and v.start is not None}


def _compare(prefix, fmu, run, ref_values, checks, tol) -> list[dict]:
    rows = []
    for name in fmu.outputs:
        if name not in ref_values:
            checks.holds(f"{prefix}.{name}_compared", False, note="no closed form for this output")
            continue
        r = relative_error(run[name], ref_values[name])
        checks.at_most(f"{prefix}.{name}_rel_error", r, tol)
        rows.append({"output": name, "unit": fmu.units.get(name) or "1",
                     "abs": max_abs_error(run[name], ref_values[name]), "rel": r, "tol": tol})
    return rows


def _validated(fmu, checks):
    from fmpy.validation import validate_fmu

    problems = validate_fmu(str(fmu.path))
    checks.holds(f"{fmu.name}.{fmu.kind.build}.fmpy_validate", not problems, note="; ".join(map(str, problems))[:300])


def _entry(fmu, run, ref_values, rows, what, out, tag) -> dict:
    ref = ReferenceRun("closed form", run.time, ref_values, 0.0)
    plot = plot_outputs(run, ref, [r["output"] for r in rows], {r["output"]: r["tol"] for r in rows},
                        out / f"{fmu.name}_{fmu.kind.build}_{tag}.png", f"{fmu.title}: {what}")
    return {"interface": "CoSimulation", "span": float(run.time[-1]), "step": float(run.time[1] - run.time[0]),
            "fmu_wall": run.wall, "ref_wall": 0.0, "rows": rows, "plot": plot.name, "what": what, "run": run}


#: a component's native FMU against its Python FMU: both step the components' C physics
#: (crank_components.c), so they differ by nothing but how a host's doubles travel
NATIVE_PYTHON_TOLERANCE = 1e-12


def check_native_against_python(native, python, checks, native_run, python_run) -> dict:
    """The two builds of one component file on the same case: every output they share."""
    return compare_builds(native, python, checks, native_run, python_run,
                          lambda name: (NATIVE_PYTHON_TOLERANCE, "component"))


def check_drive(fmu, checks, out, quick: bool) -> dict:
    from crankfmu.dynamics.drive import load_drive

    _validated(fmu, checks)
    file = load_drive(fmu.scenario_source)
    values = _values(fmu)
    drive = file.drive(values)
    speed = fmu.kind.causality == "speed"
    exp = file.experiment
    span = min(exp.stop_time, 0.5) if quick else exp.stop_time
    section = {"default": [], "hard": []}
    cases = ([("load_30", {"tau_load": 30.0})] if speed else
             [("step_from_rest", {"omega": 0.0}), ("held_speed_15", {"omega": 15.0})])
    for tag, inputs in cases:
        run = fmu.run(span, exp.output_interval, inputs, label=tag)
        prefix = f"{fmu.name}.{fmu.kind.build}.{tag}"
        if run.error:
            checks.holds(f"{prefix}.ran", False, note=run.error)
            continue
        v = {**values, **inputs}
        if speed:
            y0 = (v["i_start"], v["x_start"], v["omega_start"])
            f = lambda t, y: drive.rhs_with_rotor(*y, v["omega_set"], v["tau_load"], v["J_drive"])  # noqa: E731
        else:
            y0 = (v["i_start"], v["x_start"])
            f = lambda t, y: drive.rhs(*y, v["omega"], v["omega_set"])  # noqa: E731
        sol = solve_ivp(f, (0.0, float(run.time[-1])), y0, method="DOP853", rtol=1e-12, atol=1e-12, t_eval=run.time)
        i, x = sol.y[0], sol.y[1]
        omega = sol.y[2] if speed else np.full_like(i, v["omega"])
        u = drive.voltage(x, omega, v["omega_set"])
        ref = {"tau": drive.torque(i), "i": i, "u": u, "P_el": u * i, "x": x}
        if speed:
            ref["omega"] = omega
        rows = _compare(prefix, fmu, run, ref, checks, DRIVE_TOLERANCE)
        what = (f"load torque {inputs.get('tau_load', 0):g} N.m held, against DOP853 (rtol 1e-12)" if speed else
                f"crank speed {inputs['omega']:g} rad/s held, set-point {v['omega_set']:g} rad/s, against DOP853 "
                "(rtol 1e-12)")
        section["default"].append(_entry(fmu, run, ref, rows, what, out, tag))
    return section


def check_cushion(fmu, checks, out, quick: bool) -> dict:
    from crankfmu.dynamics.cushion import cushion_force

    _validated(fmu, checks)
    values = _values(fmu)
    step, span = 1e-3, 1.0
    times = np.arange(0.0, span + step / 2, step)
    s = values["s_seat"] + values["L_free"] - 0.05 * np.sin(3.0 * times)      # pressed in and let out
    v = -0.15 * np.cos(3.0 * times)
    run = fmu.run(span, step, {"s": float(s[0]), "v": float(v[0])}, label="ram motion", inputs=input_signal(times, s=s, v=v))
    prefix = f"{fmu.name}.{fmu.kind.build}.ram_motion"
    if run.error:
        checks.holds(f"{prefix}.ran", False, note=run.error)
        return {"default": [], "hard": []}
    # F at a communication point is the law at the inputs the host set before the step to it
    law = cushion_force(values, s, v)
    ref = {"F": np.concatenate([[law[0]], law[:-1]])}
    rows = _compare(prefix, fmu, run, ref, checks, CUSHION_TOLERANCE)
    return {"default": [_entry(fmu, run, ref, rows, "the ram pressed in and let out, F against the file's law",
                               out, "ram_motion")], "hard": []}


def check_shaft(fmu, checks, out, quick: bool) -> dict:
    from crankfmu.dynamics.shaft import shaft_torque

    _validated(fmu, checks)
    values = _values(fmu)
    step, span = 1e-3, 1.0
    times = np.arange(0.0, span + step / 2, step)
    omega_a = 20.0 + 5.0 * np.sin(3.0 * times)                    # a drive with a torque ripple
    omega_b = 20.0 + 5.0 * np.sin(3.0 * times - 0.02) - 0.05 * times  # the crank lagging and slowing
    run = fmu.run(span, step, {"omega_a": float(omega_a[0]), "omega_b": float(omega_b[0])}, label="sides turning",
                  inputs=input_signal(times, omega_a=omega_a, omega_b=omega_b))
    prefix = f"{fmu.name}.{fmu.kind.build}.sides_turning"
    if run.error:
        checks.holds(f"{prefix}.ran", False, note=run.error)
        return {"default": [], "hard": []}
    # the host holds the speeds over each step: the twist at t_n sums the differences set before
    # t_0 .. t_n-1; the torque at t_n reads the twist and the speeds set before the step to t_n
    held = np.concatenate([[0.0], (omega_a - omega_b)[:-1]])
    twist = values["twist_start"] + np.cumsum(held * step)
    last_a, last_b = np.concatenate([omega_a[:1], omega_a[:-1]]), np.concatenate([omega_b[:1], omega_b[:-1]])
    ref = {"twist": twist, "tau": shaft_torque(values, twist, last_a, last_b), "E_spring": 0.5 * values["k"] * twist ** 2}
    rows = _compare(prefix, fmu, run, ref, checks, SHAFT_TOLERANCE)
    return {"default": [_entry(fmu, run, ref, rows, "the drive's side turning with a ripple, the crank's lagging and "
                               "slowing: the twist against the sum of the held differences, tau against the law",
                               out, "sides_turning")], "hard": []}


def check_rod_string(fmu, checks, out, quick: bool) -> dict:
    from crankfmu.dynamics.rodstring import RodString
    from crankfmu.dynamics.well import load_well

    _validated(fmu, checks)
    well = load_well(fmu.scenario_source)
    values = _values(fmu)
    section = {"default": [], "hard": []}
    prefix = f"{fmu.name}.{fmu.kind.build}"

    # at rest: the load is the buoyant weight of the rods
    run = fmu.run(1.0, 0.01, {"s": 0.0, "v": 0.0}, label="at rest")
    design = well.design({k: v for k, v in values.items() if k in well.parameters})
    if run.error:
        checks.holds(f"{prefix}.at_rest.ran", False, note=run.error)
    else:
        checks.at_most(f"{prefix}.at_rest.F_vs_buoyant_weight", relative_error(run["F"], np.full_like(run["F"],
                       design.buoyant_weight)), 1e-9, note=f"Wrf = {design.buoyant_weight:.6g} N")

    # one quasi-static stroke (600 s, 1 m half stroke) on 50 m segments
    period, half = (600.0, 1.0)
    step = 0.1
    times = np.arange(0.0, period + step / 2, step)
    omega = 2.0 * math.pi / period
    s = -half * (1.0 - np.cos(omega * times))
    v = -half * omega * np.sin(omega * times)
    slow = {"segment": 50.0, "friction": 0.0}
    run = fmu.run(period, step, {**slow, "s": 0.0, "v": 0.0}, label="quasi-static stroke",
                  inputs=input_signal(times, s=s, v=v))
    if run.error:
        checks.holds(f"{prefix}.quasi_static.ran", False, note=run.error)
        return section
    design = well.design({**{k: v for k, v in values.items() if k in well.parameters}, **slow})
    phase = (omega * run.time) % (2.0 * math.pi)
    rising = (phase > 0.4 * math.pi) & (phase < 0.6 * math.pi)
    falling = (phase > 1.4 * math.pi) & (phase < 1.6 * math.pi)
    wrf, fo = design.buoyant_weight, design.fluid_load
    checks.at_most(f"{prefix}.quasi_static.upstroke_F_vs_Wrf_plus_Fo",
                   np.max(np.abs(run["F"][rising] - (wrf + fo))) / (wrf + fo), QUASI_STATIC_TOLERANCE,
                   note=f"Wrf + Fo = {wrf + fo:.6g} N")
    checks.at_most(f"{prefix}.quasi_static.downstroke_F_vs_Wrf", np.max(np.abs(run["F"][falling] - wrf)) / (wrf + fo),
                   QUASI_STATIC_TOLERANCE, note=f"Wrf = {wrf:.6g} N")
    # the in-process string, stepped as the FMU steps it (linear motion to s + v h, Courant-limited)
    string = RodString(design).hang(0.0, 0.0)
    ref = {name: np.empty(times.size) for name in ("F", "u_pump", "F_pump", "W_polished", "W_hydraulic")}

    def record(k):
        ref["F"][k], ref["u_pump"][k], ref["F_pump"][k] = string.static_load, string.pump_position, string.pump_load
        ref["W_polished"][k], ref["W_hydraulic"][k] = string.work, string.pump.hydraulic

    record(0)
    for k in range(1, times.size):
        h = times[k] - times[k - 1]
        string.advance(s[k - 1] + v[k - 1] * h, h)
        record(k)
    rows = _compare(f"{prefix}.quasi_static", fmu, run, ref, checks, 1e-9)
    section["default"].append(_entry(fmu, run, ref, rows, "a 600 s stroke: every output against the in-process "
                                     "string; F against Wrf + Fo up and Wrf down", out, "quasi_static"))
    return section
