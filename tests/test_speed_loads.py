"""Loads of the speeds beyond affine (dynamics/speed_loads.py): a fan's -c omega1 |omega1|.

- The degree of an expression in the speeds is read from its text (the Python engine and the C
  model's compiler class a load alike); the per-direction quadratic fit is exact for a quadratic.
- The press closing on its workpiece of tests/test_kinks.py with a fan on its crank: omega1(t) of
  the fast path, the reference integrator, the Python FMU and the native FMI 2.0 and 3.0 FMUs
  (Co-Simulation) against the independent Lagrange reference of test_kinks with the fan's torque,
  within 1e-8; Model Exchange (CVode at 1e-10) within 1e-6.
- The four-stroke engine driving a fan (tests/data/user/engine4s_fan_scenario.toml, a cycle of two
  turns): the fast path and the native FMU within 1e-7 of the hand-written reference of
  tests/engine_reference.py with the fan's torque (no crankfmu code).
- The four-cylinder engine driving a fan in place of its generator: the fast path and the native
  FMU against the reference integrator within 1e-7, and the fast path's energy balance closed.
- A law that is no polynomial of degree <= 2 in the speeds (1 - exp(-omega1/w0), omega1**3) is held
  as written: tests/test_speed_laws.py.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import crankfmu
from crankfmu.cli import main
from crankfmu.dynamics.speed_loads import quadratic_parts, speed_degree
from crankfmu.errors import DefinitionError

from test_kinks import reference as press_reference

USER = Path(__file__).resolve().parent / "data" / "user"
PRESS = USER / "press_contact_scenario.toml"
ENGINE = USER / "engine4_fan_scenario.toml"
FAN = '[[loads]]\nkind = "couple"\nlink = "crank"\nmoment = "-c_fan*omega1*abs(omega1)"\n\n'
C_FAN = 0.02      # N.m.s2/rad2


@pytest.mark.parametrize("source, degree, kinked", [
    ("-c*omega1", 1, False), ("-c*omega1*abs(omega1)", 2, True), ("-c*omega1**2", 2, False),
    ("-(T0 + k*omega1)*cos(phi1)", 1, False), ("-c*B_vx*abs(B_vx)", 2, True), ("-T0*sign(omega1)", 0, True),
    ("-T0*(1 - exp(-omega1/w0))", None, False), ("-c*omega1**3", 3, False), ("1/omega1", None, False),
])
def test_the_degree_in_the_speeds_is_read_from_the_text(source, degree, kinked):
    assert speed_degree(source, {"omega1", "B_vx"}) == (degree, kinked)


def test_the_fit_is_exact_for_a_quadratic_on_each_side():
    rng = np.random.default_rng(5)
    for _ in range(50):
        plus, minus = rng.normal(0, 100, 3), rng.normal(0, 100, 3)
        law = lambda w: np.polyval((plus if w > 0 else minus)[::-1], w)     # noqa: E731
        sym, anti = quadratic_parts(law, 37.0)
        assert np.allclose(np.add(sym, anti), plus, rtol=1e-11, atol=1e-9)
        assert np.allclose(np.subtract(sym, anti), minus, rtol=1e-11, atol=1e-9)


@pytest.fixture(scope="module")
def press(tmp_path_factory):
    folder = tmp_path_factory.mktemp("press_fan")
    text = PRESS.read_text().replace('J_flywheel = {', f'c_fan = {{ value = {C_FAN}, unit = "N.m.s2/rad2", min = 0, '
                                     'description = "a fan on the crank" }\nJ_flywheel = {')
    path = folder / "press_fan.toml"
    path.write_text(text.replace("[experiment]", FAN + "[experiment]").replace('fmu = "PressContact"', 'fmu = "PressFan"'))
    scenario = crankfmu.load_scenario(str(path))
    values = {k: scenario[k] for k in scenario.parameters}
    fmus = {}
    for name, extra in (("python", []), ("native", ["--native"]), ("native3", ["--native", "--fmi-version", "3"])):
        assert main(["fmu", str(path), *extra, "--out", str(folder / name)]) == 0
        fmus[name] = folder / name / "PressFan.fmu"
    return scenario, values, fmus


def fan(w):
    return -C_FAN * w * abs(w)


@pytest.mark.parametrize("method", ["fast", "reference"])
def test_the_engine_drives_the_fan(press, method):
    scenario, values, _ = press
    times = np.linspace(0.0, 2.0, 401)
    result = crankfmu.simulate(scenario, t_end=2.0, method=method, rtol=None, output_times=times)
    expected = press_reference(values, times, fan)
    assert np.max(np.abs(result.omega1 - expected)) / np.max(np.abs(expected)) < 1e-8
    # the fan matters: without it the press runs 10 rad/s faster
    assert np.mean(expected[200:]) < np.mean(press_reference(values, times)[200:]) - 5.0


@pytest.mark.parametrize("fmu", ["python", "native", "native3"])
def test_the_fmus_drive_the_fan(press, fmu):
    from fmpy import simulate_fmu

    _, values, fmus = press
    result = simulate_fmu(str(fmus[fmu]), stop_time=2.0, output_interval=1e-3, output=["omega1"])
    expected = press_reference(values, result["time"], fan)
    assert np.max(np.abs(result["omega1"] - expected)) / np.max(np.abs(expected)) < 1e-8
    if fmu != "python":
        me = simulate_fmu(str(fmus[fmu]), stop_time=2.0, output_interval=1e-3, output=["omega1"],
                          fmi_type="ModelExchange", relative_tolerance=1e-10)
        at = press_reference(values, me["time"], fan)       # ME's rows include its events' times
        assert np.max(np.abs(me["omega1"] - at)) / np.max(np.abs(at)) < 1e-6


def test_the_four_stroke_engine_drives_a_fan(tmp_path):
    """The hand-written engine's motor torque with the fan's beside it: A - B omega1 - c omega1 |omega1|."""
    from fmpy import simulate_fmu

    from engine_reference import Engine

    path = USER / "engine4s_fan_scenario.toml"

    class FanEngine(Engine):
        def torque(self, omega):
            return super().torque(omega) - self.p["c_fan"] * omega * abs(omega)
    scenario = crankfmu.load_scenario(str(path))
    stop = scenario.data["experiment"]["stop_time"]
    assert main(["fmu", str(path), "--native", "--out", str(tmp_path)]) == 0
    native = simulate_fmu(str(tmp_path / "Engine4SFan.fmu"), stop_time=stop, output_interval=1e-3, output=["omega1"])
    expected = FanEngine(path).run(native["time"])
    fast = crankfmu.simulate(scenario, t_end=stop, method="fast", rtol=None, output_times=native["time"])
    scale = np.max(np.abs(expected))
    assert np.max(np.abs(fast.omega1 - expected)) / scale < 1e-7
    assert np.max(np.abs(native["omega1"] - expected)) / scale < 1e-7
    assert np.max(np.abs(expected - Engine(path).run(native["time"]))) > 1.0       # the fan acts


def test_the_four_cylinder_engine_drives_a_fan(tmp_path):
    """The fast path and the native FMU against the reference integrator (a second method: the
    expressions evaluated at every step) over 0.3 s (about 18 crank turns at 3600 rpm)."""
    from fmpy import simulate_fmu

    scenario = crankfmu.load_scenario(str(ENGINE))
    assert main(["fmu", str(ENGINE), "--native", "--out", str(tmp_path)]) == 0
    native = simulate_fmu(str(tmp_path / "Engine4Fan.fmu"), stop_time=0.3, output_interval=1e-3, output=["omega1"])
    times = native["time"]
    reference = crankfmu.simulate(scenario, t_end=0.3, method="reference", rtol=None, output_times=times)
    fast = crankfmu.simulate(scenario, t_end=0.3, method="fast", rtol=None, output_times=times)
    scale = np.max(np.abs(reference.omega1))
    assert np.max(np.abs(fast.omega1 - reference.omega1)) / scale < 1e-7
    assert np.max(np.abs(native["omega1"] - reference.omega1)) / scale < 1e-7
    # the energy balance of the fast path: motor + loads (the fan's work in them) = the change of E_kin
    balance = fast.summary()["energy_balance"]
    assert abs(balance["residual"]) < 1e-9 * abs(balance["W_load"]), balance
