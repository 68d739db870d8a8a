"""What the commands share in reading their arguments: ``--set NAME=VALUE`` and a list of points."""

from __future__ import annotations

from ..errors import CrankfmuError


def parse_sets(items: list[str]) -> dict[str, float]:
    values = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise CrankfmuError(f"--set expects NAME=VALUE, got {item!r}")
        try:
            values[name.strip()] = float(value)
        except ValueError:
            raise CrankfmuError(f"--set {name.strip()}: {value!r} is not a number") from None
    return values


def with_friction(scenario, text: str | None):
    """``--friction MU,RADIUS``: the scenario with Coulomb friction in every joint (MU in each pin
    and slide, pins of RADIUS m; Scenario.with_joint_friction); the scenario itself without it."""
    if text is None:
        return scenario
    parts = text.split(",")
    try:
        mu, radius = (float(p) for p in parts)
    except ValueError:
        raise CrankfmuError(f"--friction expects MU,RADIUS (a coefficient in [0, 1] and a pin radius in m, "
                            f"e.g. 0.1,0.01), got {text!r}") from None
    return scenario.with_joint_friction(mu, radius)


def parse_points(text: str | None):
    return None if text is None else [p.strip() for p in text.split(",") if p.strip()]


def described(docstring: str) -> str:
    """A command's description from its module's docstring: the first paragraph, without the
    usage line it may open with (``crankfmu validate [--fmu PATH ...]``: ...), which argparse
    prints above it already."""
    import re

    first = " ".join(docstring.strip().split("\n\n")[0].split())
    first = re.sub(r"^``[^`]+``:\s*", "", first)
    return first[:1].upper() + first[1:]
