"""What a mechanism FMU of a scenario declares besides the contract's variables, shared by the
Python FMU (fmi/python), the native FMU (fmi/native) and the harness (validation): its [[outputs]]
and ports' quantities, its joint reactions, its joints' friction and the integrator's rtol."""

from __future__ import annotations

from ..contract import QUANTITY_DEPENDS, REACTION_DEPENDS, Variable
from ..parameters import Parameter


def output_quantities(scenario, ports=None) -> list:
    """The mechanism quantities an FMU of ``scenario`` outputs: its [[outputs]], then each port's
    position, velocity and acceleration (dynamics.ports). ``ports``: those of a model as built,
    whose parameters may differ from the file's (a rope's lever is a length of the design)."""
    return [*scenario.quantities, *(q for port in (scenario.ports if ports is None else ports)
                                    for q in port.quantities)]


def quantity_variables(scenario) -> list:
    """The outputs of output_quantities, each depending at once on what its order needs."""
    definition = scenario.mechanism_definition()
    return [Variable(q.name, q.unit(definition), q.description, depends=QUANTITY_DEPENDS[q.order])
            for q in output_quantities(scenario)]


def friction_variables(scenario) -> list:
    """The joints' friction's outputs (dynamics.friction.friction_outputs) of a scenario whose
    joints have friction (0 where a design's mu is 0); none otherwise."""
    from ..dynamics.friction import JointFriction, friction_outputs

    entries = scenario.friction_entries()
    if not entries:
        return []
    joints = [JointFriction(joint, k, 0.0, None) for k, joint in enumerate(scenario.mechanism_definition().joints)
              if joint.name in entries]
    # W_friction rides along in the state, as the other works; the rest are solved with the
    # acceleration, as the reactions
    return [Variable(*v, depends=("W_friction",) if v[0] == "W_friction" else REACTION_DEPENDS)
            for v in friction_outputs(joints)]


def reaction_variables(scenario) -> list:
    """The joint reactions' outputs (dynamics.reactions.reaction_outputs) of a mechanism file that
    declares its [[joints]]; none otherwise."""
    from ..dynamics.reactions import reaction_outputs

    definition = scenario.mechanism_definition()
    return ([Variable(*v, depends=REACTION_DEPENDS) for v in reaction_outputs(definition)]
            if definition.joints else [])


#: the FMU's integrator tolerance: below 1e-14 the error control asks for steps near the kernel's
#: underflow guard, so a step of the host would take unbounded time (rtol = 4e-213 made one
#: fmi2DoStep of 0.1 s run for hours: found by the FMI fuzzer, tests/fuzz/fmi2_fuzzer.c)
RTOL_MIN, RTOL_MAX = 1e-14, 0.1


def rtol_parameter(tolerance: float, tunable: bool = False) -> Parameter:
    """The FMUs' parameter rtol, starting at ``tolerance``: fixed in the Python FMU, tunable in the
    native one (its shell loads it into the kernel at each restart)."""
    return Parameter("rtol", tolerance, "1", "relative tolerance of the FMU's internal integrator "
                     "(Dormand-Prince 5(4), the C kernel)", min=RTOL_MIN, max=RTOL_MAX, tunable=tunable)
