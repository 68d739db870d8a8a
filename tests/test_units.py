"""Units as a user writes them (crankfmu.units): products, quotients, powers and parentheses of SI
symbols read into their base-unit exponents by one parser, each checked against the unit's
definition written another way; decimal prefixes, non-SI units and bad syntax refused with a
message that says what to write; every unit crankfmu itself declares reads."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from crankfmu import units
from crankfmu.check import check_scenario
from crankfmu.cli import main
from crankfmu.contract import DRIVE_OUTPUTS, INPUTS, OUTPUTS
from crankfmu.dynamics.drive import available_drives, load_drive
from crankfmu.errors import DefinitionError
from crankfmu.scenario import available_scenarios, load_scenario

USER = Path(__file__).resolve().parent / "data" / "user"


def dims(**e):
    return tuple(e.get(b, 0) for b in units.BASE)


# each spelling of the issue, against its exponents worked out by hand from N = kg.m/s2
@pytest.mark.parametrize("text, expected", [
    ("N.m/rad", dims(kg=1, m=2, s=-2, rad=-1)),
    ("N/m", dims(kg=1, s=-2)),
    ("kg.m2", dims(kg=1, m=2)),
    ("m/s2", dims(m=1, s=-2)),
    ("1/s", dims(s=-1)),
    ("N.m.s/rad", dims(kg=1, m=2, s=-1, rad=-1)),
    ("V/(rad/s)", dims(kg=1, m=2, s=-2, A=-1, rad=-1)),
    ("kg*m^2", dims(kg=1, m=2)),
    ("(N.m)/rad", dims(kg=1, m=2, s=-2, rad=-1)),
    ("J/(kg.K)", dims(m=2, s=-2, K=-1)),
    ("mol/m3", dims(mol=1, m=-3)),
    ("s-1", dims(s=-1)),
    ("cd", dims(cd=1)),
    ("1", dims()),
])
def test_the_spellings_read_to_their_exponents(text, expected):
    assert units.exponents(text) == expected


@pytest.mark.parametrize("a, b", [
    ("J", "N.m"), ("W", "J/s"), ("Pa", "N/m2"), ("V", "W/A"), ("Ohm", "V/A"), ("H", "Ohm.s"),
    ("Hz", "1/s"), ("C", "A.s"), ("F", "C/V"), ("S", "A/V"), ("Wb", "V.s"), ("T", "Wb/m2"),
    ("N.m/A", "(V/(rad/s)).rad"), ("Pa.s", "N.s/m2"),
])
def test_derived_symbols_agree_with_their_definitions(a, b):
    """The symbol table against the SI definitions written as products and quotients: a wrong
    entry in the table cannot agree with the parser's arithmetic on the others."""
    assert units.exponents(a) == units.exponents(b)


@pytest.mark.parametrize("text, message", [
    ("mm", "decimal prefix 'm' (1e-3)"),
    ("kN", "decimal prefix 'k' (1e3)"),
    ("kN.m", "write the value in N"),
    ("g", "not an SI unit: write the value in kg"),
    ("deg", "write the value in rad"),
    ("rpm", "write the value in rad/s"),
    ("J/kg.K", "J/(kg.K)"),
    ("m/s/s", "after '/' comes one factor"),
    ("N m", "a product is written with '.'"),
    ("N.", "expected a unit symbol or '('"),
    ("(m", "expected ')'"),
    ("m^", "an integer exponent"),
    ("", "empty"),
    ("furlong", "unknown symbol 'furlong'"),
])
def test_unreadable_units_are_refused_with_what_to_write(text, message):
    with pytest.raises(units.UnitError) as info:
        units.exponents(text)
    assert message in str(info.value)


def test_fmi_names_use_modelicas_spelling():
    assert units.fmi_name("kg*m^2") == "kg.m2"
    assert units.fmi_name("N.m/rad") == "N.m/rad"
    assert units.base_units("N.m/rad") == {"kg": 1, "m": 2, "s": -2, "rad": -1}


def test_every_unit_crankfmu_declares_reads():
    declared = [v.unit for v in (*OUTPUTS, *INPUTS, *DRIVE_OUTPUTS)]
    for name in available_scenarios():
        declared += [p.unit for p in load_scenario(name).parameters.values()]
    for name in available_drives():
        drive = load_drive(name)
        declared += [p.unit for p in (*drive.parameters.values(), *drive.inputs.values())]
    for text in declared:
        units.exponents(text)
    assert len(set(declared)) > 15


def test_a_bad_unit_is_refused_by_check_with_the_file_line_and_parameter(tmp_path, capsys):
    for name in ("togglepress.toml", "togglepress_scenario.toml"):
        shutil.copy(USER.parents[2] / "validation" / "data" / name, tmp_path / name)
    scenario = tmp_path / "togglepress_scenario.toml"
    text = scenario.read_text()
    line = next(i for i, l in enumerate(text.splitlines(), start=1) if l.startswith("k_cushion"))
    scenario.write_text(text.replace('unit = "N/m"', 'unit = "kN/m"'))
    report = check_scenario(str(scenario))
    assert report.status == 2
    fail = next(f for f in report.findings if f.level == "FAIL")
    assert "parameter k_cushion" in fail.what and "decimal prefix 'k'" in fail.what
    assert fail.where == f"{scenario}, line {line}"
    # crankfmu fmu refuses it the same way, in one line, and writes nothing
    assert main(["fmu", str(scenario), "--out", str(tmp_path / "fmus")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "parameter k_cushion" in err[0]
    assert not (tmp_path / "fmus").exists() or not any((tmp_path / "fmus").iterdir())


def test_a_bad_parameter_entry_is_refused_by_name():
    base = {"value": 1.0, "unit": "m"}
    from crankfmu.parameters import parse_parameters

    for spec, message in (({**base, "value": "1"}, "value must be a number"),
                          ({**base, "tunable": "yes"}, "tunable must be true or false"),
                          ({**base, "minimum": 0}, "unknown key 'minimum'"),
                          ({**base, "min": 2.0, "max": 1.0}, "min 2 exceeds max 1"),
                          ({**base, "min": 2.0}, "out of its own range")):
        with pytest.raises(DefinitionError, match=message):
            parse_parameters({"x": spec}, "file.toml")
    with pytest.raises(DefinitionError, match="parameter my-x: a name is a letter"):
        parse_parameters({"my-x": base}, "file.toml")
