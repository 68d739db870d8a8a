"""RodString.fmu as a host drives it, logging off: every value that would make a step unbounded in
time or memory is refused with fmi2Error and its valid range, at once; the FMU state it declares
serializable serializes, and a run restored from the bytes continues bit for bit."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from crankfmu.cli import main


@pytest.fixture(scope="module")
def rod_string(tmp_path_factory):
    out = tmp_path_factory.mktemp("rod_string")
    assert main(["fmu", "rp11l_guo", "--well", "--out", str(out)]) == 0
    return out / "RodString.fmu"


def _host(fmu, body: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    """A fresh process: fmpy's FMU2Slave on the FMU, logging off, every message kept in ``messages``."""
    script = textwrap.dedent(f"""
        import sys
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, \\
            fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE
        from fmpy.fmi2 import calloc, free
        messages = []
        def log(env, name, status, category, message):
            messages.append(message.decode())
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(log)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        md = read_model_description({str(fmu)!r})
        vr = {{v.name: v.valueReference for v in md.modelVariables}}
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract({str(fmu)!r}), modelIdentifier="RodString")
        fmu.instantiate(loggingOn=False, callbacks=callbacks)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
    """) + textwrap.dedent(body)
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("name, value, says", [
    ("taper1_E", 1e300, "taper 1 E = 1e+300 Pa (wave speed"),
    ("segment", 1e-6, "segment = 1e-06 m cuts the"),
    ("courant", 1e-12, "courant = 1e-12 and taper 1 E"),
])
def test_a_value_that_would_make_a_step_unbounded_is_refused_at_once(rod_string, name, value, says):
    """taper1_E = 1e300 hung the FMU (no answer in 120 s): the wave speed, and with it the number of
    internal steps, grew without bound. Now it, a segment that cuts the string into billions, and
    a Courant number that shrinks the step to nothing are refused with fmi2Error at the end of
    initialisation, the message naming the value and its valid range, whatever the logging."""
    done = _host(rod_string, f"""
        fmu.setReal([vr[{name!r}]], [{value!r}])
        try:
            fmu.exitInitializationMode()
            fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1.0)
            print("ran")
        except Exception as exc:
            print("refused:", exc)
        print("\\n".join(messages))
    """, timeout=60.0)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "refused:" in done.stdout and says in done.stdout and "valid range" in done.stdout, done.stdout


def test_the_fmu_state_serializes_and_a_restored_run_continues_bit_for_bit(rod_string):
    """canSerializeFMUstate is declared: fmi2SerializedFMUstateSize returned fmi2Fatal (the string's
    arrays were not plain data). A state serialized at 1 s, deserialized into the same instance after
    it went on to 2 s, gives the same 1 s to 2 s again to the bit."""
    done = _host(rod_string, """
        fmu.exitInitializationMode()
        def run(t0, t1):
            out, t = [], t0
            while t < t1 - 1e-12:
                s = 0.3 * (1 - __import__("math").cos(t))
                fmu.setReal([vr["s"], vr["v"]], [s, 0.3 * __import__("math").sin(t)])
                fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.01)
                t += 0.01
                out.append(fmu.getReal([vr["F"], vr["F_pump"], vr["W_polished"]]))
            return out
        run(0.0, 1.0)
        state = fmu.getFMUstate()
        data = fmu.serializeFMUstate(state)
        first = run(1.0, 2.0)
        fmu.setFMUstate(fmu.deSerializeFMUstate(data))
        again = run(1.0, 2.0)
        print(len(bytes(data)), first == again, first[-1])
    """)
    assert done.returncode == 0, done.stderr[-2000:]
    size, same, _ = done.stdout.split(" ", 2)
    assert int(size) > 1000 and same == "True", done.stdout


def test_refusing_courant_repeatedly_never_crashes_the_host(rod_string):
    """An xdist worker once died in pythonfmu's fmi2SetReal while RodString.fmu refused courant = 1.5:
    twenty fresh hosts refuse it, each exits normally."""
    for _ in range(20):
        done = _host(rod_string, """
            status = None
            try:
                fmu.setReal([vr["courant"]], [1.5])
            except Exception as exc:
                status = str(exc)
            fmu.terminate() if status is None else None
            fmu.freeInstance()
            print("refused" if status else "accepted", "|".join(messages))
        """)
        assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
        assert done.stdout.startswith("refused") and "courant" in done.stdout, done.stdout
