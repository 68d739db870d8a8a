"""An elastic shaft as its own model (ElasticShaft.fmu, shafts/*.toml): a torsion spring with
viscous damping between side a (a drive) and side b (a machine's crank), the part users put between
DriveSpeed.fmu and a mechanism FMU in torque causality (DriveShaftFourBar.ssp).

Inputs: the two sides' speeds omega_a, omega_b; state: the twist phi_a - phi_b; output: the torque
the shaft passes from a to b,

    d twist / dt = omega_a - omega_b
    tau = k twist + c (omega_a - omega_b)

which drives side b (its tau_ext) and loads side a (its tau_load). With the speeds held, or lines
in time, over a step the twist is their integral, exactly. This module states the law in Python,
the reference the tests compare the components' C (crank_components.c, cc_shaft_*) with.
"""

from __future__ import annotations

from importlib import resources

from ..datafiles import packaged
from ..parameters import ComponentFile, load_component

_FILES = resources.files(__package__.rsplit(".", 1)[0]) / "shafts"

#: what a shaft file must declare, read by name by the FMUs' models
PARAMETERS = ("k", "c", "twist_start")
INPUTS = ("omega_a", "omega_b")


def available_shafts() -> list[str]:
    return packaged(_FILES)


def shaft_torque(values: dict, twist, omega_a, omega_b):
    """tau (N.m) from side a to side b, from the parameters ``values`` (k, c)."""
    return values["k"] * twist + values["c"] * (omega_a - omega_b)


def shaft_twist(twist, omega_a, omega_b, h, rate_a=0.0, rate_b=0.0):
    """The twist (rad) after ``h`` s, each side's speed a line from the step's start (rates rad/s2)."""
    return twist + (omega_a - omega_b) * h + 0.5 * (rate_a - rate_b) * h * h


def shaft_energy(values: dict, twist):
    """The spring's elastic energy (J), k twist^2 / 2."""
    return 0.5 * values["k"] * twist * twist


def load_shaft(name_or_path) -> ComponentFile:
    """A shaft file: a packaged name (``"elastic_shaft"``) or a path to a .toml file."""
    return load_component(name_or_path, _FILES, "shaft", PARAMETERS, INPUTS)
