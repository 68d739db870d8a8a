"""What the FMUs give a master to couple them (the issue "Coupled, as good as alone (I)"), checked
from outside as a master sees it (fmpy):

- the declared dependencies: after fmi2SetReal of one input (no step), exactly the outputs whose
  ModelStructure lists it move, on every kind of FMU (mechanism in torque and speed causality with
  ports, [[outputs]] and joints; the drives; the cushion; the rod string; Python and native);
- directional derivatives against central differences of the FMU's own values (Model Exchange:
  the states set; Co-Simulation: the inputs set, the state rolled back), FMI 2.0 and 3.0, and FMI
  3.0's adjoint against the transposed directional;
- output derivatives against finite differences of the trajectory the FMU then steps."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from crankfmu.cli import main

HERE = Path(__file__).resolve().parent
PRESS = HERE.parent / "validation" / "data" / "togglepress_scenario.toml"
FRICTION = HERE.parent / "validation" / "data" / "slidercrank_friction_scenario.toml"

#: what each build is made from (crankfmu fmu's arguments) and the input steps a dependency test sets
BUILDS = {
    "FourBar": ["seed000"],
    "TogglePress": [str(PRESS)],
    "TogglePressSpeed": [str(PRESS), "--causality", "speed"],
    # joint friction: its outputs solved with the acceleration, W_friction a state
    "SliderFriction": [str(FRICTION)],
    "Drive": ["dc_pi", "--drive"],
    "DriveSpeed": ["dc_pi", "--drive", "--causality", "speed"],
    "DieCushion": ["die_cushion", "--cushion"],
    "ElasticShaft": ["elastic_shaft", "--shaft"],
    "RodString": ["rp11l_guo", "--well"],
}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """{(name, variant): path}: variant "python", "native" (FMI 2.0) and "native3" (FMI 3.0)."""
    out = tmp_path_factory.mktemp("coupling")
    paths = {}
    for name, args in BUILDS.items():
        for variant, extra in (("python", []), ("native", ["--native"]), ("native3", ["--native", "--fmi-version", "3"])):
            if variant == "python" and name not in ("FourBar", "TogglePressSpeed", "Drive", "DieCushion"):
                continue           # the Python FMUs share the contract's dependencies: two kinds suffice
            assert main(["fmu", *args, *extra, "--out", str(out / variant)]) == 0
            paths[name, variant] = out / variant / f"{name}.fmu"
    return paths


def slave(path: Path, folder: Path):
    """(instance, model description, value references by name) of a Co-Simulation FMU, initialised."""
    return slave_with(path, folder, {})


def slave_with(path: Path, folder: Path, values: dict):
    """slave(), with ``values`` set before initialisation."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(str(path))
    kind = FMU3Slave if md.fmiVersion.startswith("3") else FMU2Slave
    fmu = kind(guid=md.guid, unzipDirectory=extract(str(path), str(folder)),
               modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate()
    references = {v.name: v.valueReference for v in md.modelVariables}
    if kind is not FMU3Slave:
        fmu.setupExperiment(startTime=0.0)
    if values:
        put(fmu, [references[n] for n in values], list(values.values()))
    if kind is FMU3Slave:
        fmu.enterInitializationMode(startTime=0.0)
    else:
        fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    return fmu, md, references


def get(fmu, vrs):
    return np.array(fmu.getFloat64(vrs) if hasattr(fmu, "getFloat64") else fmu.getReal(vrs))


def put(fmu, vrs, values):
    (fmu.setFloat64 if hasattr(fmu, "setFloat64") else fmu.setReal)(list(vrs), list(values))


def declared_dependencies(md) -> dict[str, set[str]]:
    """{output: the inputs its ModelStructure entry lists}"""
    inputs = {v.name for v in md.modelVariables if v.causality == "input"}
    found = {}
    for unknown in md.outputs:
        assert unknown.dependencies is not None, f"{unknown.variable.name} declares no dependencies"
        found[unknown.variable.name] = {d.name for d in unknown.dependencies} & inputs
    return found


def drive_inputs(md, fmu, vr, steps: int = 20, h: float = 1e-3):
    """Some steps with every input at a plausible non-zero value, so that every output is away from
    a value that hides a dependency (a current of 0 times a voltage)."""
    values = {"tau_ext": 5.0, "omega": 15.0, "omega1": 12.0, "tau_load": 8.0, "s": 0.05, "v": 0.2,
              "omega_set": 20.0}
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    for k in range(steps):
        put(fmu, [vr[n] for n in inputs], [values.get(n, 300.0 + 10 * k) for n in inputs])
        fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
    return inputs


@pytest.mark.parametrize("name,variant", [(n, v) for n in BUILDS for v in ("python", "native", "native3")])
def test_an_input_set_moves_exactly_its_declared_dependents(built, name, variant, tmp_path):
    """After fmi2SetReal of one input, with no step: the outputs that read it at once (declared)
    change, and no other output does. A stale output (the last step's) or an undeclared feedthrough
    fails here. A joint reaction is declared to depend on every input (Newton-Euler with the
    acceleration and the ports' forces), a structural bound: a component the geometry makes
    independent of them (a slide's couple with its force through the block's centre) may stay; so
    may M_motor off its sliding mode (the next test)."""
    if (name, variant) not in built:
        pytest.skip("no Python FMU of this kind in the check")
    fmu, md, vr = slave(built[name, variant], tmp_path)
    try:
        depends = declared_dependencies(md)
        inputs = drive_inputs(md, fmu, vr)
        outputs = sorted(depends)
        before = get(fmu, [vr[n] for n in outputs])
        for name_in in inputs:
            old = get(fmu, [vr[name_in]])[0]
            put(fmu, [vr[name_in]], [old * 1.1 + 1.0])
            after = get(fmu, [vr[n] for n in outputs])
            moved = {n for n, a, b in zip(outputs, after, before) if a != b}
            expected = {n for n in outputs if name_in in depends[n]}
            # a reaction's structural bound, and M_motor, which reads the inputs only while the motor
            # holds omega1 at a jump of its line (test_the_motor_holding_the_speed_reads_the_inputs)
            bounds = {n for n in outputs if n.endswith(("_Fx", "_Fy", "_N", "_M"))} | {"M_motor"}
            assert moved <= expected, f"{name} ({variant}), {name_in} set: {sorted(moved - expected)} undeclared"
            assert expected - moved <= bounds, f"{name} ({variant}), {name_in} set: {sorted(expected - moved)} stale"
            put(fmu, [vr[name_in]], [old])
            assert np.array_equal(get(fmu, [vr[n] for n in outputs]), before), "setting the input back restores them"
    finally:
        fmu.terminate()
        fmu.freeInstance()


@pytest.mark.parametrize("variant", ["python", "native", "native3"])
def test_the_motor_holding_the_speed_reads_the_inputs(built, variant, tmp_path):
    """M_motor declares tau_ext: where the motor line jumps down at omega_switch (1000 N.m below
    15 rad/s, none above) the motor holds omega1 at 15 rad/s with the torque the loads and inputs
    leave, so a torque set on the crank moves M_motor by as much, opposite, at once."""
    fmu, md, vr = slave_with(built["FourBar", variant], tmp_path,
                             {"A": 0.0, "B": 0.0, "A_low": 1000.0, "B_low": 0.0, "omega_switch": 15.0})
    try:
        assert "tau_ext" in declared_dependencies(md)["M_motor"]
        for k in range(100):
            fmu.doStep(currentCommunicationPoint=k * 5e-3, communicationStepSize=5e-3)
        omega1, epsilon1, before = get(fmu, [vr["omega1"], vr["epsilon1"], vr["M_motor"]])
        assert abs(omega1 - 15.0) < 1e-9 and epsilon1 == 0.0, "the motor holds the speed"
        put(fmu, [vr["tau_ext"]], [7.0])
        after = get(fmu, [vr["M_motor"]])[0]
        assert after == pytest.approx(before - 7.0, abs=1e-9)
    finally:
        fmu.terminate()
        fmu.freeInstance()


def test_the_capabilities_are_declared(built):
    """Every native FMU offers the derivatives (but the rod string, whose grid has none), the
    input derivatives, and its outputs' dependencies; the Python FMUs say they offer none."""
    import zipfile
    from xml.etree import ElementTree as ET

    for (name, variant), path in built.items():
        with zipfile.ZipFile(path) as archive:
            cs = ET.fromstring(archive.read("modelDescription.xml")).find("CoSimulation").attrib
        offers = variant != "python" and name != "RodString"
        assert cs.get("maxOutputDerivativeOrder", "0") == ("2" if offers else "0"), (name, variant)
        for attribute in (("providesDirectionalDerivatives", "providesAdjointDerivatives") if variant == "native3"
                          else ("providesDirectionalDerivative",)):
            assert cs.get(attribute, "false") == str(offers).lower(), (name, variant, attribute)
        if variant == "native":
            assert cs["canInterpolateInputs"] == "true", name


def central_difference(evaluate, x0: float, h: float) -> np.ndarray:
    """Richardson-extrapolated central difference of a vector function of one variable."""
    d = [(evaluate(x0 + s) - evaluate(x0 - s)) / (2 * s) for s in (h, h / 2)]
    return (4 * d[1] - d[0]) / 3


@pytest.mark.parametrize("name,variant", [(n, v) for n in ("TogglePress", "SliderFriction")
                                          for v in ("native", "native3")])
def test_directional_derivatives_match_central_differences_in_co_simulation(built, name, variant, tmp_path):
    """The toggle press (ram port, [[outputs]], joints) and the slider-crank with joint friction (its
    frictions solved with the acceleration): d(every output)/d(each input) from the FMU against
    central differences of the outputs with the input set (no step) to 1e-6 relative; FMI 3.0's
    adjoint against the transposed directional to 1e-12."""
    fmu, md, vr = slave(built[name, variant], tmp_path)
    try:
        inputs = drive_inputs(md, fmu, vr, steps=37)
        outputs = [u.variable.name for u in md.outputs]
        out_vrs = [vr[n] for n in outputs]
        jacobian = np.zeros((len(outputs), len(inputs)))
        for k, name_in in enumerate(inputs):
            seed = np.zeros(len(inputs))
            seed[k] = 1.0
            if variant == "native3":
                jacobian[:, k] = fmu.getDirectionalDerivative(out_vrs, [vr[n] for n in inputs], list(seed))
            else:
                jacobian[:, k] = fmu.getDirectionalDerivative(out_vrs, [vr[n] for n in inputs], list(seed))
            x0 = get(fmu, [vr[name_in]])[0]

            def values(x):
                put(fmu, [vr[name_in]], [x])
                return get(fmu, out_vrs)

            numeric = central_difference(values, x0, 1e-3 * max(1.0, abs(x0)))
            put(fmu, [vr[name_in]], [x0])
            scale = np.maximum(np.abs(numeric), 1e-9 * np.max(np.abs(numeric)) + 1e-12)
            worst = np.max(np.abs(jacobian[:, k] - numeric) / scale)
            print(f"{name} ({variant}) d/d{name_in}: largest relative difference {worst:.1e}")
            assert worst < 1e-6, f"d/d{name_in}: relative {worst:.2e}"
        if variant == "native3":
            seed = np.linspace(1.0, 2.0, len(outputs))
            adjoint = np.array(fmu.getAdjointDerivative(out_vrs, [vr[n] for n in inputs], list(seed), len(inputs)))
            print(f"adjoint against transposed directional: {np.max(np.abs(adjoint / (jacobian.T @ seed) - 1)):.1e}")
            assert np.allclose(adjoint, jacobian.T @ seed, rtol=1e-12, atol=0.0)
    finally:
        fmu.terminate()
        fmu.freeInstance()


@pytest.mark.parametrize("name,variant", [(n, v) for n in ("Drive", "DriveSpeed") for v in ("native", "native3")])
def test_the_drives_linear_system_is_read_from_directional_derivatives(built, name, variant, tmp_path):
    """The drives declare their states (i, x, and omega where they carry the rotor) with their
    derivatives, in Co-Simulation too, so a master reads their linear system from directional
    derivatives (validation/cosim.py's implicit step does). It is the circuit's and the rotor's
    closed form, L di/dt = Kp (omega_set - omega) + Ki x - R i - n k_t omega, dx/dt = omega_set -
    omega, J_drive domega/dt = n k_t i - tau_load, to 1e-9 (the equations are linear: the central
    differences are exact but for rounding); the rates read are those equations at the point."""
    fmu, md, vr = slave(built[name, variant], tmp_path)
    try:
        drive_inputs(md, fmu, vr, steps=5)
        p = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"}
        R, L, Kp, Ki, nk = p["R"], p["L"], p["Kp"], p["Ki"], p["n_gear"] * p["k_t"]
        speed = name == "DriveSpeed"
        states = ["i", "x", "omega"] if speed else ["i", "x"]
        inputs = ["omega_set", "tau_load"] if speed else ["omega", "omega_set"]
        declared = {u.variable.name for u in md.derivatives}
        assert declared == {f"der({s})" for s in states}
        unknowns = [vr[f"der({s})"] for s in states]
        knowns = states + inputs
        jacobian = np.column_stack([fmu.getDirectionalDerivative(unknowns, [vr[k]], [1.0]) for k in knowns])
        # d/d(i, x, omega | omega, omega_set, tau_load) of der(i), der(x), der(omega)
        closed = {("der(i)", "i"): -R / L, ("der(i)", "x"): Ki / L, ("der(i)", "omega"): -(Kp + nk) / L,
                  ("der(i)", "omega_set"): Kp / L, ("der(x)", "omega"): -1.0, ("der(x)", "omega_set"): 1.0}
        if speed:
            closed.update({("der(omega)", "i"): nk / p["J_drive"], ("der(omega)", "tau_load"): -1.0 / p["J_drive"]})
        expected = np.array([[closed.get((f"der({s})", k), 0.0) for k in knowns] for s in states])
        assert np.allclose(jacobian, expected, rtol=1e-9, atol=1e-9 * np.max(np.abs(expected))), jacobian
        i, x, omega_set = get(fmu, [vr["i"], vr["x"], vr["omega_set"]])
        omega = get(fmu, [vr["omega"]])[0]
        rates = get(fmu, unknowns)
        u = Kp * (omega_set - omega) + Ki * x
        assert rates[0] == pytest.approx((u - R * i - nk * omega) / L, rel=1e-12)
        assert rates[1] == pytest.approx(omega_set - omega, rel=1e-12)
        if speed:
            assert rates[2] == pytest.approx((nk * i - get(fmu, [vr["tau_load"]])[0]) / p["J_drive"], rel=1e-12)
    finally:
        fmu.terminate()
        fmu.freeInstance()


@pytest.mark.parametrize("variant", ["native", "native3"])
def test_the_shafts_linear_system_and_its_step_on_input_lines(built, variant, tmp_path):
    """ElasticShaft declares its twist with der(twist): its linear system from directional
    derivatives is the closed form (d der(twist) = d omega_a - d omega_b; d tau = k d twist + c
    (d omega_a - d omega_b)) to 1e-9; the output derivative of tau along input lines is
    k (omega_a - omega_b) + c (rate_a - rate_b); and a step with the inputs' derivatives set ends at
    the twist the two lines integrate to (a master's extrapolated inputs cost the shaft nothing),
    with the speeds and the torque at the lines' ends (a master that reads the torque before it sets
    the speeds again, as a rollback does for its residual, reads the end's damping)."""
    fmu, md, vr = slave(built["ElasticShaft", variant], tmp_path)
    p = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"}
    k, c = p["k"], p["c"]
    fmi3 = variant == "native3"
    try:
        put(fmu, [vr["omega_a"], vr["omega_b"]], [20.0, 18.5])
        fmu.doStep(0.0, 1e-3) if fmi3 else fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
        twist = get(fmu, [vr["twist"]])[0]
        assert twist == pytest.approx(1.5e-3, rel=1e-12)
        knowns = ["twist", "omega_a", "omega_b"]
        unknowns = [vr["der(twist)"], vr["tau"]]
        jacobian = np.column_stack([fmu.getDirectionalDerivative(unknowns, [vr[n]], [1.0]) for n in knowns])
        assert np.allclose(jacobian, [[0.0, 1.0, -1.0], [k, c, -c]], rtol=1e-9, atol=1e-9 * k), jacobian
        # FMI 3.0 Co-Simulation has no input derivatives: its inputs are held (rates 0)
        slope_a, slope_b, h = (0.0, 0.0, 2e-3) if fmi3 else (300.0, -200.0, 2e-3)
        if fmi3:
            d_tau = fmu.getOutputDerivatives([vr["tau"]], [1])[0]
        else:
            fmu.setRealInputDerivatives([vr["omega_a"], vr["omega_b"]], [1, 1], [slope_a, slope_b])
            d_tau = fmu.getRealOutputDerivatives([vr["tau"]], [1])[0]
        assert d_tau == pytest.approx(k * 1.5 + c * (slope_a - slope_b), rel=1e-9)
        fmu.doStep(1e-3, h) if fmi3 else fmu.doStep(currentCommunicationPoint=1e-3, communicationStepSize=h)
        expected = twist + 1.5 * h + 0.5 * (slope_a - slope_b) * h * h
        assert get(fmu, [vr["twist"]])[0] == pytest.approx(expected, rel=1e-12)
        # at the step's end the speeds are at their lines' ends, and the torque reads them there
        ends = (20.0 + slope_a * h, 18.5 + slope_b * h)
        assert tuple(get(fmu, [vr["omega_a"], vr["omega_b"]])) == pytest.approx(ends, rel=1e-15)
        assert get(fmu, [vr["tau"]])[0] == pytest.approx(k * expected + c * (ends[0] - ends[1]), rel=1e-12)
    finally:
        fmu.terminate()
        fmu.freeInstance()


FAN = HERE / "data" / "user" / "engine4s_fan_scenario.toml"


@pytest.mark.parametrize("which", ["FourBar", "Engine4SFan", "Engine4SLaw", "SliderFriction"])
def test_directional_derivatives_match_central_differences_in_model_exchange(built, which, tmp_path):
    """FourBar in Model Exchange: d(der(phi1), der(omega1), der(W_...), epsilon1, M_motor, M_load,
    J_red, E_kin)/d(each state and tau_ext) from the FMU against central differences of the same
    values with the states set (fmi2SetContinuousStates) to 1e-6 relative, in the middle of a turn
    (the motor on its upper line, away from its kink). The engine driving a fan (-c omega1 |omega1|,
    a load of degree 2 whose omega1**2 column the kernel weighs by omega1's power) likewise: its
    d der(omega1)/d omega1 carries the fan's -2 c |omega1|; and the engine with its fan as a general
    law of the speed, -c_fan*240**2*tanh(omega1/240) (dynamics/speed_laws.py: its column weighed by
    the law the program evaluates), its d der(omega1)/d omega1 carrying the law's slope. The
    slider-crank with joint friction: W_friction the sixth state, der(W_friction) = M_friction omega1
    with the frictions solved with the acceleration, away from their switches and kinks."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Model

    if which in ("FourBar", "SliderFriction"):
        path = built[which, "native"]
    else:
        source = FAN
        if which == "Engine4SLaw":
            source = tmp_path / "law.toml"
            source.write_text(FAN.read_text().replace('moment = "-c_fan*omega1*abs(omega1)"',
                                                      'moment = "-c_fan*240**2*tanh(omega1/240)"')
                              .replace('fmu = "Engine4SFan"', 'fmu = "Engine4SLaw"'))
        assert main(["fmu", str(source), "--native", "--out", str(tmp_path / "fan")]) == 0
        path = tmp_path / "fan" / f"{which}.fmu"
    md = read_model_description(str(path))
    fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(str(path), str(tmp_path)),
                    modelIdentifier=md.modelExchange.modelIdentifier)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    start = [2.1, 240.0] if which.startswith("Engine") else [1.3, 18.0]
    put(fmu, [vr["phi1_start"], vr["omega1_start"]], start)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.newDiscreteStates()
    fmu.enterContinuousTimeMode()
    try:
        friction = "der(W_friction)" in vr
        states = ["phi1", "omega1", "W_motor", "W_load", "W_ext"] + (["W_friction"] if friction else [])
        knowns = states + ["tau_ext"]
        unknowns = [f"der({s})" for s in states] + ["epsilon1", "M_motor", "M_load", "J_red", "E_kin"]
        unknowns += ["M_friction", "slide_Ff", "O_Mf"] if friction else []
        from ctypes import c_double

        def set_states(y):
            fmu.setContinuousStates((c_double * len(y))(*y), len(y))

        x0 = np.array([*start, 10.0, -5.0, 0.0] + ([-3.0] if friction else []))
        set_states(x0)
        u_vrs = [vr[n] for n in unknowns]
        for k, known in enumerate(knowns):
            analytic = np.array(fmu.getDirectionalDerivative(u_vrs, [vr[known]], [1.0]))

            def values(x):
                if known == "tau_ext":
                    put(fmu, [vr["tau_ext"]], [x])
                else:
                    y = x0.copy()
                    y[k] = x
                    set_states(y)
                return get(fmu, u_vrs)

            centre = 0.0 if known == "tau_ext" else x0[k]
            h = 1e-4 * max(1.0, abs(centre))
            numeric = central_difference(values, centre, h)
            at = values(centre)
            # the differences' own rounding, eps |value| / h each, is no error of the FMU's: a derivative
            # near zero (the engine's d der(W_load)/d phi1, der(W_load) = M_load omega1 = -737 W) is
            # met to it (1e-9 W/rad at h = 2e-4), the others to 1e-6 of themselves
            noise = 100 * np.finfo(float).eps * np.abs(at) / h
            scale = np.maximum(np.abs(numeric), 1e-9 * np.max(np.abs(numeric)) + 1e-12)
            worst = np.max(np.maximum(np.abs(analytic - numeric) - noise, 0.0) / scale)
            raw = np.max(np.abs(analytic - numeric) / scale)
            print(f"{which} (ME) d/d{known}: largest relative difference {raw:.1e}, {worst:.1e} past the rounding")
            assert worst < 1e-6, f"d/d{known}: relative {worst:.2e} ({analytic} against {numeric})"
    finally:
        fmu.terminate()
        fmu.freeInstance()


def test_output_derivatives_match_the_trajectory(built, tmp_path):
    """FourBar and Drive in Co-Simulation: the first and second derivatives of every output at a
    communication point against one-sided five-point differences of the outputs the FMU steps to
    from there (rolled back to the saved state for each). The differences converge to the FMU's
    values as h^4 (first) and h^3 (second): at h = 1 ms and 0.5 ms FourBar's worst output is 7.1e-6
    and 6.0e-7 off (first), 9.1e-5 and 2.2e-5 (second); so h = 0.5 ms, bounds 2e-6 and 5e-5 of each
    output's size, and the error at 1 ms at least four times the error at 0.5 ms (convergence to
    the FMU's value, not to another)."""
    for name in ("FourBar", "Drive"):
        fmu, md, vr = slave(built[name, "native"], tmp_path / name)
        try:
            drive_inputs(md, fmu, vr, steps=150)
            t0 = 150 * 1e-3
            o_vrs = [vr[u.variable.name] for u in md.outputs]
            first = np.array(fmu.getRealOutputDerivatives(o_vrs, [1] * len(o_vrs)))
            second = np.array(fmu.getRealOutputDerivatives(o_vrs, [2] * len(o_vrs)))
            state = fmu.getFMUstate()

            def ahead(s):
                fmu.setFMUstate(state)
                if s > 0:
                    fmu.doStep(currentCommunicationPoint=t0, communicationStepSize=s)
                return get(fmu, o_vrs)

            errors = {}
            for h in (1e-3, 5e-4):
                y = [ahead(k * h) for k in range(5)]
                d1 = (-25 * y[0] + 48 * y[1] - 36 * y[2] + 16 * y[3] - 3 * y[4]) / (12 * h)
                d2 = (35 * y[0] - 104 * y[1] + 114 * y[2] - 56 * y[3] + 11 * y[4]) / (12 * h * h)
                errors[h] = [np.max(np.abs(ours - numeric) / (np.abs(numeric) + 1e-3 * np.max(np.abs(numeric))))
                             for ours, numeric in ((first, d1), (second, d2))]
            fmu.freeFMUstate(state)
            print(f"{name}: first, second derivatives against the trajectory: {errors}")
            assert errors[5e-4][0] < 2e-6 and errors[5e-4][1] < 5e-5, (name, errors)
            assert errors[1e-3][0] > 4 * errors[5e-4][0] and errors[1e-3][1] > 2 * errors[5e-4][1], (name, errors)
        finally:
            fmu.terminate()
            fmu.freeInstance()
