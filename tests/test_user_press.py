"""A user's knuckle-joint press (validation/data/togglepress*.toml, where the harness's coupled press scene reads it too), written from the guide alone:
two contours, a vertical ram, a spring-damper cushion, a pressing force that depends on the ram's
direction and a torsion spring on a toggle link, its parameters in units a press designer writes
(N/m, N.m/rad, Pa, m2, kg/m3, m3: none in crankfmu's old fixed table of units). It passes the
check, its FMU declares each unit with its base exponents, and the harness validates the FMU."""

from __future__ import annotations

import re
from pathlib import Path
from xml.etree import ElementTree as ET
import zipfile


from crankfmu import load_scenario, units
from crankfmu.check import check_scenario
from crankfmu.cli import main
from conftest import assert_two_integrators_agree_and_energy_closes

SCENARIO = Path(__file__).resolve().parents[1] / "validation" / "data" / "togglepress_scenario.toml"

#: the units of the old fixed table (contract.BASE_UNITS before units.py): the press must go beyond
OLD_TABLE = {"1", "s", "m", "rad", "rad/s", "rad/s2", "N.m", "J", "kg.m2", "kg/m", "N.m.s/rad", "m/s2", "m/s",
             "kg", "N.s/m", "N", "A", "W", "V", "Ohm", "H", "N.m/A", "V/(rad/s)", "V/rad"}


def test_the_press_uses_six_units_beyond_the_old_table():
    used = {p.unit for p in load_scenario(str(SCENARIO)).parameters.values()}
    assert {"N/m", "N.m/rad"} <= used
    assert len(used - OLD_TABLE) >= 6, used - OLD_TABLE


def test_the_press_passes_the_check():
    report = check_scenario(str(SCENARIO))
    assert report.status == 0, report.text()
    assert "the FMU's declarations: model identifier TogglePress" in report.text()


def test_the_press_closes_its_energy_balance_and_its_two_integrators_agree():
    """fast (tabulated model) against reference (DOP853 on the contour engine, rtol 1e-12): 1e-6
    relative leaves room for the pressing force's switches at the ram's extremes, as for the
    guide's press."""
    assert_two_integrators_agree_and_energy_closes(SCENARIO)


def test_the_press_becomes_a_validated_fmu_with_its_units_declared(tmp_path, capsys):
    assert main(["fmu", str(SCENARIO), "--out", str(tmp_path / "fmus")]) == 0
    fmu = tmp_path / "fmus" / "TogglePress.fmu"
    root = ET.fromstring(zipfile.ZipFile(fmu).read("modelDescription.xml"))
    declared = {u.get("name"): {k: int(v) for k, v in u.find("BaseUnit").attrib.items()}
                for u in root.iter("Unit")}
    for name, unit in (("k_cushion", "N/m"), ("k_torsion", "N.m/rad"), ("p_press", "Pa"), ("A_piston", "m2"),
                       ("rho_steel", "kg/m3"), ("V_ram", "m3")):
        sv = next(v for v in root.iter("ScalarVariable") if v.get("name") == name)
        assert sv.find("Real").get("unit") == unit
        assert declared[unit] == units.base_units(unit)
    assert declared["N.m/rad"] == {"kg": 1, "m": 2, "s": -2, "rad": -1}
    assert declared["N/m"] == {"kg": 1, "s": -2}
    status = main(["validate", "--fmu", str(fmu), "--out", str(tmp_path / "validation")])
    out = capsys.readouterr().out
    assert status == 0, out
    assert re.search(r"\d+ passed, 0 failed", out)
