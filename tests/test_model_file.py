"""The native mechanism FMU's model file (resources/crankfmu-model.bin, fmi/native/model_file.py) read by the
prebuilt runtime (native/model/crank_model_file.c): both sides state the same layout, the runtime
gives back what the build wrote (every variable's name, start and range), and a missing,
truncated, altered or other-format file is refused at instantiation with fmi2Error/fmi3Error and a
message naming the file, logging on or off."""

from __future__ import annotations

import hashlib
import re
import struct
from pathlib import Path

import numpy as np
import pytest

from crankfmu.fmi.native import model_file
from crankfmu.native.sources import HERE as NATIVE

HEADER = (NATIVE / "model" / "crank_variables.h").read_text()


def test_the_layout_is_stated_alike_on_both_sides():
    """The file's name, magic, format version and the variables' kinds: the C header's and the
    writer's are the same (the order of the payload is checked by every FMU a test runs: the runtime
    refuses a file whose counts, kinds or places do not fit)."""
    assert re.search(r'#define CM_MODEL_FILE "([^"]+)"', HEADER).group(1) == model_file.NAME
    magic = re.search(r'#define CM_MODEL_MAGIC "([^"]+)"', HEADER).group(1).encode().decode("unicode_escape")
    assert magic.encode() == model_file.MAGIC
    assert int(re.search(r"#define CM_MODEL_FORMAT (\d+)", HEADER).group(1)) == model_file.FORMAT
    kinds = re.search(r"enum \{ (KIND_OUTPUT[^}]+)\}", HEADER).group(1).replace("KIND_", "").split(",")
    assert [k.strip() for k in kinds if k.strip() != "COUNT"] == list(model_file.KINDS)
    # what a file's model is: the mechanism first, then the components in the writer's codes
    models = [m.strip() for m in re.search(r"enum \{ (CM_MODEL_MECHANISM[^}]+)\}", HEADER).group(1).split(",")]
    assert models[0] == "CM_MODEL_MECHANISM = 1" and model_file.MECHANISM == 1
    assert models[1:-1] == ["CM_MODEL_DRIVE", "CM_MODEL_DRIVE_SPEED", "CM_MODEL_CUSHION", "CM_MODEL_ROD_STRING",
                            "CM_MODEL_SHAFT"]
    assert sorted(model_file.COMPONENTS.values()) == list(range(2, 2 + len(models) - 2))
    assert [model_file.COMPONENTS[k] for k in (("drive", "torque"), ("drive", "speed"), ("cushion", "torque"),
                                               ("well", "torque"), ("shaft", "torque"))] == [2, 3, 4, 5, 6]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """seed000's native FMUs, FMI 2.0 and 3.0, and engine4's (the largest program: four cylinders)."""
    from crankfmu.fmi.native.build import build_native

    out = tmp_path_factory.mktemp("model_file")
    return {(name, version): build_native(name, out / f"{name}{version}", fmi_version=version)
            for name in ("seed000", "engine4") for version in ("2.0", "3.0")}


def _unzip(fmu: Path, where: Path) -> Path:
    import zipfile

    with zipfile.ZipFile(fmu) as z:
        z.extractall(where)
    return where


def _instantiate(fmu: Path, unzipped: Path, version: str, logging: bool):
    """(the instance or None, the messages logged) of the FMU unpacked at ``unzipped``."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    messages = []
    if version == "2.0":
        from fmpy.fmi2 import FMU2Slave

        from fuzz_host import callbacks

        keep = callbacks(lambda env, name, status, category, message: messages.append(message.decode()))
        slave = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped), modelIdentifier=md.coSimulation.modelIdentifier)
        try:
            slave.instantiate(callbacks=keep[0], loggingOn=logging)
        except Exception:
            return None, messages
        return slave, messages
    from fmpy.fmi3 import FMU3Slave

    slave = FMU3Slave(guid=md.guid, unzipDirectory=str(unzipped), modelIdentifier=md.coSimulation.modelIdentifier)
    slave.logMessage = lambda env, status, category, message: messages.append(message.decode())
    try:
        slave.instantiate(loggingOn=logging, logMessage=slave.logMessage)
    except Exception:
        return None, messages
    return slave, messages


def _damaged(data: bytes, damage: str) -> bytes | None:
    body = data[64:]
    if damage == "missing":
        return None
    if damage == "truncated":
        return data[: len(data) // 2]
    if damage == "altered":                      # one byte of the payload, the digest as it was
        i = len(body) // 3
        return data[:64] + body[:i] + bytes([body[i] ^ 0x10]) + body[i + 1:]
    if damage == "format":                       # a format this runtime does not read, its digest right
        return model_file.MAGIC + struct.pack("<IIQ", model_file.FORMAT + 1, 1, len(body)) + data[32:]
    return b"not a model: " + bytes(range(256))       # junk


REFUSALS = {"missing": "is missing", "truncated": "is truncated", "altered": "was altered",
            "format": f"is of format {model_file.FORMAT + 1}", "junk": "is not a crankfmu model file"}


@pytest.mark.parametrize("version", ["2.0", "3.0"])
@pytest.mark.parametrize("logging", [False, True])
@pytest.mark.parametrize("damage", list(REFUSALS))
def test_a_damaged_model_file_is_refused_at_instantiation_by_name(built, tmp_path, version, logging, damage):
    fmu = built[("seed000", version)]
    unzipped = _unzip(fmu, tmp_path / "fmu")
    path = unzipped / "resources" / model_file.NAME
    data = _damaged(path.read_bytes(), damage)
    if data is None:
        path.unlink()
    else:
        path.write_bytes(data)
    slave, messages = _instantiate(fmu, unzipped, version, logging)
    assert slave is None
    said = [m for m in messages if REFUSALS[damage] in m]
    assert said, messages
    assert str(path) in said[-1] and said[-1].startswith(("fmi2Instantiate: ", "fmi3InstantiateCoSimulation: "))


def test_the_runtime_gives_back_the_variables_the_build_wrote(built, tmp_path):
    """Every variable's value at instantiation (a parameter's: its start) is the modelDescription's
    start, read by value reference from the runtime, for the two scenarios in both FMI versions;
    and its ranges are the runtime's: a value just out of a parameter's range is refused with it."""
    from fmpy import read_model_description

    for (name, version), fmu in built.items():
        md = read_model_description(str(fmu))
        slave, messages = _instantiate(fmu, _unzip(fmu, tmp_path / f"{name}{version}"), version, False)
        assert slave is not None, messages
        params = [v for v in md.modelVariables if v.causality in ("parameter", "input")]
        get = slave.getReal if version == "2.0" else slave.getFloat64
        got = get([v.valueReference for v in params])
        np.testing.assert_array_equal(got, [float(v.start) for v in params])
        bounded = [v for v in params if v.min is not None and float(v.min) > 0][0]
        set_ = slave.setReal if version == "2.0" else slave.setFloat64
        with pytest.raises(Exception):
            set_([bounded.valueReference], [-1.0])
        assert f"parameter {bounded.name} = -1.0 is out of range" in messages[-1], messages[-1]
        slave.freeInstance()


def test_the_file_records_the_sha256_of_its_payload(built, tmp_path):
    """The header's digest is hashlib's SHA-256 of the payload (the runtime computes its own:
    crank_model_file.c's md_sha256, which accepted every file above and refused the altered one)."""
    data = (_unzip(built[("engine4", "2.0")], tmp_path) / "resources" / model_file.NAME).read_bytes()
    magic, (fmt, kind, size), digest = data[:16], struct.unpack("<IIQ", data[16:32]), data[32:64]
    assert (magic, fmt, kind, size) == (model_file.MAGIC, model_file.FORMAT, model_file.MECHANISM, len(data) - 64)
    assert digest == hashlib.sha256(data[64:]).digest()


def test_a_resource_location_that_is_no_file_uri_is_refused(built, tmp_path):
    """fmi2Instantiate with an http: resource location, or none, says where the model is read from."""
    import ctypes

    from fmpy import read_model_description

    from fuzz_host import callbacks

    fmu = built[("seed000", "2.0")]
    md = read_model_description(str(fmu))
    unzipped = _unzip(fmu, tmp_path / "fmu")
    messages = []
    cb, _ = callbacks(lambda env, name, status, category, message: messages.append(message.decode()))
    library = ctypes.CDLL(str(unzipped / "binaries" / "linux64" / "FourBar.so"))
    library.fmi2Instantiate.restype = ctypes.c_void_p
    for location in (b"http://example.com/resources", None):
        assert library.fmi2Instantiate(b"x", 1, md.guid.encode(), location, ctypes.byref(cb), 0, 0) is None
        assert f"resources/{model_file.NAME}" in messages[-1], messages


@pytest.mark.parametrize("version", ["2.0", "3.0"])
def test_a_component_file_its_model_cannot_run_is_refused_by_name(tmp_path, version):
    """A component's model finds the variables it uses by their names: a file (its digest right)
    that lacks one, or names a kind no runtime has, is refused at instantiation with the file and
    what was wrong, logging off; the file as built instantiates."""
    from crankfmu.fmi.native.components import ComponentModel, build_native_component
    from crankfmu.fmi.source import preflight

    fmu = build_native_component("drive", "dc_pi", tmp_path / "built", fmi_version=version)
    model = ComponentModel(preflight("drive", "dc_pi", None, None))
    good = model.model_file()
    model.rows = [("R_renamed", *row[1:]) if row[0] == "R" else row for row in model.rows]
    renamed = model.model_file()
    unknown = model_file.MAGIC + struct.pack("<IIQ", model_file.FORMAT, 9, len(good) - 64) + good[32:]
    for data, said in ((renamed, "has no variable R, which its model needs"), (unknown, "is of kind 9")):
        unzipped = _unzip(fmu, tmp_path / f"x{len(said)}")
        (unzipped / "resources" / model_file.NAME).write_bytes(data)
        instance, messages = _instantiate(fmu, unzipped, version, logging=False)
        assert instance is None and messages and said in messages[-1] and model_file.NAME in messages[-1], messages
    unzipped = _unzip(fmu, tmp_path / "good")
    assert (unzipped / "resources" / model_file.NAME).read_bytes() == good
    instance, messages = _instantiate(fmu, unzipped, version, logging=False)
    assert instance is not None and messages == [], messages
    instance.freeInstance()
