"""The FMU's scenario run in process, sampled where the FMU reported.

``reference_run`` is the in-process reference integrator (DOP853 with the motor kink located,
rtol = atol = 1e-12) or any other crankfmu method, on the FMU's time grid.

``periodic_reference`` serves long runs. The scenario is autonomous (no load depends on time), so
once the start-up transient has died out the motion repeats every crank turn with a period T.
The reference integrates until successive periods agree to 1e-11 relative, then extends the
settled cycle: phi1(t + n T) = phi1(t) + 2 pi n, omega1(t + n T) = omega1(t), and each work
grows by its per-cycle amount. The extension is exact up to the period's error, so a 1000 s
reference costs as much as a 12 s one, and its own phase error after N cycles is about
N * |dT| * omega1 (reported as ``phase_uncertainty``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from crankfmu.contract import COLUMNS
from crankfmu.dynamics.equation import OMEGA, PHI, W_EXT, W_LOAD, W_MOTOR
from crankfmu.errors import CrankfmuError
from crankfmu.simulation import simulate

TWO_PI = 2.0 * math.pi


@dataclass
class ReferenceRun:
    label: str
    time: np.ndarray
    values: dict[str, np.ndarray]
    wall: float
    settings: dict = field(default_factory=dict)
    result: object = None              # the crankfmu Result behind it, when there is one
    model: object = None               # the crankfmu model it ran
    quantity_names: frozenset = frozenset()     # the [[outputs]] and the ports' s, v, a among values
    reaction_names: frozenset = frozenset()     # the joint reactions among values

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]


def reference_run(scenario, times, method: str = "reference", rtol: float | None = None,
                  angle_step: float | None = None, progress=None) -> ReferenceRun:
    times = np.asarray(times, dtype=float)
    started = time.perf_counter()
    r = simulate(scenario, t_end=float(times[-1]), method=method, rtol=rtol, angle_step=angle_step,
                 output_times=times, progress=progress)
    wall = time.perf_counter() - started
    values = {c: np.asarray(getattr(r, c)) for c in COLUMNS if c != "time"}
    if r.W_friction is not None:           # joint friction: its work and outputs (dynamics.friction)
        values.update(W_friction=np.asarray(r.W_friction), **{k: np.asarray(v) for k, v in r.friction.items()})
    return with_outputs(ReferenceRun(method, times, values, wall, dict(r.settings), r, r.model), scenario)


def built_reference(scenario, times, model=None) -> ReferenceRun | None:
    """The reference run the FMU's build made of the default experiment (fmi.reference: this
    integrator at the same settings, kept in the per-user cache under the design's digest, or
    carried by the installation for a packaged scenario) where ``times`` is that experiment's grid,
    with the other outputs at its states as reference_run adds them: the harness does not
    integrate it a second time (engine4's took 32 s). None where it is not that run: another grid,
    or joint friction (its outputs are not in the build's columns). ``model``: the scenario's,
    where the caller has built it."""
    from crankfmu.fmi.reference import default_grid, reference_values

    if scenario.friction_entries() or not np.array_equal(times, default_grid(scenario.experiment)):
        return None
    started = time.perf_counter()
    values = {name: v for name, v in reference_values(scenario).items() if name != "time"}
    settings = {"method": "reference (the FMU build's run of the default experiment)", "rtol": 1e-12}
    return with_outputs(ReferenceRun("reference", times, values, time.perf_counter() - started, settings, None,
                                     scenario.build() if model is None else model), scenario)


def _run_key(scenario, times: np.ndarray) -> tuple:
    """A run's identity in this process's caches: the scenario's file and every value, the grid."""
    return (str(scenario.where), tuple(sorted(scenario.values.items())), times.size, float(times[0]),
            float(times[-1]), hash(times.tobytes()))


#: reference runs made in this process, by (scenario file and values, times, method): the Python
#: and the native FMU of one scenario, and each interface, share them
_RUNS: dict = {}


def cached_reference(scenario, times, method: str = "reference", model=None) -> ReferenceRun:
    """``reference_run`` once per scenario (its file and every value), time grid and method; on the
    default experiment's grid, the run the FMU's build made (built_reference; ``model``: the
    scenario's, where the caller has built it)."""
    times = np.asarray(times, dtype=float)
    key = (*_run_key(scenario, times), method)
    if key not in _RUNS:
        built = built_reference(scenario, times, model) if method == "reference" else None
        _RUNS[key] = built if built is not None else reference_run(scenario, times, method) \
            if method != "periodic" else periodic_reference(scenario, times)
    return _RUNS[key]


#: the reference against a second method, by _run_key
_GAPS: dict = {}


def second_method_gap(scenario, times) -> float:
    """How far the reference (rtol 1e-12) is from a second, independent method on ``times``: the
    fast path (compiled Dormand-Prince on the C model's tables, rtol 1e-13), as max |omega1
    difference| / max |omega1|. It bounds the reference's own error (plus the second method's): a
    bar must stand well above it, and the report prints it beside the bar. NaN where the fast path
    cannot run the scenario. A 1e-13 run of the reference itself would cost about 1.3 times the
    reference (33 s on a 155-turn engine); this costs a few per cent."""
    times = np.asarray(times, dtype=float)
    key = _run_key(scenario, times)
    if key not in _GAPS:
        ref = cached_reference(scenario, times)
        try:
            second = reference_run(scenario, times, "fast", rtol=1e-13)
        except CrankfmuError:
            _GAPS[key] = math.nan
        else:
            scale = float(np.max(np.abs(ref["omega1"]))) or 1.0
            _GAPS[key] = float(np.max(np.abs(second["omega1"] - ref["omega1"]))) / scale
    return _GAPS[key]


def with_outputs(run: ReferenceRun, scenario) -> ReferenceRun:
    """The run with every other output a mechanism FMU declares, at the reference's states (of
    ``run.model``, the model it ran): the scenario's [[outputs]] and the ports' s, v, a (the analytic
    kinematics), and the joint reactions (Newton-Euler, the ports' inputs zero as the harness leaves
    them)."""
    from crankfmu.fmi.variables import output_quantities, reaction_variables
    from crankfmu.mechanisms.quantities import evaluate_all

    values, model = run.values, run.model
    phi1, omega1, epsilon1 = (np.asarray(values[n], dtype=float) for n in ("phi1", "omega1", "epsilon1"))
    quantities = output_quantities(scenario)
    kin = model.mechanism.kinematics(phi1) if quantities or reaction_variables(scenario) else None
    if quantities:
        values.update(evaluate_all(quantities, kin, omega1, epsilon1))
    reactions = reaction_variables(scenario)
    if reactions:
        from crankfmu.dynamics.reactions import joint_reactions, reaction_arrays

        values.update({k: np.asarray(v, dtype=float) for k, v in reaction_arrays(
            joint_reactions(model.reduced, phi1, omega1, epsilon1, kin=kin)).items()})
    run.quantity_names = frozenset(q.name for q in quantities)
    run.reaction_names = frozenset(v.name for v in reactions)
    return run


def periodic_reference(scenario, times, settle_time: float = 12.0, progress=None) -> ReferenceRun:
    """The reference over ``times`` (any length) from a settled cycle; see the module docstring."""
    times = np.asarray(times, dtype=float)
    started = time.perf_counter()
    r = simulate(scenario, t_end=max(settle_time, 1e-3), output_times=[0.0, settle_time], progress=progress)
    phi0 = r.trajectory.y[PHI][0]
    turns = int(math.floor((r.state([settle_time])[PHI, 0] - phi0) / TWO_PI))
    if turns < 4:
        raise CrankfmuError(f"periodic reference: only {turns} crank turns in {settle_time:g} s; the "
                            "extension needs a crank that keeps turning forward")
    marks = r.time_at_angle(phi0 + TWO_PI * np.arange(turns - 2, turns + 1))
    periods = np.diff(marks)
    period = float(periods[-1])
    settled = abs(periods[-1] - periods[-2]) / period
    if settled > 1e-11:
        raise CrankfmuError(f"periodic reference: the period still changes by {settled:.1e} (relative) after "
                            f"{turns} turns; give a longer settle_time than {settle_time:g} s")
    t_a, t_b = float(marks[-2]), float(marks[-1])
    y_a, y_b = r.state([t_a])[:, 0], r.state([t_b])[:, 0]
    per_cycle = y_b - y_a

    early = times < t_a
    y = np.empty((y_a.size, times.size))
    if early.any():
        y[:, early] = r.state(times[early])
    late = ~early
    n = np.floor((times[late] - t_a) / period)
    tau = np.clip(t_a + (times[late] - t_a - n * period), t_a, t_b)
    y_late = r.state(tau)
    y_late[PHI] += TWO_PI * n
    for row in (W_MOTOR, W_LOAD, W_EXT):
        y_late[row] += n * per_cycle[row]
    y[:, late] = y_late
    out = r.model.equation.outputs(y[PHI], y[OMEGA])
    values = {"phi1": y[PHI], "omega1": y[OMEGA], **out,
              "W_motor": y[W_MOTOR], "W_load": y[W_LOAD], "W_ext": y[W_EXT]}
    cycles = max(float(np.max(n)) if n.size else 0.0, 0.0)
    # the period is known to about the DOP853 tolerance times the time scale of one turn
    period_error = max(abs(periods[-1] - periods[-2]), 1e-12 * period)
    settings = {"method": "reference, periodic extension", "settle_time": settle_time, "period": period,
                "cycles_extended": cycles,
                "phase_uncertainty": cycles * period_error * float(np.max(np.abs(y[OMEGA])))}
    return with_outputs(ReferenceRun("reference (periodic)", times, values, time.perf_counter() - started,
                                      settings, r, r.model), scenario)
