"""The C mechanism model (crank_mechanism.c) from Python: a compiled scenario (dynamics.program)
bound to parameter values, its engine evaluated and its table built in C.

numpy and ctypes only. ``CModel`` owns one mm_model; ``table()`` gives the kernel's table as
dynamics.tabulated.ReducedTable does, ``engine(phi1)`` the table's functions at any angles
(what the tests compare with the Python engine).
"""

from __future__ import annotations

import ctypes
import time
import weakref

import numpy as np

from . import LIBRARY

I, D = ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_double)
#: the tables a model gives (crank_mechanism.h's MM_TABLE_...)
REDUCED, QUANTITIES, REACTIONS, FRICTION = range(4)
#: what each table holds, as the build's and check's messages name it
TABLE_NAMES = {REDUCED: "the movement equation", QUANTITIES: "[[outputs]] and ports", REACTIONS: "joint reactions",
               FRICTION: "the joints' friction"}
#: crank_mechanism.h's MM_MAX_SWITCHES and MM_MAX_FRICTIONS
MAX_SWITCHES, MAX_FRICTIONS = 64, 16

#: crank_mechanism.h's error codes, and what each says (the Python engine's words)
ERRORS = {
    -1: "the contour equations have no real solution",
    -2: "the contour Jacobian is singular (dead point)",
    -3: "Newton's method did not converge",
    -4: "Newton's method did not converge from the file's guess",
    -5: "the continuation lost the assembly",
    -6: "after one crank turn an unknown does not return to its start (branch change)",
    -7: "the mechanism passes a dead point (the contour Jacobian's determinant changes sign)",
    -8: "the mechanism locks at a dead point",
    -9: "the closed form does not satisfy the contour equations",
    -10: "a value is negative or not finite",
    -11: "a rocker load's link does not have two extreme positions per crank turn",
    -12: "a direction-dependent load's coordinate never changes direction",
    -13: "a function of the table cannot be tabulated to its tolerance with 65536 intervals",
    -14: "out of memory",
    -15: "too many switch angles",
    -16: "a function of the table is not finite (or beyond 1e150)",
    -17: "a closed form's unknown jumps along the turn (not a whole turn)",
}


class MMProgram(ctypes.Structure):
    _fields_ = [("n_registers", ctypes.c_int), ("n_code", ctypes.c_int), ("code", I), ("literals", D),
                ("n_sections", ctypes.c_int), ("sections", I), ("n_q", ctypes.c_int), ("n_contours", ctypes.c_int),
                ("n_chains", ctypes.c_int), ("n_terms", ctypes.c_int), ("terms", I),
                ("n_angles", ctypes.c_int), ("angles", I), ("chain_constants", I),
                ("angle_column", I), ("closed_form", ctypes.c_int), ("guess", ctypes.c_int), ("phi1", ctypes.c_int),
                ("kinematics", ctypes.c_int), ("n_points", ctypes.c_int), ("omega1", ctypes.c_int),
                ("n_rows", ctypes.c_int), ("rows", I), ("n_columns", ctypes.c_int), ("columns", I),
                ("n_searches", ctypes.c_int), ("searches", I), ("n_checks", ctypes.c_int), ("checks", I),
                ("min_conditioning", ctypes.c_double), ("n_coordinates", ctypes.c_int), ("coordinates", I),
                ("n_links", ctypes.c_int), ("links", I), ("crank", ctypes.c_int), ("n_joints", ctypes.c_int),
                ("joints", I), ("n_terms_reaction", ctypes.c_int), ("term_inertia", I), ("n_applied", ctypes.c_int),
                ("applied", I), ("cycle_turns", ctypes.c_int), ("law_speed", ctypes.c_int), ("laws", I),
                ("n_frictions", ctypes.c_int), ("frictions", I)]


class MMModel(ctypes.Structure):
    _fields_ = [("program", ctypes.c_void_p), ("registers", D), ("length_scale", ctypes.c_double),
                ("turn_start", ctypes.c_double), ("turn", D), ("winding", D), ("have_turn", ctypes.c_int),
                ("error_angle", ctypes.c_double), ("error_value", ctypes.c_double), ("error_index", ctypes.c_int),
                ("n_switches", ctypes.c_int), ("switches", ctypes.c_double * MAX_SWITCHES), ("forces", D),
                ("worst_conditioning", ctypes.c_double), ("worst_angle", ctypes.c_double), ("scan", D),
                ("coordinate_winding", D), ("reaction_kept", I), ("have_quantity_winding", ctypes.c_int),
                ("have_reaction_mask", ctypes.c_int), ("error_step", ctypes.c_double), ("error_jumps", ctypes.c_int),
                ("law_ready", ctypes.c_int), ("n_active", ctypes.c_int), ("active", ctypes.c_int * MAX_FRICTIONS),
                ("moving", ctypes.c_int * MAX_FRICTIONS), ("rate_peak", ctypes.c_double * MAX_FRICTIONS),
                ("friction_signs", ctypes.c_double * (MAX_SWITCHES * MAX_FRICTIONS)), ("friction_kept", I),
                ("have_friction_mask", ctypes.c_int)]


class MechanismError(Exception):
    """The C model refused the values: ``code`` (crank_mechanism.h), where (rad) and which."""

    def __init__(self, code: int, angle: float, index: int, value: float):
        self.code, self.angle, self.index, self.value = code, angle, index, value
        super().__init__(f"{ERRORS.get(code, f'error {code}')} (phi1 = {np.degrees(angle) % 360:.3f} deg)")


def _ints(a):
    a = np.ascontiguousarray(a, dtype=np.int32)
    return a, a.ctypes.data_as(I)


def _struct(program) -> tuple:
    """(mm_program, the arrays it points into) of a compiled program, built once per program."""
    cached = getattr(program, "_c_struct", None)
    if cached is not None:
        return cached
    keep = []

    def ints(a):
        arr, ptr = _ints(a)
        keep.append(arr)
        return ptr
    literals = np.ascontiguousarray(program.literals, dtype=float)
    keep.append(literals)
    s = MMProgram()
    s.n_registers, s.n_code, s.code = program.n_registers, len(program.code), ints(program.code)
    s.literals = literals.ctypes.data_as(D)
    s.n_sections, s.sections = len(program.sections), ints(program.sections)
    s.n_q, s.n_contours, s.n_chains = program.n_q, program.n_contours, program.n_chains
    s.n_terms, s.terms = len(program.terms), ints(program.terms)
    s.n_angles, s.angles = len(program.angles), ints(program.angles)
    s.chain_constants, s.angle_column = ints(program.chain_constants), ints(program.angle_column)
    s.closed_form, s.guess, s.phi1 = program.closed_form, program.guess, program.phi1
    s.kinematics, s.n_points, s.omega1 = program.kinematics, program.n_points, program.omega1
    s.n_rows, s.rows = len(program.rows), ints(program.rows)
    s.n_columns, s.columns = len(program.columns), ints(program.columns)
    s.n_searches, s.searches = len(program.searches), ints(program.searches)
    s.n_checks, s.checks = len(program.checks), ints(program.checks)
    s.min_conditioning = program.min_conditioning
    s.n_coordinates, s.coordinates = len(program.coordinates), ints(program.coordinates)
    s.n_links, s.links, s.crank = len(program.links), ints(program.links), program.crank
    s.n_joints, s.joints = len(program.joints), ints(program.joints)
    s.n_terms_reaction, s.term_inertia = len(program.term_inertia), ints(program.term_inertia)
    s.n_applied, s.applied = len(program.applied), ints(program.applied)
    s.cycle_turns = program.cycle_turns
    s.law_speed, s.laws = program.law_speed, ints(program.laws)
    s.n_frictions, s.frictions = len(program.frictions), ints(program.frictions)
    program._c_struct = (s, keep)
    return program._c_struct


class CModel:
    """A compiled scenario at parameter values: assembly checked, loads' switch angles found."""

    def __init__(self, program, parameters: np.ndarray):
        self.program = program
        lib = LIBRARY
        s, keep = _struct(program)
        self._keep, self._struct, self._lib = keep, s, lib
        self._model = MMModel()
        self._parameters = np.ascontiguousarray(parameters, dtype=float)
        started = time.perf_counter()
        self._raise(lib.mm_bind(ctypes.byref(self._model), ctypes.byref(s), self._parameters.ctypes.data_as(D),
                                len(self._parameters)))
        self._raise(lib.mm_prepare(ctypes.byref(self._model)))
        self.prepare_time = time.perf_counter() - started

    def _raise(self, status: int):
        if status:
            m = self._model
            raise MechanismError(status, m.error_angle, m.error_index, m.error_value)

    def __del__(self):
        lib = getattr(self, "_lib", None)
        if lib is not None:
            lib.mm_free(ctypes.byref(self._model))

    def found(self) -> dict[int, dict[str, float]]:
        """What the loads' searches found, by the load's index in the scenario file: a rocker's
        extremes {"phi1d", "phi1a"} (rad), a slider's {"low", "high"} (m) (Program.found)."""
        r = np.ctypeslib.as_array(self._model.registers, (self.program.n_registers,))
        out: dict[int, dict[str, float]] = {}
        for index, name, register in self.program.found:
            out.setdefault(index, {})[name] = float(r[register])
        return out

    @property
    def worst_conditioning(self) -> tuple[float, float]:
        """(worst conditioning over the turn, crank angle rad where it is)."""
        return self._model.worst_conditioning, self._model.worst_angle

    def engine(self, phi1, table: int = REDUCED) -> np.ndarray:
        """A table's functions (rows, len(phi1)) at the crank angles: REDUCED, QUANTITIES or REACTIONS."""
        phi1 = np.ascontiguousarray(np.atleast_1d(phi1), dtype=float)
        out = np.empty((self._lib.mm_rows(ctypes.byref(self._model), table), phi1.size))
        self._raise(self._lib.mm_engine(ctypes.byref(self._model), table, phi1.ctypes.data_as(D), phi1.size,
                                        out.ctypes.data_as(D)))
        return out

    @property
    def winding(self) -> np.ndarray:
        """Whole turns per crank turn of each [[outputs]] or port coordinate (after a QUANTITIES table)."""
        n = len(self.program.coordinates)
        if not self._model.have_quantity_winding:
            return np.zeros(n)
        return np.ctypeslib.as_array(self._model.coordinate_winding, (max(n, 1),))[:n].copy()

    def registers(self, phi1: float) -> np.ndarray:
        """Every register after the kinematics and the rows at phi1 (the tests read the positions,
        transfer functions and points there)."""
        self._raise(self._lib.mm_evaluate(ctypes.byref(self._model), float(phi1)))
        return np.ctypeslib.as_array(self._model.registers, (self.program.n_registers,)).copy()

    def schedule(self):
        """(switch_angles rad, forces N (max(m, 1), 2, columns)), as loads.slider_schedule."""
        m = self._model
        n, nc = m.n_switches, len(self.program.columns)
        switches = np.array(m.switches[:n], dtype=float)
        forces = np.ctypeslib.as_array(m.forces, (max(n, 1) * 2 * max(nc, 1),))[:max(n, 1) * 2 * nc].copy()
        return switches, forces.reshape(max(n, 1), 2, nc)

    @property
    def reaction_terms(self) -> int:
        """The reaction table's terms at these values (its loads', then each active friction's)."""
        return self._lib.mm_reaction_terms(ctypes.byref(self._model))

    @property
    def active_frictions(self) -> np.ndarray:
        """The declared joint frictions (Program.frictions' rows) active at these values (mu > 0)."""
        return np.array(self._model.active[:self._model.n_active], dtype=int)

    def friction(self):
        """(components (n_f,), c (n_f,), signs (max(m, 1), n_f)) of the active joint frictions, as
        friction_table.FrictionTable holds them; None without any."""
        m, n_f = self._model, self._model.n_active
        if n_f == 0:
            return None
        joints = self.program.frictions[self.active_frictions, 0]
        components = np.where(self.program.joints[joints, 0] == 1, 1, 2).astype(np.int32)
        r = np.ctypeslib.as_array(m.registers, (self.program.n_registers,))
        c = r[self.program.frictions[self.active_frictions, 1]].copy()
        signs = np.array(m.friction_signs[:max(m.n_switches, 1) * n_f], dtype=float).reshape(-1, n_f)
        return components, c, signs

    def table(self, tolerance: float = 1e-11):
        """(coefficients (rows, m, 4), switch angles, forces, checked error bound, construction):
        the reduced model's table built in C (dynamics.tabulated.c_table wraps it)."""
        coefficients, error, construction = self.cubics(REDUCED, tolerance)
        return (coefficients, *self.schedule(), error, construction)

    def cubics(self, table: int, tolerance: float):
        """(coefficients (rows, m, 4), checked error bound, construction) of a table."""
        cubics = ctypes.POINTER(ctypes.c_double)()
        m, error, n = ctypes.c_int(), ctypes.c_double(), ctypes.c_int()
        self._raise(self._lib.mm_tabulate(ctypes.byref(self._model), table, tolerance, ctypes.byref(cubics),
                                          ctypes.byref(m), ctypes.byref(error), ctypes.byref(n)))
        rows = self._lib.mm_rows(ctypes.byref(self._model), table)
        if rows * m.value:
            # the C buffer itself, not a copy (a table is up to a few MB): freed with the array
            flat = np.ctypeslib.as_array(cubics, (rows * m.value * 4,))
            weakref.finalize(flat, self._lib.mm_release, cubics)
            coefficients = flat.reshape(rows, m.value, 4)
        else:
            self._lib.mm_release(cubics)
            coefficients = np.zeros((rows, m.value, 4))
        turns = self._lib.mm_table_turns(ctypes.byref(self._model), table)
        over = f" over a cycle of {turns} turns" if turns != 1 else ""
        if n.value == 0:
            return coefficients, error.value, f"cubic spline of {m.value} samples{over}, in C"
        return (coefficients, error.value,
                f"Fourier series of {n.value} samples, Hermite cubics on {m.value} intervals{over}, in C")


class LawEvaluator:
    """The laws of the speed of a table's columns (dynamics/speed_laws.py) evaluated in C by the
    C model's own rule (crank_mechanism.c's mm_law on a LAWS section): what the Python paths give
    the kernel (native.Tables), so that a law costs them what it costs the native FMU, not a Python
    call per evaluation. ``sources[s]`` column s's law (None: none), ``env`` the values it reads;
    the registers hold those values, the section computes each law from the speed's register."""

    def __init__(self, sources, env: dict):
        from ..dynamics.program import LAWS, _Code

        code = _Code(0)
        registers: dict[int, float] = {}
        names = {}
        for source in sources:
            if source is None:
                continue
            from ..expressions import Expression
            for name in Expression(source, "a law of the speed").names - {"omega1"}:
                if name not in names:
                    names[name] = code.register()
                    registers[names[name]] = float(env[name])
        speed = code.register()
        code.begin(LAWS)
        laws = [-1 if s is None else code.expression(s, {**names, "omega1": speed}, "a law of the speed")
                for s in sources]
        code.end()
        sections = np.array([code.sections.get(i, (0, 0)) for i in range(LAWS + 1)], dtype=np.int32)
        keep = []

        def ints(a):
            arr, ptr = _ints(a)
            keep.append(arr)
            return ptr
        literals = np.ascontiguousarray(code.literals or [0.0], dtype=float)
        self.registers = np.zeros(code.n)
        for r, v in registers.items():
            self.registers[r] = v
        program = MMProgram()
        program.n_registers, program.n_code = code.n, len(code.code)
        program.code = ints(np.array(code.code, dtype=np.int32).reshape(-1, 5))
        program.literals = literals.ctypes.data_as(D)
        program.n_sections, program.sections = len(sections), ints(sections)
        program.n_columns, program.law_speed, program.laws = len(sources), speed, ints(laws)
        model = MMModel()
        model.program = ctypes.addressof(program)
        model.registers = self.registers.ctypes.data_as(D)
        self._keep = (keep, literals, program)
        self.model = model
        #: (the C function, its context) for crank_kernel.h's CkTables.law and law_context
        self.function = ctypes.cast(LIBRARY.mm_law, ctypes.c_void_p).value
        self.context = ctypes.addressof(model)

    def __call__(self, column: int, omega: float) -> float:
        return LIBRARY.mm_law(self.context, column, omega)
