"""Joint friction in the C kernel (issue 69): the fast path and the Python FMU solve the frictions
from their tables (dynamics/friction_table.py, native/kernel/crank_friction.c), checked against the
independent body-by-body Newton-Euler of tests/friction_reference.py and against the reference
engine's own rule (dynamics.friction)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import crankfmu
from crankfmu.dynamics.reactions import joint_reactions
from crankfmu.simulation import simulate

from friction_reference import SliderCrankWithFriction

SCENARIO = Path(__file__).resolve().parents[1] / "validation" / "data" / "slidercrank_friction_scenario.toml"
TIMES = np.linspace(0.0, 3.0, 301)


@pytest.fixture(scope="module")
def scenario():
    return crankfmu.load_scenario(SCENARIO)


@pytest.fixture(scope="module")
def expected():
    """The independent reference's 3 s from rest (DOP853 at rtol 1e-12, every dead centre located)."""
    return SliderCrankWithFriction().run(3.0, TIMES)


@pytest.fixture(scope="module")
def fast(scenario):
    return simulate(scenario, t_end=3.0, method="fast", output_times=TIMES)


def test_the_fast_path_follows_the_independent_newton_euler(fast, expected):
    # the fast path's default rtol (1e-11), tables checked to 1e-11 and the kinks of the guide's |N|
    # located: omega1 to 1.4e-9 rad/s here (between 6e-9 and 2.5e-8 with the kinks stepped across)
    assert np.max(np.abs(fast.omega1 - expected[1])) < 1e-8
    assert np.max(np.abs(fast.phi1 - expected[0])) < 1e-8
    # the friction's work (72 J, 4 % of the motor's): its state integrated by the kernel
    assert abs(fast.W_friction[-1] - expected[5][-1]) < 1e-8 * abs(expected[5][-1])


def test_the_fast_paths_energy_balance_holds_with_the_frictions_dissipation(fast):
    balance = fast.energy_balance()
    closing = balance["W_motor"] + balance["W_load"] + balance["W_friction"] - balance["dE_kin"]
    assert abs(closing) < 1e-9 * balance["W_motor"]
    assert balance["W_friction"] < -0.04 * balance["W_motor"]


def test_the_kernels_frictions_are_the_engines(scenario, fast):
    """The kernel's solve from the tables against the engine's Newton-Euler solve at the same
    states (Equation.outputs): each joint's friction and power, their generalised force, the
    acceleration and the motor's torque. Away from rest (t = 0 starts on a dead centre, where the
    slide's rate is zero and its friction set-valued)."""
    model = scenario.build()
    moving = TIMES > 0.0
    state = np.array([fast.phi1, fast.omega1])[:, moving]
    engine = model.equation.outputs(state[0], state[1], t=TIMES[moving])
    for name, value in fast.friction.items():
        scale = np.max(np.abs(engine[name]))
        assert np.max(np.abs(value[moving] - engine[name])) < 1e-7 * scale, name
    # the tables are checked to 1e-11, the frictions' Newton to round-off
    assert np.max(np.abs(fast.epsilon1[moving] - engine["epsilon1"])) < 1e-7 * np.max(np.abs(engine["epsilon1"]))
    assert np.max(np.abs(fast.friction["slide_Ff"])) > 20.0       # the guide's friction: up to 26 N here


def test_the_fast_path_holds_a_crank_that_friction_holds(scenario):
    """At rest the kernel's frictions are those of the motion that would follow: a motor torque
    the friction can carry leaves the crank still, 30 N.m more starts it (the engine's own test of
    the same state: test_friction.py)."""
    phi = 1.3
    at_rest = lambda model, signs: model.solve(phi, 0.0, signs)[0]     # noqa: E731
    forward = {"O": 1.0, "A": -1.0, "B": 1.0, "slide": -1.0, "work": 0.0}
    free = [at_rest(SliderCrankWithFriction(A=a, B=0.0, mu_pin=0.0, mu_guide=0.0), forward) for a in (0.0, 1.0)]
    A_hold = -free[0] / (free[1] - free[0])
    still = scenario.with_params(A=A_hold, A_low=A_hold, B=0.0, B_low=0.0, phi1_start=phi, omega1_start=0.0)
    r = simulate(still, t_end=0.2, method="fast")
    assert np.all(r.omega1 == 0.0) and np.all(r.phi1 == phi)
    moving = simulate(still.with_params(A=A_hold + 30.0, A_low=A_hold + 30.0), t_end=0.2, method="fast")
    assert moving.omega1[-1] > 1.0


@pytest.fixture(scope="module")
def python_fmu(tmp_path_factory):
    from crankfmu.fmi.python.build import build

    return build("scenario", str(SCENARIO), tmp_path_factory.mktemp("friction_fmu"))


@pytest.mark.parametrize("values", [{"mu_pin": 0.0, "mu_guide": 0.0}, {"mu_pin": 0.2, "r_pin": 0.02, "mu_guide": 0.05}])
def test_the_python_fmus_friction_parameters_are_set_before_initialisation(scenario, python_fmu, values):
    """mu and the pins' radius are parameters of the FMU like any other: set by the host before
    initialisation, the FMU runs the machine the fast path runs with the same values (the same kernel
    and tables: what is left is where the two stop their steps), and with every mu at 0 it has no
    friction at all."""
    from fmpy import simulate_fmu

    r = simulate_fmu(str(python_fmu), stop_time=1.0, output_interval=0.01, start_values={"rtol": 1e-11, **values},
                     output=["omega1", "W_friction", "M_friction"])
    same = simulate(scenario.with_params(**values), t_end=1.0, method="fast", rtol=1e-11, output_times=r["time"])
    assert np.max(np.abs(r["omega1"] - same.omega1)) < 1e-8
    if values["mu_pin"] == 0.0:
        assert np.all(r["W_friction"] == 0.0) and np.all(r["M_friction"] == 0.0) and same.W_friction is None
    else:
        assert abs(r["W_friction"][-1] - same.W_friction[-1]) < 1e-8 * abs(same.W_friction[-1])
        # the pins' friction circles four times the file's (mu 0.2 on 20 mm pins): more work lost
        # than with the file's values, though the guide's mu is halved
        base = simulate(scenario, t_end=1.0, method="fast", rtol=1e-11, output_times=r["time"])
        assert same.W_friction[-1] < 1.2 * base.W_friction[-1]


def test_in_speed_causality_the_drive_takes_the_friction(scenario):
    """A drive imposes omega1 = 5 + 4 t rad/s through the kernel's speed-causal step: its torque with
    friction is the Newton-Euler drive moment of that motion with the joints' frictions (the
    engine's joint_reactions at the kernel's own phi1, omega1, epsilon1: an independent solve;
    measured 8e-12 N.m of 36 N.m), and the drive's work closes the energy balance with the
    friction's (Gauss-Legendre works on pieces of at most a degree)."""
    from crankfmu import native
    from crankfmu.dynamics.tabulated import table_of
    from crankfmu.integrators.fast import TABLE_TOLERANCE, SpeedStepper

    model = scenario.build(table=TABLE_TOLERANCE)
    stepper = SpeedStepper(table_of(model.reduced, TABLE_TOLERANCE), model.reduced.J_flywheel)
    first = stepper.start(0.0, 0.0, 5.0).copy()
    rows = np.array([stepper.advance(k * 1e-3, 5.0 + 4.0 * (k - 1) * 1e-3, 4.0).copy() for k in range(1, 1001)])
    field = native.SPEED_ROW_FIELDS.index
    phi1, omega1, epsilon1 = rows[:, 0], rows[:, 1], rows[:, field("epsilon1")]
    found = joint_reactions(model.reduced, phi1, omega1, epsilon1)
    assert np.max(np.abs(rows[:, field("tau_drive")] - found.driving_moment)) < 1e-9 * np.max(np.abs(found.driving_moment))
    kin = model.mechanism.kinematics(phi1)
    rates = model.reduced.friction.rates(kin)
    generalised = sum(rates[i] * found.friction[f.name] for i, f in enumerate(model.reduced.friction.frictions))
    assert np.max(np.abs(rows[:, field("M_friction")] - generalised)) < 1e-9 * np.max(np.abs(generalised))
    E = 0.5 * rows[:, field("J_red")] * omega1 ** 2
    E0 = 0.5 * first[field("J_red")] * 25.0
    works = rows[-1, field("W_drive")] + rows[-1, field("W_load")] + rows[-1, field("W_friction")]
    assert rows[-1, field("W_friction")] < -0.02 * rows[-1, field("W_drive")]
    assert abs(works - (E[-1] - E0)) < 1e-9 * rows[-1, field("W_drive")]


def test_the_speed_causal_python_fmu_outputs_the_friction(tmp_path):
    """The speed-causal Python FMU (a drive imposes omega1: 5 + 4 t rad/s through fmpy) declares
    and reports the friction's outputs, and its works close the energy balance with them."""
    from fmpy import simulate_fmu

    from crankfmu.fmi.python.build import build

    fmu = build("scenario", str(SCENARIO), tmp_path, causality="speed")
    signal = np.array([(t, 5.0 + 4.0 * t) for t in np.linspace(0.0, 1.0, 1001)],
                      dtype=[("time", float), ("omega1", float)])
    r = simulate_fmu(str(fmu), stop_time=1.0, output_interval=1e-3, input=signal,
                     output=["W_drive", "W_load", "W_friction", "E_kin", "M_friction", "slide_Ff", "slide_Pf"])
    assert r["W_friction"][-1] < 0.0 and np.all(r["M_friction"][1:] <= 0.0) and np.all(r["slide_Pf"] <= 1e-12)
    assert np.max(np.abs(r["slide_Ff"])) > 1.0
    closing = r["W_drive"][-1] + r["W_load"][-1] + r["W_friction"][-1] - (r["E_kin"][-1] - r["E_kin"][0])
    assert abs(closing) < 1e-9 * abs(r["W_drive"][-1]), closing


def test_the_flywheel_study_sizes_a_flywheel_with_friction(scenario, tmp_path):
    """crankfmu flywheel with joint friction: the flywheel whose steady cycle has delta 0.05 by the
    kernel's batch has it by the engine's crank-angle steady cycle too (an independent integrator with
    the engine's friction solve: measured 9e-10 apart), eq. 17's swing counts the friction at the mean
    speed, and the paper's eq. 3 scheme, which takes no friction, is left out with the reason (no
    stability figure)."""
    from crankfmu.cli import main
    import json

    out = tmp_path / "flywheel"
    assert main(["flywheel", str(SCENARIO), "--delta", "0.05", "--set", "omega1_start=15", "--out", str(out)]) == 0
    found = json.loads((out / "flywheel.json").read_text())
    assert abs(found["delta_achieved"] - 0.05) < 1e-9
    assert abs(found["delta_achieved_crank_angle"] - 0.05) < 1e-7
    assert "takes no joint friction" in found["eq3_stability"]["skipped"]
    assert found["movement"]["eq3_1deg_max_error_first_3_turns"] is None
    assert "eq3_stability.png" not in found["plots"] and not (out / "eq3_stability.png").exists()
    assert any("joints' friction" in words for words in found["eq17_departures"])


def test_eq17s_friction_is_the_kernels_at_a_steady_speed(scenario):
    """The friction eq. 17's swing and the turning moment diagram count (the engine's Newton-Euler
    with the motion given: omega1 constant, epsilon1 0) against the kernel's own solve from its
    tables when a drive holds the crank at that speed (the speed-causal step, ck_friction_values'
    rule): within 1e-9 of its largest over the turn."""
    from crankfmu import native
    from crankfmu.dynamics.tabulated import table_of
    from crankfmu.integrators.fast import TABLE_TOLERANCE, SpeedStepper
    from crankfmu.studies.flywheel import friction_torque

    omega = 16.0
    model = scenario.build(table=TABLE_TOLERANCE)
    stepper = SpeedStepper(table_of(model.reduced, TABLE_TOLERANCE), model.reduced.J_flywheel)
    stepper.start(0.0, 0.0, omega)
    rows = np.array([stepper.advance(k * 2e-3, omega, 0.0).copy() for k in range(1, 200)])
    field = native.SPEED_ROW_FIELDS.index
    assert np.all(rows[:, field("epsilon1")] == 0.0)
    kernel = rows[:, field("M_friction")]
    engine = friction_torque(model, rows[:, 0], omega)
    assert np.max(np.abs(engine - kernel)) < 1e-9 * np.max(np.abs(kernel))
    assert np.all(engine <= 0.0) and np.min(engine) < -1.0


def test_the_kernels_steady_cycles_carry_the_friction(scenario, tmp_path):
    """The fast kernel's batch of steady cycles (studies.batch, which crankfmu sweep runs) steps with
    the frictions as the fast path does: the issue's machine's steady cycle has the period of the
    independent reference's periodic turn (tests/friction_reference.py) within 1e-10 of it (both
    integrate at 1e-11..1e-12 over a turn and shoot to 1e-12..1e-13; measured 2e-12), where the
    frictionless machine's (mu 0) is 4 % of it away. The sweep's (rtol 1e-9) within 1e-6."""
    from crankfmu.studies.batch import SteadyBatch
    from crankfmu.studies.sweep import SweepAxis, run_sweep

    reference = SliderCrankWithFriction()
    w0, _ = reference.steady_turn(16.0)
    period = reference.turn(w0)[1]
    row = SteadyBatch(scenario, rtol=1e-11, shoot_tol=1e-12).run([{"J_flywheel": 5.0}]).rows[0]
    assert abs(row["period"] - period) < 1e-10 * period, (row["period"], period)
    free = SteadyBatch(scenario.with_params(mu_pin=0.0, mu_guide=0.0), rtol=1e-11, shoot_tol=1e-12)
    assert abs(free.run([{"J_flywheel": 5.0}]).rows[0]["period"] - period) > 0.01 * period
    swept = run_sweep(scenario, [SweepAxis("J_flywheel", [2.0, 5.0])], tmp_path, study="steady")
    assert not swept.failed and len(swept.rows) == 2
    at5 = next(r for r in swept.rows if r["J_flywheel"] == 5.0)
    assert abs(at5["period"] - period) < 1e-6 * period
    assert abs(at5["delta"] - row["delta"]) < 1e-6 * row["delta"]


def test_a_shaper_with_friction_in_its_ten_joints_follows_the_engine():
    """seed001's shaper six-bar (two slides, eight pins: 10 frictions, each with its own table of
    reaction terms) with --friction 0.1,0.01: the kernel's run against the reference engine's over
    0.5 s of its start (measured over 2 s: omega1 within 2.5e-9 rad/s, each friction within 5e-10 of
    its largest)."""
    shaper = crankfmu.load_scenario("seed001").with_joint_friction(0.1, 0.01)
    times = np.linspace(0.0, 0.5, 51)
    fast = simulate(shaper, t_end=0.5, method="fast", output_times=times)
    engine = simulate(shaper, t_end=0.5, method="reference", output_times=times)
    assert len(shaper.build().reduced.friction) == 10
    assert np.max(np.abs(fast.omega1 - engine.omega1)) < 1e-8
    assert abs(fast.W_friction[-1] - engine.W_friction[-1]) < 1e-8 * abs(engine.W_friction[-1])
    for name, value in engine.friction.items():
        assert np.max(np.abs(fast.friction[name][1:] - value[1:])) < 1e-7 * np.max(np.abs(value)), name


@pytest.mark.parametrize("overrides", [{}, {"mu_guide": 0.0}, {"mu_pin": 0.0}, {"F_work": 0.0, "g": 0.0}],
                         ids=["all", "pins only", "guide only", "unloaded"])
def test_the_c_models_friction_table_is_the_engines(scenario, overrides):
    """The C mechanism model's friction table (crank_engine.c, what the native FMUs tabulate when
    they initialise) against tabulate_frictions' from the Python engine: the same active
    frictions (a mu of 0 is none), their coefficients, switch angles and signs, and each function
    within 1e-10 of its largest (both are checked to 1e-11 of it against their own engine)."""
    from crankfmu.dynamics import tabulated
    from crankfmu.dynamics.cubics import evaluate_cubics
    from crankfmu.dynamics.friction_table import tabulate_frictions

    reduced = scenario.with_params(**overrides).build().reduced
    engine = tabulate_frictions(reduced)
    c_table = tabulated.c_table(*reduced.source)
    assert c_table is not None and "in C" in c_table.friction.construction
    table = c_table.friction
    assert table.components.tolist() == engine.components.tolist()
    assert table.n_terms == engine.n_terms
    assert np.array_equal(table.c, engine.c)
    assert np.array_equal(c_table.switch_angles, reduced.slider_schedule()[0])
    assert np.array_equal(table.signs, engine.signs)
    phi1 = np.linspace(0.0, reduced.period, 2001)
    ours = evaluate_cubics(table.coefficients, phi1, reduced.period)
    theirs = evaluate_cubics(engine.coefficients, phi1, reduced.period)
    scale = np.maximum(np.max(np.abs(theirs), axis=1, keepdims=True), 1e-300)
    assert np.max(np.abs(ours - theirs) / scale) < 1e-10


def test_without_any_active_friction_the_c_model_tabulates_none(scenario):
    """Every mu 0: no friction table, and a reaction table without the unit frictions' terms (the
    kernel's weights then match it: a design without friction runs as before friction existed)."""
    from crankfmu.dynamics import tabulated

    reduced = scenario.with_params(mu_pin=0.0, mu_guide=0.0).build().reduced
    assert reduced.friction is None
    assert tabulated.c_table(*reduced.source).friction is None
    model = tabulated.c_model(*reduced.source)
    assert model.reaction_terms == len(model.program.term_inertia) - len(model.program.frictions)
