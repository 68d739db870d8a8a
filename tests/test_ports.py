"""Ports ([[ports]] in a scenario file, dynamics.ports): a force or a couple a master sets, and
the coordinate it acts along as outputs. Checked against a second statement of the same physics:
the same force written as a data-file load, the energy balance with the port's work, the port's
outputs against the analytic kinematics, and the FMUs (pythonfmu and native, Co-Simulation and
Model Exchange) against the in-process reference. Bad [[ports]] entries are refused by name."""

from __future__ import annotations

import copy
import math
import re
from pathlib import Path

import numpy as np
import pytest

import crankfmu
from crankfmu.cli import main
from crankfmu.errors import DefinitionError, ParameterError, SchemeError
from crankfmu.scenario import Scenario, load_scenario

HERE = Path(__file__).resolve().parent
#: the knuckle-joint press of the user's guide tests, with a ram port along +y at E
PRESS = HERE.parent / "validation" / "data" / "togglepress_scenario.toml"


def _variant(path, **changes) -> Scenario:
    """The scenario at ``path`` with top-level sections replaced (a list value replaces the list)."""
    base = load_scenario(str(path))
    data = copy.deepcopy(dict(base.data))
    data.update(changes)
    return Scenario(data, base.where, base.path)


def _without_ports(path) -> dict:
    data = copy.deepcopy(dict(load_scenario(str(path)).data))
    data.pop("ports", None)
    return data


@pytest.mark.parametrize("method, rtol", [("reference", None), ("fast", 1e-12)])
def test_a_constant_port_force_is_the_same_force_written_as_a_load(method, rtol):
    """ram_F = -800 N along +y at E, against a `force` load fy = -800 at E on the ram: the same
    generalised force, once through the port's tabulated transfer function and W_ext, once through
    the load's and W_load. The reference integrates both at rtol 1e-12 and the fast path at 1e-12
    (at its default 1e-10 the two runs differ by its own error control, 1.6e-10 measured), so the
    issue's 1e-10 bar on omega1 is the physics' agreement, not the integrators'."""
    data = _without_ports(PRESS)
    data["loads"] = [*data["loads"], {"kind": "force", "link": "ram", "point": "E", "fx": "0", "fy": "-800"}]
    base = load_scenario(str(PRESS))
    as_load = Scenario(data, base.where, base.path)
    port = crankfmu.simulate(base, method=method, rtol=rtol, inputs={"ram_F": -800.0})
    load = crankfmu.simulate(as_load, method=method, rtol=rtol)
    assert np.max(np.abs(port.omega1 - load.omega1)) <= 1e-10 * np.max(np.abs(load.omega1))
    # the work moved from W_load to W_ext: the sums agree, and the port did work
    assert abs(port.W_ext[-1]) > 1.0
    total_port, total_load = port.W_load + port.W_ext, load.W_load + load.W_ext
    assert np.max(np.abs(total_port - total_load)) <= 1e-9 * np.max(np.abs(total_load))


def test_a_constant_port_couple_is_the_same_couple_written_as_a_load():
    """A couple port on the upper toggle link against a `couple` load of the same moment."""
    couple = [{"name": "arm", "kind": "couple", "link": "upper"}]
    with_port = _variant(PRESS, ports=couple)
    data = _without_ports(PRESS)
    data["loads"] = [*data["loads"], {"kind": "couple", "link": "upper", "moment": "12.5"}]
    base = load_scenario(str(PRESS))
    as_load = Scenario(data, base.where, base.path)
    port = crankfmu.simulate(with_port, inputs={"arm_M": 12.5})
    load = crankfmu.simulate(as_load)
    assert np.max(np.abs(port.omega1 - load.omega1)) <= 1e-10 * np.max(np.abs(load.omega1))
    assert sorted(port.ports) == ["arm_M", "arm_angle", "arm_epsilon", "arm_omega"]


@pytest.mark.parametrize("method", ["reference", "fast"])
def test_the_energy_balance_closes_with_the_ports_work(method):
    """A port force varying in time (a die cushion's push, 0 to 2 kN): the kinetic energy's change
    equals the work of the motor, the loads and the port (W_ext). Each integrator carries the
    works as states, so the balance holds to its tolerance: 1e-9 of the work done."""
    force = lambda t: -1000.0 * (1.0 + math.sin(7.0 * t))          # noqa: E731
    result = crankfmu.simulate(str(PRESS), method=method, inputs={"ram_F": force})
    balance = result.energy_balance()
    assert abs(balance["W_ext"]) > 10.0
    assert abs(balance["residual"]) <= 1e-9, balance
    # W_ext is the integral of F v along the port: trapezoids on the 1 ms output grid
    power = result.ports["ram_F"] * result.ports["ram_v"]
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(result.time))])
    assert np.max(np.abs(integral - result.W_ext)) <= 1e-3 * np.max(np.abs(result.W_ext))


def test_the_ports_outputs_are_the_points_motion_along_its_axis():
    """ram_s, ram_v, ram_a at E along +y against E.y and its derivatives from the analytic
    kinematics (the press's [[outputs]] ram_y is E.y): the same numbers."""
    result = crankfmu.simulate(str(PRESS), method="reference", t_end=0.5)
    kin = result.model.mechanism.kinematics(result.phi1)
    _, y, _, dy, _, ddy = kin.point("E")
    assert np.max(np.abs(result.ports["ram_s"] - y)) <= 1e-15 * np.max(np.abs(y)) + 1e-15
    np.testing.assert_allclose(result.ports["ram_v"], dy * result.omega1, rtol=0, atol=1e-13)
    np.testing.assert_allclose(result.ports["ram_a"], ddy * result.omega1 ** 2 + dy * result.epsilon1,
                               rtol=0, atol=1e-10 * np.max(np.abs(result.ports["ram_a"])))


@pytest.mark.parametrize("entry, message", [
    ({"name": "ram", "kind": "spring", "link": "ram"}, r"kind must be 'force', 'couple' or 'rope'"),
    ({"name": "ram", "kind": "force", "link": "ram", "axis": "0"}, r"needs point = one of"),
    ({"name": "ram", "kind": "force", "link": "ram", "point": "E"}, r"needs axis"),
    ({"name": "ram", "kind": "force", "link": "ram", "point": "E", "axis": "l*2"}, r"axis = 'l\*2' must be a finite"),
    ({"name": "ram", "kind": "force", "link": "nope", "point": "E", "axis": "0"}, r"link must be one of"),
    ({"name": "2ram", "kind": "couple", "link": "ram"}, r"name must be an identifier"),
    ({"name": "arm", "kind": "couple", "link": "upper", "point": "E"}, r"no point or axis"),
    ({"name": "arm", "kind": "couple", "link": "upper", "gain": 2}, r"unknown key\(s\) gain"),
    ({"name": "rod", "kind": "rope", "link": "ram", "point": "E", "axis": "0"}, r"a rope port needs lever"),
    ({"name": "rod", "kind": "rope", "link": "ram", "point": "E", "axis": "0", "lever": "0"}, r"lever = '0' must be a non-zero"),
    ({"name": "rod", "kind": "rope", "link": "ram", "point": "E", "axis": "0", "lever": "nope"}, r"lever = 'nope' must be"),
    ({"name": "ram", "kind": "force", "link": "ram", "point": "E", "axis": "0", "lever": "1"}, r"only a rope port has a lever"),
])
def test_a_bad_port_is_refused_by_name(entry, message):
    with pytest.raises(DefinitionError, match=message):
        _variant(PRESS, ports=[entry]).build()


def test_port_names_must_not_clash(tmp_path, capsys):
    """Two ports of one name, and a port whose outputs take an [[outputs]] name: refused by the
    build and by `crankfmu check`, with no FMU written."""
    twice = [{"name": "arm", "kind": "couple", "link": "upper"}] * 2
    with pytest.raises(DefinitionError, match=r"names must be unique"):
        _variant(PRESS, ports=twice).build()
    clash = _variant(PRESS, outputs=[{"name": "ram_v", "of": "E.y", "order": 1}])
    text = PRESS.read_text() + '\n[[outputs]]\nname = "ram_v"\nof = "E.y"\norder = 1\n'
    scenario_file = tmp_path / "clash_scenario.toml"
    scenario_file.write_text(text)
    (tmp_path / "togglepress.toml").write_text((PRESS.parent / "togglepress.toml").read_text())
    assert main(["fmu", str(scenario_file), "--out", str(tmp_path / "out")]) != 0
    assert re.search(r"ram_v", capsys.readouterr().err)
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    assert clash.ports[0].name == "ram"


def test_an_unknown_or_bad_input_is_refused():
    with pytest.raises(ParameterError, match=r"unknown input 'die_F'.*tau_ext, ram_F"):
        crankfmu.simulate(str(PRESS), t_end=0.1, inputs={"die_F": 1.0})
    with pytest.raises(ParameterError, match=r"ram_F = nan must be a finite number"):
        crankfmu.simulate(str(PRESS), t_end=0.1, inputs={"ram_F": float("nan")})
    with pytest.raises(SchemeError, match=r"crank-angle schemes take no port inputs"):
        crankfmu.simulate(str(PRESS), t_end=0.1, method="badoiu-eq17", inputs={"ram_F": 1.0})


# ------------------------------------------------------------------ the FMUs
@pytest.fixture(scope="module")
def press_fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("press")
    assert main(["fmu", str(PRESS), "--out", str(out / "python")]) == 0
    assert main(["fmu", str(PRESS), "--native", "--out", str(out / "native")]) == 0
    return {"python": out / "python" / "TogglePress.fmu", "native": out / "native" / "TogglePress.fmu"}


def _constant(name, value, stop):
    return np.array([(0.0, value), (stop, value)], dtype=[("time", float), (name, float)])


@pytest.mark.parametrize("kind", ["python", "native"])
def test_the_fmus_declare_the_port_and_fmpy_finds_no_problem(press_fmus, kind):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(press_fmus[kind])) == []
    md = read_model_description(str(press_fmus[kind]))
    variables = {v.name: v for v in md.modelVariables}
    assert (variables["ram_F"].causality, variables["ram_F"].unit) == ("input", "N")
    assert [(variables[n].causality, variables[n].unit) for n in ("ram_s", "ram_v", "ram_a")] == [
        ("output", "m"), ("output", "m/s"), ("output", "m/s2")]
    assert md.coSimulation.canInterpolateInputs == (kind == "native")


@pytest.mark.parametrize("kind, fmi_type", [("python", "CoSimulation"), ("native", "CoSimulation"),
                                            ("native", "ModelExchange")])
def test_the_fmus_port_matches_the_in_process_reference(press_fmus, kind, fmi_type):
    """ram_F = -500 N held: omega1 and the port's outputs against simulate(method="reference") to
    1e-6 of each one's largest value (the FMUs' own rtol 1e-10, CVode's 1e-10 in ME)."""
    import fmpy

    stop = 1.0
    outputs = ["omega1", "W_ext", "ram_s", "ram_v", "ram_a"]
    run = fmpy.simulate_fmu(str(press_fmus[kind]), fmi_type=fmi_type, stop_time=stop, output_interval=1e-3,
                            input=_constant("ram_F", -500.0, stop), output=outputs, relative_tolerance=1e-10)
    reference = crankfmu.simulate(str(PRESS), t_end=stop, method="reference", inputs={"ram_F": -500.0})
    expected = {"omega1": reference.omega1, "W_ext": reference.W_ext, **reference.ports}
    for name in outputs:
        got = np.interp(reference.time, run["time"], run[name])
        assert np.max(np.abs(got - expected[name])) <= 1e-6 * np.max(np.abs(expected[name])), name


def _drive_with_ramp(fmu_path, tmp_path, rate, derivatives: bool, stop=0.5, h=1e-3):
    """The native FMU stepped by fmpy's low-level API with ram_F = -300 + rate t set at every
    communication point, and its derivative given (or not): omega1 at the end."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu_path), str(tmp_path / f"x{derivatives}")),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate(loggingOn=False)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    for k in range(int(round(stop / h))):
        t = k * h
        fmu.setReal([vr["ram_F"]], [-300.0 + rate * t])
        if derivatives:
            fmu.setRealInputDerivatives([vr["ram_F"]], [1], [rate])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
    omega = fmu.getReal([vr["omega1"]])[0]
    fmu.terminate()
    fmu.freeInstance()
    return omega


def test_the_native_fmu_takes_input_derivatives(press_fmus, tmp_path):
    """ram_F rising linearly (-300 N + 4 kN/s t): with its derivative at each communication point
    the input is exact over every step, so omega1 matches the in-process reference with the same
    function of time to the FMU's tolerance (1e-7 relative); held over each step it lags by half a
    step's rise, an error at least 100 times larger."""
    rate = 4000.0
    reference = crankfmu.simulate(str(PRESS), t_end=0.5, method="reference", output_times=[0.0, 0.5],
                                  inputs={"ram_F": lambda t: -300.0 + rate * t}).omega1[-1]
    with_derivatives = _drive_with_ramp(press_fmus["native"], tmp_path, rate, True)
    held = _drive_with_ramp(press_fmus["native"], tmp_path, rate, False)
    assert abs(with_derivatives - reference) <= 1e-7 * abs(reference)
    assert abs(held - reference) >= 100 * abs(with_derivatives - reference)


def test_a_bad_input_derivative_is_refused_with_logging_off(press_fmus, tmp_path):
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    from fuzz_host import callbacks

    path = press_fmus["native"]
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    messages = []
    keep = callbacks(lambda env, name, status, category, message: messages.append(message.decode()))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), str(tmp_path / "x")),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate(loggingOn=False, callbacks=keep[0])
    for vrs, order, value, expected in (([vr["ram_F"]], [2], [1.0], r"ram_F: order 2; .*first derivative only"),
                                        ([vr["omega1"]], [1], [1.0], r"is not an input of this FMU"),
                                        ([vr["ram_F"]], [1], [float("nan")], r"ram_F: the derivative nan must be finite")):
        with pytest.raises(FMICallException):
            fmu.setRealInputDerivatives(vrs, order, value)
        assert re.search(expected, messages[-1]), messages[-1]
    fmu.freeInstance()
