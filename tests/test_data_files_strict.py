"""Strict data files: a key a file's kind does not know is an error naming the key, its table, the
file's line and the closest valid key; `crankfmu schema KIND` prints the JSON Schema an editor
validates against, and an independent validator (jsonschema) accepts every packaged file with it
and rejects a misspelt one. Expressions evaluate in bounded time and memory, and a load that is
not finite is named with its expression and angle."""

from __future__ import annotations

import glob
import json
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import jsonschema
import pytest

from crankfmu.errors import DefinitionError
from crankfmu.expressions import MAX_LENGTH, evaluate
from crankfmu.schema import SCHEMAS, schema_json

ROOT = Path(__file__).resolve().parents[1]
ENGINE = ROOT / "tests" / "data" / "user" / "engine2s_scenario.toml"
FILES = {
    "scenario": glob.glob(str(ROOT / "src/crankfmu/scenarios/*.toml")) + glob.glob(str(ROOT / "tests/data/user/*_scenario.toml"))
    + glob.glob(str(ROOT / "validation/data/*_scenario.toml")),
    "mechanism": glob.glob(str(ROOT / "src/crankfmu/mechanisms/files/*.toml"))
    + [f for f in glob.glob(str(ROOT / "tests/data/user/*.toml")) + glob.glob(str(ROOT / "validation/data/*.toml"))
       if not f.endswith("_scenario.toml")],
    "drive": glob.glob(str(ROOT / "src/crankfmu/drives/*.toml")),
    "cushion": glob.glob(str(ROOT / "src/crankfmu/elements/*.toml")),
    "shaft": glob.glob(str(ROOT / "src/crankfmu/shafts/*.toml")),
    "well": glob.glob(str(ROOT / "src/crankfmu/wells/*.toml")),
}


def crankfmu(*args):
    return subprocess.run([sys.executable, "-m", "crankfmu", *args], capture_output=True, text=True, timeout=300)


def edited(tmp_path, old: str, new: str, source: Path = ENGINE, name: str = "x_scenario.toml") -> Path:
    text = source.read_text()
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


# ---------------------------------------------------------------- misspelt keys are named
@pytest.mark.parametrize("old, new, key, table, hint", [
    ("stop_time = 4.0", "stop_tme = 4.0", "stop_tme", "[experiment]", "did you mean stop_time?"),
    ('kind = "force"                      # the gas', 'kind = "force"\nlnk = "slider" # the gas', "lnk",
     "the 2nd [[loads]]", "did you mean link?"),
    ('name = "user_engine2s"', 'name = "user_engine2s"\ncolour = "red"', "colour", "the top level", None),
    ('l1 = { value = 0.04, unit = "m"', 'l1 = { value = 0.04, units = "m"', "units", "[parameters.l1]",
     "did you mean unit?"),
])
def test_check_names_a_misspelt_key_with_its_table_and_line(tmp_path, old, new, key, table, hint):
    path = edited(tmp_path, old, new)
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if f"{key} =" in text)
    run = crankfmu("check", str(path))
    assert run.returncode == 2, run.stdout
    said = run.stdout
    assert f"line {line}: unknown key '{key}' in {table}" in said, said
    assert (hint in said) if hint else "did you mean" not in said.split("unknown key")[1].split(";")[0]
    # every command that reads the file refuses it the same way, before any work
    run = crankfmu("simulate", str(path), "--out", str(tmp_path / "run"))
    assert run.returncode == 1 and f"unknown key '{key}'" in run.stderr and len(run.stderr.splitlines()) == 1
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("kind", ["mechanism", "drive", "well", "shaft"])
def test_every_kind_of_file_refuses_an_unknown_key(tmp_path, kind):
    from crankfmu.dynamics.drive import load_drive
    from crankfmu.dynamics.shaft import load_shaft
    from crankfmu.dynamics.well import load_well
    from crankfmu.mechanisms import load_mechanism

    source = Path(sorted(FILES[kind])[0])
    path = tmp_path / source.name
    text = source.read_text()
    first_header = text.index("\n[") + 1
    path.write_text(text[:first_header] + "titel = \"x\"\n" + text[first_header:])
    load = {"mechanism": load_mechanism, "drive": load_drive, "well": load_well, "shaft": load_shaft}[kind]
    with pytest.raises(DefinitionError, match=r"unknown key 'titel' in the top level \(did you mean title\?\)"):
        load(str(path))


def test_a_shaft_file_without_what_its_model_reads_is_refused_in_one_line(tmp_path):
    """A shaft file without its stiffness: `crankfmu fmu --shaft` says what is missing and what a
    shaft file declares, in one line, and leaves no FMU behind."""
    source = ROOT / "src/crankfmu/shafts/elastic_shaft.toml"
    path = tmp_path / "soft_shaft.toml"
    path.write_text("\n".join(line for line in source.read_text().splitlines() if not line.startswith("k =")))
    run = crankfmu("fmu", str(path), "--shaft", "--out", str(tmp_path / "out"))
    assert run.returncode == 1 and len(run.stderr.splitlines()) == 1, run.stderr
    assert "missing k (parameters k, c, twist_start; inputs omega_a, omega_b)" in run.stderr
    assert not list(tmp_path.rglob("*.fmu"))


# ---------------------------------------------------------------- the JSON Schemas
@pytest.mark.parametrize("kind", sorted(SCHEMAS))
def test_the_schema_validates_every_packaged_file_and_rejects_a_misspelt_one(kind, tmp_path):
    """jsonschema (not crankfmu's own check) reads `crankfmu schema KIND`'s output: every packaged
    and test file of the kind is valid; the same file with a misspelt key is not."""
    run = crankfmu("schema", kind)
    assert run.returncode == 0, run.stderr
    schema = json.loads(run.stdout)
    assert schema == json.loads(schema_json(kind))
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    assert FILES[kind]
    for path in FILES[kind]:
        data = tomllib.loads(Path(path).read_text())
        errors = [e.message for e in validator.iter_errors(data)]
        assert not errors, (path, errors[:3])
    data = tomllib.loads(Path(FILES[kind][0]).read_text())
    data["nmae"] = data.pop("name", "x")
    assert any("nmae" in e.message for e in validator.iter_errors(data))


def test_schema_refuses_an_unknown_kind():
    run = crankfmu("schema", "scenarios")
    assert run.returncode == 2 and "invalid choice: 'scenarios'" in run.stderr


# ---------------------------------------------------------------- bounded expressions
@pytest.mark.parametrize("source, said", [
    ("9**9**9**9", "overflows"),
    ("+".join(["x"] * 600), "terms; at most"),
    ("1" * (MAX_LENGTH + 1), "characters long"),
])
def test_an_expression_is_refused_in_bounded_time(source, said):
    started = time.perf_counter()
    with pytest.raises(DefinitionError, match=said):
        evaluate(source, {"x": 1.0})
    assert time.perf_counter() - started < 0.5       # 9**9**9**9 as Python integers ran for minutes


def test_numbers_are_floats_as_in_the_c_model():
    assert evaluate("2**10", {}) == 1024.0 and evaluate("7/2", {}) == 3.5 and evaluate("2**-1", {}) == 0.5


def test_code_is_still_refused():
    for source in ("__import__('os')", "x.__class__", "(lambda: 1)()", "[1, 2]"):
        with pytest.raises(DefinitionError):
            evaluate(source, {"x": 1.0})


@pytest.mark.parametrize("expression, value, angle", [
    ("1/sin(phi1)", "inf", "0.00"),
    ("1e308*1e308*0", "nan", "0.00"),
    ("9**9**9**9", None, None),
])
def test_check_names_a_load_that_is_not_finite(tmp_path, expression, value, angle):
    """check answers in well under a second and names the expression and the angle (it once said
    "too close to a dead point" for these, and ran for minutes on 9**9**9**9)."""
    path = edited(tmp_path, 'fy = "0"', f'fy = "{expression}"')
    started = time.perf_counter()
    run = crankfmu("check", str(path))
    elapsed = time.perf_counter() - started
    said = run.stdout + run.stderr
    assert run.returncode != 0 and "dead point" not in said, said
    if value is None:
        assert "overflows" in said
    else:
        assert f"fy = '{expression}' is not finite ({value}) at phi1 = {angle} deg" in said, said
        assert "RuntimeWarning" not in said
    assert elapsed < 30          # the whole process, Python's start included; the refusal itself takes ms


def test_the_tabulator_calls_a_function_that_is_not_finite_so():
    import numpy as np

    from crankfmu.dynamics.cubics import _why_not_tabulated

    values = np.vstack([np.ones(8), np.r_[1.0, 2.0, np.inf, 1.0, 1.0, 1.0, 1.0, 1.0]])
    said = _why_not_tabulated(values, np.array([0.0, np.nan]), ("the loads", ("a", "b")), 1e-11, 8)
    assert said == ("the loads: b is not finite (inf) at phi1 = 90.00 deg: an expression of the data file divides "
                    "by zero or overflows there (crankfmu check names it)")
