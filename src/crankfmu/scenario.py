"""Scenarios: a paper's example as a data file (geometry, masses, loads, motor, flywheel, start,
duration), read by the CLI, the tests and the FMU alike.

``load_scenario("seed000")`` (a packaged name or a path to a .toml file) returns a
:class:`Scenario`; ``scenario.with_params(A=380, J_flywheel=0.5)`` returns a copy with parameters
overridden by name (each checked against its declared range at once); ``scenario.build()``
returns the :class:`Model` (mechanism, reduced model, motor, movement equation, initial state)
after checking that the geometry assembles over the whole crank turn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Mapping

import numpy as np

from .contract import CONTRACT_PARAMETERS
from .dynamics import LinkInertia, MotorLine, MovementEquation, ReducedModel
from .dynamics.friction import JointFrictions, joint_frictions
from .dynamics.user_entries import parse_user_load
from .datafiles import packaged, read_toml
from .errors import AssemblyError, CrankfmuError, DefinitionError, ParameterError, ScenarioNotFound, did_you_mean
from .expressions import Expression, evaluate
from .mechanisms import Mechanism, MechanismDefinition, load_mechanism
from .mechanisms.definition import parse_friction_entry
from .parameters import Experiment, Parameter, parse_parameters  # noqa: F401 (Parameter: the scenario's API)
from .scenario_loads import USER_LOADS, check_affine, check_kinks, make_load

_SCENARIOS = resources.files(__package__) / "scenarios"

#: what a mechanism FMU takes at its crank: a torque (it integrates the movement equation) or the
#: speed (it answers with the drive torque, fmi.python.speed)
CAUSALITIES = ("torque", "speed")

#: the longest machine cycle a scenario may declare, in crank turns (cycle_turns)
MAX_CYCLE_TURNS = 8



def in_words(named: list[str], empty: str = "none") -> str:
    """A list as a sentence says it: "a", "a and b", "a, b and c"; ``empty`` where it is empty."""
    if not named:
        return empty
    return named[0] if len(named) == 1 else ", ".join(named[:-1]) + " and " + named[-1]

class Scenario:
    """A scenario file, with parameter overrides."""

    def __init__(self, data: Mapping, where: str, path: str | None = None,
                 overrides: Mapping[str, float] | None = None):
        self.data = data
        self.where = where
        self.path = path
        try:
            self.name = data["name"]
            self.mechanism_name = data["mechanism"]
            raw = data["parameters"]
        except KeyError as exc:
            raise DefinitionError(f"{where}: missing {exc.args[0]!r}") from None
        self.title = data.get("title", self.name)
        params = parse_parameters(raw, where)
        missing = [n for n in CONTRACT_PARAMETERS if n not in params]
        if missing:
            raise DefinitionError(f"{where}: missing contract parameter(s) {', '.join(missing)}")
        self.parameters: dict[str, Parameter] = params
        #: what the scenario and its with_params copies share, read once (the mechanism's definition)
        self._kept: dict = {}
        self.overrides: dict[str, float] = {}
        for k, v in (overrides or {}).items():
            self.overrides[k] = self._param(k).check(v)
        self.experiment = Experiment.from_dict(data.get("experiment", {}))
        if not self.experiment.stop_time > self.experiment.start_time:
            raise DefinitionError(f"{where}: experiment stop_time must exceed start_time")
        turns = data.get("cycle_turns", 1)
        if isinstance(turns, bool) or not isinstance(turns, int) or not 1 <= turns <= MAX_CYCLE_TURNS:
            raise DefinitionError(f"{where}: cycle_turns must be a whole number of crank turns from 1 to "
                                  f"{MAX_CYCLE_TURNS} (a four-stroke engine's cycle is 2), got {turns!r}")
        #: crank turns of the machine's cycle (a four-stroke engine's 2): the loads repeat over it,
        #: and delta, the flywheel, the steady cycle and the summaries' cycles are taken over it
        self.cycle_turns: int = turns

    def load_words(self) -> list[str]:
        """What each [[loads]] entry is, for a figure's words: its ``description``, else its kind and
        where it acts ("the weights", "a force at B", "a couple on crank")."""
        words = []
        for spec in self.data.get("loads", []):
            kind, at = spec.get("kind", "load"), spec.get("point") or spec.get("link")
            words.append(str(spec.get("description") or {
                "weights": "the weights", "slider_force": f"the slider force at {at}",
                "viscous_force": f"the viscous force at {at}", "dead_point_moment": "the dead-point moment",
                "spring_damper": f"the spring-damper {spec.get('a')}-{spec.get('b')}",
            }.get(kind, f"a {kind.replace('_', ' ')} {'at' if spec.get('point') else 'on'} {at}")))
        return words

    def describe_loads(self, reduced, which=None) -> str:
        """The loads ``which`` (indices into reduced.loads, all by default) in words, each entry
        once, in the file's order: "the gas force on the piston and the generator"; "none"."""
        words = self.load_words()
        chosen = range(len(reduced.load_entries)) if which is None else which
        return in_words(list(dict.fromkeys(words[reduced.load_entries[i]] for i in chosen)))

    def _param(self, name: str) -> Parameter:
        if name not in self.parameters:
            raise ParameterError(
                f"unknown parameter {name!r} for scenario {self.name}{did_you_mean(name, self.parameters)}; "
                "valid names: "
                f"{', '.join(self.parameters)}", name)
        return self.parameters[name]

    @property
    def values(self) -> dict[str, float]:
        """Every parameter's value (SI), overrides applied."""
        out = {n: p.value for n, p in self.parameters.items()}
        out.update(self.overrides)
        return out

    @property
    def cycle_angle(self) -> float:
        """rad of crank angle in one machine cycle: 2 pi cycle_turns."""
        return 2.0 * math.pi * self.cycle_turns

    def __getitem__(self, name: str) -> float:
        self._param(name)
        return self.values[name]

    def with_params(self, **values) -> "Scenario":
        """A copy with parameters overridden by name; each value is range-checked now. The file's
        parsed parameters and experiment are shared, not parsed again (a sweep makes one copy per
        design)."""
        copy = object.__new__(Scenario)
        copy.__dict__.update(self.__dict__)
        copy.overrides = dict(self.overrides)
        for k, v in values.items():
            copy.overrides[k] = copy._param(k).check(v)
        return copy

    def with_joint_friction(self, mu: float, radius: float) -> "Scenario":
        """A copy with Coulomb friction in every joint of its mechanism: coefficient ``mu`` in each
        pin and slide, ``radius`` (m) for each pin, as the new parameters ``mu_joints`` and
        ``r_pins`` (range-checked as any parameter: ``--set`` changes them); the file's own
        ``[friction]`` entries, if any, give way to these."""
        joints = self.mechanism_definition().joints
        if not joints:
            raise DefinitionError(f"{self.where}: mechanism {self.mechanism_name!r} declares no [[joints]]: "
                                  "joint friction needs them")
        taken = [name for name in ("mu_joints", "r_pins") if name in self.parameters]
        if taken:
            raise DefinitionError(f"{self.where}: joint friction would add the parameter(s) {', '.join(taken)}, "
                                  "which the scenario has already")
        data = dict(self.data)
        data["parameters"] = {**self.data["parameters"],
                              "mu_joints": {"value": float(mu), "unit": "1", "min": 0.0, "max": 1.0,
                                            "description": "friction coefficient of every joint (--friction)"},
                              "r_pins": {"value": float(radius), "unit": "m", "min": 0.0, "min_inclusive": False,
                                         "description": "radius of every pin (--friction)"}}
        data["friction"] = {j.name: ({"mu": "mu_joints", "radius": "r_pins"} if j.kind == "revolute"
                                     else {"mu": "mu_joints"}) for j in joints}
        copy = Scenario(data, self.where, self.path)
        copy._kept = self._kept
        return copy.with_params(**self.overrides)

    def __repr__(self) -> str:
        extra = f", overrides={self.overrides}" if self.overrides else ""
        return f"Scenario({self.name!r}{extra})"

    # ------------------------------------------------------------------ building the model
    def mechanism_source(self) -> str | Path:
        """The mechanism file: a packaged name, or a .toml path relative to this scenario's file
        (a user keeps the two side by side) or to the working directory."""
        name = self.mechanism_name
        if str(name).endswith(".toml") and self.path and not Path(name).is_absolute():
            beside = Path(self.path).parent / name
            if beside.exists():
                return beside
        return name

    def mechanism_definition(self) -> MechanismDefinition:
        """The mechanism file's definition, read the first time this scenario or any of its
        with_params copies asks for it, then kept by all of them (a sweep's designs are copies:
        the file is read once, not once per design)."""
        if "definition" not in self._kept:
            self._kept["definition"] = load_mechanism(self.mechanism_source())
        return self._kept["definition"]

    def __getstate__(self):
        # a pickled scenario (a Dask worker's) reads its mechanism again where it is unpickled: a
        # definition holds compiled expressions, which do not pickle
        return {**self.__dict__, "_kept": {}}

    @property
    def quantities(self):
        """The mechanism-specific outputs of the ``[[outputs]]`` entries (slider position, arm speed...)."""
        from .mechanisms.quantities import parse_quantities
        return parse_quantities(self.data.get("outputs", []), self.mechanism_definition(), self.where)

    @property
    def ports(self):
        """The ``[[ports]]`` entries (dynamics.ports): force and couple inputs a master sets."""
        from .dynamics.ports import parse_ports
        return parse_ports(self.data.get("ports", []), self.mechanism_definition(), self.where, self.values)

    @property
    def causality(self) -> str:
        """``[crank] causality``: "torque" (the default: the FMU takes a torque on the crank and
        integrates the movement equation) or "speed" (it takes omega1 and outputs the drive torque)."""
        crank = self.data.get("crank", {})
        value = crank.get("causality", "torque") if isinstance(crank, dict) else None
        if value not in CAUSALITIES:
            raise DefinitionError(f"{self.where}: [crank] causality must be one of {', '.join(CAUSALITIES)}, "
                                  f"got {value!r}")
        return value

    @property
    def kinematics_study(self) -> dict:
        """The ``[kinematics]`` section: the paper's constant-speed kinematic study."""
        return dict(self.data.get("kinematics", {}))

    def assembled_mechanism(self, definition: MechanismDefinition | None = None):
        """(mechanism, worst conditioning, crank angle rad where it occurs) for these parameter values,
        assembly checked over the whole turn; AssemblyError names the bound of each changed parameter.
        ``definition``: the scenario's mechanism definition, when the caller has it already."""
        definition = definition or self.mechanism_definition()
        mechanism = Mechanism(definition, self.values)
        try:
            worst, at = mechanism.check_assembly()
        except AssemblyError as exc:
            raise self._explain_assembly(exc, definition) from None
        return mechanism, worst, at

    def build(self, table: float | None = None) -> "Model":
        """Mechanism, reduced model, motor and equation of motion for these parameter values.

        ``table``: also tabulate the reduced model to this relative tolerance by the C model
        (dynamics.tabulated.c_table, what table_of then returns). The C model then checks the
        assembly over the turn and finds the loads' switch angles, by the rules the Python engine
        states (tests/test_c_model.py compares them), and the Python engine does not do them again:
        the fast path's model costs the C model's work, not the engine's. Where the C model does
        not take the scenario or refuses the values, the Python engine builds the model as without
        ``table`` (and says why it cannot)."""
        values = self.values
        definition = self.mechanism_definition()
        friction_entries = self.friction_entries(definition)
        frictions = joint_frictions(definition, friction_entries, values, self.where) if friction_entries else []
        prepared = table_built = None
        if table is not None:                       # (c_model is None with joint friction: the engine's tables)
            from .dynamics.tabulated import c_model, c_table
            prepared = c_model(self, values)
            table_built = prepared and c_table(self, values, table, prepared)
            if table_built is None:
                prepared = None
        if prepared is None:
            mechanism, worst, at = self.assembled_mechanism(definition)
            found = {}
        else:
            mechanism = Mechanism(definition, values)
            (worst, at), found = prepared.worst_conditioning, prepared.found()
        links = []
        for lname, ld in definition.links.items():
            mass = evaluate(ld.mass, values, f"{self.name}: mass of {lname}")
            inertia = evaluate(ld.inertia, values, f"{self.name}: inertia of {lname}")
            for what, v in (("mass", mass), ("inertia", inertia)):
                if not (v >= 0 and math.isfinite(v)):
                    raise ParameterError(
                        f"{self.name}: the {what} of link {lname} ({ld.mass if what == 'mass' else ld.inertia}"
                        f" = {v:g}) must be >= 0", lname)
            links.append(LinkInertia(lname, ld.centre, mass, inertia))
        loads, entries = [], []
        for i, spec in enumerate(self.data.get("loads", [])):
            if spec.get("kind") in USER_LOADS:
                made = parse_user_load(spec, mechanism, {l.name for l in links}, values, f"{self.where}: load {i + 1}")
                check_affine(made, mechanism, values, f"{self.where}: load {i + 1}")
                check_kinks(made, self.cycle_turns, f"{self.where}: load {i + 1}")
                loads += made
                entries += [i] * len(made)
            else:
                loads.append(make_load(spec, mechanism, links, values, self.where, self.name, found.get(i)))
                entries.append(i)
        from .dynamics.ports import parse_ports
        ports = parse_ports(self.data.get("ports", []), definition, self.where, values)
        reduced = ReducedModel(mechanism, links, values["J_flywheel"], loads, ports, self.cycle_turns)
        reduced.source = (self, values)          # what the C model tabulates it from (table_of)
        reduced.load_entries = entries           # each load's [[loads]] entry (load_words names it)
        if frictions:
            reduced.friction = JointFrictions(mechanism, links, frictions)
        if prepared is not None:
            from .dynamics.tabulated import keep_table
            reduced.c_model = prepared           # the output tables are built on it (fmi.python.slave)
            keep_table(reduced, table_built)
        # J = J_flywheel + the links' kinetic energy per omega1^2 / 2, a sum of terms >= 0 (masses
        # and inertias were checked >= 0): a flywheel makes it positive at every angle; without
        # one, it is checked on a grid
        J = (np.array([values["J_flywheel"]]) if values["J_flywheel"] > 0
             else table_built.coefficients[0, :, 0] if table_built is not None
             else reduced.coefficients(np.linspace(0, 2 * math.pi, 721))[0])
        if not np.min(J) > 0:
            raise ParameterError(
                f"{self.name}: the reduced inertia J(phi1) must be > 0 at every angle (min {np.min(J):g} "
                "kg.m2): give the links mass or add a flywheel (J_flywheel > 0)", "J_flywheel")
        motor = MotorLine(values["A"], values["B"], values["A_low"], values["B_low"], values["omega_switch"])
        equation = MovementEquation(reduced, motor)
        y0 = np.zeros(equation.state_size)
        y0[0], y0[1] = values["phi1_start"], values["omega1_start"]
        return Model(self, mechanism, reduced, motor, equation, y0, worst, at)

    def friction_entries(self, definition: MechanismDefinition | None = None) -> dict:
        """Joint name -> its friction's expressions {"mu": ..., "radius": ...}: the mechanism file's
        ``friction`` on each ``[[joints]]`` entry, replaced joint by joint by the scenario's
        ``[friction]`` table (``O = { mu = "mu_pin", radius = "r_pin" }``), which gives friction
        to a packaged mechanism without copying its file."""
        definition = definition or self.mechanism_definition()
        entries = {joint.name: joint.friction for joint in definition.joints if joint.friction}
        table = self.data.get("friction", {})
        if not isinstance(table, dict):
            raise DefinitionError(f"{self.where}: [friction] must be a table of joints, got {table!r}")
        kinds = {joint.name: joint.kind for joint in definition.joints}
        for name, entry in table.items():
            if name not in kinds:
                raise DefinitionError(f"{self.where}: [friction] {name!r} is not a joint of mechanism "
                                      f"{definition.name!r}{did_you_mean(name, kinds)} (joints: {', '.join(kinds)})")
            entries[name] = parse_friction_entry(entry, name, kinds[name], f"{self.where}: [friction]")
        return entries

    def load_parameters(self) -> list[str]:
        """Parameters the loads depend on (g for weights, the amplitudes' names)."""
        names: set[str] = set()
        for spec in self.data.get("loads", []):
            if spec.get("kind") == "weights":
                names.add("g")
            for key, value in spec.items():
                if key in ("kind", "link", "links", "point", "a", "b", "axis", "band", "direction_of", "description"):
                    continue
                for text in (value.values() if isinstance(value, dict) else [value]):
                    if isinstance(text, str):
                        names |= Expression(text).names
        return sorted(names & set(self.parameters))

    def _explain_assembly(self, exc: AssemblyError, definition: MechanismDefinition) -> AssemblyError:
        """Add the bound each geometry parameter must respect for the crank to turn fully, the
        others as given: for the parameters the user changed (--set) against the file's value; for
        a file's own values, for every geometry parameter whose change alone within a factor of
        ten makes the mechanism assemble."""
        changed = [p for p in definition.geometry_parameters if p in self.overrides]
        suspects = changed or [p for p in definition.geometry_parameters if p in self.parameters]
        hints = []
        for p in suspects:
            asked = self.values[p]
            bound = self._assembly_bound(p, definition)
            if bound is not None:
                side = "<" if bound < asked else ">"
                hints.append(f"{p} {side} {bound:.6g} {self.parameters[p].unit} "
                             f"({'asked' if p in self.overrides else 'the file gives'} {asked:g})")
        message = str(exc)
        if hints:
            # one bound in the words the C model uses for it (the native FMU's refusal says the same)
            each = "each with the others as given," if len(hints) > 1 else "with the other parameters as given"
            message += (f"; {each} the crank turns fully only for " + (", or for ".join(hints) if len(hints) < 3 else
                        ", for ".join(hints[:-1]) + ", or for " + hints[-1]))
        return AssemblyError(message, parameter=", ".join(changed) or exc.parameter)

    #: the factors a file's value is scaled by, nearest first, to find a value that assembles
    LADDER = (1.02, 1 / 1.02, 1.1, 1 / 1.1, 1.25, 1 / 1.25, 1.6, 1 / 1.6, 2.5, 1 / 2.5, 4.0, 1 / 4.0, 10.0, 0.1)

    def _assembly_bound(self, name: str, definition: MechanismDefinition, iterations: int = 40):
        """Bisect between a value that assembles and the asked value (which does not): the file's
        value where the user changed it, else the nearest of the file's value scaled by LADDER."""
        bad = self.values[name]

        def assembles(v):
            try:
                Mechanism(definition, {**self.values, name: v}).check_assembly(coarse=True)
                return True
            except (AssemblyError, DefinitionError):  # a closed form that misses the contours or jumps
                return False                          # does not assemble either (the C model's bound: the same)

        if name in self.overrides:
            good = self.parameters[name].value
            if not assembles(good):
                return None
        else:
            valid = self.parameters[name]
            candidates = [bad * f for f in self.LADDER]
            good = next((v for v in candidates if self._in_range(valid, v) and assembles(v)), None)
            if good is None:
                return None
        for _ in range(iterations):
            mid = 0.5 * (good + bad)
            if assembles(mid):
                good = mid
            else:
                bad = mid
        return good

    @staticmethod
    def _in_range(parameter, value) -> bool:
        try:
            parameter.check(value)
            return True
        except CrankfmuError:
            return False


@dataclass
class Model:
    """A scenario built into numbers: what the integrators run."""

    scenario: Scenario
    mechanism: Mechanism
    reduced: ReducedModel
    motor: MotorLine
    equation: MovementEquation
    y0: np.ndarray                 # phi1 rad, omega1 rad/s, works J
    conditioning: float            # worst Jacobian conditioning over the turn (1 good, 0 dead point)
    conditioning_at: float         # crank angle where it occurs, rad


def available_scenarios() -> list[str]:
    return packaged(_SCENARIOS)


def load_scenario(name_or_path: str | Path) -> Scenario:
    """A packaged scenario by name (``"seed000"``) or a scenario file by path."""
    if isinstance(name_or_path, Scenario):
        return name_or_path
    data, where, origin = read_toml(name_or_path, _SCENARIOS, "scenario", ScenarioNotFound)
    return Scenario(data, where, origin)
