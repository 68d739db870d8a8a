"""A fixed-step co-simulation master on fmpy: an instrument of the harness, small on purpose, that
couples FMI 2.0 Co-Simulation FMUs the way the common masters do, to measure what the FMUs' coupling
features buy (docs/coupling.md).

The coupling is affine (``Coupling``): the connected inputs u are u = M y + N z + c of the connected
outputs y and the master's own states z, which move as dz/dt = P y + Q z. A plain connection is a
row of M; an elastic shaft between two FMUs is the master's twist z and its torque k z + c (omega_a -
omega_b) (``Coupling.shaft``).

At each communication point t_n the inputs are first made consistent, u_n = M y_n + N z_n + c (set and
read again while an output feeds through from an input). Over the step each input is then a line
from u_n, given to the FMU as its value and first derivative (fmi2SetRealInputDerivatives). The
modes differ in the line's slope:

- ``hold``: the values only, held (a zero-order hold: what ecos and libcosim do): an O(H)
  coupling error;
- ``extrapolate``: the coupling's own rate at t_n from the source FMUs' first output derivatives
  (fmi2GetRealOutputDerivatives): O(H^2). PyFMI's Master with extrapolation_order = 1, OMSimulator
  with --inputExtrapolation;
- ``implicit``: linearly implicit, one doStep per FMU per step. Each FMU's linear system at t_n
  (A, B, C, D from fmi2GetDirectionalDerivative on its declared states and connected inputs, the
  states' rates read) predicts its outputs at t_n + H for an input line of any slope, exactly for a
  linear FMU (the matrix exponential's phi1, phi2); the slopes are those for which the coupling holds
  at t_n + H on that prediction, the master's states integrated by the trapezoidal rule. A stiff
  coupling (a shaft) is then stable at steps far above its period; what PyFMI's linear_correction
  and fmigo's shaft constraint build on;
- ``rollback``: the step iterated on the FMUs' real steps (fmi2GetFMUstate / fmi2SetFMUstate):
  Newton on the lines' end values, its Jacobian from one extra step per input, until the coupling
  holds at t_n + H; an input's start is the coupling's value at t_n with the step's slopes set, so
  an output that reads an input's derivative (a speed-causal mechanism's tau_drive reads epsilon1)
  is consistent at both ends. What Maestro's and CoFMPy's rollback iterations do.

The error of each mode is measured against the one-model references of validation/coupling.py.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MODES = ("hold", "extrapolate", "implicit", "rollback")
#: the consistent start's and Newton's relative tolerance, and Newton's iterations after the first
TOLERANCE = 1e-10
NEWTON_ITERATIONS = 6


class Diverged(RuntimeError):
    """A coupled run left the bounds it was given."""


@dataclass
class Coupled:
    """The variables recorded at each communication point (``record``: "FMU.variable" names), and
    the FMU steps each FMU took (``steps``: the communication points, times the rollback's trials)."""

    time: np.ndarray
    values: dict
    steps: int = 0

    def __getitem__(self, name):
        return self.values[name]


@dataclass
class Coupling:
    """u = M y + N z + c and dz/dt = P y + Q z, with y the ``outputs`` and u the ``inputs`` ("FMU.variable"
    each) and z the master's states, ``z0`` at the start."""

    outputs: list
    inputs: list
    M: np.ndarray
    N: np.ndarray = None
    c: np.ndarray = None
    P: np.ndarray = None
    Q: np.ndarray = None
    z0: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self):
        m, p, q = len(self.inputs), len(self.outputs), len(self.z0)
        self.M = np.asarray(self.M, float).reshape(m, p)
        self.N = np.zeros((m, q)) if self.N is None else np.asarray(self.N, float).reshape(m, q)
        self.c = np.zeros(m) if self.c is None else np.asarray(self.c, float)
        self.P = np.zeros((q, p)) if self.P is None else np.asarray(self.P, float).reshape(q, p)
        self.Q = np.zeros((q, q)) if self.Q is None else np.asarray(self.Q, float).reshape(q, q)

    @classmethod
    def connections(cls, connections) -> "Coupling":
        """Plain connections ((from FMU, output, to FMU, input), ...): each input equals its output."""
        outputs = list(dict.fromkeys(f"{a}.{o}" for a, o, _, _ in connections))
        inputs = [f"{b}.{i}" for _, _, b, i in connections]
        M = np.zeros((len(inputs), len(outputs)))
        for row, (a, o, _, _) in enumerate(connections):
            M[row, outputs.index(f"{a}.{o}")] = 1.0
        return cls(outputs, inputs, M)

    def links(self) -> list:
        """The plain connections ((from FMU, output, to FMU, input), ...) this coupling is, for a
        master that has no equations of its own; ValueError if it has some."""
        plain = not len(self.z0) and not self.c.any() and all(sorted(row) == [0.0] * (len(row) - 1) + [1.0]
                                                              for row in self.M)
        if not plain:
            raise ValueError("this coupling has equations of its own, not only connections")
        return [(*self.outputs[int(np.argmax(row))].split(".", 1), *name.split(".", 1))
                for row, name in zip(self.M, self.inputs)]

    @classmethod
    def shaft(cls, drive: str, machine: str, k: float, c: float) -> "Coupling":
        """An elastic shaft (stiffness ``k`` N.m/rad, damping ``c`` N.m.s/rad) from a speed-causal
        drive (output omega, input tau_load) to a torque-causal mechanism (output omega1, input
        tau_ext): the twist z = phi_drive - phi1 is the master's state; the shaft's torque
        k z + c (omega - omega1) loads the drive and drives the crank."""
        return cls([f"{drive}.omega", f"{machine}.omega1"], [f"{drive}.tau_load", f"{machine}.tau_ext"],
                   [[c, -c], [c, -c]], N=[[k], [k]], P=[[1.0, -1.0]], z0=np.zeros(1))

    def inputs_at(self, y, z) -> np.ndarray:
        return self.M @ y + self.N @ z + self.c

    def advance(self, z, y0, dy, h, theta=0.5) -> np.ndarray:
        """z at t + h, the master's states stepped like an FMU on their inputs, the outputs from y0 (at
        t) by dy over the step: the theta rule (0.5: the trapezoidal rule, exact for a line and Q = 0;
        1: backward Euler)."""
        if not len(z):
            return z
        rhs = z + h * (self.P @ (y0 + theta * dy) + (1.0 - theta) * self.Q @ z)
        return np.linalg.solve(np.eye(len(z)) - theta * h * self.Q, rhs)


def _phi(A: np.ndarray, h: float):
    """phi1(hA) and phi2(hA) (exp(Z) = I + Z phi1(Z), phi1(Z) = I + Z phi2(Z)), the top row of one
    block matrix's exponential."""
    from scipy.linalg import expm

    n = len(A)
    big = np.zeros((3 * n, 3 * n))
    big[:n, :n] = h * A
    big[:n, n:2 * n] = np.eye(n)
    big[n:2 * n, 2 * n:] = np.eye(n)
    E = expm(big)
    return E[:n, n:2 * n], E[:n, 2 * n:]


class _Unit:
    """One FMU as the master drives it: fmpy's FMU2Slave, its value references, its declared states
    and their derivatives (ModelStructure), and what it offers (directional derivatives)."""

    def __init__(self, name, path, work, parameters, stop_time):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        md = read_model_description(str(path))
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), str(work / name)),
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.ref = {v.name: v.valueReference for v in md.modelVariables}
        self.states = [d.variable.derivative.valueReference for d in md.derivatives]
        self.rates = [d.variable.valueReference for d in md.derivatives]
        self.directional = bool(md.coSimulation.providesDirectionalDerivative)
        self.derivatives = (md.coSimulation.maxOutputDerivativeOrder or 0) >= 1
        fmu = self.fmu
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0, stopTime=stop_time)
        if parameters:
            fmu.setReal([self.ref[n] for n in parameters], list(parameters.values()))
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()

    def linear(self, outputs, inputs, h):
        """The outputs' change over a step of h, linearised at the current point, as g + G_step (a - u)
        + G_line s h + D (b - u) for inputs that start at a, run with slope s and end at b (u: their
        values now): (g, G_step, G_line, D) from the FMU's own linear system and its matrix
        exponential; without directional derivatives, g the outputs' first derivatives times h."""
        fmu = self.fmu
        ys = [self.ref[o] for o in outputs]
        us = [self.ref[i] for i in inputs]
        zero = np.zeros((len(ys), len(us)))
        if not self.directional:
            return h * self.output_rates(ys), zero, zero, zero
        nx = len(self.states)
        unknowns = self.rates + ys
        J = np.column_stack([fmu.getDirectionalDerivative(unknowns, [k], [1.0]) for k in self.states + us]) \
            if unknowns and self.states + us else np.zeros((len(unknowns), nx + len(us)))
        A, B, C, D = J[:nx, :nx], J[:nx, nx:], J[nx:, :nx], J[nx:, nx:]
        if nx == 0:          # no declared state: the outputs move along the step as their derivatives say
            return h * self.output_rates(ys), zero, zero, D
        xdot = np.array(fmu.getReal(self.rates))
        phi1, phi2 = _phi(A, h)
        return h * C @ phi1 @ xdot, h * C @ phi1 @ B, h * C @ phi2 @ B, D


    def output_rates(self, refs) -> np.ndarray:
        """The outputs' first derivatives, or zeros where the FMU gives none (a rod string: its
        outputs are held over the step)."""
        if not self.derivatives:
            return np.zeros(len(refs))
        return np.array(self.fmu.getRealOutputDerivatives(list(refs), [1] * len(refs)))


class Master:
    """The FMUs ``fmus`` ({name: path}) coupled by ``coupling``, each FMU's ``parameters`` ({name:
    {variable: value}}) set before initialisation."""

    def __init__(self, fmus: dict, coupling: Coupling, parameters: dict, stop_time: float, folder=None,
                 theta: float = 0.5):
        if not 0.5 <= theta <= 1.0:
            raise ValueError(f"theta must be in [0.5, 1] (0.5: second order; 1: L-stable), got {theta!r}")
        self.theta = theta
        work = Path(folder or tempfile.mkdtemp(prefix="crankfmu-cosim-"))
        self.units = {}
        try:
            for name, path in fmus.items():
                self.units[name] = _Unit(name, path, work, parameters.get(name, {}), stop_time)
        except Exception:
            self.close()
            raise
        self.coupling = coupling
        self.out = [self._split(q) for q in coupling.outputs]
        self.inp = [self._split(q) for q in coupling.inputs]
        self.steps = 0

    def _split(self, qualified):
        name, variable = qualified.split(".", 1)
        return name, self.units[name].ref[variable]

    def read(self, which) -> np.ndarray:
        return np.array([self.units[n].fmu.getReal([r])[0] for n, r in which])

    def set_inputs(self, values, slopes=None):
        for j, (name, ref) in enumerate(self.inp):
            fmu = self.units[name].fmu
            fmu.setReal([ref], [float(values[j])])
            if slopes is not None:
                fmu.setRealInputDerivatives([ref], [1], [float(slopes[j])])

    def consistent(self, z, w=None, h=None, slopes=None):
        """The inputs at the current point made to hold u = M y + N z + c, set and read again while
        an output feeds through from an input; with end values ``w``, each input the line from
        there to w over h, or with ``slopes`` (the outputs read with those slopes set: a
        speed-causal mechanism's tau_drive reads its input's slope). Returns (u, y)."""
        u = None
        for _ in range(5):
            y = self.read(self.out)
            new = self.coupling.inputs_at(y, z)
            if u is not None and np.all(np.abs(new - u) <= TOLERANCE * (1.0 + np.abs(u))):
                break
            u = new
            self.set_inputs(u, (w - u) / h if w is not None else slopes)
        return u, y

    def do_step(self, t, h):
        for unit in self.units.values():
            unit.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        self.steps += 1

    # ------------------------------------------------------------------ the modes' slopes
    def output_rates(self) -> np.ndarray:
        return np.array([self.units[n].output_rates([r])[0] for n, r in self.out])

    def extrapolated(self, y, z) -> np.ndarray:
        cp = self.coupling
        return cp.M @ self.output_rates() + cp.N @ (cp.P @ y + cp.Q @ z if len(z) else z)

    def implicit(self, u, y, z, h):
        """The inputs' start values and slopes for which the coupling holds at t + h on each FMU's
        linear prediction, and the outputs' predicted change over the step. The inputs run as lines
        to their end values b: from u (theta = 0.5, second order, A-stable), or held at b (theta = 1,
        first order, L-stable: a stiff coupling's fast mode damped in one step), or between."""
        cp, theta = self.coupling, self.theta
        p, m, q = len(self.out), len(self.inp), len(z)
        g, G = np.zeros(p), np.zeros((p, m))
        for name, unit in self.units.items():
            rows = [k for k, (n, _) in enumerate(self.out) if n == name]
            cols = [j for j, (n, _) in enumerate(self.inp) if n == name]
            if not rows:
                continue
            names = {v: k for k, v in unit.ref.items()}
            gu, step, line, D = unit.linear([names[self.out[k][1]] for k in rows],
                                            [names[self.inp[j][1]] for j in cols], h)
            g[rows] = gu
            # the line from u + (2 theta - 1) du with slope 2 (1 - theta) du / h to b = u + du
            G[np.ix_(rows, cols)] = (2 * theta - 1) * step + 2 * (1 - theta) * line + D
        # du and dz: du = M (g + G du) + N dz, dz = h (P (y + theta dy) + Q (z + theta dz))
        K = np.block([[np.eye(m) - cp.M @ G, -cp.N],
                      [-theta * h * cp.P @ G, np.eye(q) - theta * h * cp.Q]])
        rhs = np.concatenate([cp.M @ g, h * (cp.P @ y + cp.Q @ z) + theta * h * cp.P @ g])
        du = np.linalg.solve(K, rhs)[:m]
        return u + (2 * theta - 1) * du, 2 * (1 - theta) * du / h, g + G @ du

    def rollback(self, t, h, u, z, guess):
        """One step iterated on the FMUs' real steps until the coupling holds at t + h; returns the
        master's states there."""
        cp = self.coupling
        saved = {n: unit.fmu.getFMUstate() for n, unit in self.units.items()}

        def trial(w):
            for n, unit in self.units.items():
                unit.fmu.setFMUstate(saved[n])
            _, y0 = self.consistent(z, w, h)
            self.do_step(t, h)
            y1 = self.read(self.out)
            z1 = cp.advance(z, y0, y1 - y0, h)
            return w - cp.inputs_at(y1, z1), z1

        try:
            w = u + h * guess
            r, z1 = trial(w)
            delta = 1e-6 * np.maximum(1.0, np.abs(w))
            J = np.empty((len(w), len(w)))
            for j in range(len(w)):
                e = np.zeros(len(w))
                e[j] = delta[j]
                J[:, j] = (trial(w + e)[0] - r) / delta[j]
            for _ in range(NEWTON_ITERATIONS):
                w = w - np.linalg.solve(J, r)
                r, z1 = trial(w)
                if np.all(np.abs(r) <= TOLERANCE * (1.0 + np.abs(w))):
                    break
            return z1
        finally:
            for n, unit in self.units.items():
                unit.fmu.freeFMUstate(saved[n])

    # ------------------------------------------------------------------ the run
    def run(self, stop_time: float, step: float, mode: str, record=(), bound: float = np.inf) -> Coupled:
        """The run; Diverged as soon as a recorded value is beyond ``bound`` in magnitude (a diverging
        coupling spins the FMUs ever faster: they would take ever more integration steps to refuse)."""
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        n_steps = int(round(stop_time / step))
        times = np.arange(n_steps + 1) * step
        recorded = {name: np.empty(n_steps + 1) for name in record}
        watched = [self._split(q) for q in record]
        z = np.array(self.coupling.z0, float)
        for n in range(n_steps + 1):
            u, y = self.consistent(z)
            for name, value in zip(record, self.read(watched)):
                recorded[name][n] = value
                if not abs(value) <= bound:
                    raise Diverged(f"{name} = {value:.6g} at t = {times[n]:.6g} s, beyond {bound:.6g}")
            if n == n_steps:
                break
            t = times[n]
            if mode == "rollback":
                # Newton starts from the lines the FMUs' output derivatives give (held where an FMU gives
                # none): the rod string's load answers its end position with a segment's stiffness, and
                # from held lines the first iterate overshoots by that stiffness times a step's travel
                z = self.rollback(t, step, u, z, self.extrapolated(y, z))
                continue
            if mode == "hold":              # values only, as a zero-order-hold master sets them
                dy = np.zeros(len(y))
            else:
                if mode == "extrapolate":
                    start, slopes, dy = u, self.extrapolated(y, z), step * self.output_rates()
                else:
                    start, slopes, dy = self.implicit(u, y, z, step)
                if np.array_equal(start, u):   # the lines start at the coupling's values, with their slopes set
                    u, y = self.consistent(z, slopes=slopes)
                else:
                    self.set_inputs(start, slopes)
            self.do_step(t, step)
            z = self.coupling.advance(z, y, dy, step, self.theta if mode == "implicit" else 0.5)
        return Coupled(times, recorded, self.steps)

    def close(self):
        for unit in self.units.values():
            unit.fmu.terminate()
            unit.fmu.freeInstance()
        self.units = {}


def cosimulate(fmus: dict, coupling: Coupling, parameters: dict, stop_time: float, step: float, mode: str = "hold",
               record=(), folder: Path | None = None, theta: float = 0.5, bound: float = np.inf) -> Coupled:
    """Run ``fmus`` coupled by ``coupling`` from 0 to ``stop_time`` at the communication step ``step``
    (s) in ``mode`` (MODES), recording ``record`` ("FMU.variable" names) at each communication point;
    ``theta``: the implicit mode's weight of the step's end (Master.implicit); ``bound``: Master.run's."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    master = Master(fmus, coupling, parameters, stop_time, folder, theta)
    try:
        return master.run(stop_time, step, mode, record, bound)
    finally:
        master.close()


def jacobi(fmus: dict, connections, parameters: dict, stop_time: float, step: float, mode: str = "hold",
           record=(), folder: Path | None = None) -> Coupled:
    """``cosimulate`` with plain connections ((from FMU, output, to FMU, input), ...)."""
    return cosimulate(fmus, Coupling.connections(connections), parameters, stop_time, step, mode, record, folder)


def observed_order(steps, errors) -> float:
    """The slope of log(error) against log(step) between the two smallest steps."""
    (h1, e1), (h2, e2) = sorted(zip(steps, errors))[:2]
    return float(np.log(e2 / e1) / np.log(h2 / h1))
