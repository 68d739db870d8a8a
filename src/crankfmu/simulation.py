"""``simulate(scenario, ...)``: run a scenario with one integrator and return named arrays."""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from .dynamics.equation import OMEGA, PHI, W_EXT, W_FRICTION, W_LOAD, W_MOTOR
from .errors import CrankfmuError, ParameterError
from .integrators import Trajectory, make_integrator
from .scenario import Model, Scenario, load_scenario

TWO_PI = 2.0 * math.pi

@dataclass
class Result:
    """A simulated run. Arrays are at the output times and named like the CSV columns.

    time      s        output times
    phi1      rad      crank angle, unwrapped
    omega1    rad/s    crank speed
    epsilon1  rad/s2   crank angular acceleration
    M_motor   N.m      motor torque on the crank
    M_load    N.m      weights and technological loads reduced to the crank (Q)
    J_red     kg.m2    reduced inertia, flywheel included
    E_kin     J        kinetic energy of the mechanism, 0.5*J_red*omega1^2
    W_motor, W_load, W_ext   J   work done since the start by the motor, the loads, and the
                       external inputs (tau_ext and the ports)
    ports     dict     each port's input and outputs by FMU variable name (ram_F, ram_s, ram_v,
                       ram_a; arm_M, arm_angle, ...), in SI units
    W_friction J       with joint friction (dynamics.friction): the friction's work since the start
                       (<= 0); None without
    friction  dict     with joint friction: M_friction (N.m, its generalised force on the crank),
                       each joint's <joint>_Mf (N.m) or <joint>_Ff (N) and <joint>_Pf (W)
    """

    scenario: Scenario
    model: Model
    method: str
    trajectory: Trajectory
    time: np.ndarray
    phi1: np.ndarray
    omega1: np.ndarray
    epsilon1: np.ndarray
    M_motor: np.ndarray
    M_load: np.ndarray
    J_red: np.ndarray
    E_kin: np.ndarray
    W_motor: np.ndarray
    W_load: np.ndarray
    W_ext: np.ndarray
    wall_time: float = 0.0            # s spent integrating
    settings: dict = field(default_factory=dict)
    ports: dict = field(default_factory=dict)
    W_friction: np.ndarray | None = None
    friction: dict = field(default_factory=dict)

    # ------------------------------------------------------------------ state anywhere
    def state(self, times) -> np.ndarray:
        """State rows (phi1, omega1, W_motor, W_load, W_ext, and W_friction with joint friction) at any
        times within the run."""
        return self.trajectory.sample(times)

    def time_at_angle(self, phi1) -> np.ndarray:
        """Times (s) at which the crank angle reaches ``phi1`` (rad); needs phi1 monotone there."""
        phi1 = np.atleast_1d(np.asarray(phi1, dtype=float))
        tr = self.trajectory
        phis = tr.y[PHI]
        if np.any(np.diff(phis) <= 0):
            # first passage only: the monotone prefix of the run
            stop = int(np.argmax(np.diff(phis) <= 0))
            t_nodes, phi_nodes = tr.t[:stop + 1], phis[:stop + 1]
        else:
            t_nodes, phi_nodes = tr.t, phis
        if np.any(phi1 < phi_nodes[0]) or np.any(phi1 > phi_nodes[-1]):
            raise CrankfmuError(
                f"the crank angle {math.degrees(float(np.max(phi1))):.1f} deg is not reached with the crank "
                f"turning forward in this run (it reaches {math.degrees(phi_nodes[-1]):.1f} deg); "
                "run longer (t_end) or check the motor")
        t = np.interp(phi1, phi_nodes, t_nodes)
        if tr.dense is not None:
            for _ in range(8):      # Newton on the dense output: dphi/dt = omega
                y = tr.dense(t)
                t = t - (y[PHI] - phi1) / y[OMEGA]
        return t

    def omega_at_angle(self, phi1) -> np.ndarray:
        """omega1 (rad/s) as a function of the crank angle (rad), for comparing schemes stepped in phi1."""
        phi1 = np.atleast_1d(np.asarray(phi1, dtype=float))
        tr = self.trajectory
        if tr.dense is None:
            return np.interp(phi1, tr.y[PHI], tr.y[OMEGA])
        return tr.dense(self.time_at_angle(phi1))[OMEGA]

    # ------------------------------------------------------------------ cycles and balances
    def cycle_bounds(self, k: int) -> tuple[float, float]:
        """Start and end time (s) of the k-th machine cycle (k = 1 is the first: one crank turn, or
        the scenario's cycle_turns turns)."""
        phi0, cycle = self.trajectory.y[PHI][0], self.scenario.cycle_angle
        t0, t1 = self.time_at_angle([phi0 + cycle * (k - 1), phi0 + cycle * k])
        return float(t0), float(t1)

    def cycle_stats(self, k: int) -> dict:
        """omega1 min, max, time mean and the coefficient of speed fluctuation over cycle k.

        omega1_mean is the time mean (the cycle's angle over its time T); delta = (max - min)/mean.
        """
        t0, t1 = self.cycle_bounds(k)
        tr = self.trajectory
        if tr.dense is not None:
            ts = np.linspace(t0, t1, 4001)
            w = tr.dense(ts)[OMEGA]

            def polish(sign, i):
                lo, hi = ts[max(i - 1, 0)], ts[min(i + 1, ts.size - 1)]
                res = minimize_scalar(lambda s: sign * tr.dense(s)[OMEGA][0], bounds=(lo, hi),
                                      method="bounded", options={"xatol": 1e-13})
                return min(sign * w[i], float(res.fun)) * sign

            w_min = polish(1.0, int(np.argmin(w)))
            w_max = polish(-1.0, int(np.argmax(w)))
        else:
            inside = (tr.t >= t0) & (tr.t <= t1)
            w = np.concatenate([tr.y[OMEGA][inside], self.state([t0, t1])[OMEGA]])
            w_min, w_max = float(np.min(w)), float(np.max(w))
        mean = self.scenario.cycle_angle / (t1 - t0)
        return {"cycle": k, "t_start": t0, "t_end": t1, "period": t1 - t0,
                "omega1_min": w_min, "omega1_max": w_max, "omega1_mean": mean,
                "delta": (w_max - w_min) / mean}

    def energy_balance(self, t=None) -> dict:
        """Work of motor, loads and tau_ext (and the joints' friction, where there is any) against
        the change of kinetic energy, from the start to t.

        ``residual`` = (W_motor + W_load + W_ext + W_friction - dE_kin) / (|W_motor| + |W_load| +
        |W_ext| + |W_friction|).
        """
        t_end = self.time[-1] if t is None else float(t)
        y0 = self.state([self.time[0]])[:, 0]
        y1 = self.state([t_end])[:, 0]
        eq = self.model.equation
        J0 = eq.reduced.coefficients(y0[PHI])[0][0]
        J1 = eq.reduced.coefficients(y1[PHI])[0][0]
        dE = 0.5 * J1 * y1[OMEGA] ** 2 - 0.5 * J0 * y0[OMEGA] ** 2
        rows = [W_MOTOR, W_LOAD, W_EXT] + ([W_FRICTION] if y1.size > W_FRICTION else [])
        works = y1[rows] - y0[rows]
        scale = float(np.sum(np.abs(works)))
        out = {"t": t_end, "W_motor": float(works[0]), "W_load": float(works[1]), "W_ext": float(works[2])}
        if len(rows) > 3:
            out["W_friction"] = float(works[3])
        return {**out, "dE_kin": float(dE), "residual": float((np.sum(works) - dE) / scale) if scale else 0.0}

    def friction_summary(self, k: int) -> dict:
        """Joint friction over cycle k: the works (J), the efficiency (the work the loads take
        over the motor's, -W_load / W_motor, with the change of kinetic energy beside it: 0 in a
        steady cycle), each joint's largest friction and its mean power (W)."""
        t0, t1 = self.cycle_bounds(k)
        y0, y1 = self.state([t0])[:, 0], self.state([t1])[:, 0]
        works = {name: float(y1[row] - y0[row]) for name, row in
                 (("W_motor", W_MOTOR), ("W_load", W_LOAD), ("W_ext", W_EXT), ("W_friction", W_FRICTION))}
        inside = (self.time >= t0) & (self.time <= t1)
        joints = {}
        for name, value in self.friction.items():
            joint, _, what = name.rpartition("_")
            if what in ("Mf", "Ff"):
                joints[joint] = {f"max_abs_{what}": float(np.max(np.abs(value[inside]))),
                                 # from the output samples (the joints' sum is W_friction, integrated)
                                 "mean_power_W_sampled": float(np.trapezoid(self.friction[f"{joint}_Pf"][inside],
                                                                            self.time[inside]) / (t1 - t0))}
        J = self.model.reduced.coefficients(np.array([y0[PHI], y1[PHI]]))[0]
        dE = 0.5 * J[1] * y1[OMEGA] ** 2 - 0.5 * J[0] * y0[OMEGA] ** 2
        motor = works["W_motor"] + max(works["W_ext"], 0.0)
        return {"cycle": k, **works, "dE_kin": float(dE),
                "efficiency": -works["W_load"] / motor if motor > 0.0 else None,
                "friction_share": -works["W_friction"] / motor if motor > 0.0 else None, "joints": joints}

    def summary(self, cycle: int | None = None) -> dict:
        """What summary.json holds: the cycle's speed statistics, J_red range, energy residual."""
        exp = self.scenario.experiment
        k = exp.summary_cycle if cycle is None else cycle
        stats = self.cycle_stats(k)
        grid = np.linspace(0.0, TWO_PI, 3601)
        J = self.model.reduced.coefficients(grid)[0]
        try:
            t_energy = self.cycle_bounds(exp.cycles)[1]
            energy_over = f"{exp.cycles} cycles"
        except CrankfmuError:
            t_energy, energy_over = self.time[-1], "the whole run"
        energy = self.energy_balance(t_energy)
        return {
            "scenario": self.scenario.name,
            "parameters": self.scenario.values,
            "method": self.method,
            "settings": self.settings,
            f"cycle_{k}": stats,
            "omega1_min": stats["omega1_min"],
            "omega1_max": stats["omega1_max"],
            "omega1_mean": stats["omega1_mean"],
            "delta": stats["delta"],
            "J_red_min": float(J.min()),
            "J_red_max": float(J.max()),
            "J_red_min_at_deg": float(np.degrees(grid[np.argmin(J)])),
            "J_red_max_at_deg": float(np.degrees(grid[np.argmax(J)])),
            "energy_balance": {**energy, "over": energy_over},
            "energy_residual": energy["residual"],
            **({"friction": self.friction_summary(k)} if self.W_friction is not None else {}),
            "n_rhs": self.trajectory.n_rhs,
            "n_steps": self.trajectory.n_steps,
            "events": [{"t": t, "what": w} for t, w in self.trajectory.events],
            "wall_time_s": self.wall_time,
        }


def simulate(scenario, t_end: float | None = None, method: str = "reference", rtol: float | None = None,
             output_times=None, angle_step: float | None = None, progress=None, inputs=None) -> Result:
    """Run ``scenario`` (a Scenario, a packaged name or a path) and return a :class:`Result`.

    t_end         s      end time (default: the scenario's stop_time)
    method               "fast" (the C kernel's Dormand-Prince on the tabulated model, every switch
                         located; rtol default 1e-11), "reference" (DOP853 on the contour engine,
                         rtol = atol = 1e-12), "radau", "dopri5", "badoiu-eq17", "lv-eq3"
    rtol          1      relative (and absolute) tolerance of the time-domain methods
    output_times  s      where arrays are sampled (default: the scenario's output interval for the
                         time-domain methods, the scheme's own nodes for the crank-angle schemes)
    angle_step    rad    crank-angle step of the schemes (default 0.1 deg)
    progress             callable(t) called now and then with the time reached
    inputs               the FMU's inputs by name: tau_ext (N.m) and each port's (ram_F N,
                         arm_M N.m), each a number or a function of time t (s); default 0. The fast
                         method takes a function of time linear between output times.
    """
    scenario = load_scenario(scenario)
    exp = scenario.experiment
    t0 = exp.start_time
    if t_end is None:
        t_end = exp.stop_time
    try:
        t_end = float(t_end)
    except (TypeError, ValueError):
        raise ParameterError(f"t_end must be a time in s, got {t_end!r}", "t_end") from None
    if not (math.isfinite(t_end) and t_end > t0):
        raise ParameterError(f"t_end = {t_end!r} s: the duration must be > 0 (t_end > start time {t0:g} s)",
                             "t_end")
    if rtol is not None and not (rtol > 0 and math.isfinite(rtol)):
        raise ParameterError(f"rtol must be > 0, got {rtol!r}", "rtol")
    integrator = make_integrator(method, rtol, angle_step)
    # the fast path runs on the C model's table: its assembly check and switch angles are the C
    # model's too; every other method builds and checks the model with the Python engine
    model = scenario.build(table=getattr(integrator, "table_tolerance", None))
    if inputs:
        _set_inputs(model.equation, inputs)
    times = None
    if output_times is not None:
        times = np.atleast_1d(np.asarray(output_times, dtype=float))
        if np.any(times < t0) or np.any(times > t_end) or np.any(np.diff(times) < 0):
            raise ParameterError(f"output_times must be increasing and within [{t0:g}, {t_end:g}] s",
                                 "output_times")
    elif integrator.time_domain:
        n = int(round((t_end - t0) / exp.output_interval))
        times = t0 + exp.output_interval * np.arange(n + 1)
        times = times[times <= t_end]
        if times[-1] < t_end:
            times = np.append(times, t_end)
    started = _time.perf_counter()
    # the fast path fills the outputs from its tables while it runs; the others are sampled below
    trajectory = integrator.run(model.equation, t0, model.y0, t_end, progress=progress, output_times=times)
    wall = _time.perf_counter() - started

    if times is None:
        keep = trajectory.t < t_end
        times = np.append(trajectory.t[keep], t_end)
    if trajectory.outputs is not None:
        out = dict(trajectory.outputs)
        y = out.pop("state")
    else:
        y = trajectory.sample(times)
        out = model.equation.outputs(y[PHI], y[OMEGA], trajectory.mode_at(times), times)
    if trajectory.epsilon is not None:
        # the scheme's own acceleration (eq. 10), not the time-domain formula
        out["epsilon1"] = np.interp(times, trajectory.t, trajectory.epsilon)
    settings = {"method": integrator.name}
    if integrator.time_domain:
        settings.update(rtol=integrator.rtol, atol=integrator.atol, solver=integrator.method)
    else:
        settings.update(angle_step_deg=math.degrees(integrator.angle_step))
    if trajectory.table is not None:
        settings.update(table_intervals=trajectory.table.n_intervals, table_error=trajectory.table.error_bound)
    return Result(
        scenario=scenario, model=model, method=integrator.name, trajectory=trajectory,
        time=times, phi1=y[PHI], omega1=y[OMEGA], epsilon1=out["epsilon1"], M_motor=out["M_motor"],
        M_load=out["M_load"], J_red=out["J_red"], E_kin=out["E_kin"], W_motor=y[W_MOTOR],
        W_load=y[W_LOAD], W_ext=y[W_EXT], wall_time=wall, settings=settings,
        ports=_port_outputs(model, times, y[PHI], y[OMEGA], out["epsilon1"]),
        W_friction=y[W_FRICTION] if y.shape[0] > W_FRICTION else None,
        friction={name: out[name] for name in model.equation.friction_names if name in out},
    )


def _set_inputs(equation, inputs) -> None:
    """tau_ext and the ports' inputs from a mapping by FMU variable name."""
    by_name = {port.input_name: i for i, port in enumerate(equation.ports)}
    known = ["tau_ext", *by_name]
    for name, value in dict(inputs).items():
        if name not in known:
            raise ParameterError(f"unknown input {name!r}: this scenario's inputs are {', '.join(known)}", name)
        if not callable(value):
            try:
                value = float(value)
            except (TypeError, ValueError):
                value = math.nan
            if not math.isfinite(value):
                raise ParameterError(f"input {name} = {inputs[name]!r} must be a finite number or a function of "
                                     "time t (s)", name)
        if name == "tau_ext":
            if callable(value):
                raise ParameterError("input tau_ext: a constant in process (N.m); a function of time is for the "
                                     "ports' inputs", name)
            equation.tau_ext = value
        else:
            equation.port_inputs[by_name[name]] = value


def _port_outputs(model, times, phi1, omega1, epsilon1) -> dict:
    """Each port's input and its coordinate's position, velocity and acceleration at the output times."""
    ports = model.equation.ports
    if not ports:
        return {}
    kin = model.mechanism.kinematics(np.asarray(phi1, dtype=float))
    out = {}
    for port, value in zip(ports, model.equation.port_values(np.asarray(times, dtype=float))):
        out[port.input_name] = np.broadcast_to(np.asarray(value, dtype=float), np.shape(times)).copy()
        for quantity in port.quantities:
            out[quantity.name] = quantity.evaluate(kin, omega1, epsilon1)
    return out
