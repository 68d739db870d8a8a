"""The compiled program's optimisation (dynamics.program.optimise): what varies with the crank
angle stays in the per-angle sections, what does not moves to SETUP, and a repeated computation
reads its first result. Every value is the same operation on the same operands as in the program
the files' expressions state, so the C model's results must be equal bit for bit, not merely
close: the tables, the switch schedule with its forces, what the searches find, the worst
conditioning, and every refusal. A register the C model writes itself that the pass took for a
constant (a search's finding, the crank's direction) shows here as a different force or table.
"""

import numpy as np
import pytest

from crankfmu.dynamics.program import CLOSED, FIRST_SEARCH, OP, ROWS, SETUP, optimise, parameter_values
from crankfmu.dynamics.program_scenario import compile_scenario
from crankfmu.native.mechanism import QUANTITIES, REACTIONS, REDUCED, CModel, MechanismError
from crankfmu.scenario import load_scenario

from test_c_model import SCENARIOS, _guide_scenario, _perturbed, _scenario

TRANSCENDENTAL = {OP[name] for name in ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "hypot", "exp",
                                        "log", "sqrt", "pow")}


@pytest.fixture(scope="module")
def guide(tmp_path_factory):
    return _guide_scenario(tmp_path_factory)


def _everything(program, values) -> list:
    """What the C model gives at these values, as exact bytes or the refusal."""
    try:
        model = CModel(program, parameter_values(program, values))
    except MechanismError as exc:
        return [("refused", exc.code, exc.index, exc.value, exc.angle)]
    switches, forces = model.schedule()
    out = [switches.tobytes(), forces.tobytes(), repr(model.found()), repr(model.worst_conditioning)]
    for table in (REDUCED, QUANTITIES, REACTIONS):
        try:
            coefficients, error, construction = model.cubics(table, 1e-11)
            out += [coefficients.tobytes(), repr(error), construction]
        except MechanismError as exc:
            out.append(("not tabulated", exc.code, exc.index, exc.value))
    return out


@pytest.mark.parametrize("name", SCENARIOS)
def test_optimised_program_gives_the_same_bits(name, guide):
    scenario = _scenario(name, guide)
    optimised, as_written = compile_scenario(scenario), compile_scenario(scenario, optimised=False)
    if optimised is None:
        pytest.skip("the C model does not take this scenario")
    for values in (scenario.values, _perturbed(scenario).values):
        assert _everything(optimised, values) == _everything(as_written, values)


def _per_angle(program, section):
    start, end = program.sections[section]
    return program.code[start:end]


def test_per_angle_work_shrinks():
    """The four-bar's closed form states sin(phi1) and cos(phi1) twice and squares link lengths at
    every angle; its rows multiply masses by constants: after the pass the closed form takes two
    transcendental calls fewer, and neither section computes a constant."""
    scenario = load_scenario("seed000")
    optimised, as_written = compile_scenario(scenario), compile_scenario(scenario, optimised=False)
    for section in (CLOSED, ROWS):
        assert len(_per_angle(optimised, section)) < len(_per_angle(as_written, section))
        assert OP["literal"] not in _per_angle(optimised, section)[:, 0]
    calls = [int(np.isin(_per_angle(p, CLOSED)[:, 0], list(TRANSCENDENTAL)).sum()) for p in (optimised, as_written)]
    assert calls[0] <= calls[1] - 2


# ---------------------------------------------------------------- the pass's rules on small programs
OP_NAMES = {number: name for name, number in OP.items()}


def _program(*sections, numbers=None):
    """(code, sections) of instruction lists given per section, SETUP first (or numbered ``numbers``)."""
    code, placed = [], {}
    for number, instructions in zip(numbers or range(len(sections)), sections):
        placed[number] = (len(code), len(code) + len(instructions))
        code += [(OP[op], dst, *operands, *(0,) * (3 - len(operands))) for op, dst, *operands in instructions]
    return code, placed


def _section(code, placed, number):
    start, end = placed[number]
    return [(OP_NAMES[op], dst, *operands) for op, dst, *operands in code[start:end]]


def test_a_value_that_changes_with_the_angle_stays_in_its_section():
    """r1 is a parameter, r5 the crank angle (the C model writes it): l1^2 moves to SETUP, sin(phi1)
    stays; a search section's last instruction, the one the search reads, stays too, though it
    does not change with the angle; another section's moves."""
    body = [("mul", 10, 1, 1), ("sin", 11, 5), ("mul", 12, 10, 11), ("mul", 13, 1, 2)]
    code, placed = _program([("literal", 2, 0)], body, numbers=(SETUP, FIRST_SEARCH))
    out, where = optimise(code, placed, runtime={5}, literals=[2.0])
    assert ("mul", 10, 1, 1, 0) in _section(out, where, SETUP)
    assert [ins[0] for ins in _section(out, where, FIRST_SEARCH)] == ["sin", "mul", "mul"]
    assert _section(out, where, FIRST_SEARCH)[-1][1] == 13
    code, placed = _program([("literal", 2, 0)], body, numbers=(SETUP, ROWS))
    out, where = optimise(code, placed, runtime={5}, literals=[2.0])
    assert [ins[0] for ins in _section(out, where, ROWS)] == ["sin", "mul"]


def test_a_repeat_after_its_operand_changed_is_computed_again():
    """sin(r5) twice with r5 overwritten between them: the second is not the first's copy; without the
    overwrite it is."""
    for overwrite in (("copy", 5, 6), ("add", 5, 6, 7)):
        code, placed = _program([], [("sin", 10, 5), overwrite, ("sin", 11, 5), ("add", 12, 10, 11)])
        out, where = optimise(code, placed, runtime={5, 6, 7}, literals=[])
        assert [ins[0] for ins in _section(out, where, 1)] == ["sin", overwrite[0], "sin", "add"]
    repeated = [("sin", 10, 5), ("sin", 11, 5), ("add", 12, 10, 11)]
    code, placed = _program([], repeated)
    out, where = optimise(code, placed, runtime={5}, literals=[])
    assert _section(out, where, 1)[1][:3] == ("copy", 11, 10)


def test_a_copy_is_not_read_through_once_its_source_changed():
    """r11 copies r10, then r10 is computed anew: a later read of r11 keeps reading r11."""
    code, placed = _program([], [("sin", 10, 5), ("copy", 11, 10), ("add", 10, 6, 7), ("cos", 12, 11)])
    out, where = optimise(code, placed, runtime={5, 6, 7}, literals=[])
    assert _section(out, where, 1)[-1][:3] == ("cos", 12, 11)


def test_signed_zeros_are_different_literals():
    """0.0 and -0.0 compare equal but divide differently: the pass keeps both."""
    code, placed = _program([("literal", 10, 0), ("literal", 11, 1)])
    out, where = optimise(code, placed, runtime=set(), literals=[0.0, -0.0])
    assert [ins[0] for ins in _section(out, where, 0)] == ["literal", "literal"]
