"""A scenario's [[loads]] entries made into the reduced model's loads: the packaged kinds (weights,
a dead-point moment, a viscous or a slider force) and the checks a user's load must pass (affine
or polynomial in the speeds, kinks only in a machine of one turn). Scenario.build calls them."""

from __future__ import annotations

import math

import numpy as np

from .dynamics import DeadPointMoment, SliderForce, ViscousForce, Weights
from .errors import DefinitionError, ParameterError
from .expressions import evaluate
from .mechanisms import Mechanism

#: the load kinds a user writes as expressions (dynamics.user_loads)
USER_LOADS = ("force", "couple", "spring_damper")


def make_load(spec, mechanism: Mechanism, links, values, where: str, name: str, found: dict | None = None):
    """A packaged kind's load of a [[loads]] entry (``where``: the file, ``name``: the scenario, for
    the messages); ``found``: what the C model's searches found for it (CModel.found), taken
    instead of searching with the Python engine."""
    kind = spec.get("kind")
    if kind == "weights":
        return Weights({l.name: l.mass for l in links}, {l.name: l.centre for l in links}, values["g"])
    if kind == "dead_point_moment":
        amplitude = evaluate(spec["amplitude"], values, f"{name}: load amplitude")
        if found:
            return DeadPointMoment(spec["link"], amplitude, found["phi1d"], found["phi1a"])
        return DeadPointMoment.from_geometry(mechanism, spec["link"], amplitude)
    if kind in ("viscous_force", "slider_force"):
        axis = {"x": 0, "y": 1}.get(spec.get("axis"))
        if axis is None or spec.get("point") not in mechanism.definition.points:
            raise DefinitionError(f"{where}: {kind} needs point (one of the mechanism's "
                                  f"points) and axis ('x' or 'y'), got {spec!r}")
        link = spec.get("link") or next((l.name for l in links if l.centre == spec["point"]), None)
        if link not in {l.name for l in links}:
            raise DefinitionError(f"{where}: {kind} on point {spec['point']!r} needs the link it "
                                  f"acts on (link = one of {', '.join(l.name for l in links)})")
        if kind == "viscous_force":
            coefficient = load_value(spec, "coefficient", values, "N.s/m", where, name)
            return ViscousForce(spec["point"], axis, coefficient, link)
        band = spec.get("band", [0.0, 1.0])
        if (not isinstance(band, list) or len(band) != 2
                or not all(isinstance(v, (int, float)) for v in band) or not 0 <= band[0] < band[1] <= 1):
            raise DefinitionError(f"{where}: slider_force band must be [lo, hi] with "
                                  f"0 <= lo < hi <= 1 (fractions of the stroke), got {band!r}")
        forward, backward = (load_value(spec, k, values, "N", where, name) for k in ("forward", "backward"))
        band = tuple(float(v) for v in band)
        if found:
            return SliderForce(spec["point"], link, axis, forward, backward, band, found["low"], found["high"])
        return SliderForce.from_geometry(mechanism, spec["point"], link, axis, forward, backward, band)
    raise DefinitionError(f"{where}: unknown load kind {kind!r} (known: weights, dead_point_moment, "
                          f"viscous_force, slider_force, {', '.join(USER_LOADS)})")


def load_value(spec, key: str, values, unit: str, where: str, name: str) -> float:
    """A load's magnitude (an expression of parameters), which must be >= 0."""
    if key not in spec:
        raise DefinitionError(f"{where}: {spec.get('kind')} load needs {key!r}")
    value = evaluate(spec[key], values, f"{name}: load {key}")
    if not value >= 0:
        raise ParameterError(f"{name}: the load's {key} {spec[key]} = {value:g} {unit} must be >= 0",
                             str(spec[key]))
    return value


def check_kinks(loads, cycle_turns: int, where: str) -> None:
    """A load's kinks are located over one crank turn (user_loads.KinkedLoad): a machine whose
    cycle is longer (a four-stroke engine's) is refused by name."""
    from .dynamics.user_loads import KinkedLoad

    for load in loads:
        if isinstance(load, KinkedLoad) and cycle_turns != 1:
            raise DefinitionError(
                f"{where}: its kinks ({', '.join(load.calls)}) are "
                f"located over one crank turn, and this machine's cycle is {cycle_turns} turns: a kink in a load of a "
                "machine whose cycle is longer than a turn is not supported yet (write the load smooth)")


def check_affine(loads, mechanism, values, where: str) -> None:
    """A user's load of the speeds must be affine in omega1 (user_loads.SpeedLoad): checked at 48
    angles over (-w, 3 w), w the start speed (at least 10 rad/s), to 1e-9 of its size."""
    from .dynamics.speed_laws import SpeedLawLoad
    from .dynamics.speed_loads import PolynomialSpeedLoad
    from .dynamics.user_loads import SpeedLoad

    for load in loads:
        if isinstance(load, SpeedLawLoad):     # held as written: a(phi1) g(omega1), nothing fitted
            continue
        if isinstance(load, PolynomialSpeedLoad):
            kin = mechanism.kinematics((np.arange(48) + 0.5) * (2.0 * math.pi / 48))
            gap = load.polynomial_gap(kin)
            if not gap <= 1e-9:
                written = ", ".join(f"{k} = {str(e.source)!r}" for k, e in load.increasing.items())
                raise DefinitionError(
                    f"{where}: {written} is no polynomial of degree <= 2 in omega1 on each side of omega1 = 0: its "
                    f"torque departs from the quadratic through its values at 1, 2 and 3 times {load.scale:g} rad/s by "
                    f"{gap:.2g} of its size")
        elif isinstance(load, SpeedLoad):
            kin = mechanism.kinematics((np.arange(48) + 0.5) * (2.0 * math.pi / 48))
            gap = load.affine_gap(kin, max(abs(values["omega1_start"]), 10.0))
            if not gap <= 1e-9:
                written = ", ".join(f"{k} = {str(e.source)!r}" for k, e in load.increasing.items())
                raise DefinitionError(
                    f"{where}: {written} is not affine in the speeds (omega1, P_vx, P_vy, U_dot): its torque departs "
                    f"from Q0 + omega1 Q1 by {gap:.2g} of its size. The fast path, the kernel and the FMUs hold a "
                    "load of the speeds of degree 1 as Q0(phi1) + omega1 Q1(phi1) (a brake -c*omega1, a generator "
                    "a + b*omega1, a damper -c*P_vx), one of degree 2 (a fan -c*omega1*abs(omega1)) by its parts")
