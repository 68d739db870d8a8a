"""What the FMUs' coupling features buy a master (the issue "Coupled, as good as alone (I)"): the
coupled scenes of validation/scenes.py run by validation/cosim.py's master on the native FMI 2.0
FMUs, against their one-model references (DOP853). Error: max |omega1 - reference| / max omega1.

- FourBarDrive: inputs held are first order; extrapolated from the FMUs' output derivatives second
  order (<= 2e-4 at 1 ms); the linearly implicit step from their directional derivatives second
  order (<= 1e-4 at 1 ms, <= 1.2e-2 at 10 ms), one doStep per FMU per step.
- The elastic shaft (k = 1e5 N.m/rad, 5 % damping) between DriveSpeed and FourBar: inputs held
  diverge at 10 ms (stable below 2c/k = 0.2 ms); the linearly implicit step, the inputs held at
  their end values (theta = 1, L-stable), is stable at 10 ms.
- The flywheel on the crank side in speed causality: inputs held diverge at every step; the step
  iterated with rollback is stable at 10 ms within 2e-2, second order.

The figures are printed for the closing note and docs/coupling.md."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from crankfmu.validation import scenes
from crankfmu.validation.cosim import observed_order


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    return scenes.build(tmp_path_factory.mktemp("scenes"))


def table(name, results):
    for (mode, step), m in sorted(results.items()):
        print(f"{name} {mode:11s} H = {step * 1e3:5.1f} ms: error {m.error:.3e} ({m.steps} FMU steps)"
              + (f" diverged: {m.failure[:80]}" if m.failure else ""))


def test_fourbardrive_second_order_from_output_and_directional_derivatives(built, tmp_path):
    scene = scenes.scene("FourBarDrive")
    references = {}
    results = {(mode, h): scenes.measure(scene, built, mode, h, folder=tmp_path / f"{mode}{h}", references=references)
               for mode in ("hold", "extrapolate", "implicit") for h in (1e-2, 2e-3, 1e-3)}
    table("FourBarDrive", results)
    steps = (2e-3, 1e-3)
    order = {mode: observed_order(steps, [results[mode, h].error for h in steps])
             for mode in ("hold", "extrapolate", "implicit")}
    print(f"FourBarDrive observed orders: {order}")
    assert 0.9 < order["hold"] < 1.2
    assert order["extrapolate"] >= 1.9 and results["extrapolate", 1e-3].error <= 2e-4
    assert order["implicit"] >= 1.9 and results["implicit", 1e-3].error <= 1e-4
    assert results["implicit", 1e-2].error <= 1.2e-2
    assert results["implicit", 1e-3].steps == results["hold", 1e-3].steps == 2000, "one doStep per FMU per step"


def test_a_stiff_shaft_is_stable_at_10_ms_with_the_linearly_implicit_step(built, tmp_path):
    scene = scenes.scene("ShaftDrive", k=1e5)
    results = {("hold", 1e-2): scenes.measure(scene, built, "hold", 1e-2, folder=tmp_path / "hold"),
               ("implicit", 1e-2): scenes.measure(scene, built, "implicit", 1e-2, theta=1.0, folder=tmp_path / "imp")}
    table("ShaftDrive k = 1e5", results)
    assert results["hold", 1e-2].error == np.inf, "held inputs are stable only below 2c/k"
    assert results["implicit", 1e-2].error < 5e-2
    assert results["implicit", 1e-2].steps == 200


@pytest.mark.parametrize("k,mode,theta,step", [(1e4, "hold", 0.5, 1e-4), (1e5, "implicit", 1.0, 1e-2)])
def test_the_shaft_fmu_couples_as_the_masters_own_shaft_equation(built, tmp_path, k, mode, theta, step):
    """ElasticShaft.fmu between the drive and the four-bar (three FMUs, plain connections) against
    the same shaft written as the master's own equation (Coupling.shaft: the twist the master's
    state, the torque k z + c (omega - omega1)), a second statement of the same law: the FMU's step
    integrates the input lines it is given exactly, the master's theta rule integrates the same
    lines, so the runs agree to rounding (1e-10 of max omega1) with held inputs at 0.1 ms and with
    the linearly implicit step at theta 1 and 10 ms."""
    from crankfmu.validation.cosim import Coupling, cosimulate

    scene = scenes.scene("ShaftDrive", k=k)
    shaft = scene.parameters["Shaft"]
    fmus = {component: built[fmu] for component, fmu in scene.fmus.items()}
    stop = 0.5
    with_fmu = cosimulate(fmus, scene.coupling, scene.parameters, stop, step, mode, record=("FourBar.omega1",),
                          folder=tmp_path / "fmu", theta=theta)
    equation = cosimulate({c: fmus[c] for c in ("Drive", "FourBar")},
                          Coupling.shaft("Drive", "FourBar", shaft["k"], shaft["c"]),
                          {c: scene.parameters[c] for c in ("Drive", "FourBar")}, stop, step, mode,
                          record=("FourBar.omega1",), folder=tmp_path / "equation", theta=theta)
    a, b = with_fmu["FourBar.omega1"], equation["FourBar.omega1"]
    print(f"shaft k = {k:g}, {mode} at {step * 1e3:g} ms: FMU against equation {np.max(np.abs(a - b)):.2e} rad/s "
          f"of {np.max(np.abs(b)):.3g}")
    assert np.max(np.abs(a - b)) <= 1e-10 * np.max(np.abs(b))


def test_the_flywheel_on_the_crank_is_stable_at_10_ms_with_rollback(built, tmp_path):
    scene = scenes.scene("FlywheelOnCrank")
    references = {}
    results = {("hold", 1e-2): scenes.measure(scene, built, "hold", 1e-2, folder=tmp_path / "hold")}
    for h in (1e-2, 5e-3):
        results["rollback", h] = scenes.measure(scene, built, "rollback", h, folder=tmp_path / f"r{h}",
                                                references=references)
    table("FlywheelOnCrank", results)
    assert results["hold", 1e-2].error == np.inf, "held inputs diverge at every step"
    assert results["rollback", 1e-2].error <= 2e-2
    assert observed_order((1e-2, 5e-3), [results["rollback", h].error for h in (1e-2, 5e-3)]) >= 1.8


def test_the_c_master_extrapolates_with_the_fmi2_dlls_under_wine_as_on_linux(built, tmp_path):
    """FourBarDrive with the inputs extrapolated in the project's C master (tests/c_host/
    system_driver.c: fmi2GetRealOutputDerivatives -> fmi2SetRealInputDerivatives) on the FMI 2.0
    FMUs' linux64 binaries and, compiled with MinGW, their win64 DLLs under wine: the same rows to
    1e-12 of the scale (the binaries are compiled from the same C, FMA contraction off), within 2e-4
    of the one-model reference at 1 ms as validation/cosim.py's master; and the directional
    derivatives the DLLs give: d der(omega1)/d tau_ext = 1/J_red, d der(i)/d i = -R/L to 1e-9."""
    import shutil
    import subprocess

    from fmpy import extract, read_model_description

    from crankfmu.validation.coupling import coupled_reference
    from wine import run_in_session, windows_path, wine_prefix

    scene = scenes.scene("FourBarDrive")
    parts = {}
    for component, fmu in scene.fmus.items():
        md = read_model_description(str(built[fmu]))
        parts[component] = (Path(extract(str(built[fmu]), str(tmp_path / component))), md.coSimulation.modelIdentifier,
                            md.guid, {v.name: v.valueReference for v in md.modelVariables},
                            {v.name: v.start for v in md.modelVariables})
    vr = {component: part[3] for component, part in parts.items()}
    step, stop = 1e-3, 2.0

    def plan(path_of) -> str:
        lines = [f"fmu {c} {path_of(folder)} {model} {guid}" for c, (folder, model, guid, _, _) in parts.items()]
        lines += [f"set {c} {vr[c][n]} {value!r}" for c, values in scene.parameters.items()
                  for n, value in values.items()]
        lines += [f"connect {a} {vr[a][o]} {b} {vr[b][i]}" for a, o, b, i in scene.coupling.links()]
        lines += [f"record FourBar {vr['FourBar']['omega1']}", f"record FourBar {vr['FourBar']['J_red']}",
                  f"directional FourBar {vr['FourBar']['der(omega1)']} {vr['FourBar']['tau_ext']}",
                  f"directional Drive {vr['Drive']['der(i)']} {vr['Drive']['i']}",
                  "extrapolate", f"step {step!r}", f"stop {stop!r}"]
        return "\n".join(lines) + "\n"

    def parse(output):
        rows = np.array([[float(x) for x in line[4:].split(",")] for line in output.splitlines()
                         if line.startswith("row ")])
        directional = [float(line.split()[-1]) for line in output.splitlines() if line.startswith("directional ")]
        return rows, directional

    headers = Path(__import__("fmpy").__file__).parent / "c-code"
    source = Path(__file__).parent / "c_host" / "system_driver.c"
    linux_driver = tmp_path / "system_driver"
    subprocess.run(["gcc", "-std=c99", "-O2", f"-I{headers}", "-o", str(linux_driver), str(source), "-ldl"], check=True)
    (tmp_path / "plan_linux.txt").write_text(plan(str), encoding="utf-8")
    done = subprocess.run([str(linux_driver), str(tmp_path / "plan_linux.txt")], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stdout[-3000:]
    linux, linux_directional = parse(done.stdout)
    reference = coupled_reference(linux[:, 0])
    error = np.max(np.abs(linux[:, 1] - reference["omega1"])) / np.max(np.abs(reference["omega1"]))
    p = parts["Drive"][4]
    expected = [1.0 / linux[-1, 2], -float(p["R"]) / float(p["L"])]
    print(f"C master, inputs extrapolated, 1 ms: error {error:.3e}; directional {linux_directional} "
          f"against {expected}")
    assert error <= 2e-4
    assert np.allclose(linux_directional, expected, rtol=1e-9)

    compiler = shutil.which("x86_64-w64-mingw32-gcc")
    if compiler is None:
        pytest.skip("MinGW-w64 is not installed (make installs it)")
    wine, env = wine_prefix(tmp_path / "wine")
    windows_driver = tmp_path / "system_driver.exe"
    subprocess.run([compiler, "-O2", f"-I{headers}", "-o", str(windows_driver), str(source), "-static"], check=True)
    (tmp_path / "plan_windows.txt").write_text(plan(windows_path), encoding="utf-8")
    returncode = run_in_session([wine, str(windows_driver), windows_path(tmp_path / "plan_windows.txt")], env,
                                tmp_path / "windows.log")
    output = (tmp_path / "windows.log").read_text(errors="replace")
    assert returncode == 0, output[-3000:]
    windows, windows_directional = parse(output)
    assert windows.shape == linux.shape
    for k in (1, 2):
        assert np.max(np.abs(windows[:, k] - linux[:, k])) <= 1e-12 * np.max(np.abs(linux[:, k]))
    # central differences of the rates (Richardson): the last bits of the two C libraries' exp in
    # the state reach them as about 1e-10 of the value; both are the closed form to 1e-9
    assert np.allclose(windows_directional, expected, rtol=1e-9)
    assert np.allclose(windows_directional, linux_directional, rtol=1e-9)


def test_libcosims_ecco_runs_fourbardrive_on_its_power_bond(built, tmp_path):
    """libcosim's ECCO (libcosimpy >= 0.0.6, a master we did not write) runs FourBarDrive on the
    native FMUs with a power bond on the crank (omega1 and tau_ext against Drive's tau and omega),
    choosing its steps from the energy the coupling fails to conserve. Its error is reported beside
    the fixed-step master's with as many steps, held and extrapolated; measured: ECCO keeps near its
    smallest step (1e-4 s) and reaches 1.2e-3, where held inputs at that step reach 5.7e-4 and
    extrapolated ones 1.7e-6."""
    algorithm = pytest.importorskip("libcosimpy.CosimAlgorithm")
    assert hasattr(algorithm.CosimAlgorithm, "create_ecco_algorithm"), "libcosimpy >= 0.0.6 has ECCO"
    scene = scenes.scene("FourBarDrive")
    ecco = scenes.measure_ecco(scene, built)
    assert ecco.failure == "", ecco.failure
    same = scene.stop_time / ecco.steps
    fixed = {mode: scenes.measure(scene, built, mode, same, folder=tmp_path / mode) for mode in ("hold", "extrapolate")}
    print(f"FourBarDrive: ECCO {ecco.error:.3e} in {ecco.steps} steps; with as many fixed steps "
          f"(H = {same * 1e3:.3f} ms): held {fixed['hold'].error:.3e}, extrapolated {fixed['extrapolate'].error:.3e}")
    assert ecco.error < 1e-2
    assert fixed["extrapolate"].error < fixed["hold"].error
    # and the drive on the four-bar through ElasticShaft.fmu (k = 1e4): a power bond on each side
    shaft = scenes.measure_ecco(scenes.scene("ShaftDrive", k=1e4), built)
    print(f"ShaftDrive k = 1e4: ECCO {shaft.error:.3e} in {shaft.steps} steps")
    assert shaft.failure == "" and shaft.error < 5e-2


def test_cofmpys_jacobi_holds_the_inputs_as_our_master_does(built, tmp_path):
    """CoFMPy (cofmupy 1.0.0, a master in pure Python we did not write) runs FourBarDrive on the
    native FMUs. Its Jacobi holds each input at the other FMU's last output, as our "hold" does:
    the errors agree to 1 % at 10 and 1 ms (measured 0.3 %: CoFMPy starts with the inputs at their
    start values); its iteration with rollback converges to inputs held at the step's end, first
    order too."""
    pytest.importorskip("cofmupy")
    scene = scenes.scene("FourBarDrive")
    results = {(mode, h): scenes.measure(scene, built, mode, h, folder=tmp_path / f"{mode}{h}")
               for mode in ("cofmpy", "cofmpy-iterative", "hold") for h in (1e-2, 1e-3)}
    table("FourBarDrive", results)
    for h in (1e-2, 1e-3):
        assert results["cofmpy", h].error == pytest.approx(results["hold", h].error, rel=1e-2)
    order = observed_order((1e-3, 1e-2), [results["cofmpy-iterative", h].error for h in (1e-3, 1e-2)])
    assert 0.8 < order < 1.3


def test_the_harness_reports_the_coupled_scenes_and_fails_a_missed_bar(built, tmp_path, monkeypatch):
    """crankfmu validate finds the scenes' FMUs among those it validates and reports each scene (its
    table and figure); a bar the run misses fails its check: FourBarDrive's implicit step at 10 ms
    (8.3e-3) against a bar of 1e-3 set for this test, beside its real bar at 1 ms, which passes."""
    from crankfmu.validation import coupled, report
    from crankfmu.validation.checks import CheckList
    from crankfmu.validation.fmu_runner import kind_of

    # the press is a user's file: the group builds it beside the report
    assert coupled.coupled_fmus({str(p): kind_of(p) for p in built.values()}) == {
        name: path for name, path in built.items() if name != "TogglePress"}
    monkeypatch.setattr(coupled, "SCENES", (("FourBarDrive", {}),))
    for other in ("AGREES", "ORDERS", "STABLE"):
        monkeypatch.setattr(coupled, other, {})
    monkeypatch.setattr(coupled, "BARS", {("FourBarDrive", "implicit", 1e-3): 1e-4,
                                          ("FourBarDrive", "implicit", 1e-2): 1e-3})
    checks = CheckList(echo=None)
    section = coupled.run(built, tmp_path, True, checks)
    status = {c.name: c.status for c in checks.items}
    assert status == {"coupled.FourBarDrive.implicit_1ms_error": "passed",
                      "coupled.FourBarDrive.implicit_10ms_error": "failed"}
    (scene,) = section["scenes"]
    assert {r["master"] for r in scene["rows"]} == {"hold", "implicit"}
    assert (tmp_path / scene["plot"]).is_file()
    text = "\n".join(report._coupled(section))
    held = [report._g(r["error"]) for r in sorted(scene["rows"], key=lambda r: r["step"]) if r["master"] == "hold"]
    assert f"| hold | {held[0]} | {held[1]} |" in text and "### FourBarDrive" in text
