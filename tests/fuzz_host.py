"""A Python co-simulation host (fmpy's FMU2Slave) that fuzzes one FMU; run as a child process by
tests/test_fmu_fuzz.py, so that a crash or a hang of the FMU fails that test, not the test run.

    python tests/fuzz_host.py FMU GROUP LOGGING(0|1) [SEED]

prints one JSON object: ``problems`` (each a sentence: what was called, what came back, what the
contract says) and ``counts`` (what was exercised). The contract every call is held to:
- a refused call returns fmi2Error (never fmi2OK, fmi2Discard or fmi2Fatal) and the host's logger
  receives a message with category logStatusError, whatever loggingOn is;
- an accepted call returns fmi2OK and every output read afterwards is finite.
"""

from __future__ import annotations

import json
import math
import random
import resource
import sys
from pathlib import Path

from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4
FUZZ_VALUES = (math.nan, math.inf, -math.inf, -1e300, 1e300, 0.0, -1.0)


def callbacks(logger):
    """FMI callbacks with ``logger(env, instance, status, category, message)`` (the shim passes the
    formatted text); keep the returned tuple alive as long as the instance."""
    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return cb, logger


def quiet_slave(fmu_path, where, model: str):
    """(an fmpy FMU2Slave of the FMU instantiated with loggingOn false, value references by name,
    the list its messages go to, the callbacks to keep alive)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_path))
    messages = []
    keep = callbacks(lambda env, name, status, category, message: messages.append(message.decode()))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu_path), str(where)), modelIdentifier=model)
    fmu.instantiate(loggingOn=False, callbacks=keep[0])
    return fmu, {v.name: v.valueReference for v in md.modelVariables}, messages, keep


class Host:
    """One FMU instance driven through fmpy's raw calls: statuses are returned, not raised."""

    def __init__(self, unzipped, md, logging: bool, name: str = "fuzz"):
        self.md = md
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.outputs = [v.valueReference for v in md.modelVariables if v.causality == "output"]
        self.messages: list[tuple[int, str, str]] = []
        self.logging = logging
        self._instantiate(unzipped, md, logging, name)
        self.t = 0.0

    def _log(self, status, category, message):
        self.messages.append((status, (category or b"").decode(), message.decode(errors="replace")))

    def _instantiate(self, unzipped, md, logging, name):
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self._keep = callbacks(lambda env, instance, status, category, message: self._log(status, category, message))
        self.fmu.instantiate(callbacks=self._keep[0], loggingOn=logging)

    def call(self, name, *args):
        """(status, messages logged during the call) of a raw FMI call."""
        before = len(self.messages)
        try:
            status = getattr(self.fmu, "fmi2" + name)(self.fmu.component, *args)
        except FMICallException as exc:         # fmpy raises for fmi2Error and worse
            status = exc.status
        return status, self.messages[before:]

    def set_real(self, name_or_vr, value):
        vr = self.vr[name_or_vr] if isinstance(name_or_vr, str) else name_or_vr
        from fmpy.fmi2 import fmi2Real, fmi2ValueReference
        return self.call("SetReal", (fmi2ValueReference * 1)(vr), 1, (fmi2Real * 1)(value))

    def get_real(self, vrs):
        from fmpy.fmi2 import fmi2Real, fmi2ValueReference
        values = (fmi2Real * len(vrs))()
        status, logged = self.call("GetReal", (fmi2ValueReference * len(vrs))(*vrs), len(vrs), values)
        return status, logged, list(values)

    def start(self):
        return self.call("SetupExperiment", 0, 0.0, 0.0, 0, 0.0)[0], self.call("EnterInitializationMode")[0]

    def step(self, h):
        status, logged = self.call("DoStep", self.t, h, 1)
        if status == OK:
            self.t += h
        return status, logged

    def free(self):
        self.fmu.fmi2Terminate(self.fmu.component)
        self.fmu.fmi2FreeInstance(self.fmu.component)


class _Fmi2Names:
    """An FMU3Slave seen through the FMU state calls' FMI 2.0 names, which the groups use."""

    def __init__(self, fmu):
        self._fmu = fmu
        self.instanceName = fmu.instanceName
        self.component = fmu.component
        self.getFMUstate, self.setFMUstate, self.freeFMUstate = fmu.getFMUState, fmu.setFMUState, fmu.freeFMUState
        self.serializeFMUstate, self.deSerializeFMUstate = fmu.serializeFMUState, fmu.deserializeFMUState


class Host3(Host):
    """The same host for an FMI 3.0 FMU (fmpy's FMU3Slave): each FMI 2.0 call the groups make is made
    as its FMI 3.0 counterpart (fmi3EnterInitializationMode takes the experiment's times,
    fmi3DoStep returns its flags, Float64 for Real: the same C types), statuses returned, not raised."""

    CALLS = {"SetReal": "SetFloat64", "GetReal": "GetFloat64", "GetInteger": "GetInt32",
             "DeSerializeFMUstate": "DeserializeFMUState", "SetFMUstate": "SetFMUState"}

    def _instantiate(self, unzipped, md, logging, name):
        from fmpy.fmi3 import FMU3Slave

        raw = FMU3Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                        instanceName=name)
        raw.instantiate(loggingOn=logging, logMessage=lambda env, status, category, message: self._log(status, category,
                                                                                                        message))
        self._raw = raw
        self.fmu = _Fmi2Names(raw)

    def call(self, name, *args):
        from ctypes import byref

        from fmpy.fmi3 import fmi3Boolean, fmi3Float64

        raw = self._raw
        if name == "EnterInitializationMode":
            args = (False, 0.0, 0.0, False, 0.0)
        elif name == "DoStep":
            flags = [fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64()]
            args = (*args, *(byref(f) for f in flags))
        elif name in ("SetReal", "GetReal", "GetInteger"):
            args = (*args, args[1])                 # nValues: every variable is a scalar
        elif name == "DeSerializeFMUstate":
            from fmpy.fmi3 import fmi3Byte
            data, size, handle = args
            args = ((fmi3Byte * len(data)).from_buffer_copy(data), size, handle)
        before = len(self.messages)
        try:
            status = getattr(raw, "fmi3" + self.CALLS.get(name, name))(raw.component, *args)
        except FMICallException as exc:
            status = exc.status
        return status, self.messages[before:]

    def start(self):
        return OK, self.call("EnterInitializationMode")[0]

    def free(self):
        self._raw.fmi3Terminate(self._raw.component)
        self._raw.fmi3FreeInstance(self._raw.component)


def host_for(unzipped, md, logging: bool, name: str = "fuzz") -> Host:
    """The host of the FMU's FMI version."""
    return (Host3 if md.fmiVersion.startswith("3") else Host)(unzipped, md, logging, name)


class Report:
    def __init__(self):
        self.problems: list[str] = []
        self.counts: dict[str, int] = {}

    def count(self, what, n=1):
        self.counts[what] = self.counts.get(what, 0) + n

    def refused(self, what: str, status: int, logged, name: str | None = None):
        """The call must have been refused with fmi2Error and a logStatusError message (naming
        ``name`` when given)."""
        self.count("refusals")
        errors = [m for s, c, m in logged if s == ERROR and c == "logStatusError"]
        if status != ERROR:
            self.problems.append(f"{what}: status {status}, expected fmi2Error (3)")
        elif not errors:
            self.problems.append(f"{what}: fmi2Error without a logStatusError message (got {logged})")
        elif name is not None and not any(name in m for m in errors):
            self.problems.append(f"{what}: the message does not name {name}: {errors}")

    def accepted(self, what: str, status: int, logged):
        if status != OK:
            self.problems.append(f"{what}: status {status}, expected fmi2OK; log {logged}")
            return False
        return True

    def outcome(self, what: str, status: int, logged) -> str:
        """'ok' or 'refused' for a call that may do either; a problem for anything else."""
        if status == OK:
            return "ok"
        self.refused(what, status, logged)
        return "refused"


def finite_outputs(report: Report, host: Host, what: str) -> dict | None:
    status, logged, values = host.get_real(host.outputs)
    if not report.accepted(f"{what}: fmi2GetReal of the outputs", status, logged):
        return None
    names = {v.valueReference: v.name for v in host.md.modelVariables}
    bad = [names[vr] for vr, v in zip(host.outputs, values) if not math.isfinite(v)]
    if bad:
        report.problems.append(f"{what}: non-finite outputs {bad} with fmi2OK")
        return None
    return {names[vr]: v for vr, v in zip(host.outputs, values)}


def energy_residual_ok(report, what, start, end):
    """|E_kin - E_kin(0) - W_motor - W_load - W_ext| <= 1e-6 (|W_motor| + |W_load| + 1 J)."""
    residual = end["E_kin"] - start["E_kin"] - end["W_motor"] - end["W_load"] - end["W_ext"]
    bound = 1e-6 * (abs(end["W_motor"]) + abs(end["W_load"]) + 1.0)
    report.count("energy balances")
    if not abs(residual) <= bound:
        report.problems.append(f"{what}: energy residual {residual:.3g} J > {bound:.3g} J")


def parameters_of(md):
    return [v for v in md.modelVariables if v.causality == "parameter"]


# ---------------------------------------------------------------------------------- groups
def group_parameters(unzipped, md, logging, report, seed):
    """Every parameter set to each fuzz value: refused at fmi2SetReal or at initialisation, or
    accepted and stepped with finite outputs."""
    host = host_for(unzipped, md, logging)
    for var in parameters_of(md):
        for value in FUZZ_VALUES:
            what = f"{var.name} = {value!r}"
            host.call("Reset")
            host.t = 0.0
            host.start()
            status, logged = host.set_real(var.name, value)
            if status != OK:
                report.refused(f"fmi2SetReal {what}", status, logged, var.name)
                report.count("refused at fmi2SetReal")
                continue
            status, logged = host.call("ExitInitializationMode")
            if report.outcome(f"fmi2ExitInitializationMode after {what}", status, logged) == "refused":
                report.count("refused at fmi2ExitInitializationMode")
                status, logged = host.step(0.01)        # every later step: refused with the reason
                report.refused(f"fmi2DoStep after a refused {what}", status, logged)
                continue
            report.count("accepted")
            for _ in range(10):
                status, logged = host.step(0.01)
                if report.outcome(f"fmi2DoStep with {what}", status, logged) == "refused":
                    report.count("refused while stepping")
                    break
                if finite_outputs(report, host, f"after a step with {what}") is None:
                    break
    host.free()


def random_design(md, rng):
    values = {}
    for var in parameters_of(md):
        default = float(var.start)
        if var.name in ("g", "omega1_start", "phi1_start", "rtol"):
            continue
        values[var.name] = default * rng.uniform(0.4, 1.6)
    names = {v.name for v in parameters_of(md)}
    if "g" in names:                                 # a mechanism FMU
        values["g"] = rng.choice([0.0, 9.81])
        values["omega1_start"] = rng.choice([0.0, 0.1, 5.0, 20.0])
    return values


def group_designs(unzipped, md, logging, report, seed):
    """20 random designs within +-60 % of the defaults: refused with fmi2Error at set or
    initialisation, or 2 s at 10 ms with finite outputs and the energy balance."""
    rng = random.Random(seed)
    for k in range(20):
        design = random_design(md, rng)
        host = host_for(unzipped, md, logging, name=f"design{k}")
        host.start()
        what = f"design {k} {design}"
        refused = False
        for name, value in design.items():
            status, logged = host.set_real(name, value)
            if report.outcome(f"fmi2SetReal {name} of {what}", status, logged) == "refused":
                refused = True
        if refused:
            report.count("designs refused at fmi2SetReal")
            host.free()
            continue
        status, logged = host.call("ExitInitializationMode")
        if report.outcome(f"fmi2ExitInitializationMode of {what}", status, logged) == "refused":
            report.count("designs refused at initialisation")
            host.free()
            continue
        start = finite_outputs(report, host, what)
        end = start
        for _ in range(200):
            status, logged = host.step(0.01)
            if not report.accepted(f"fmi2DoStep at t = {host.t:g} of {what}", status, logged):
                end = None
                break
            end = finite_outputs(report, host, f"t = {host.t:g} of {what}")
            if end is None:
                break
        if start is not None and end is not None:
            report.count("designs stepped for 2 s")
            if "E_kin" in start:                     # a mechanism: its energy balance
                energy_residual_ok(report, what, start, end)
        host.free()


def group_calls(unzipped, md, logging, report, seed):
    """Bad fmi2DoStep arguments and calls out of order, each on a fresh (reset) instance."""
    host = host_for(unzipped, md, logging)
    fixed = next(v.name for v in parameters_of(md) if v.variability == "fixed")
    tunable = next(v.name for v in parameters_of(md) if v.variability == "tunable")
    n_vars = len(md.modelVariables)

    def fresh(initialise=True):
        host.call("Reset")
        host.t = 0.0
        host.start()
        if initialise:
            report.accepted("fmi2ExitInitializationMode (defaults)", *host.call("ExitInitializationMode"))

    fresh(initialise=False)
    report.refused("fmi2DoStep before initialisation", *host.step(0.01))
    for label, t, h in (("step size NaN", 0.0, math.nan), ("step size +inf", 0.0, math.inf),
                        ("step size -0.01", 0.0, -0.01), ("step size 0", 0.0, 0.0),
                        ("current time NaN", math.nan, 0.01), ("current time inf", math.inf, 0.01),
                        ("current time one step ahead", 0.01, 0.01)):
        fresh()
        status, logged = host.call("DoStep", t, h, 1)
        report.refused(f"fmi2DoStep with {label}", status, logged)
        # the refusal leaves the model as it was: a correct step still goes
        report.accepted(f"fmi2DoStep after refusing {label}", *host.step(0.01))
        finite_outputs(report, host, f"after refusing {label}")
    fresh()
    host.step(0.01)
    _, _, (before,) = host.get_real([host.vr[fixed]])
    report.refused(f"fmi2SetReal of the fixed parameter {fixed} after initialisation",
                   *host.set_real(fixed, before * 1.1 + 1.0), name=fixed)
    _, _, (after,) = host.get_real([host.vr[fixed]])
    if after != before:
        report.problems.append(f"{fixed} reads {after} after a refused set, the model keeps {before}")
    report.accepted(f"fmi2SetReal of the tunable parameter {tunable} after initialisation",
                    *host.set_real(tunable, float(next(v.start for v in parameters_of(md) if v.name == tunable))))
    status, logged, values = host.get_real([n_vars + 7])
    report.refused(f"fmi2GetReal of the unknown value reference {n_vars + 7}", status, logged)
    report.refused(f"fmi2SetReal of the unknown value reference {n_vars + 7}", *host.set_real(n_vars + 7, 1.0))
    output = next(v.name for v in md.modelVariables if v.causality == "output")
    report.refused(f"fmi2SetReal of the output {output}", *host.set_real(output, 1.0), name=output)
    from fmpy.fmi2 import fmi2Integer, fmi2ValueReference
    report.refused("fmi2GetInteger (the FMU has no Integer variables)",
                   *host.call("GetInteger", (fmi2ValueReference * 1)(0), 1, (fmi2Integer * 1)()))
    report.refused("fmi2ExitInitializationMode twice", *host.call("ExitInitializationMode"))
    report.refused("fmi2EnterInitializationMode while stepping", *host.call("EnterInitializationMode"))
    # the instance still steps after all these refusals
    report.accepted("fmi2DoStep after the refused calls", *host.step(0.01))
    finite_outputs(report, host, "after the refused calls")
    host.free()
    report.count("call cases", 16)


def run_steps(host, n, h=0.01):
    out = []
    for _ in range(n):
        host.step(h)
        out.append(tuple(host.get_real(host.outputs)[2]))
    return out


def group_cycles(unzipped, md, logging, report, seed):
    """200 instantiate / initialise / step / free cycles in one process: the same results, and
    resident memory growing by less than 100 MB (after the first cycle, which loads everything).
    Half the cycles log, half do not (``logging`` says which comes first)."""
    first = None
    rss0 = None
    for k in range(200):
        host = host_for(unzipped, md, logging if k % 2 == 0 else not logging, name=f"cycle{k}")
        host.start()
        host.call("ExitInitializationMode")
        result = run_steps(host, 5)
        host.free()
        if first is None:
            first = result
            rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        elif result != first:
            report.problems.append(f"cycle {k}: results differ from the first cycle")
            break
    growth = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0 - rss0
    report.counts["cycles"] = k + 1
    report.counts["rss growth MB"] = round(growth, 1)
    if growth > 100.0:
        report.problems.append(f"resident memory grew by {growth:.0f} MB over 200 cycles")


def group_instances(unzipped, md, logging, report, seed):
    """Three instances stepped interleaved equal one alone; state get/set and
    serialize/deserialize continue bit for bit."""
    alone = host_for(unzipped, md, logging, "alone")
    alone.start()
    alone.call("ExitInitializationMode")
    expected = run_steps(alone, 30)
    alone.free()
    hosts = [host_for(unzipped, md, logging, f"i{k}") for k in range(3)]
    for h in hosts:
        h.start()
        h.call("ExitInitializationMode")
    results = [[], [], []]
    for _ in range(30):
        for h, r in zip(hosts, results):
            r += run_steps(h, 1)
    for h, r in zip(hosts, results):
        if r != expected:
            report.problems.append(f"interleaved instance {h.fmu.instanceName} differs from one alone")
        h.free()

    host = host_for(unzipped, md, logging, "state")
    host.start()
    host.call("ExitInitializationMode")
    run_steps(host, 10)
    state = host.fmu.getFMUstate()
    t_saved = host.t
    serialized = host.fmu.serializeFMUstate(state)
    continued = run_steps(host, 20)

    def continues_bit_for_bit(target, saved, what):
        target.fmu.setFMUstate(saved)
        target.t = t_saved
        if run_steps(target, 20) != continued:
            report.problems.append(f"{what}: the continuation differs")
        target.fmu.freeFMUstate(saved)

    continues_bit_for_bit(host, state, "fmi2SetFMUstate")
    continues_bit_for_bit(host, host.fmu.deSerializeFMUstate(serialized), "fmi2DeSerializeFMUstate")
    host.free()
    # a serialized state in another initialised instance continues the same way
    other = host_for(unzipped, md, logging, "other")
    other.start()
    other.call("ExitInitializationMode")
    continues_bit_for_bit(other, other.fmu.deSerializeFMUstate(serialized), "a serialized state in another instance")
    # a corrupted serialized state is refused, not fatal
    from ctypes import byref
    from fmpy.fmi2 import fmi2FMUstate
    junk = bytes(serialized[: len(serialized) // 2]) + b"\x00garbage"
    handle = fmi2FMUstate()              # a void pointer in either version
    status, logged = other.call("DeSerializeFMUstate", junk, len(junk), byref(handle))
    if status == OK:
        status, logged = other.call("SetFMUstate", handle)
        report.refused("fmi2SetFMUstate of a corrupted serialized state", status, logged)
    else:
        report.refused("fmi2DeSerializeFMUstate of corrupted bytes", status, logged)
    report.accepted("fmi2DoStep after refusing a corrupted state", *other.step(0.01))
    other.free()
    report.count("state checks", 4)


GROUPS = {"parameters": group_parameters, "designs": group_designs, "calls": group_calls,
          "cycles": group_cycles, "instances": group_instances}


def main(argv):
    fmu, group, logging = argv[1], argv[2], argv[3] == "1"
    seed = int(argv[4]) if len(argv) > 4 else 0
    md = read_model_description(fmu)
    unzipped = extract(fmu)
    report = Report()
    GROUPS[group](unzipped, md, logging, report, seed)
    print(json.dumps({"fmu": Path(fmu).name, "group": group, "logging": logging,
                      "problems": report.problems, "counts": report.counts}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
