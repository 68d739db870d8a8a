"""General laws of the crank speed in a user's load (dynamics/speed_laws.py): a(phi1) g(omega1),
g any expression of omega1 and the parameters.

- The split is read from the text: the polynomial part plus each law's coefficient times the law
  is the expression again (random values), and a law of a point's speed or of the position is
  refused by name (the term, the factor, the names it reads).
- A law acts in either direction and at rest: the table's Q at omega1 = 0 and at -+ speeds is the
  exact torque, for a law whose value at rest is not zero.
- The C evaluator the Python paths use (native.mechanism.LawEvaluator, the C model's own rule) gives
  the expression's values to rounding.
- The press closing on its workpiece (tests/test_kinks.py) with a friction clutch on its crank,
  -T_d tanh(omega1/w_d), and a force on its ram that fades in with speed,
  -F_d xB/l2 (1 - exp(-omega1/w_d)): omega1(t) of the fast path, the reference integrator, the
  Python FMU and the native FMI 2.0 and 3.0 FMUs (Co-Simulation) within 1e-8 of an independent
  reference (the in-line slider-crank's Lagrange equation by hand, tests/test_kinks.py, with the two
  laws added), Model Exchange (CVode at 1e-10) within 1e-6; the native FMU with T_d set before
  initialisation follows it (the same reference at that value).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import crankfmu
from crankfmu.cli import main
from crankfmu.dynamics.speed_laws import split_laws
from crankfmu.errors import DefinitionError
from crankfmu.expressions import Expression

from test_kinks import STOP, fmu_follows
from test_kinks import reference as press_reference

USER = Path(__file__).resolve().parent / "data" / "user"
PRESS = USER / "press_contact_scenario.toml"
CLUTCH = "-T_d*tanh(omega1/w_d)"
RAM = "-F_d*xB/l2*(1 - exp(-omega1/w_d))"
VALUES = {"T_d": 40.0, "w_d": 5.0, "F_d": 300.0}


@pytest.mark.parametrize("source, laws", [
    ("-T0*tanh(omega1/w0)", {"tanh(omega1 / w0)"}),
    ("-c*omega1 - T0*(1 - exp(-omega1/w0))*cos(phi1)", {"1.0 - exp(-omega1 / w0)"}),
    ("-c*omega1**3 + k*B_vx*abs(B_vx) - T0", {"omega1 ** 3.0"}),
    ("T0*exp(-omega1/w0)/(1 + omega1**2/w0**2) + T0*tanh(omega1/w0)*B_x",
     {"exp(-omega1 / w0) / (1.0 + omega1 ** 2.0 / w0 ** 2.0)", "tanh(omega1 / w0)"}),
])
def test_the_split_is_the_expression_again(source, laws):
    speeds, fixed = {"omega1", "B_vx"}, {"T0", "w0", "c", "k"}
    polynomial, found = split_laws({"moment": Expression(source, "moment")}, speeds, fixed, "load 1: couple")
    assert {law.source for law, _ in found} == laws
    rng = np.random.default_rng(3)
    for _ in range(20):
        env = {"T0": rng.uniform(1, 5), "w0": rng.uniform(1, 20), "c": rng.uniform(0, 1), "k": rng.uniform(0, 1),
               "phi1": rng.uniform(0, 6), "B_x": rng.normal(), "omega1": rng.normal(0, 30)}
        env["B_vx"] = rng.normal() * env["omega1"]
        rebuilt = sum(float(e.evaluate(env)) for e in polynomial.values())
        rebuilt += sum(float(g.evaluate(env)) * float(a["moment"].evaluate(env)) for g, a in found)
        exact = float(Expression(source).evaluate(env))
        assert rebuilt == pytest.approx(exact, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("law, said", [
    ("-T_d*tanh(B_vx/w_d)", r"its factor 'tanh\(B_vx / w_d\)' reads B_vx"),
    ("-T_d*tanh(omega1*phi1/w_d)", r"its factor 'tanh\(omega1 \* phi1 / w_d\)' reads phi1"),
])
def test_a_law_of_a_point_speed_or_of_the_position_is_refused_by_name(tmp_path, law, said, capsys):
    path = press_file(tmp_path, law)
    assert main(["check", str(path)]) != 0
    err = capsys.readouterr()
    text = err.out + err.err
    assert "Traceback" not in text
    assert re.search(said + r".*a law that reads a point's or an unknown's speed, or the position, is not supported", text), text
    with pytest.raises(DefinitionError, match=said):
        crankfmu.load_scenario(str(path)).build()


def press_file(folder: Path, clutch: str = CLUTCH, ram: str | None = RAM) -> Path:
    """The press of tests/test_kinks.py with the clutch on its crank and the force on its ram."""
    text = PRESS.read_text().replace('J_flywheel = {', (
        'T_d = { value = 40.0, unit = "N.m", min = 0, description = "the clutch\'s slipping torque" }\n'
        'w_d = { value = 5.0, unit = "rad/s", min = 0.001, description = "the clutch\'s speed scale" }\n'
        'F_d = { value = 300.0, unit = "N", min = 0, description = "the ram\'s drag force" }\nJ_flywheel = {'))
    loads = f'[[loads]]\nkind = "couple"\nlink = "crank"\nmoment = "{clutch}"\n\n'
    if ram:
        loads += f'[[loads]]\nkind = "force"\nlink = "slider"\npoint = "B"\nfx = "{ram}"\n\n'
    path = folder / "press_law.toml"
    path.write_text(text.replace("[experiment]", loads + "[experiment]").replace('fmu = "PressContact"',
                                                                                 'fmu = "PressLaw"'))
    return path


def reference(p, times):
    """omega1 at ``times``: the press's Lagrange equation by hand (test_kinks.reference, restarted at
    each contact) with the clutch on the crank and the force on the ram."""
    return press_reference(p, times, lambda w: -p["T_d"] * math.tanh(w / p["w_d"]),
                           lambda phi, xB, w: -p["F_d"] * xB / p["l2"] * (1.0 - math.exp(-w / p["w_d"])))


@pytest.fixture(scope="module")
def press(tmp_path_factory):
    folder = tmp_path_factory.mktemp("press_law")
    path = press_file(folder)
    scenario = crankfmu.load_scenario(str(path))
    values = {k: scenario[k] for k in scenario.parameters}
    fmus = {}
    for name, extra in (("python", []), ("native", ["--native"]), ("native3", ["--native", "--fmi-version", "3"])):
        assert main(["fmu", str(path), *extra, "--out", str(folder / name)]) == 0
        fmus[name] = folder / name / "PressLaw.fmu"
    return scenario, values, fmus


def test_a_law_acts_in_either_direction_and_at_rest(tmp_path):
    """The table's Q against the loads' exact torque at omega1 = 0 and -+ 7 rad/s, for a law whose
    value at rest is T_d (not zero): a column held only while the crank turns would lose it. The
    angles include the ram on its workpiece: a kink's columns, the same in either direction, act at
    rest too (modes.column_factor)."""
    from crankfmu.dynamics.tabulated import table_of

    scenario = crankfmu.load_scenario(str(press_file(tmp_path, "-T_d*cos(omega1/w_d)")))
    model = scenario.build()
    table = table_of(model.reduced)
    phi1 = np.linspace(0.1, 6.2, 23)
    kin = model.reduced.mechanism.kinematics(phi1)
    for omega in (0.0, 7.0, -7.0):
        _, _, Q = table.coefficients_at(phi1, np.full_like(phi1, omega), 0.0)
        exact = sum(load.torque(kin, np.full_like(phi1, omega)) for load in model.reduced.loads)
        assert np.max(np.abs(Q - exact)) < 1e-8 * np.max(np.abs(exact)), omega


def test_the_c_evaluator_is_the_expression():
    from crankfmu.native.mechanism import LawEvaluator

    sources = (None, "-T_d*tanh(omega1/w_d)", "-F_d*(1 - exp(-omega1/w_d))", "omega1**3/w_d")
    laws = LawEvaluator(sources, VALUES)
    for omega in (-40.0, -1.5, 0.0, 0.3, 12.0, 300.0):
        env = {**VALUES, "omega1": omega}
        for s, source in enumerate(sources):
            if source is None:
                assert math.isnan(laws(s, omega))
            else:
                assert laws(s, omega) == pytest.approx(float(Expression(source).evaluate(env)), rel=1e-15, abs=1e-300)


@pytest.mark.parametrize("method", ["fast", "reference"])
def test_the_press_with_its_laws(press, method):
    scenario, values, _ = press
    times = np.linspace(0.0, STOP, 401)
    result = crankfmu.simulate(scenario, t_end=STOP, method=method, rtol=None, output_times=times)
    expected = reference(values, times)
    assert np.max(np.abs(result.omega1 - expected)) / np.max(np.abs(expected)) < 1e-8
    # the laws matter: without them the press runs faster by several rad/s
    without = reference({**values, "T_d": 0.0, "F_d": 0.0}, times)
    assert np.mean(without[200:]) > np.mean(expected[200:]) + 3.0


@pytest.mark.parametrize("fmu", ["python", "native", "native3"])
def test_the_fmus_with_the_laws(press, fmu):
    _, values, fmus = press
    fmu_follows(fmus[fmu], STOP, lambda times: reference(values, times), fmu)


def test_the_native_fmu_follows_a_law_parameter(press):
    """T_d set before initialisation: the C program's law reads it (the same reference at 60 N.m)."""
    from fmpy import simulate_fmu

    _, values, fmus = press
    result = simulate_fmu(str(fmus["native"]), stop_time=STOP, output_interval=1e-3, output=["omega1"],
                          start_values={"T_d": 60.0})
    expected = reference({**values, "T_d": 60.0}, result["time"])
    assert np.max(np.abs(result["omega1"] - expected)) / np.max(np.abs(expected)) < 1e-8
    assert np.max(np.abs(expected - reference(values, result["time"]))) > 0.5


def test_check_passes_and_names_the_laws(tmp_path, capsys):
    assert main(["check", str(press_file(tmp_path))]) == 0
    out = capsys.readouterr().out
    assert "the load on crank has a law of the speed, tanh(omega1 / w_d)" in out
    assert "the load on slider has a law of the speed, 1 - exp(-omega1 / w_d)" in out


def test_the_fmi3_binaries_agree_under_qemu(press, tmp_path):
    """The FMI 3.0 FMU (the contact's kink and both laws) in the project's C host
    (tests/c_host/fmu3_driver.c): its x86_64-linux binary and its aarch64-linux binary under
    qemu-aarch64 agree to 1e-12, and both with the reference to 1e-8."""
    from test_fmi3 import linux_and_arm_rows

    _, values, fmus = press
    runs = linux_and_arm_rows(fmus["native3"], "PressLaw", int(round(STOP / 1e-3)), 0.001, "omega1", tmp_path)
    linux, arm = runs["x86_64-linux"], runs["aarch64-linux"]
    expected = reference(values, linux[:, 0])
    scale = np.max(np.abs(expected))
    assert np.max(np.abs(linux[:, 1] - expected)) <= 1e-8 * scale
    assert arm.shape == linux.shape and np.max(np.abs(arm[:, 1] - linux[:, 1])) <= 1e-12 * scale


def test_the_native_fmus_reactions_carry_the_laws(press):
    """The native FMU's joint reactions over the run are Newton-Euler's at its (phi1, omega1,
    epsilon1) with every load applied exactly (the laws at the FMU's omega1: SpeedLawLoad.applied),
    to the tables' bound, away from the contact's switch angles; and the laws are in them (the same
    solve without the two laws differs)."""
    from fmpy import simulate_fmu

    from crankfmu.dynamics.reactions import joint_reactions, reaction_arrays, reaction_outputs
    from crankfmu.fmi.python.slave import REACTION_TOLERANCE
    from switches import away_from_switches

    scenario, _, fmus = press
    model = scenario.build()
    names = [name for name, _, _ in reaction_outputs(scenario.mechanism_definition())]
    run = simulate_fmu(str(fmus["native"]), stop_time=STOP, output_interval=1e-3,
                       output=["phi1", "omega1", "epsilon1", *names])
    expected = reaction_arrays(joint_reactions(model.reduced, run["phi1"], run["omega1"], run["epsilon1"]))
    scale = max(np.max(np.abs(expected[name])) for name in names)
    away = away_from_switches(model.reduced, run["phi1"])
    for name in names:
        assert np.max(np.abs(run[name] - expected[name])[away]) <= REACTION_TOLERANCE * scale, name
    laws = [load for load in model.reduced.loads if type(load).__name__ == "SpeedLawLoad"]
    assert len(laws) == 2
    others = [load for load in model.reduced.loads if load not in laws]
    without = reaction_arrays(joint_reactions(model.reduced, run["phi1"], run["omega1"], run["epsilon1"],
                                              loads=others))
    assert max(np.max(np.abs(without[name] - expected[name])) for name in names) > 1e3 * REACTION_TOLERANCE * scale
