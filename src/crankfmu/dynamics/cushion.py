"""A die cushion as its own model (DieCushion.fmu, elements/*.toml): the small second FMU a press's
ram port is coupled to in PressCushion.ssp.

Inputs: the ram's coordinate s and velocity v along the port's axis; output: the force on the
ram along that axis,

    F = -(k (d - L_free) + c dd/dt),   d = s - s_seat

the tension law of the data files' ``spring_damper`` (user_loads.spring_damper_tension) with the
line of action along the axis. No state: the FMU is an algebraic map of its inputs.
"""

from __future__ import annotations

from importlib import resources

from ..datafiles import packaged
from ..parameters import ComponentFile, load_component
from .user_loads import spring_damper_tension

_FILES = resources.files(__package__.rsplit(".", 1)[0]) / "elements"


def available_cushions() -> list[str]:
    return packaged(_FILES)


def cushion_force(values: dict, s, v):
    """F (N) on the ram along its axis, from the parameters ``values`` (k, c, L_free, s_seat)."""
    return -spring_damper_tension(values["k"], values["c"], s - values["s_seat"], values["L_free"], v)


def load_cushion(name_or_path) -> ComponentFile:
    """A cushion file: a packaged name (``"die_cushion"``) or a path to a .toml file."""
    return load_component(name_or_path, _FILES, "cushion", ("k", "c", "L_free", "s_seat"), ("s", "v"))
