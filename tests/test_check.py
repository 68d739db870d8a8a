"""``crankfmu check``: a user's files checked before anything is built. Every packaged scenario and
the user's six-bar pass; each kind of bad file gets its message, the file and line where one
applies, and exit status 1 (a check fails) or 2 (the files cannot be read), never a traceback."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from crankfmu.check import check_scenario, grashof
from crankfmu.cli import main
from crankfmu.scenario import available_scenarios, load_scenario

ROOT = Path(__file__).resolve().parents[1]
USER = ROOT / "tests" / "data" / "user"


@pytest.mark.parametrize("name", [*available_scenarios(), str(USER / "sixbar_scenario.toml")])
def test_packaged_and_user_scenarios_pass_the_check(name):
    report = check_scenario(name)
    assert report.status == 0, report.text()
    assert "assembles over the whole turn" in report.text()
    assert "J_red from" in report.text()


def test_grashof_class_follows_the_link_lengths():
    """s + l against p + q on seed 000's loop: 0.2 + 0.75 < 0.5 + 0.55 with the crank shortest; a
    longer crank (0.35: 0.35 + 0.75 > 0.5 + 0.55) makes it a non-Grashof triple rocker."""
    fourbar = load_scenario("seed000")
    definition = fourbar.mechanism_definition()
    assert "Grashof crank-rocker" in grashof(definition, fourbar.values)[0]
    assert "non-Grashof triple rocker" in grashof(definition, {**fourbar.values, "l1": 0.35})[0]
    assert "double crank" in grashof(definition, {**fourbar.values, "l0": 0.15, "l1": 0.3})[0]


def user_copy(tmp_path, mechanism_edit=None, scenario_edit=None) -> Path:
    """The user's six-bar in tmp_path, with one edit (old, new) applied to a file's text."""
    for name in ("sixbar.toml", "sixbar_scenario.toml"):
        shutil.copy(USER / name, tmp_path / name)
    for name, edit in (("sixbar.toml", mechanism_edit), ("sixbar_scenario.toml", scenario_edit)):
        if edit:
            text = (tmp_path / name).read_text()
            assert edit[0] in text, edit[0]
            (tmp_path / name).write_text(text.replace(edit[0], edit[1], 1))
    return tmp_path / "sixbar_scenario.toml"


BAD_FILES = {
    # name: (mechanism edit, scenario edit, exit status, message pattern, line named)
    "misspelt section": (("[unknowns]\n", "[unknown]\n"), None, 2,
                         "unknown key 'unknown' in the top level \\(did you mean unknowns\\?\\)", "sixbar.toml, line 9"),
    "unknown unknown": (("lAP*u(phi2 + beta) + l4*u(phi4)", "lAP*u(phi2 + beta) + l4*u(phi9)"), None, 1,
                        "contour O-A-P-D-O: unknown name\\(s\\) phi9", "sixbar.toml, line 24"),
    "syntax error": (('B = "A + l2*u(phi2)"', 'B = "A + l2*u(phi2"'), None, 2,
                     "point B: cannot parse 'A \\+ l2\\*u\\(phi2'", "sixbar.toml, line 29"),
    "forbidden name": (('mass = "m2"', 'mass = "m2.__class__"'), None, 2,
                       "Attribute is not allowed in 'm2.__class__'", None),
    "chain does not close": (("- xD*u(0) - yD*u(pi/2)", "- xD*u(0) - 3*yD*u(pi/2)"), None, 1,
                             "cannot be assembled over the whole crank turn.*Newton's method did not converge", None),
    "misspelt array of tables": (("[[contours]]\nname = \"O-A-P-D-O\"", "[[nocontours]]\nname = \"O-A-P-D-O\""), None,
                                 2, "unknown key 'nocontours' in the top level \\(did you mean contours\\?\\)", None),
    "too many contours": (("[points]\n", "[[contours]]\nname = \"again\"\nequation = \"l1*u(phi1) + l2*u(phi2) + l3*u(phi3) - l0*u(0)\"\n\n[points]\n"),
                          None, 2, "3 contour\\(s\\) give 6 equations for 4 unknowns", None),
    "branch never assembles": (None, ('l3 = { value = 0.4,', 'l3 = { value = 0.1,'), 1,
                               "cannot be assembled over the whole crank turn.*l3 = 0.1", None),
    "TOML syntax": (None, ('[parameters]', '[parameters'), 2, "cannot be read.*line", "sixbar_scenario.toml, line"),
    "unknown parameter name in a mass": (('mass = "m4"', 'mass = "m44"'), None, 1,
                                         "link rod: unknown name\\(s\\) m44", "sixbar.toml, line"),
    # the load's own line, not the [parameters] header its message's list of known names mentions
    "unknown name in a load": (None, ('coefficient = "c_slider"\n', 'coefficient = "c_slider"\n[[loads]]\nkind = "force"\n'
                                      'link = "rod"\npoint = "D"\nfx = "0"\nfy = "-kk*D_y"\n'), 1,
                               "load 3: force fy = '-kk\\*D_y' uses unknown name\\(s\\) kk", "sixbar_scenario.toml, line 47"),
}


@pytest.mark.parametrize("case", BAD_FILES)
def test_bad_files_get_a_message_a_place_and_an_exit_status(case, tmp_path, capsys):
    mech_edit, scen_edit, status, pattern, place = BAD_FILES[case]
    path = user_copy(tmp_path, mech_edit, scen_edit)
    report = check_scenario(str(path))
    assert report.status == status, report.text()
    failing = [f for f in report.findings if f.level == "FAIL"]
    import re

    assert any(re.search(pattern, f.what) for f in failing), report.text()
    if place:
        assert any(place in f.where for f in failing), report.text()
    assert main(["check", str(path)]) == status
    out = capsys.readouterr()
    assert "Traceback" not in out.out + out.err


def test_a_missing_scenario_file_is_refused_by_name():
    report = check_scenario("no_such_scenario")
    assert report.status == 2 and "unknown scenario 'no_such_scenario'" in report.text()
