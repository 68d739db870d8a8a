"""``crankfmu fmu`` leaves no broken artifact: a failure at any stage of the build (provoked here
at each one) is one error line naming the stage, exit status 1, no traceback, and the output
folder exactly as it was: no partial FMU, no temporary file, an FMU built earlier untouched."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from crankfmu.cli import main
from crankfmu.contract import COLUMNS
from crankfmu.fmi import documentation, source
from crankfmu.fmi.python import build as fmu_build

# a stage: (where the build calls it, what the error line names)
STAGES = {
    "copy_runtime": "copying the package",
    "pack": "packing the package",
    "FmuBuilder.build_FMU": "pythonfmu's build of the slave",
    "compile_shim": "compiling the linux64 shim",
    "reference_result": "the reference run of the default experiment",
    "complete_model_description": "completing the modelDescription",
    "documentation.scenario_documentation": "the documentation",
    "pythonfmu_binaries": "finding pythonfmu's platform binaries",
    "cross_check_options": "writing the cross-check files",
}


def folder_state(folder: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir()} if folder.exists() else {}


@pytest.fixture(scope="module")
def built_before(tmp_path_factory):
    """seed000's FMU built once, as a user's earlier build in the output folder."""
    out = tmp_path_factory.mktemp("fmus")
    assert main(["fmu", "seed000", "--out", str(out)]) == 0
    return out


@pytest.mark.parametrize("stage", STAGES)
def test_a_failure_at_each_stage_is_one_line_and_leaves_the_folder_as_it_was(stage, built_before, monkeypatch,
                                                                             capsys, tmp_path):
    import pythonfmu

    if stage != "reference_result":    # the reference run is the slow stage: a short one stands in

        def short_reference(scenario):
            return ",".join(f'"{c}"' for c in COLUMNS) + "\n" + "\n".join(
                ",".join(str(t if c == "time" else 1.0) for c in COLUMNS) for t in (0.0, 1.0)) + "\n"
        monkeypatch.setattr(source, "reference_result", short_reference)

    def boom(*args, **kwargs):
        raise RuntimeError(f"provoked failure in {stage}")

    owner, _, name = stage.rpartition(".")
    # where the build looks each up when it calls it: the reference run is the Source's (fmi.source)
    target = {"": source if name == "reference_result" else fmu_build, "FmuBuilder": pythonfmu.FmuBuilder,
              "documentation": documentation}[owner]
    monkeypatch.setattr(target, name, boom)
    before = folder_state(built_before)
    assert main(["fmu", "seed000", "--out", str(built_before)]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert STAGES[stage] in lines[0] and "provoked failure" in lines[0] and "FourBar.fmu" in lines[0]
    assert folder_state(built_before) == before


def test_a_refusal_before_the_build_writes_nothing(tmp_path, capsys):
    out = tmp_path / "fmus"
    assert main(["fmu", "seed000", "--name", "Four-Bar", "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "must be a C identifier" in err[0]
    assert folder_state(out) == {}
