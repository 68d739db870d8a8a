"""The native FMU (``crankfmu fmu SCENARIO --native``): the C kernel behind one FMI 2.0 shell, the
scenario's tables as data. It needs nothing on the host: the same numbers as the pythonfmu FMU of
the same scenario (the same kernel and tables: bit for bit), fmpy's validation clean, binaries
that link nothing beyond the C library, run by a C host with an empty environment and no Python
on PATH, refusals that are loud with logging off, and an FMU state restored bit for bit."""

from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from crankfmu.cli import main
from wine import run_win64_under_wine

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FIELDS = ("phi1", "omega1", "epsilon1", "M_motor", "M_load", "J_red", "E_kin", "W_motor", "W_load")
PRESS = HERE.parent / "validation" / "data" / "togglepress_scenario.toml"
#: the six packaged scenarios and the guide's press (a user's file), by FMU name
SCENARIOS = {"FourBar": "seed000", "ThreeLoop": "seed001", "SliderCrank": "seed002", "Shaper": "seed003",
             "QuickReturn": "seed004", "PumpJack": "pumpjack", "TogglePress": str(PRESS)}


def _built(name: str, native: bool, scratch: Path) -> Path:
    """build/fmus[/native]/NAME.fmu as `make fmu` leaves it; built here when pytest runs alone
    (and always for the press, which `make fmu` does not build)."""
    folder = ROOT / "build" / "fmus" / ("native" if native else "")
    if name == "TogglePress" or not (folder / f"{name}.fmu").exists():
        folder = scratch / ("native" if native else "python")
        assert main(["fmu", SCENARIOS[name], *(["--native"] if native else []), "--out", str(folder)]) == 0
    return folder / f"{name}.fmu"


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    return tmp_path_factory.mktemp("fmus")


@pytest.fixture(scope="module")
def native(scratch):
    return _built("FourBar", True, scratch)


@pytest.mark.parametrize("name", SCENARIOS)
def test_fmpy_finds_no_problem(name, scratch):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(_built(name, True, scratch))) == []


def _columns(result, names) -> dict:
    return {n: np.asarray(result[n], dtype=float) for n in names}


@pytest.mark.parametrize("name", SCENARIOS)
def test_the_native_fmu_gives_the_pythonfmu_fmus_numbers(name, scratch):
    """Co-Simulation, default experiment, 1 ms, every output the two declare (the contract's and
    the scenario's [[outputs]]): the same kernel on the same tables, and the [[outputs]] from
    their tabulated transfer functions (checked to 1e-11 of each function's largest value) against
    the analytic kinematics; the issue's bar is 1e-9 relative to each output's largest value."""
    import fmpy

    from crankfmu.dynamics.reactions import reaction_outputs
    from crankfmu.scenario import load_scenario

    native_fmu, python_fmu = _built(name, True, scratch), _built(name, False, scratch)
    a = fmpy.simulate_fmu(str(native_fmu), output_interval=1e-3)
    b = fmpy.simulate_fmu(str(python_fmu), output_interval=1e-3)
    # the joint reactions: tabulated terms in the native FMU, Newton-Euler when read in the
    # pythonfmu FMU (test_native_reactions.py: to 1e-8 of the largest reaction, away from the
    # slider forces' switch angles, where the force is set-valued)
    scenario = load_scenario(SCENARIOS[name])
    reactions = [n for n, _, _ in reaction_outputs(scenario.mechanism_definition())]
    names = [n for n in b.dtype.names if n != "time" and n not in reactions]
    assert set(names) <= set(a.dtype.names) and set(reactions) <= set(a.dtype.names)
    assert len(names) >= len(FIELDS) + (0 if name == "FourBar" else 1)
    assert a["time"][-1] == pytest.approx(b["time"][-1])
    for n in names:
        scale = np.max(np.abs(b[n]))
        assert np.max(np.abs(a[n] - b[n])) <= 1e-9 * scale, (n, np.max(np.abs(a[n] - b[n])) / max(scale, 1e-300))
    from test_native_reactions import away_from_switches

    away = away_from_switches(scenario.build().reduced, b["phi1"])
    scale = max(np.max(np.abs(b[n])) for n in reactions)
    for n in reactions:
        assert np.max(np.abs(a[n] - b[n])[away]) <= 1e-8 * scale, (n, np.max(np.abs(a[n] - b[n])[away]) / scale)


@pytest.mark.parametrize("name", SCENARIOS)
def test_model_exchange_through_cvode_matches_the_reference(name, scratch):
    """Model Exchange: fmpy's CVode (rtol 1e-10) integrates the native FMU's states and finds its
    events through the event indicators; the outputs on the default experiment's grid match the
    in-process reference (DOP853 on the contour engine, not the tables) to 1e-6 relative, the
    issue's bar. The [[outputs]] are checked against the analytic kinematics at the reference's
    state."""
    import fmpy

    import crankfmu
    from crankfmu.mechanisms.quantities import evaluate_all

    fmu = _built(name, True, scratch)
    scenario = crankfmu.load_scenario(SCENARIOS[name])
    exp = scenario.experiment
    grid = exp.start_time + exp.output_interval * np.arange(int(round((exp.stop_time - exp.start_time)
                                                                        / exp.output_interval)) + 1)
    me = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", solver="CVode", relative_tolerance=1e-10,
                           output_interval=exp.output_interval)
    reference = crankfmu.simulate(scenario, method="reference", output_times=grid)
    # the rows at the grid's times (an event adds rows: keep the one after it)
    after = np.append(np.diff(me["time"]) > 0, True)
    rows = np.searchsorted(me["time"][after], grid)
    assert np.allclose(me["time"][after][rows], grid, rtol=0, atol=1e-9)
    kin = scenario.build().mechanism.kinematics(reference.phi1)
    expected = {n: getattr(reference, n) for n in FIELDS}
    expected.update(evaluate_all(scenario.quantities, kin, reference.omega1, reference.epsilon1))
    for n, values in expected.items():
        got = me[n][after][rows]
        scale = np.max(np.abs(values))
        error = np.abs(got - values)
        assert np.max(error) <= 1e-6 * scale, (n, float(np.max(error) / scale))


def test_the_binaries_link_nothing_beyond_the_c_library(native, tmp_path):
    with zipfile.ZipFile(native) as z:
        z.extractall(tmp_path)
        names = set(z.namelist())
    assert {"sources/crank_kernel.c", "sources/fmi2_shell.c", "sources/crank_model_file.c",
            "resources/crankfmu-model.bin",
            "sources/buildDescription.xml", "documentation/index.html",
            "extra/org.fmi-standard.fmi-ls-ref/FourBar_out.csv"} <= names
    linked = subprocess.run(["ldd", str(tmp_path / "binaries" / "linux64" / "FourBar.so")], capture_output=True,
                            text=True).stdout
    libraries = {line.split()[0] for line in linked.splitlines() if line.strip()}
    assert libraries <= {"linux-vdso.so.1", "libm.so.6", "libc.so.6", "/lib64/ld-linux-x86-64.so.2"}, libraries
    dll = tmp_path / "binaries" / "win64" / "FourBar.dll"
    if shutil.which("x86_64-w64-mingw32-objdump") and dll.exists():
        dump = subprocess.run(["x86_64-w64-mingw32-objdump", "-p", str(dll)], capture_output=True, text=True).stdout
        assert set(re.findall(r"DLL Name: (\S+)", dump)) <= {"KERNEL32.dll", "msvcrt.dll"}


def test_refusals_are_loud_with_logging_off(native, tmp_path):
    """A parameter out of its range names the range (a fixed one, the geometry, as a tunable); NaN
    is refused; all with fmi2Error and a message, loggingOn false."""
    from fmpy.fmi1 import FMICallException

    from fuzz_host import quiet_slave

    fmu, vr, messages, keep = quiet_slave(native, tmp_path / "x", "FourBar")

    for name, value, expected in (("l1", -0.3, r"parameter l1 = -0\.3 is out of range: valid range \(0, inf\) m"),
                                  ("J_flywheel", -1.0, r"J_flywheel = -1\.0 is out of range: valid range \[0, inf\) kg\.m2"),
                                  ("A", float("nan"), r"parameter A = nan is out of range"),
                                  ("omega1", 1.0, r"omega1 is computed by the FMU: it cannot be set")):
        with pytest.raises(FMICallException):
            fmu.setReal([vr[name]], [value])
        assert re.search(expected, messages[-1]), messages[-1]
    fmu.setReal([vr["l1"]], [0.2])                    # in its range: accepted
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    with pytest.raises(FMICallException):             # the refused J_flywheel and A not set anew: as the Python FMU
        fmu.exitInitializationMode()
    assert messages[-1].startswith("fmi2ExitInitializationMode: cannot initialise: "), messages[-1]
    assert "J_flywheel: parameter J_flywheel = -1.0 is out of range" in messages[-1], messages[-1]
    assert "A: parameter A = nan is out of range" in messages[-1], messages[-1]
    fmu.setReal([vr["J_flywheel"], vr["A"]], [0.02, 5.0])
    with pytest.raises(FMICallException):             # mended, not yet initialised: says so, not the old reason
        fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    assert "the model is not initialised (call fmi2ExitInitializationMode first)" in messages[-1], messages[-1]
    fmu.exitInitializationMode()
    with pytest.raises(FMICallException):
        fmu.doStep(currentCommunicationPoint=0.5, communicationStepSize=1e-3)
    assert "this instance is at t = 0" in messages[-1]
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
    # the state: saved, stepped, restored and stepped again gives the same outputs bit for bit
    state = fmu.getFMUstate()
    serialized = fmu.serializeFMUstate(state)
    for k in range(100):
        fmu.doStep(currentCommunicationPoint=(k + 1) * 1e-3, communicationStepSize=1e-3)
    first = fmu.getReal([vr[n] for n in FIELDS])
    fmu.setFMUstate(fmu.deSerializeFMUstate(serialized))
    for k in range(100):
        fmu.doStep(currentCommunicationPoint=(k + 1) * 1e-3, communicationStepSize=1e-3)
    assert fmu.getReal([vr[n] for n in FIELDS]) == first
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc builds the C driver")
def test_a_c_host_runs_it_with_an_empty_environment_and_no_python(native, tmp_path, fmu_path):
    """tests/c_host/fmu_driver.c (dlopen, RTLD_LOCAL) under `env -i`: no PATH, no HOME, no Python."""
    import fmpy
    from fmpy import extract, read_model_description

    headers = Path(fmpy.__file__).parent / "c-code"
    driver = tmp_path / "fmu_driver"
    subprocess.run(["gcc", "-O1", "-Wall", "-Werror", f"-I{headers}", "-o", str(driver),
                    str(HERE / "c_host" / "fmu_driver.c"), "-ldl"], check=True)
    md = read_model_description(str(native))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    where = extract(str(native), str(tmp_path / "unzipped"))
    done = subprocess.run(["env", "-i", str(driver), where, "FourBar", md.guid, "2000", "0.001", str(vr["omega1"])],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout[-2000:]
    t, omega = map(float, re.search(r"result t=(\S+) value=(\S+)", done.stdout).groups())
    reference = fmpy.simulate_fmu(str(fmu_path))
    assert t == pytest.approx(2.0)
    assert abs(omega - reference["omega1"][-1]) <= 1e-9 * abs(reference["omega1"][-1])


def test_the_win64_dll_runs_under_wine_through_fmpy_remoting(native, tmp_path):
    """The win64 DLL under wine (run_win64_under_wine) matches the linux64 binary to 1e-12 of each
    output's largest value (the two C libraries' pow and the like differ in the last bits, so not
    bit for bit)."""
    import fmpy

    # the contract's outputs and two joint reactions (tabulated terms times the kernel's weights)
    fields = (*FIELDS, "O_Fx", "A_Fy")
    remote = run_win64_under_wine(native, tmp_path, fields)
    local = fmpy.simulate_fmu(str(native), output_interval=1e-3)
    assert remote.shape[1] == local.size and remote[0][-1] == pytest.approx(2.0)
    for i, name in enumerate(fields, start=1):
        scale = np.max(np.abs(local[name]))
        assert np.max(np.abs(remote[i] - local[name])) <= 1e-12 * scale, name


def test_no_event_indicator_is_zero_after_event_mode(scratch, tmp_path):
    """A plain Model Exchange master (explicit Euler, 0.1 ms, an event wherever an indicator changes
    sign) on ThreeLoop (slider forces that switch at their reversals) and FourBar (the motor's
    kink): after every event update no indicator is 0 (the hysteresis) and the update settled in
    one call; the states the FMU put on a switching surface are taken up."""
    from ctypes import POINTER, c_double

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Model

    def read(function, size):
        out = np.zeros(size)
        function(out.ctypes.data_as(POINTER(c_double)), size)
        return out

    for name in ("ThreeLoop", "FourBar"):
        fmu_file = _built(name, True, scratch)
        md = read_model_description(str(fmu_file))
        fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(str(fmu_file), str(tmp_path / name)),
                        modelIdentifier=md.modelExchange.modelIdentifier, instanceName=name)
        fmu.instantiate(loggingOn=False)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        n, m = md.numberOfContinuousStates, md.numberOfEventIndicators
        assert (n, m) == (5, 5)
        fmu.newDiscreteStates()
        fmu.enterContinuousTimeMode()
        x, z = read(fmu.getContinuousStates, n), read(fmu.getEventIndicators, m)
        assert np.all(z != 0.0)
        t, h, events = 0.0, 1e-4, 0
        while t < float(md.defaultExperiment.stopTime) - 0.5 * h:
            x = x + h * read(fmu.getDerivatives, n)
            t += h
            fmu.setTime(t)
            fmu.setContinuousStates(x.ctypes.data_as(POINTER(c_double)), n)
            z_new = read(fmu.getEventIndicators, m)
            if np.any(np.sign(z_new) != np.sign(z)):
                events += 1
                fmu.enterEventMode()
                needed, terminate, _, states_changed, _, _ = fmu.newDiscreteStates()
                assert not needed and not terminate
                if states_changed:
                    x = read(fmu.getContinuousStates, n)
                fmu.enterContinuousTimeMode()
                z_new = read(fmu.getEventIndicators, m)
                assert np.all(z_new != 0.0), (name, t, z_new)
            z = z_new
        # FourBar crosses the kink once on its run-up; ThreeLoop's slider forces switch every turn
        assert events >= {"FourBar": 1, "ThreeLoop": 4}[name], (name, events)
        fmu.terminate()
        fmu.freeInstance()


@pytest.mark.parametrize("master", ["ecos", "ecospy", "libcosim"])
def test_third_party_masters_run_it(master, native, reference):
    """The ecos C++ command, ecospy (the same engine in process) and libcosim (OSP, FMI Library) run
    the native FMU's default experiment at 1 ms and match the in-process reference (DOP853 on the
    contour engine) to 1e-6 relative: the ecos command writes its CSV with 6 decimals."""
    pytest.importorskip("ecospy")
    pytest.importorskip("libcosimpy")
    from crankfmu.validation import masters

    run = masters.run(master, native, 2.0, 1e-3, ["omega1", "phi1"])
    assert not run.error, run.output[-3000:]
    assert run.time[-1] == pytest.approx(2.0, abs=1e-6)
    for name in ("omega1", "phi1"):
        got = run.values[name]
        expected = np.interp(run.time, reference.time, getattr(reference, name))
        assert np.max(np.abs(got - expected)) <= 1e-6 * np.max(np.abs(expected)), name


def test_a_native_build_compiles_nothing_and_ships_the_installations_runtimes(tmp_path, monkeypatch):
    """The installation compiles the runtimes for every platform whose compiler is there (setup.py,
    and make test's set-up once MinGW and the aarch64 compiler are installed): a native build on an
    empty per-user cache runs no compiler, and each binary it ships is the installation's runtime,
    byte for byte (FMI 2.0 and 3.0)."""
    from crankfmu.fmi.native import build as native_build
    from crankfmu.native.sources import PLATFORMS, RUNTIMES

    monkeypatch.setenv("CRANKFMU_CACHE", str(tmp_path / "cache"))
    commands = []
    monkeypatch.setattr(native_build, "_run", lambda cmd, cc: commands.append(cmd))
    for version in PLATFORMS:
        fmu = native_build.build_native("seed000", tmp_path / version, fmi_version=version)
        with zipfile.ZipFile(fmu) as z:
            shipped = {n.split("/")[1]: z.read(n) for n in z.namelist() if n.startswith("binaries/")}
        for folder, cc in PLATFORMS[version]:
            if shutil.which(cc):
                (runtime,) = (RUNTIMES / f"fmi{version[0]}" / folder).glob("crankfmu-*")
                assert shipped[folder] == runtime.read_bytes(), (version, folder)
    assert commands == [] and not (tmp_path / "cache" / "runtimes").exists()


def test_a_compiler_that_fails_at_installation_is_one_line_and_leaves_no_runtime(tmp_path):
    """sources.py --prebuild (make test's set-up, after it installs the cross compilers) where a
    compiler fails: one line naming the compiler and its message, no traceback, a non-zero exit,
    and no runtime (whole or partial) in the folder a build takes them from."""
    import os
    import sys

    from crankfmu.native.sources import HERE as NATIVE

    copy = tmp_path / "native"
    shutil.copytree(NATIVE, copy, ignore=shutil.ignore_patterns("runtimes", "__pycache__", "*.so"))
    fake = tmp_path / "bin"
    fake.mkdir()
    (fake / "gcc").write_text("#!/bin/sh\necho 'crank_kernel.c:1: error: the disk is full' >&2\nexit 1\n")
    os.chmod(fake / "gcc", 0o755)
    done = subprocess.run([sys.executable, str(copy / "sources.py"), "--prebuild"], capture_output=True, text=True,
                          env={"PATH": str(fake)})
    assert done.returncode != 0
    assert "Traceback" not in done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "gcc failed compiling" in lines[0] and "the disk is full" in lines[0], lines
    assert [p for p in (copy / "runtimes").rglob("*") if p.is_file()] == []


def test_a_build_on_a_terminal_shows_its_stage_and_time_then_clears_the_line(tmp_path):
    """`crankfmu fmu` on a terminal says which stage the build is in and for how long (the build
    takes seconds); the line is cleared before "built", and a pipe (a log, CI) gets none of it."""
    import os
    import pty
    import sys

    # on an empty cache: the reference run and the figures take over the line's second of delay (a
    # build from a warm cache takes under a second and shows no line)
    command = [sys.executable, "-m", "crankfmu", "fmu", "seed003", "--native", "--out", str(tmp_path / "tty")]
    main_fd, terminal = pty.openpty()
    cold = {**os.environ, "CRANKFMU_CACHE": str(tmp_path / "cache")}
    done = subprocess.run(command, stdout=subprocess.PIPE, stderr=terminal, text=True, env=cold)
    os.close(terminal)
    seen = b""
    while True:
        try:
            chunk = os.read(main_fd, 65536)
        except OSError:                 # the terminal's other end is closed: all read
            break
        if not chunk:
            break
        seen += chunk
    os.close(main_fd)
    assert done.returncode == 0 and done.stdout.startswith("built ")
    shown = seen.decode()
    # a stage may name a platform (compiling the linux64 binary)
    assert re.search(r"Shaper\.fmu: [a-zA-Z0-9 ]+ \(\d+\.\d s\)", shown), shown
    assert shown.endswith("\r"), shown                  # cleared: "built" starts a clean line
    piped = subprocess.run([*command[:-1], str(tmp_path / "pipe")], capture_output=True, text=True)
    assert piped.returncode == 0 and piped.stderr == ""


def test_a_missing_compiler_is_named():
    """A runtime the installation lacks is compiled into the per-user cache: a compiler that is not
    installed is named as missing, in one line."""
    from crankfmu.errors import CrankfmuError
    from crankfmu.fmi.native.build import _run

    with pytest.raises(CrankfmuError, match="no-such-cc not found; it compiles the native FMUs' runtime"):
        _run(["no-such-cc", "-c", "x.c"], "no-such-cc")


def test_a_refused_state_says_what_it_judged(tmp_path):
    """A native FMU that refuses bytes as a state says why, with the values it judged (the size it
    got and the size of its states), as the Python FMU's refusals do: the mechanism's shell and the
    components' alike, logging off."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from fuzz_host import callbacks

    for args, fmu, said in ((["seed000"], "FourBar", r"not a serialized state of this FMU: 10 bytes, where its states are \d+$"),
                            (["dc_pi", "--drive"], "Drive",
                             r"these 10 bytes are not a state of this FMU: its states are at least \d+ bytes$")):
        assert main(["fmu", *args, "--native", "--out", str(tmp_path)]) == 0
        md = read_model_description(str(tmp_path / f"{fmu}.fmu"))
        messages = []
        keep = callbacks(lambda env, name, status, category, message: messages.append(message.decode()))
        instance = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(tmp_path / f"{fmu}.fmu"), str(tmp_path / fmu)),
                             modelIdentifier=md.coSimulation.modelIdentifier)
        instance.instantiate(loggingOn=False, callbacks=keep[0])
        with pytest.raises(Exception):
            instance.deserializeFMUState(b"x" * 10)
        assert messages and re.search(said, messages[-1]), messages
        instance.freeInstance()


@pytest.mark.parametrize("variant", ["python", "native"])
def test_a_failed_step_says_the_kernels_words(variant, native, scratch, tmp_path):
    """A = 1e300 set while stepping: the next step's size underflows, and the Python and the native
    FMU say it in the same words (the kernel's ck_status_text), loggingOn false."""
    from fmpy.fmi1 import FMICallException

    from fuzz_host import quiet_slave

    path = native if variant == "native" else _built("FourBar", False, scratch)
    fmu, vr, messages, keep = quiet_slave(path, tmp_path / variant, "FourBar")
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.02)
    fmu.setReal([vr["A"]], [1e300])
    with pytest.raises(FMICallException):
        fmu.doStep(currentCommunicationPoint=0.02, communicationStepSize=0.02)
    assert re.fullmatch(r"fmi2DoStep: step from t = 0\.02 s failed: step size underflow at t = [\d.e-]+ s",
                        messages[-1]), messages[-1]
    fmu.freeInstance()
