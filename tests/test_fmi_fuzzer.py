"""The coverage-guided fuzzer of the native FMU's FMI 2.0 API (tests/fuzz/fmi2_fuzzer.c, libFuzzer
through Debian's clang, with AddressSanitizer and UndefinedBehaviorSanitizer): built from make
fmu's FourBar.fmu sources/ and run for 30 s from its corpus (tests/fuzz/corpus/); make soak runs
it for 10 minutes. No crash, no sanitizer report, no hang (a call over 20 s), and every refusal
is fmi2Error with a logStatusError message; the run reaches the API's code (its coverage).

The fuzzer found two hangs, now refused: rtol = 4e-213 (rtol's valid range is now [1e-14, 0.1])
and a torque ramp of 6.7e10 N.m/s (one communication step may take at most 1e7 kernel steps;
the fuzzer is built with 1e5 so that it reaches that refusal often)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def build_fuzzer(where: Path) -> Path:
    import fmpy

    clang = shutil.which("clang")
    if clang is None:
        if os.environ.get("CI"):
            pytest.fail("clang is missing: `make` installs it")
        pytest.skip("clang is not installed (make installs it)")
    fmu = ROOT / "build" / "fmus" / "native" / "FourBar.fmu"
    if not fmu.is_file():
        pytest.skip("make fmu builds build/fmus/native/FourBar.fmu")
    with zipfile.ZipFile(fmu) as z:
        for member in z.namelist():
            if member.startswith(("sources/", "resources/")):
                z.extract(member, where)
    sources = sorted(str(p) for p in (where / "sources").glob("*.c"))
    out = where / "fmi2_fuzzer"
    done = subprocess.run([clang, "-g", "-O1", "-fsanitize=fuzzer,address,undefined", "-fno-sanitize-recover=undefined",
                           "-DCK_API=", "-DCK_MAX_STEPS_PER_CALL=100000L", f"-I{where / 'sources'}",
                           f"-I{Path(fmpy.__file__).parent / 'c-code'}", "-o", str(out),
                           str(ROOT / "tests" / "fuzz" / "fmi2_fuzzer.c"), *sources, "-lm"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    return out


def run_fuzzer(fuzzer: Path, where: Path, seconds: int) -> str:
    corpus = where / "corpus"
    shutil.copytree(ROOT / "tests" / "fuzz" / "corpus", corpus)
    done = subprocess.run([str(fuzzer), f"-max_total_time={seconds}", "-timeout=20", "-rss_limit_mb=2048",
                           "-print_final_stats=1", f"-artifact_prefix={where}/", str(corpus)],
                          capture_output=True, text=True, timeout=seconds + 300,
                          env={**os.environ, "FUZZ_RESOURCES": str(where / "resources")})
    output = done.stdout + done.stderr
    assert done.returncode == 0, output[-4000:]
    assert not list(where.glob("crash-*")) and not list(where.glob("timeout-*")) and not list(where.glob("leak-*"))
    return output


def test_the_fmi_api_survives_the_fuzzer(tmp_path):
    output = run_fuzzer(build_fuzzer(tmp_path), tmp_path, 30)
    runs = int(re.search(r"stat::number_of_executed_units:\s+(\d+)", output).group(1))
    coverage = int(re.findall(r"cov: (\d+)", output)[-1])
    print(f"fuzzer: {runs} executions in 30 s, {coverage} coverage edges")
    # an input that sets the geometry and initialises builds the tables from the C mechanism model,
    # some ms under the sanitizers: about 800 executions in 30 s, reaching the model's code too
    assert runs > 300 and coverage > 700


if __name__ == "__main__":          # make soak: a long run
    import sys
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        text = run_fuzzer(build_fuzzer(Path(tmp)), Path(tmp), int(sys.argv[1]) if len(sys.argv) > 1 else 600)
        print("\n".join(line for line in text.splitlines() if line.startswith(("stat::", "#")) and "DONE" in line
                        or line.startswith("stat::")))


@pytest.mark.parametrize("build", ["native", "python"])
def test_what_the_fuzzer_found_is_refused_with_its_reason(build, tmp_path):
    """rtol below 1e-14 is refused at fmi2SetReal with rtol's valid range (both builds); a torque
    ramp that would spin the crank at 1e9 rad/s ends the native FMU's step within seconds with
    fmi2Error and the reason, not after hours (logging off: the host sees it all the same)."""
    import time

    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    from fuzz_host import callbacks

    path = ROOT / "build" / "fmus" / ("native" if build == "native" else "") / "FourBar.fmu"
    if not path.is_file():
        pytest.skip(f"make fmu builds {path}")
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    messages = []
    keep = callbacks(lambda env, name, status, category, message: messages.append(message.decode()))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), str(tmp_path)),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate(callbacks=keep[0], loggingOn=False)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    with pytest.raises(FMICallException):
        fmu.setReal([vr["rtol"]], [3.9e-213])
    assert re.search(r"rtol = 3\.9e-213 is out of range: valid range \[1e-14, 0\.1\]", messages[-1]), messages[-1]
    fmu.setReal([vr["rtol"]], [1e-11])          # a valid value again (the Python FMU waits for one)
    fmu.exitInitializationMode()
    if build == "native":
        fmu.setRealInputDerivatives([vr["tau_ext"]], [1], [-6.7e10])
        started = time.perf_counter()
        with pytest.raises(FMICallException):
            fmu.doStep(0.0, 0.1)
        assert time.perf_counter() - started < 60.0
        assert "over 1e7 integration steps in one communication step" in messages[-1], messages[-1]
    fmu.terminate()
    fmu.freeInstance()
