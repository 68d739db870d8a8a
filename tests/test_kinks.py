"""Kinks in a user's load (max, min, abs, sign): a press closing on its workpiece,
fx = -k_w max(0, xB - x_w), is a switched load whose switch angles are where the ram meets the
workpiece, on every path.

- The branches of an expression reproduce it on each side of its kinks (random points).
- The contact angles the C model and the Python engine find are the closed form's (the in-line
  slider-crank's xB(phi1) = x_w solved by brentq), to 1e-12 rad.
- omega1(t) of the fast path, the reference integrator, the Python FMU and the native FMI 2.0 and
  3.0 FMUs (Co-Simulation) against an independent reference within 1e-8: the in-line slider-crank's
  Lagrange equation from its closed-form kinematics, differentiated by hand here, integrated by
  DOP853 at rtol 1e-13 and restarted at each contact so that no step straddles the kink. Model
  Exchange (CVode at 1e-10) within 1e-6. A native FMU with x_w and k_w set before initialisation
  relocates its contact angles (the same reference at those values, 1e-8), its win64 DLL too, under
  wine (1e-12 of the linux64 binary).
- A load with more kinks than it may have is refused by name.
- Jansen's leg (the packaged scenario jansen, written from the guide: seven bodies, three contours,
  its plates' angles constants that follow their sides) walking on the ground through
  fy = k_g max(0, y_ground - G_y): the fast path, the Python FMU and the native FMI 2.0 and 3.0
  FMUs (Co-Simulation) within 1e-8 of an independent reference over 4 s (tests/jansen_reference.py:
  circle intersections, complex-step velocities, Lagrange's equation); Model Exchange within 1e-6.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import crankfmu
from crankfmu.cli import main
from crankfmu.dynamics.tabulated import table_of
from crankfmu.errors import DefinitionError
from crankfmu.expressions import Expression, kink_arguments, kink_branch

SCENARIO = Path(__file__).resolve().parent / "data" / "user" / "press_contact_scenario.toml"
STOP = 2.0


def ram_rate(phi, p):
    """dxB/dphi1 of the in-line slider-crank, by hand (as lagrange_terms)."""
    lam = p["l1"] / p["l2"]
    s2 = -lam * math.sin(phi)
    return -p["l1"] * math.sin(phi) + p["l2"] * s2 * lam * math.cos(phi) / math.sqrt(1.0 - s2 * s2)


def lagrange_terms(phi, p):
    """(J, J'/2, Q, xB) of the in-line slider-crank with the contact, by hand from sin(phi2) =
    -l1 sin(phi1) / l2: bars of mass q l with centres at mid-length, a slider of m3 at B."""
    l1, l2, m3, g = p["l1"], p["l2"], p["m3"], p["g"]
    m1, m2 = p["q1"] * l1, p["q2"] * l2
    s, c = math.sin(phi), math.cos(phi)
    lam = l1 / l2
    s2 = -lam * s
    c2 = math.sqrt(1.0 - s2 * s2)
    d2 = -lam * c / c2                                       # dphi2/dphi1
    dd2 = lam * s / c2 - lam ** 3 * s * c * c / c2 ** 3
    dgx = -l1 * s - 0.5 * l2 * s2 * d2                       # the rod's centre
    dgy = l1 * c + 0.5 * l2 * c2 * d2
    ddgx = -l1 * c + 0.5 * l2 * (-c2 * d2 * d2 - s2 * dd2)
    ddgy = -l1 * s + 0.5 * l2 * (-s2 * d2 * d2 + c2 * dd2)
    xB = l1 * c + l2 * c2
    dxB = -l1 * s - l2 * s2 * d2
    ddxB = -l1 * c - l2 * (c2 * d2 * d2 + s2 * dd2)
    I2 = m2 * l2 ** 2 / 12
    J = p["J_flywheel"] + m1 * l1 ** 2 / 3 + m2 * (dgx ** 2 + dgy ** 2) + I2 * d2 ** 2 + m3 * dxB ** 2
    half_dJ = m2 * (dgx * ddgx + dgy * ddgy) + I2 * d2 * dd2 + m3 * dxB * ddxB
    Q = -g * (m1 * 0.5 * l1 * c + m2 * dgy) - p["k_w"] * max(0.0, xB - p["x_w"]) * dxB
    return J, half_dJ, Q, xB


def reference(p, times, speed_torque=lambda w: 0.0, ram_force=None):
    """omega1 at ``times``: DOP853 restarted at every contact; ``speed_torque(omega1)``: a load of
    the speed on the crank (N.m) beside the motor (tests/test_speed_loads.py's fan);
    ``ram_force(phi1, xB, omega1)``: a force on the ram along x (N), its torque that times dxB/dphi1
    (tests/test_speed_laws.py, the damped contact here)."""
    def motor(w):
        line = p["A"] - p["B"] * w if w > p["omega_switch"] else p["A_low"] - p["B_low"] * w
        return line + speed_torque(w)

    def rhs(t, y):
        J, half_dJ, Q, xB = lagrange_terms(y[0], p)
        if ram_force is not None:
            Q += ram_force(y[0], xB, y[1]) * ram_rate(y[0], p)
        return [y[1], (motor(y[1]) + Q - half_dJ * y[1] ** 2) / J]

    # the contact angles in the turn (the gap's roots; phi1 only grows): each piece is integrated
    # twice, once to find the time phi1 reaches the next one, then again on a span that ends there,
    # so that no step evaluates the right-hand side past the kink (a step across it would mix both
    # sides' forces into its stages and its dense output)
    gap = lambda phi: lagrange_terms(phi, p)[3] - p["x_w"]          # noqa: E731
    grid = np.linspace(0.0, 2 * math.pi, 721)
    gaps = [gap(a) for a in grid]
    kinks = [brentq(gap, grid[i], grid[i + 1], xtol=1e-15) for i in range(grid.size - 1)
             if np.sign(gaps[i]) != np.sign(gaps[i + 1])]

    def next_kink(phi):
        turn = math.floor(phi / (2 * math.pi)) * 2 * math.pi
        return min(k + turn + 2 * math.pi * lap for k in kinks for lap in (0, 1) if k + turn + 2 * math.pi * lap > phi + 1e-9)
    pieces, t, y = [], 0.0, [p["phi1_start"], p["omega1_start"]]
    while t < STOP:
        target = next_kink(y[0])
        reach = lambda t, y: y[0] - target          # noqa: E731
        reach.terminal = True
        probe = solve_ivp(rhs, (t, STOP), y, method="DOP853", rtol=1e-13, atol=1e-12, events=reach)
        end = probe.t_events[0][0] if probe.t_events[0].size else STOP
        run = solve_ivp(rhs, (t, end), y, method="DOP853", rtol=1e-13, atol=1e-12, dense_output=True)
        pieces.append((t, end, run.sol))
        t, y = end, run.y[:, -1]
    return np.array([next(sol(x)[1] for a, b, sol in pieces if a <= x <= b) for x in times])


def fmu_follows(fmu, stop: float, expected, kind: str) -> None:
    """omega1 of ``fmu`` (fmpy, Co-Simulation at 1 ms) within 1e-8 of ``expected(times)``; a native
    one's Model Exchange (CVode at 1e-10, its event indicators on the switch angles) within 1e-6."""
    from fmpy import simulate_fmu

    result = simulate_fmu(str(fmu), stop_time=stop, output_interval=1e-3, output=["omega1"])
    want = expected(result["time"])
    assert np.max(np.abs(result["omega1"] - want)) / np.max(np.abs(want)) < 1e-8
    if kind != "python":
        me = simulate_fmu(str(fmu), stop_time=stop, output_interval=1e-3, output=["omega1"],
                          fmi_type="ModelExchange", relative_tolerance=1e-10)
        assert np.max(np.abs(me["omega1"] - expected(me["time"]))) / np.max(np.abs(want)) < 1e-6


@pytest.fixture(scope="module")
def scenario():
    return crankfmu.load_scenario(str(SCENARIO))


@pytest.fixture(scope="module")
def values(scenario):
    return {k: scenario[k] for k in scenario.parameters}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("kinks")
    for folder, extra in (("python", []), ("native", ["--native"]), ("native3", ["--native", "--fmi-version", "3"])):
        assert main(["fmu", str(SCENARIO), *extra, "--out", str(out / folder)]) == 0
    return {folder: out / folder / "PressContact.fmu" for folder in ("python", "native", "native3")}


def test_the_branches_are_the_expression_on_each_side_of_its_kinks():
    source = "k*max(0, y0 - y) + abs(min(y, 2*x) - 1)*sign(x) - max(x, y)"
    arguments = kink_arguments(source)
    assert len(arguments) == 5
    rng = np.random.default_rng(7)
    for _ in range(200):
        env = dict(zip(("k", "y0", "y", "x"), rng.normal(0.0, 2.0, 4)))
        bits = [int(Expression(a).evaluate(env) > 0.0) for a in arguments]
        exact = Expression(source).evaluate(env)
        assert Expression(kink_branch(source, bits)).evaluate(env) == pytest.approx(exact, rel=1e-14, abs=1e-14)


def test_the_contact_angles_are_where_the_ram_meets_the_workpiece(scenario, values):
    """The switch angles of the C model's table (the fast path's and native FMU's) and of the
    Python engine's schedule against xB(phi1) = x_w solved by brentq."""
    def gap(phi):
        return lagrange_terms(phi, values)[3] - values["x_w"]
    grid = np.linspace(0.0, 2 * math.pi, 721)
    signs = np.sign([gap(a) for a in grid])
    closed = sorted(brentq(gap, grid[i], grid[i + 1], xtol=1e-15) for i in np.flatnonzero(signs[:-1] != signs[1:]))
    assert len(closed) == 2
    model = scenario.build()
    c_angles = table_of(model.reduced).switch_angles
    python_angles = model.reduced.slider_schedule()[0]
    assert np.allclose(sorted(c_angles), closed, atol=1e-12, rtol=0)
    assert np.allclose(sorted(python_angles), closed, atol=1e-12, rtol=0)


def test_simulate_draws_the_contact_force_at_its_located_angles(values, tmp_path):
    """contacts.png's caption states the switch angles and the peak of fx = -k_w max(0, xB - x_w):
    both against the hand-written xB(phi1) (brentq for the angles, a 0.01 deg grid for the peak, the
    figure's grid being 0.05 deg: the peak of a smooth curve is met to (0.05 deg)^2)."""
    from PIL import Image

    assert main(["simulate", str(SCENARIO), "--method", "fast", "--out", str(tmp_path)]) == 0
    with Image.open(tmp_path / "contacts.png") as image:
        caption = image.text["Description"]
    gap = lambda phi: lagrange_terms(phi, values)[3] - values["x_w"]       # noqa: E731
    grid = np.linspace(0.0, 2 * math.pi, 36001)
    gaps = np.array([gap(a) for a in grid])
    crossing = np.flatnonzero(np.sign(gaps[:-1]) != np.sign(gaps[1:]))
    closed = sorted(math.degrees(brentq(gap, grid[i], grid[i + 1], xtol=1e-15)) for i in crossing)
    stated = re.search(r"switches at phi1 = ([0-9.]+), ([0-9.]+) deg", caption)
    assert stated, caption
    assert [float(a) for a in stated.groups()] == pytest.approx(closed, abs=0.006)      # printed to 0.01 deg
    peak = re.search(r"fx on slider at B peaks at ([-0-9.e+]+) N", caption)
    assert peak, caption
    expected = -values["k_w"] * np.max(np.maximum(gaps, 0.0))
    assert float(peak.group(1)) == pytest.approx(expected, rel=1e-3)                   # printed to 4 digits
    assert json.loads((tmp_path / "summary.json").read_text())["figures"][-1] == "contacts.png"


def test_a_run_without_a_kink_draws_no_contact(tmp_path):
    assert main(["simulate", "seed000", "--method", "fast", "--out", str(tmp_path)]) == 0
    assert not (tmp_path / "contacts.png").exists()


@pytest.mark.parametrize("method", ["fast", "reference"])
def test_the_engine_follows_the_contact(scenario, values, method):
    times = np.linspace(0.0, STOP, 401)
    result = crankfmu.simulate(scenario, t_end=STOP, method=method, rtol=None, output_times=times)
    expected = reference(values, times)
    assert np.max(np.abs(result.omega1 - expected)) / np.max(np.abs(expected)) < 1e-8


@pytest.mark.parametrize("fmu", ["python", "native", "native3"])
def test_the_fmus_follow_the_contact(fmus, values, fmu):
    fmu_follows(fmus[fmu], STOP, lambda times: reference(values, times), fmu)


DAMPED = '[[loads]]\nkind = "force"\nlink = "slider"\npoint = "B"\nfx = "-lam_w*max(0, xB - x_w)*B_vx"\n\n'


@pytest.fixture(scope="module")
def damped(tmp_path_factory):
    """The press with Hunt and Crossley's damping of the workpiece beside its stiffness: a load of
    the speeds with a kink of the position (speed_loads.KinkedSpeedLoad), and its three FMUs."""
    out = tmp_path_factory.mktemp("damped")
    path = out / "press_damped.toml"
    path.write_text(SCENARIO.read_text().replace("J_flywheel = {", (
        'lam_w = { value = 3.0e4, unit = "N.s/m2", min = 0, description = "Hunt-Crossley damping of the '
        'workpiece" }\nJ_flywheel = {')).replace("[experiment]", DAMPED + "[experiment]")
        .replace('fmu = "PressContact"', 'fmu = "PressDamped"'))
    for folder, extra in (("python", []), ("native", ["--native"]), ("native3", ["--native", "--fmi-version", "3"])):
        assert main(["fmu", str(path), *extra, "--out", str(out / folder)]) == 0
    scenario = crankfmu.load_scenario(str(path))
    p = {k: scenario[k] for k in scenario.parameters}

    def expected(times):
        return reference(p, times, ram_force=lambda phi, xB, w: -p["lam_w"] * max(0.0, xB - p["x_w"])
                         * ram_rate(phi, p) * w)
    return scenario, expected, {folder: out / folder / "PressDamped.fmu" for folder in ("python", "native", "native3")}


@pytest.mark.parametrize("method", ["fast", "reference"])
def test_the_damped_contact_on_the_engine(damped, values, method):
    """-lam_w max(0, xB - x_w) B_vx: its parts per power of omega1 on each side of the contact are
    columns (each valued by the side's indicator), the contact angles located as before; within
    1e-8 of the hand-written reference with the damping's force, which moves omega1 by ~8 rad/s."""
    scenario, expected, _ = damped
    times = np.linspace(0.0, STOP, 401)
    result = crankfmu.simulate(scenario, t_end=STOP, method=method, rtol=None, output_times=times)
    want = expected(times)
    assert np.max(np.abs(result.omega1 - want)) / np.max(np.abs(want)) < 1e-8
    assert np.max(np.abs(want - reference(values, times))) > 1.0


@pytest.mark.parametrize("fmu", ["python", "native", "native3"])
def test_the_damped_contact_in_the_fmus(damped, fmu):
    _, expected, fmus = damped
    fmu_follows(fmus[fmu], STOP, expected, fmu)


def test_kinks_of_the_position_and_of_a_speed_in_one_load_are_refused(scenario):
    from crankfmu.scenario import Scenario

    data = {**scenario.data, "loads": [*scenario.data["loads"],
                                       {"kind": "force", "link": "slider", "point": "B",
                                        "fx": "-k_w*max(0, xB - x_w)*sign(B_vx)"}]}
    with pytest.raises(DefinitionError, match=r"kinks of the position \(max\(0, xB - x_w\)\) and of the speeds "
                                              r"\(sign\(B_vx\)\) in one load.*write them as two loads"):
        Scenario(data, scenario.where, scenario.path).build()


def test_a_native_fmu_relocates_its_contact_when_the_workpiece_moves(fmus, values):
    from fmpy import simulate_fmu

    moved = {"x_w": 0.70, "k_w": 5e4}
    result = simulate_fmu(str(fmus["native"]), stop_time=STOP, output_interval=1e-3, output=["omega1"],
                          start_values=moved)
    expected = reference({**values, **moved}, result["time"])
    assert np.max(np.abs(result["omega1"] - expected)) / np.max(np.abs(expected)) < 1e-8


def test_the_win64_dll_relocates_the_contact_under_wine(fmus, values, tmp_path):
    """The native FMU's win64 DLL (the prebuilt runtime's ZEROS search in MinGW's build), the
    workpiece moved, under wine through fmpy's remoting: the reference at those values to 1e-8 and
    the linux64 binary to 1e-12."""
    from fmpy import simulate_fmu

    from wine import run_win64_under_wine

    moved = {"x_w": 0.70, "k_w": 5e4}
    remote = run_win64_under_wine(fmus["native"], tmp_path, ("omega1",), moved)
    local = simulate_fmu(str(fmus["native"]), stop_time=STOP, output_interval=1e-3, output=["omega1"],
                         start_values=moved)
    expected = reference({**values, **moved}, remote[0])
    scale = np.max(np.abs(expected))
    assert np.max(np.abs(remote[1] - expected)) < 1e-8 * scale
    assert remote[1].shape == local["omega1"].shape
    assert np.max(np.abs(remote[1] - local["omega1"])) <= 1e-12 * scale


def test_too_many_kinks_in_one_load_are_refused(scenario):
    from crankfmu.scenario import Scenario

    data = {**scenario.data, "loads": [{"kind": "force", "link": "slider", "point": "B", "fy": "0",
                                        "fx": "max(0, xB - x_w) + abs(phi2) + sign(xB) + min(phi2, 0.1)"}]}
    with pytest.raises(DefinitionError, match=r"4 kinks .* at most 3 per load"):
        Scenario(data, scenario.where, scenario.path).build()


# ------------------------------------------------------------------------------------------------
# [assembly] constants as expressions: a triangle's angle that follows its sides

TRIANGLE = SCENARIO.parent / "triangle_scenario.toml"            # beta = "acos(...)" in [assembly] constants
TRIANGLE_INLINE = SCENARIO.parent / "triangle_inline_scenario.toml"   # the same text written where beta is used


@pytest.mark.parametrize("method", ["fast", "reference"])
def test_a_constant_that_follows_the_sides_moves_as_the_inlined_one(method):
    """At the file's values and with a side changed (the constant follows it): the same motion."""
    times = np.linspace(0.0, 1.0, 201)
    for changes in ({}, {"b": 0.4, "a": 0.28}):
        runs = [crankfmu.simulate(crankfmu.load_scenario(str(path)).with_params(**changes), t_end=1.0,
                                  method=method, rtol=None, output_times=times) for path in (TRIANGLE, TRIANGLE_INLINE)]
        assert np.max(np.abs(runs[0].omega1 - runs[1].omega1)) <= 1e-10 * np.max(np.abs(runs[1].omega1))
    moved = crankfmu.simulate(crankfmu.load_scenario(str(TRIANGLE)).with_params(b=0.4), t_end=1.0, method=method,
                              rtol=None, output_times=times)
    assert np.max(np.abs(moved.omega1 - runs[0].omega1)) > 1e-3       # the side matters: the test can fail


def test_a_native_fmu_evaluates_its_constants_when_the_sides_are_set(tmp_path):
    from fmpy import simulate_fmu

    results = []
    for path, name in ((TRIANGLE, "Triangle"), (TRIANGLE_INLINE, "TriangleInline")):
        assert main(["fmu", str(path), "--native", "--out", str(tmp_path / name)]) == 0
        results.append(simulate_fmu(str(tmp_path / name / f"{name}.fmu"), stop_time=1.0, output_interval=1e-3,
                                    output=["omega1"], start_values={"b": 0.4})["omega1"])
    assert np.max(np.abs(results[0] - results[1])) <= 1e-10 * np.max(np.abs(results[1]))


@pytest.mark.parametrize("constant, message", [
    ("beta = \"acos(q)\"", r"\[assembly\] constants beta.*\bq\b"),
    ("beta = \"gamma*2\", gamma = 0.1", r"constants beta = 'gamma\*2' uses gamma, defined after it"),
    ("beta = \"acos(l2/a)\"", r"constants beta = 'acos\(l2/a\)' is not finite \(nan\)"),
])
def test_bad_constants_are_refused_by_name(tmp_path, constant, message):
    text = (SCENARIO.parent / "triangle.toml").read_text()
    start = text.index("constants = {")
    end = text.index("\n", start)
    (tmp_path / "triangle.toml").write_text(text[:start] + f"constants = {{ branch = 1.0, {constant} }}" + text[end:])
    (tmp_path / "triangle_scenario.toml").write_text(TRIANGLE.read_text())
    from crankfmu.check import check_scenario

    report = check_scenario(str(tmp_path / "triangle_scenario.toml"))
    assert report.status in (1, 2)
    assert re.search(message, report.text()), report.text()
    assert "Traceback" not in report.text()


def test_a_kink_that_keeps_one_side_over_the_turn_acts_on_it(scenario, tmp_path):
    """A workpiece the ram presses all the turn round (x_w below the ram's travel): the kink's
    argument never changes sign, no switch angle, and the load is its one side everywhere (the
    same load written without max, to round-off), on the fast path and in the native FMU."""
    from fmpy import simulate_fmu

    text = SCENARIO.read_text().replace('x_w = { value = 0.72,', 'x_w = { value = 0.2,').replace(
        'k_w = { value = 2.0e5,', 'k_w = { value = 2.0e2,')
    smooth = text.replace('fx = "-k_w*max(0, xB - x_w)"', 'fx = "-k_w*(xB - x_w)"')
    runs = []
    for name, body in (("kinked", text), ("smooth", smooth)):
        (tmp_path / f"{name}.toml").write_text(body.replace('fmu = "PressContact"', f'fmu = "{name.title()}"'))
        s = crankfmu.load_scenario(str(tmp_path / f"{name}.toml"))
        times = np.linspace(0.0, 1.0, 101)
        runs.append(crankfmu.simulate(s, t_end=1.0, method="fast", rtol=None, output_times=times).omega1)
        assert main(["fmu", str(tmp_path / f"{name}.toml"), "--native", "--out", str(tmp_path / name)]) == 0
        runs.append(simulate_fmu(str(tmp_path / name / f"{name.title()}.fmu"), stop_time=1.0, output_interval=1e-2,
                                 output=["omega1"])["omega1"])
    assert np.max(np.abs(runs[0] - runs[2])) <= 1e-10 * np.max(np.abs(runs[2]))
    assert np.max(np.abs(runs[1] - runs[3])) <= 1e-10 * np.max(np.abs(runs[3]))
    assert np.max(np.abs(runs[2] - runs[0])) < np.max(np.abs(runs[2] - runs[2][0]))    # the load does act


# ------------------------------------------------------------------------------------------------
# Jansen's leg walking on the ground

JANSEN = "jansen"          # the packaged scenario
JANSEN_STOP = 4.0


@pytest.fixture(scope="module")
def jansen(tmp_path_factory):
    import jansen_reference

    scenario = crankfmu.load_scenario(JANSEN)
    out = tmp_path_factory.mktemp("jansen")
    fmus = {}
    for folder, extra in (("python", []), ("native", ["--native"]), ("native3", ["--native", "--fmi-version", "3"])):
        assert main(["fmu", JANSEN, *extra, "--out", str(out / folder)]) == 0
        fmus[folder] = out / folder / "JansenLeg.fmu"
    reference = jansen_reference.omega1({k: scenario[k] for k in scenario.parameters}, JANSEN_STOP)
    return scenario, fmus, reference


def test_jansens_leg_touches_the_ground_twice_a_turn(jansen):
    scenario, _, _ = jansen
    model = scenario.build()
    assert len(table_of(model.reduced).switch_angles) == 2


def test_jansens_leg_walks_on_the_fast_path(jansen):
    scenario, _, reference = jansen
    times = np.linspace(0.0, JANSEN_STOP, 801)
    result = crankfmu.simulate(scenario, t_end=JANSEN_STOP, method="fast", rtol=None, output_times=times)
    expected = reference(times)
    assert np.max(np.abs(result.omega1 - expected)) / np.max(np.abs(expected)) < 1e-8


@pytest.mark.parametrize("fmu", ["python", "native", "native3"])
def test_jansens_leg_walks_in_every_fmu(jansen, fmu):
    _, fmus, reference = jansen
    fmu_follows(fmus[fmu], JANSEN_STOP, reference, fmu)


def test_a_press_held_still_on_its_workpiece_feels_the_contact(values, tmp_path):
    """Speed causality with omega1 = 0 exactly (a drive holding the press still, the ram on its
    workpiece): the drive takes the contact's torque, -Q of the closed form, on the fast stepper and
    in the native speed-causal FMU. A kink's columns are the same in either direction, so they act at
    rest (modes.column_factor); a Coulomb force's would not."""
    from fmpy import simulate_fmu

    from crankfmu.integrators.fast import SpeedStepper

    phi = 0.1                                         # rad: the ram 1.4 mm into the workpiece
    _, _, Q, xB = lagrange_terms(phi, values)
    assert xB > values["x_w"]
    path = tmp_path / "press_speed.toml"
    path.write_text(SCENARIO.read_text().replace("[experiment]", '[crank]\ncausality = "speed"\n\n[experiment]')
                    .replace('fmu = "PressContact"', 'fmu = "PressSpeed"'))
    scenario = crankfmu.load_scenario(str(path))
    model = scenario.build()
    row = SpeedStepper(table_of(model.reduced), values["J_flywheel"]).start(0.0, phi, 0.0)
    assert row[6] == pytest.approx(-Q, rel=1e-9)          # tau_drive
    assert main(["fmu", str(path), "--native", "--out", str(tmp_path / "native")]) == 0
    result = simulate_fmu(str(tmp_path / "native" / "PressSpeed.fmu"), stop_time=0.01, output_interval=1e-3,
                          start_values={"phi1_start": phi, "omega1": 0.0}, output=["tau_drive", "phi1"])
    assert np.allclose(result["phi1"], phi, rtol=0, atol=1e-15)
    assert np.allclose(result["tau_drive"], -Q, rtol=1e-9, atol=0)
