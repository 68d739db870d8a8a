"""The variables every crankfmu result and FMU exposes (docs/fmu-contract.md): the one home of
each output's and input's name, SI unit, description, causality and initial dependencies.

Read by ``simulation.Result`` and timeseries.csv (the columns), the FMU's variable registration
(``fmi.python.slave``), the modelDescription writer (``fmi.python.build``: units, UnitDefinitions,
InitialUnknowns) and the harness. A scenario's own parameters and ``[[outputs]]`` carry their units
in the scenario and mechanism files.
"""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class Variable:
    """One contract variable.

    ``initial``: what the output depends on at initialisation, as parameter names and the groups
    ``*geometry`` (lengths and masses of the mechanism file), ``*loads`` (the scenario's load
    parameters) and ``*all`` (every parameter and input); () for an output fixed at the start.

    ``depends``: what the output depends on at once while the FMU runs (its ModelStructure's
    dependencies): names of continuous states and inputs, ``*inputs`` for every input and
    ``*acceleration`` for what epsilon1 depends on (direct_dependencies resolves them for an FMU); a
    name that is neither a state nor an input of that FMU drops out (a Co-Simulation FMU without
    states lists the inputs an output feeds through from)."""

    name: str
    unit: str
    description: str
    causality: str = "output"
    initial: tuple[str, ...] = ("*all",)
    depends: tuple[str, ...] = ("*inputs",)


TIME = Variable("time", "s", "simulation time", "independent", ())

OUTPUTS = (
    Variable("phi1", "rad", "crank angle, unwrapped (keeps growing past 2*pi)", initial=("phi1_start",),
             depends=("phi1",)),
    Variable("omega1", "rad/s", "crank angular speed", initial=("omega1_start",), depends=("omega1",)),
    # the movement equation: J epsilon1 = M_motor + Q + tau_ext + the ports' torques - 0.5 J' omega1^2
    Variable("epsilon1", "rad/s2", "crank angular acceleration", depends=("phi1", "omega1", "*inputs")),
    # the motor line at omega1; where the line jumps down at omega_switch the motor holds omega1 there
    # (the kernel's sliding mode) with the torque the loads and inputs leave: then phi1 and the inputs
    Variable("M_motor", "N.m", "motor torque on the crank",
             initial=("omega1_start", "A", "B", "A_low", "B_low", "omega_switch"),
             depends=("phi1", "omega1", "*inputs")),
    Variable("M_load", "N.m", "all external loads (weights, technological loads) reduced to the crank",
             initial=("phi1_start", "omega1_start", "*geometry", "*loads"), depends=("phi1", "omega1")),
    Variable("J_red", "kg.m2", "reduced moment of inertia at the crank, flywheel included",
             initial=("phi1_start", "J_flywheel", "*geometry"), depends=("phi1",)),
    Variable("E_kin", "J", "kinetic energy of the whole mechanism",
             initial=("phi1_start", "omega1_start", "J_flywheel", "*geometry"), depends=("phi1", "omega1")),
    # the work integrals ride along in the state: a host checks the energy balance
    # E_kin(t) - E_kin(0) = W_motor + W_load + W_ext without quadrature error
    Variable("W_motor", "J", "work done by the motor on the crank since the start", initial=(), depends=("W_motor",)),
    Variable("W_load", "J", "work done by the loads (weights, technological loads) since the start", initial=(),
             depends=("W_load",)),
    Variable("W_ext", "J", "work done by tau_ext and the ports since the start", initial=(), depends=("W_ext",)),
)

#: what the states' derivatives depend on at once (Model Exchange's y: phi1, omega1 and the works,
#: whose rates are M_motor omega1, Q omega1 and the external torque times omega1)
STATE_DERIVATIVE_DEPENDS = {"phi1": ("omega1",), "omega1": ("*acceleration",), "W_motor": ("phi1", "omega1", "*inputs"),
                            "W_load": ("phi1", "omega1"), "W_ext": ("phi1", "omega1", "*inputs"),
                            # (joint friction's: M_friction omega1, the frictions solved with the acceleration)
                            "W_friction": ("phi1", "omega1", "*acceleration", "*inputs")}

#: an [[outputs]] quantity or a port's s, v, a by its order (position, velocity, acceleration), and a
#: joint reaction (Newton-Euler with the acceleration and the ports' forces)
QUANTITY_DEPENDS = (("phi1",), ("phi1", "omega1"), ("phi1", "omega1", "*acceleration"))
REACTION_DEPENDS = ("phi1", "omega1", "*acceleration", "*inputs")


def direct_dependencies(depends, outputs, inputs, states=()) -> list[str]:
    """The names among ``inputs`` and ``states`` (an FMU's) that ``depends`` (Variable.depends) names,
    in the order of states then inputs; ``outputs``: the FMU's Variables (epsilon1's depends is
    what *acceleration stands for)."""
    acceleration = next((v.depends for v in outputs if v.name == "epsilon1"), ())
    named = set()

    def add(names):
        for name in names:
            if name == "*inputs":
                named.update(inputs)
            elif name == "*acceleration":
                add(acceleration)
            else:
                named.add(name)

    add(depends)
    return [n for n in (*states, *inputs) if n in named]


INPUTS = (
    Variable("tau_ext", "N.m", "extra torque on the crank from outside (the coupling port)", "input", ()),
)

#: a mechanism FMU in speed causality (``[crank] causality = "speed"``): the drive imposes omega1
#: and the FMU answers with the torque that takes (inverse dynamics)
SPEED_INPUTS = (
    Variable("omega1", "rad/s", "crank speed imposed by the drive (the coupling input)", "input", ()),
)
_TORQUE_CAUSAL = {v.name: v for v in OUTPUTS}


def _speed_causal(name: str) -> Variable:
    """A torque-causal output as the speed-causal FMU has it: omega1 (an input there) in place of
    omega1_start among what it depends on at the start."""
    v = _TORQUE_CAUSAL[name]
    return replace(v, initial=tuple("omega1" if d == "omega1_start" else d for d in v.initial))


SPEED_OUTPUTS = (
    replace(_TORQUE_CAUSAL["phi1"], description="crank angle, unwrapped: the integral of omega1"),
    # the next step's slope: omega1's derivative where given, else (omega1 - its last value) / step
    replace(_TORQUE_CAUSAL["epsilon1"], description="crank angular acceleration: omega1's derivative (the host's "
            "input derivative, else omega1's change over the last communication step)", depends=("omega1",)),
    Variable("tau_drive", "N.m", "torque the drive must apply to the crank: J epsilon1 + 0.5 J' omega1^2 - Q - "
             "the ports' torque", initial=("phi1_start", "omega1", "J_flywheel", "*geometry", "*loads"),
             depends=("phi1", "omega1", "*inputs")),
    *(_speed_causal(n) for n in ("M_load", "J_red", "E_kin")),
    Variable("W_drive", "J", "work done by the drive on the crank since the start", initial=(), depends=("W_drive",)),
    *(_TORQUE_CAUSAL[n] for n in ("W_load", "W_ext")),
)

#: Drive.fmu's outputs (its inputs and parameters are the drive file's)
DRIVE_OUTPUTS = (
    Variable("tau", "N.m", "torque of the drive on the crank (n_gear k_t i)", depends=("i",)),
    Variable("i", "A", "armature current", depends=("i",)),
    # u = Kp (omega_set - omega) + Ki x: omega is the drive's input, or in speed causality its state
    Variable("u", "V", "armature voltage from the PI controller", depends=("omega", "omega_set")),
    Variable("P_el", "W", "electrical power into the armature (u i)", depends=("i", "omega", "omega_set")),
    # a state beside i (and omega in speed causality): a master that builds the drive's linear system
    # from directional derivatives names it as a known
    Variable("x", "rad", "integral of the speed error, omega_set - omega (the PI controller's state)",
             depends=("x",)),
)
#: DieCushion.fmu's output (its inputs and parameters are its file's): a law of the ram's motion
CUSHION_OUTPUTS = (
    Variable("F", "N", "force of the cushion on the ram along the ram's axis (to the press's ram_F)",
             depends=("s", "v")),
)

#: ElasticShaft.fmu's outputs (its inputs and parameters are its file's): the torque it passes from
#: side a (a drive) to side b (a machine's crank), its state the twist phi_a - phi_b
SHAFT_OUTPUTS = (
    Variable("tau", "N.m", "torque the shaft passes from side a to side b, k twist + c (omega_a - omega_b): it "
             "drives b (to a mechanism's tau_ext) and loads a (to DriveSpeed's tau_load)",
             depends=("twist", "omega_a", "omega_b")),
    Variable("twist", "rad", "twist of the shaft, phi_a - phi_b (its state)", depends=("twist",)),
    Variable("E_spring", "J", "elastic energy stored in the shaft, k twist^2 / 2", depends=("twist",)),
)
#: the shaft's state and what its rate, omega_a - omega_b, depends on at once
SHAFT_STATE_DEPENDS = {"twist": ("omega_a", "omega_b")}

#: RodString.fmu's outputs (its inputs s, v and its parameters are its well file's)
#: (the string's grid is its state: the polished rod's motion enters at the next step)
ROD_STRING_OUTPUTS = (
    Variable("F", "N", "polished rod load: the rods' pull down on the unit's rope port (to the unit's rod_F)",
             depends=()),
    Variable("u_pump", "m", "plunger position, downward, on the polished rod's scale (s)", depends=()),
    Variable("F_pump", "N", "rod tension at the pump (the pump card's load)", depends=()),
    Variable("W_polished", "J", "work done by the polished rod on the string since the start", depends=()),
    Variable("W_hydraulic", "J", "work done by the plunger on the fluid since the start", depends=()),
)

#: the drives' continuous states (outputs all), in the native runtime's order, and what each one's
#: rate depends on at once: L di/dt = u - R i - n_gear k_t omega with u = Kp (omega_set - omega) + Ki x;
#: dx/dt = omega_set - omega; J_drive domega/dt = n_gear k_t i - tau_load (speed causality). The native
#: FMUs declare them with their derivatives, so a master reads the drive's linear system from
#: directional derivatives (docs/coupling.md)
DRIVE_STATE_DEPENDS = {"i": ("i", "x", "omega", "omega_set"), "x": ("omega", "omega_set")}
DRIVE_SPEED_STATE_DEPENDS = {**DRIVE_STATE_DEPENDS, "omega": ("i", "tau_load")}

#: DriveSpeed.fmu's outputs: the crank speed it imposes, then Drive.fmu's
DRIVE_SPEED_OUTPUTS = (
    Variable("omega", "rad/s", "crank speed the drive imposes (its rotor and flywheel, at the crank)",
             depends=("omega",)),
    *DRIVE_OUTPUTS,
)

#: columns of timeseries.csv and fields of Result, in order, with their units
COLUMNS = {v.name: v.unit for v in (TIME, *OUTPUTS)}

#: the motor line's parameters (tunable in the FMU)
MOTOR_PARAMETERS = ("A", "B", "A_low", "B_low", "omega_switch")

#: parameters every scenario must declare, each with its value, unit and range in the scenario file
CONTRACT_PARAMETERS = (*MOTOR_PARAMETERS, "J_flywheel", "phi1_start", "omega1_start", "g")
