"""Bad input: each gives a clear error naming the parameter and the valid range."""

import math

import pytest

import crankfmu
from crankfmu.errors import AssemblyError, DefinitionError, ParameterError, ScenarioNotFound
from crankfmu.mechanisms import MechanismDefinition


def test_unknown_scenario():
    with pytest.raises(ScenarioNotFound, match=r"unknown scenario 'seed999'.*seed000"):
        crankfmu.load_scenario("seed999")


def test_unknown_parameter_lists_the_valid_names(scenario):
    with pytest.raises(ParameterError, match=r"unknown parameter 'l9'.*valid names: l0, l1") as info:
        scenario.with_params(l9=0.3)
    assert info.value.parameter == "l9"


def test_copies_with_other_values_are_independent_and_checked_on_each_copy(scenario):
    """with_params shares the file's parsed parameters (a sweep makes a copy per design), not the
    overrides: each copy keeps its own values, and a refused value leaves the copy it came from as
    it was."""
    a = scenario.with_params(l1=0.21)
    b = a.with_params(l2=0.51)
    with pytest.raises(ParameterError, match="l3 = -1.0 is out of range"):
        b.with_params(l3=-1.0)
    assert scenario.values["l1"] == 0.2 and "l1" not in scenario.overrides
    assert (a.values["l1"], a.values["l2"]) == (0.21, 0.5)
    assert (b.values["l1"], b.values["l2"], b.values["l3"]) == (0.21, 0.51, 0.55)
    assert b.parameters is scenario.parameters and b.overrides is not a.overrides


@pytest.mark.parametrize("name, value, expected", [
    ("l1", 0.0, r"l1 = 0.0 is out of range: valid range \(0, inf\) m"),
    ("l2", -0.5, r"l2 = -0.5 is out of range: valid range \(0, inf\) m"),
    ("q1", 0.0, r"q1 = 0.0 is out of range: valid range \(0, inf\) kg/m"),
    ("q3", -1.0, r"q3 = -1.0 is out of range"),
    ("J_flywheel", -0.1, r"J_flywheel = -0.1 is out of range: valid range \[0, inf\) kg.m2"),
    ("B", -1.0, r"B = -1.0 is out of range: valid range \[0, inf\) N.m.s/rad"),
    ("l0", float("nan"), r"l0 = nan is out of range"),
])
def test_out_of_range_parameters(scenario, name, value, expected):
    with pytest.raises(ParameterError, match=expected) as info:
        scenario.with_params(**{name: value})
    assert info.value.parameter == name


def test_geometry_that_cannot_be_assembled_names_the_parameter_and_its_bound(scenario):
    """A crank of 0.5 m cannot turn fully: the loop needs l0 + l1 <= l2 + l3 (l1 <= 0.3 m) and
    |l2 - l3| <= l0 - l1 (l1 <= 0.7 m); the message gives the binding bound, 0.3 m."""
    with pytest.raises(AssemblyError) as info:
        scenario.with_params(l1=0.5).build()
    msg = str(info.value)
    assert "cannot be assembled over the whole crank turn" in msg
    assert "the crank turns fully only for l1 < 0.3 m (asked 0.5)" in msg
    assert info.value.parameter == "l1"


def test_geometry_with_a_lock_inside_the_turn(scenario):
    """A short rocker: l0 + l1 <= l2 + l3 needs l3 >= 0.45 m."""
    with pytest.raises(AssemblyError, match=r"turns fully only for l3 > 0.45 m \(asked 0.4\)"):
        scenario.with_params(l3=0.40).build()


def test_change_point_geometry_is_refused_as_a_dead_point(scenario):
    """l1 + l0 = l2 + l3 exactly: the four-bar folds flat at phi1 = 180 deg (transmission angle 0)."""
    with pytest.raises(AssemblyError, match="dead point|no real solution"):
        scenario.with_params(l1=0.3).build()


@pytest.mark.parametrize("t_end", [0.0, -1.0, float("nan")])
def test_non_positive_duration(scenario, t_end):
    with pytest.raises(ParameterError, match="t_end .* duration must be > 0") as info:
        crankfmu.simulate(scenario, t_end=t_end)
    assert info.value.parameter == "t_end"


def test_bad_tolerance_and_method(scenario):
    with pytest.raises(ParameterError, match="rtol must be > 0"):
        crankfmu.simulate(scenario, rtol=0.0)
    with pytest.raises(ParameterError, match="unknown method 'euler'; valid methods: fast, reference"):
        crankfmu.simulate(scenario, method="euler")
    with pytest.raises(ParameterError, match="angle_step must be a positive angle"):
        crankfmu.simulate(scenario, method="badoiu-eq17", angle_step=-math.radians(1))


def test_mechanism_file_errors():
    base = {"name": "x", "unknowns": {"phi2": "angle", "phi3": "angle"},
            "contours": [{"equation": "l1*u(phi1) + l2*u(phi2) + l3*u(phi3) - l0*u(0)"}],
            "assembly": {"branch": "up", "guess": {"phi2": 1, "phi3": -1}}}
    MechanismDefinition.from_dict(base)
    with pytest.raises(DefinitionError, match="give 2 equations for 3 unknowns"):
        MechanismDefinition.from_dict({**base, "unknowns": {"phi2": "angle", "phi3": "angle", "s": "length"}})
    with pytest.raises(DefinitionError, match="allowed in"):
        MechanismDefinition.from_dict({**base, "contours": [{"equation": "__import__('os')"}]})
    with pytest.raises(DefinitionError, match="must state the branch"):
        MechanismDefinition.from_dict({**base, "assembly": {"guess": {"phi2": 1, "phi3": -1}}})
    with pytest.raises(DefinitionError, match="only one slider displacement"):
        MechanismDefinition.from_dict({**base, "contours": [{"equation": "phi2*u(phi1) + l2*u(phi3)"}]})
