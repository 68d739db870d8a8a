"""FMI 3.0 native FMUs (crankfmu fmu SCENARIO --native --fmi-version 3): the model and kernel of
the FMI 2.0 FMU behind fmi3_shell.c, and what hosts see of it.

- fmpy's validation is clean; the variables are the FMI 2.0 FMU's at the same value references,
  each of a Float64Type with its SI unit, plus the event indicators and time;
- Co-Simulation without event mode and early return steps as the FMI 2.0 FMU does: the same
  outputs, bit for bit (the same kernel calls), and so the in-process reference to 1e-8;
- with event mode, early return or both (fmpy's master), every value at the communication
  points is still the FMI 2.0 FMU's, bit for bit: the kernel's steps do not change, only where
  the FMU returns; each early return is at a switch the kernel located (seed 001: its slider
  forces' switch angles), where phi1 is on a switch angle of the tables;
- Model Exchange through fmpy's CVode against the reference to 1e-6;
- the project's C host (tests/c_host/fmu3_driver.c) runs the x86_64-linux binary under env -i,
  the x86_64-windows DLL under wine and the aarch64-linux binary under qemu-aarch64: the three
  agree to 1e-12 (measured: bit for bit) and with the reference to 1e-8;
- refusals are fmi3Error with the message whatever loggingOn says;
- terminalsAndIcons: the icon and one terminal per port.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest

import crankfmu
from crankfmu.cli import main

ROOT = Path(__file__).resolve().parents[1]
#: a scenario with many switches (seed 001: slider forces that switch on and off twice a turn)
SCENARIO, FMU = "seed001", "ThreeLoop"
STOP, STEP = 2.0, 1e-3


def headers() -> Path:
    import fmpy

    return Path(fmpy.__file__).parent / "c-code"


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """(the FMI 3.0 FMU, the FMI 2.0 FMU) of seed 001: make fmu's where built, else built here."""
    out = tmp_path_factory.mktemp("fmi3")
    found = []
    for version, folder in (("3", ROOT / "build" / "fmus" / "native3"), ("2", ROOT / "build" / "fmus" / "native")):
        if (folder / f"{FMU}.fmu").is_file():
            found.append(folder / f"{FMU}.fmu")
        else:
            assert main(["fmu", SCENARIO, "--native", "--fmi-version", version, "--out", str(out / version)]) == 0
            found.append(out / version / f"{FMU}.fmu")
    return tuple(found)


@pytest.fixture(scope="module")
def fmi2_run(fmus):
    import fmpy

    return fmpy.simulate_fmu(str(fmus[1]), stop_time=STOP, output_interval=STEP, output=["omega1", "phi1", "M_load"])


@pytest.fixture(scope="module")
def reference():
    times = np.round(np.arange(int(round(STOP / STEP)) + 1) * STEP, 12)
    return crankfmu.simulate(SCENARIO, method="reference", t_end=STOP, output_times=times)


def test_fmpy_validates_it_and_its_variables_are_the_fmi2_fmus(fmus):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmus[0])) == []
    md3, md2 = (read_model_description(str(p)) for p in fmus)
    assert md3.fmiVersion == "3.0" and md3.coSimulation is not None and md3.modelExchange is not None
    two = {v.name: (v.valueReference, v.causality, v.unit) for v in md2.modelVariables}
    types = {t.name: t.unit for t in md3.typeDefinitions}
    for v in md3.modelVariables:
        if v.name in two:
            vr, causality, unit = two[v.name]
            assert (v.valueReference, v.causality) == (vr, causality), v.name
            assert (v.unit or types.get(v.declaredType.name if v.declaredType else None)) == unit, v.name
    extra = {v.name for v in md3.modelVariables} - set(two)
    assert extra == {"time"} | {f"eventIndicator{k}" for k in range(5)}
    with zipfile.ZipFile(fmus[0]) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
        names = set(z.namelist())
    assert len(root.findall("ModelStructure/EventIndicator")) == 5
    assert len(root.findall("ModelStructure/ContinuousStateDerivative")) == 5
    assert root.find("CoSimulation").get("hasEventMode") == "true"
    assert root.find("CoSimulation").get("mightReturnEarlyFromDoStep") == "true"
    assert {f"binaries/{p}/{FMU}{s}" for p, s in (("x86_64-linux", ".so"), ("x86_64-windows", ".dll"))} <= names
    assert {"terminalsAndIcons/terminalsAndIcons.xml", "terminalsAndIcons/icon.png", "sources/fmi3_shell.c",
            "sources/crank_model.c", "sources/buildDescription.xml", "documentation/index.html"} <= names


def test_co_simulation_without_events_is_the_fmi2_fmu_bit_for_bit(fmus, fmi2_run, reference):
    import fmpy

    run = fmpy.simulate_fmu(str(fmus[0]), stop_time=STOP, output_interval=STEP, output=["omega1", "phi1", "M_load"])
    for name in ("omega1", "phi1", "M_load"):
        np.testing.assert_array_equal(run[name], fmi2_run[name])
    scale = np.max(np.abs(reference.omega1))
    assert np.max(np.abs(run["omega1"] - reference.omega1)) <= 1e-8 * scale


@pytest.mark.parametrize("event_mode, early_return", [(True, False), (False, True), (True, True)])
def test_event_mode_and_early_return_keep_every_value_and_stop_at_the_switches(fmus, fmi2_run, event_mode,
                                                                                early_return):
    import fmpy

    from crankfmu.dynamics.tabulated import table_of
    from crankfmu.scenario import load_scenario

    run = fmpy.simulate_fmu(str(fmus[0]), stop_time=STOP, output_interval=STEP, output=["omega1", "phi1"],
                            use_event_mode=event_mode, early_return_allowed=early_return)
    t = np.round(run["time"], 9)
    last = {time: (w, p) for time, w, p in zip(t, run["omega1"], run["phi1"])}
    on_grid = np.array([last[time][0] for time in np.round(fmi2_run["time"], 9)])
    np.testing.assert_array_equal(on_grid, fmi2_run["omega1"])
    stops = sorted(set(t) - set(np.round(fmi2_run["time"], 9)))
    if not early_return:
        assert stops == []
        return
    # seed 001 switches its slider forces at fixed crank angles: every early return is on one
    switch_angles = table_of(load_scenario(SCENARIO).build().reduced).switch_angles
    assert len(stops) >= 2 * int(fmi2_run["phi1"][-1] / (2 * math.pi))
    for time in stops:
        phi = math.fmod(last[time][1], 2 * math.pi)
        assert np.min(np.abs(np.angle(np.exp(1j * (switch_angles - phi))))) < 1e-9, (time, phi)


def test_model_exchange_through_cvode_matches_the_reference(fmus, reference):
    import fmpy

    run = fmpy.simulate_fmu(str(fmus[0]), fmi_type="ModelExchange", stop_time=STOP, output_interval=STEP,
                            relative_tolerance=1e-10, output=["omega1"])
    # at the communication points (the others are the events' times, where the reference has no value)
    last = {time: w for time, w in zip(np.round(run["time"], 9), run["omega1"])}
    on_grid = np.array([last[time] for time in np.round(reference.time, 9)])
    scale = np.max(np.abs(reference.omega1))
    assert np.max(np.abs(on_grid - reference.omega1)) <= 1e-6 * scale


def test_a_refusal_is_fmi3_error_with_the_message_with_logging_off(fmus, tmp_path):
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(str(fmus[0]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    messages = []
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(fmus[0]), str(tmp_path)),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate(loggingOn=False, logMessage=lambda env, status, category, message: messages.append(message.decode()))
    fmu.enterInitializationMode()
    with pytest.raises(Exception, match="fmi3SetFloat64 failed with status 3"):
        fmu.setFloat64([vr["J_flywheel"]], [-1.0])
    # the Python FMU's words: the name first, the description last
    assert re.search(r"^J_flywheel: parameter J_flywheel = -1\.0 is out of range: valid range \[0, inf\) kg\.m2 "
                     r"\(.+\)$", messages[-1]), messages
    with pytest.raises(Exception, match="fmi3ExitInitializationMode failed with status 3"):
        fmu.exitInitializationMode()                 # the refused value not set anew: as the Python FMU
    assert messages[-1].startswith("fmi3ExitInitializationMode: cannot initialise: J_flywheel: parameter"), messages
    fmu.setFloat64([vr["J_flywheel"], vr["l1"]], [0.0, 0.5])   # a geometry that cannot turn: refused where the FMU tabulates
    with pytest.raises(Exception, match="fmi3ExitInitializationMode failed with status 3"):
        fmu.exitInitializationMode()
    # the CLI's message, word for word: the angle, the reason, the bound
    from crankfmu.errors import AssemblyError
    from crankfmu.scenario import load_scenario

    with pytest.raises(AssemblyError) as cli:
        load_scenario("seed001").with_params(l1=0.5).build()
    assert messages[-1] == f"fmi3ExitInitializationMode: {cli.value}", messages[-1]
    fmu.setFloat64([vr["l1"]], [0.2])
    fmu.exitInitializationMode()
    with pytest.raises(Exception, match="fmi3DoStep failed with status 3"):
        fmu.doStep(1.0, 1e-3)
    assert "fmi3DoStep at t = 1.0 s, but this instance is at t = 0.0 s" in messages[-1]
    fmu.terminate()
    fmu.freeInstance()


def test_terminals_and_icon(tmp_path):
    """PumpJack's rope port as a terminal: its pull flows in, its position, velocity and
    acceleration are signals, each a variable of the FMU."""
    assert main(["fmu", "pumpjack", "--native", "--fmi-version", "3", "--out", str(tmp_path)]) == 0
    with zipfile.ZipFile(tmp_path / "PumpJack.fmu") as z:
        terminals = ET.fromstring(z.read("terminalsAndIcons/terminalsAndIcons.xml"))
        names = {v.get("name") for v in ET.fromstring(z.read("modelDescription.xml")).iter("Float64")}
        assert z.read("terminalsAndIcons/icon.png")[:8] == b"\x89PNG\r\n\x1a\n"
    (terminal,) = terminals.iter("Terminal")
    members = {m.get("variableName"): m.get("variableKind") for m in terminal.iter("TerminalMemberVariable")}
    assert terminal.get("name") == "rod"
    assert members == {"rod_F": "inflow", "rod_s": "signal", "rod_v": "signal", "rod_a": "signal"}
    assert set(members) <= names


def _rows(text: str, mark: str = "row ") -> np.ndarray:
    return np.array([[float(x) for x in line[len(mark):].split(",")] for line in text.splitlines()
                     if line.startswith(mark)])


def linux_and_arm_rows(fmu: Path, model: str, steps: int, step: float, out: str, tmp_path: Path,
                       settings: dict | None = None) -> dict:
    """{platform: rows (t, out)} of an FMI 3.0 FMU's x86_64-linux binary and its aarch64-linux binary
    under qemu-aarch64, each in the project's C host (tests/c_host/fmu3_driver.c) for ``steps``
    Co-Simulation steps of ``step`` s, ``settings`` (name -> value) set before initialisation.
    Skipped without the cross compiler or qemu (failed on CI: `make` installs them)."""
    from fmpy import read_model_description

    if not (shutil.which("aarch64-linux-gnu-gcc") and shutil.which("qemu-aarch64")):
        if os.environ.get("CI"):
            pytest.fail("aarch64-linux-gnu-gcc or qemu-aarch64 is missing: `make` installs them")
        pytest.skip("aarch64-linux-gnu-gcc or qemu-aarch64 is not installed (make test installs them)")
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = tmp_path / "fmu"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unzipped)
    driver = ROOT / "tests" / "c_host" / "fmu3_driver.c"
    args = [str(unzipped), model, md.guid, str(steps), repr(step), str(vr[out]),
            *(f"{vr[name]}={value!r}" for name, value in (settings or {}).items())]
    runs = {}
    for platform, compiler, runner in (("x86_64-linux", "gcc", []),
                                       ("aarch64-linux", "aarch64-linux-gnu-gcc",
                                        ["qemu-aarch64", "-L", "/usr/aarch64-linux-gnu"])):
        program = tmp_path / platform
        subprocess.run([compiler, "-std=c99", "-O2", f"-I{headers()}", "-o", str(program), str(driver), "-ldl"],
                       check=True, capture_output=True)
        done = subprocess.run([*runner, str(program), *args], capture_output=True, text=True, timeout=900)
        assert done.returncode == 0, done.stdout[-2000:]
        runs[platform] = _rows(done.stdout)
    return runs


def test_the_three_binaries_run_in_the_c_host_and_agree(fmus, reference, tmp_path):
    """x86_64-linux under env -i, x86_64-windows under wine, aarch64-linux under qemu-aarch64."""
    from fmpy import read_model_description

    from wine import run_in_session, wine_prefix, windows_path

    md = read_model_description(str(fmus[0]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = tmp_path / "fmu"
    with zipfile.ZipFile(fmus[0]) as z:
        z.extractall(unzipped)
    driver = ROOT / "tests" / "c_host" / "fmu3_driver.c"
    args = lambda where: [where, FMU, md.guid, str(int(round(STOP / STEP))), repr(STEP), str(vr["omega1"])]  # noqa: E731
    runs = {}
    subprocess.run(["gcc", "-std=c99", "-O2", f"-I{headers()}", "-o", str(tmp_path / "linux"), str(driver), "-ldl"],
                   check=True, capture_output=True)
    done = subprocess.run(["env", "-i", str(tmp_path / "linux"), *args(str(unzipped))], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-2000:]
    runs["x86_64-linux"] = _rows(done.stdout)
    derivatives = {"x86_64-linux": _rows(done.stdout, "derivatives ")}
    on_ci = bool(os.environ.get("CI"))
    if shutil.which("aarch64-linux-gnu-gcc") and shutil.which("qemu-aarch64"):
        assert (unzipped / "binaries" / "aarch64-linux" / f"{FMU}.so").is_file()
        subprocess.run(["aarch64-linux-gnu-gcc", "-std=c99", "-O2", f"-I{headers()}", "-o", str(tmp_path / "arm"),
                        str(driver), "-ldl"], check=True, capture_output=True)
        done = subprocess.run(["qemu-aarch64", "-L", "/usr/aarch64-linux-gnu", str(tmp_path / "arm"),
                               *args(str(unzipped))], capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stdout[-2000:]
        runs["aarch64-linux"] = _rows(done.stdout)
        derivatives["aarch64-linux"] = _rows(done.stdout, "derivatives ")
    elif on_ci:
        pytest.fail("aarch64-linux-gnu-gcc or qemu-aarch64 is missing: `make` installs them")
    if shutil.which("x86_64-w64-mingw32-gcc"):
        wine, env = wine_prefix(tmp_path / "wine")
        subprocess.run(["x86_64-w64-mingw32-gcc", "-O2", f"-I{headers()}", "-o", str(tmp_path / "windows.exe"),
                        str(driver), "-static"], check=True, capture_output=True)
        code = run_in_session([wine, str(tmp_path / "windows.exe"), *args(windows_path(unzipped))], env,
                              tmp_path / "wine.log")
        output = (tmp_path / "wine.log").read_text(errors="replace")
        assert code == 0, output[-2000:]
        runs["x86_64-windows"] = _rows(output)
        derivatives["x86_64-windows"] = _rows(output, "derivatives ")
    elif on_ci:
        pytest.fail("x86_64-w64-mingw32-gcc is missing: `make` installs it")
    linux = runs["x86_64-linux"]
    scale = np.max(np.abs(reference.omega1))
    assert np.max(np.abs(linux[:, 1] - reference.omega1[1:])) <= 1e-8 * scale
    for platform, rows in runs.items():
        assert rows.shape == linux.shape, platform
        assert np.max(np.abs(rows[:, 1] - linux[:, 1])) <= 1e-12 * scale, platform
    # the derivatives a master reads (fmi3GetOutputDerivatives, fmi3GetDirectionalDerivative,
    # fmi3GetAdjointDerivative): omega1's rate is epsilon1 (the reference's, to its differences'
    # tolerance of 1e-6), d omega1/d omega1 is 1, and every platform gives the same
    print(f"derivatives on {sorted(derivatives)}: {derivatives}")
    assert all(values.shape == (1, 4) for values in derivatives.values()), derivatives
    rate, _, directional, adjoint = derivatives["x86_64-linux"][0]
    assert rate == pytest.approx(reference.epsilon1[-1], rel=1e-6, abs=1e-6 * np.max(np.abs(reference.epsilon1)))
    assert directional == pytest.approx(1.0, abs=1e-9) and adjoint == directional
    for platform, values in derivatives.items():
        assert np.allclose(values, derivatives["x86_64-linux"], rtol=1e-9, atol=0.0), platform


def test_the_sources_alone_build_the_binary_with_cmake(fmus, tmp_path):
    """The FMU's sources/ (with the FMI headers and a CMakeLists.txt) compile with CMake in an
    environment with neither crankfmu nor Python (env -i, PATH /usr/bin:/bin); the binary they give
    runs in the C host as the shipped one does, bit for bit."""
    from fmpy import read_model_description

    cmake = shutil.which("cmake")
    if cmake is None:
        if os.environ.get("CI"):
            pytest.fail("cmake is missing")
        pytest.skip("cmake is not installed")
    md = read_model_description(str(fmus[0]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    with zipfile.ZipFile(fmus[0]) as z:
        z.extractall(tmp_path / "fmu")
        for member in z.namelist():
            if member.startswith("sources/"):
                z.extract(member, tmp_path / "alone")
    bare = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    for command in ([cmake, "-S", str(tmp_path / "alone" / "sources"), "-B", str(tmp_path / "build"),
                     "-DCMAKE_BUILD_TYPE=Release"], [cmake, "--build", str(tmp_path / "build")]):
        done = subprocess.run(command, capture_output=True, text=True, env=bare, timeout=900)
        assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    built = tmp_path / "build" / f"{FMU}.so"
    assert built.is_file()
    subprocess.run(["gcc", "-std=c99", "-O2", f"-I{headers()}", "-o", str(tmp_path / "host"),
                    str(ROOT / "tests" / "c_host" / "fmu3_driver.c"), "-ldl"], check=True, capture_output=True)
    outputs = []
    for binary in (None, built):
        if binary is not None:
            shutil.copy2(binary, tmp_path / "fmu" / "binaries" / "x86_64-linux" / f"{FMU}.so")
        done = subprocess.run(["env", "-i", str(tmp_path / "host"), str(tmp_path / "fmu"), FMU, md.guid, "500", "0.001",
                               str(vr["omega1"])], capture_output=True, text=True)
        assert done.returncode == 0, done.stdout[-2000:]
        outputs.append(_rows(done.stdout))
    np.testing.assert_array_equal(outputs[0], outputs[1])


#: make fmu's FMI 3.0 FMUs: (scenario, model identifier)
PACKAGED = [("seed000", "FourBar"), ("seed001", "ThreeLoop"), ("seed002", "SliderCrank"), ("seed003", "Shaper"),
            ("seed004", "QuickReturn"), ("pumpjack", "PumpJack")]


@pytest.mark.parametrize("scenario, name", PACKAGED)
def test_every_packaged_fmu_in_every_co_simulation_mode_matches_the_reference(scenario, name):
    """make fmu's FMI 3.0 FMU of each packaged scenario: fmpy validates it, and in Co-Simulation
    without events, with event mode, with early return and with both, and in Model Exchange
    through fmpy's CVode, its omega1 at every communication point is the in-process reference's
    to 1e-8 of its scale."""
    import fmpy
    from fmpy.validation import validate_fmu

    path = ROOT / "build" / "fmus" / "native3" / f"{name}.fmu"
    if not path.is_file():
        if os.environ.get("CI"):
            pytest.fail(f"make fmu builds {path}")
        pytest.skip(f"make fmu builds {path}")
    assert validate_fmu(str(path)) == []
    stop = 1.0
    times = np.round(np.arange(int(round(stop / STEP)) + 1) * STEP, 12)
    ref = crankfmu.simulate(scenario, method="reference", t_end=stop, output_times=times)
    scale = np.max(np.abs(ref.omega1))
    for event_mode, early_return in ((False, False), (True, False), (False, True), (True, True)):
        run = fmpy.simulate_fmu(str(path), stop_time=stop, output_interval=STEP, output=["omega1"],
                                use_event_mode=event_mode, early_return_allowed=early_return)
        last = {t: w for t, w in zip(np.round(run["time"], 9), run["omega1"])}
        on_grid = np.array([last[t] for t in np.round(times, 9)])
        assert np.max(np.abs(on_grid - ref.omega1)) <= 1e-8 * scale, (event_mode, early_return)
    # Model Exchange through CVode at rtol 1e-12: measured 7e-12 (pumpjack) to 1.1e-9 (seed 003)
    run = fmpy.simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=stop, output_interval=STEP,
                            relative_tolerance=1e-12, output=["omega1"])
    last = {t: w for t, w in zip(np.round(run["time"], 9), run["omega1"])}
    on_grid = np.array([last[t] for t in np.round(times, 9)])
    assert np.max(np.abs(on_grid - ref.omega1)) <= 1e-8 * scale, "Model Exchange"


@pytest.mark.parametrize("name", ["FourBar", "ThreeLoop"])
def test_the_ecos_master_runs_it(name):
    """ecospy's ecos command (its FMI 3.0 Co-Simulation, no event mode) runs FourBar.fmu and
    ThreeLoop.fmu (make fmu's): the FMI 2.0 FMU's values to ecos's 6 decimals."""
    pytest.importorskip("ecospy")
    from crankfmu.validation import masters

    paths = [ROOT / "build" / "fmus" / folder / f"{name}.fmu" for folder in ("native3", "native")]
    if not all(p.is_file() for p in paths):
        if os.environ.get("CI"):
            pytest.fail(f"make fmu builds {paths}")
        pytest.skip(f"make fmu builds {paths}")
    three = masters.run("ecos", paths[0], STOP, STEP, ["omega1"])
    two = masters.run("ecos", paths[1], STOP, STEP, ["omega1"])
    assert not three.error and not two.error, (three.output[-2000:], two.output[-2000:])
    assert three.time.shape == two.time.shape and len(three.time) >= int(STOP / STEP)
    assert np.max(np.abs(three["omega1"] - two["omega1"])) <= 1e-6


def test_speed_causality_in_fmi3(tmp_path):
    """FourBarSpeed.fmu in FMI 3.0 (Co-Simulation only): validated, and its tau_drive with omega1
    held is the FMI 2.0 FMU's bit for bit."""
    import fmpy
    from fmpy.validation import validate_fmu

    runs = []
    for version in ("2", "3"):
        assert main(["fmu", "seed000", "--native", "--causality", "speed", "--fmi-version", version,
                     "--out", str(tmp_path / version)]) == 0
        path = tmp_path / version / "FourBarSpeed.fmu"
        assert validate_fmu(str(path)) == []
        runs.append(fmpy.simulate_fmu(str(path), stop_time=0.5, output_interval=1e-3, output=["tau_drive", "phi1"]))
    md = fmpy.read_model_description(str(tmp_path / "3" / "FourBarSpeed.fmu"))
    assert md.modelExchange is None
    for name in ("tau_drive", "phi1"):
        np.testing.assert_array_equal(runs[0][name], runs[1][name])


#: the components' FMI 3.0 FMUs (make fmu's), the inputs each takes in the comparison
COMPONENTS = {"Drive": ("omega",), "DriveSpeed": ("tau_load",), "DieCushion": ("s", "v"), "RodString": ("s", "v")}


@pytest.mark.parametrize("name", list(COMPONENTS))
def test_each_component_in_fmi3_is_its_fmi2_fmu_bit_for_bit(name):
    """Drive.fmu, DriveSpeed.fmu, DieCushion.fmu and RodString.fmu in FMI 3.0 (fmi3_shell.c on
    the components' model, component_model.c): fmpy validates each, and on the same inputs over
    2 s every output equals the FMI 2.0 FMU's, bit for bit."""
    import fmpy
    from fmpy.validation import validate_fmu

    paths = [ROOT / "build" / "fmus" / folder / f"{name}.fmu" for folder in ("native3", "native")]
    if not all(p.is_file() for p in paths):
        if os.environ.get("CI"):
            pytest.fail(f"make fmu builds {paths}")
        pytest.skip(f"make fmu builds {paths}")
    assert validate_fmu(str(paths[0])) == []
    md = fmpy.read_model_description(str(paths[0]))
    assert md.fmiVersion == "3.0" and md.modelExchange is None
    t = np.linspace(0.0, 2.0, 201)
    signal = np.zeros(t.size, dtype=[("time", float)] + [(n, float) for n in COMPONENTS[name]])
    signal["time"] = t
    for n in COMPONENTS[name]:
        signal[n] = 0.5 * np.sin(3.0 * t) + (0.2 if n == "s" else 0.0)
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    three, two = (fmpy.simulate_fmu(str(p), stop_time=2.0, output_interval=0.01, input=signal, output=outputs)
                  for p in paths)
    for output in outputs:
        np.testing.assert_array_equal(three[output], two[output])


def test_the_rod_strings_three_binaries_agree_in_the_c_host(tmp_path):
    """RodString.fmu in FMI 3.0: its x86_64-linux, x86_64-windows (wine) and aarch64-linux (qemu)
    binaries hang the RP 11L string the same way, bit for bit."""
    from fmpy import read_model_description

    from wine import run_in_session, wine_prefix, windows_path

    path = ROOT / "build" / "fmus" / "native3" / "RodString.fmu"
    if not path.is_file():
        if os.environ.get("CI"):
            pytest.fail(f"make fmu builds {path}")
        pytest.skip(f"make fmu builds {path}")
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    with zipfile.ZipFile(path) as z:
        z.extractall(tmp_path / "fmu")
    driver = ROOT / "tests" / "c_host" / "fmu3_driver.c"
    args = lambda where: [where, "RodString", md.guid, "200", "0.005", str(vr["F"]), f"{vr['s']}=0.3"]  # noqa: E731
    subprocess.run(["gcc", "-std=c99", "-O2", f"-I{headers()}", "-o", str(tmp_path / "linux"), str(driver), "-ldl"],
                   check=True, capture_output=True)
    done = subprocess.run(["env", "-i", str(tmp_path / "linux"), *args(str(tmp_path / "fmu"))], capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stdout[-2000:]
    linux = _rows(done.stdout)
    assert linux.shape == (200, 2) and np.all(np.isfinite(linux))
    runs = {}
    if shutil.which("aarch64-linux-gnu-gcc") and shutil.which("qemu-aarch64"):
        subprocess.run(["aarch64-linux-gnu-gcc", "-std=c99", "-O2", f"-I{headers()}", "-o", str(tmp_path / "arm"),
                        str(driver), "-ldl"], check=True, capture_output=True)
        done = subprocess.run(["qemu-aarch64", "-L", "/usr/aarch64-linux-gnu", str(tmp_path / "arm"),
                               *args(str(tmp_path / "fmu"))], capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stdout[-2000:]
        runs["aarch64-linux"] = _rows(done.stdout)
    if shutil.which("x86_64-w64-mingw32-gcc"):
        wine, env = wine_prefix(tmp_path / "wine")
        subprocess.run(["x86_64-w64-mingw32-gcc", "-O2", f"-I{headers()}", "-o", str(tmp_path / "windows.exe"),
                        str(driver), "-static"], check=True, capture_output=True)
        code = run_in_session([wine, str(tmp_path / "windows.exe"), *args(windows_path(tmp_path / "fmu"))], env,
                              tmp_path / "wine.log")
        output = (tmp_path / "wine.log").read_text(errors="replace")
        assert code == 0, output[-2000:]
        runs["x86_64-windows"] = _rows(output)
    if os.environ.get("CI"):
        assert set(runs) == {"aarch64-linux", "x86_64-windows"}
    for platform, rows in runs.items():
        np.testing.assert_array_equal(rows, linux, err_msg=platform)


@pytest.mark.parametrize("args, fmu, why", [
    (["dc_pi", "--drive"], "Drive", "it has no events"),
    (["seed000", "--causality", "speed"], "FourBarSpeed", "in speed causality the host's omega1 drives it"),
])
def test_an_fmu_without_event_mode_refuses_event_mode_at_instantiation(tmp_path, args, fmu, why):
    """A host that asks for event mode from an FMU whose modelDescription says hasEventMode = false
    is refused at fmi3InstantiateCoSimulation with the reason, logging off, as the Reference FMUs
    do (Drive.fmu accepted it and refused only at the first fmi3UpdateDiscreteStates); without
    event mode the same FMU instantiates."""
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave

    assert main(["fmu", *args, "--native", "--fmi-version", "3", "--out", str(tmp_path)]) == 0
    path = tmp_path / f"{fmu}.fmu"
    md = read_model_description(str(path))
    assert md.coSimulation.hasEventMode is False or str(md.coSimulation.hasEventMode).lower() == "false"
    unzipped = extract(str(path), str(tmp_path / "x"))
    messages = []

    def instance():
        return FMU3Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier)

    refused = instance()
    with pytest.raises(Exception, match="Failed to instantiate"):
        refused.instantiate(loggingOn=False, eventModeUsed=True,
                            logMessage=lambda env, status, category, message: messages.append(message.decode()))
    assert len(messages) == 1 and "eventModeUsed = true, but this FMU has no event mode" in messages[0], messages
    assert why in messages[0] and "instantiate with eventModeUsed = false" in messages[0], messages
    accepted = instance()
    accepted.instantiate(loggingOn=False, eventModeUsed=False)
    accepted.freeInstance()
