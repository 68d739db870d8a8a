"""Each FMU's ``documentation/index.html`` (FMI 2.0's place for it; fmpy's GUI shows it), written for
the engineer who uses the FMU: what the FMU is (Python or native, FMI version, interfaces,
platforms, what the host needs), the mechanism's drawing, the equations it solves (MathML, rendered
by the browser), its parameters grouped (geometry, masses, loads, motor, start, solver) with when
each may change, its inputs and outputs, the default experiment with the reference result's plot.

Built with the FMU (``fmi.python.build``, ``fmi.native.build``) from what the FMU is made of: the
completed modelDescription (variables, units, ranges, variability, interfaces, the build), the
data file (title, citation, contours, branch) and the reference result the FMU carries. The
equations are stated once here, in the expression syntax of the data files (``pages.mathml``
turns them into MathML); each names the module that implements it. Nothing here runs inside the FMU.
"""

from __future__ import annotations

import hashlib
import html
import io
from dataclasses import fields
from xml.etree import ElementTree as ET

from ..pages.markup import page
from ..scenario import in_words
from ..pages.mathml import math

#: the reduced model and the movement equation (dynamics.reduced, dynamics.equation): text, what it says
MECHANISM_EQUATIONS = (
    ("J(phi1) == J_flywheel + sum(m_j*(t_j**2 + p_j**2) + I_j*q_j**2)",
     "the reduced moment of inertia at the crank: each link's mass m_j and central inertia I_j through its mass "
     "centre's transfer functions t_j = dx_j/dphi1, p_j = dy_j/dphi1 and its angle's q_j = dphi_j/dphi1"),
    ("0.5*J_prime(phi1) == sum(m_j*(t_j*t_j_prime + p_j*p_j_prime) + I_j*q_j*q_j_prime)",
     "half its derivative, from the second transfer functions t_j' = dt_j/dphi1, p_j' and q_j'"),
    ("Q(phi1, omega1) == sum(F_jx*t_j + F_jy*p_j + M_j*q_j)",
     "the loads reduced to the crank by virtual power: weights, viscous and slider forces, the data file's "
     "loads (F_j, M_j on link j)"),
    ("J(phi1)*der(omega1) + 0.5*J_prime(phi1)*omega1**2 == M_motor(omega1) + Q(phi1, omega1) + tau_e",
     "the movement equation (Lagrange's for one coordinate); tau_e is the input tau_ext plus each port's input "
     "times its transfer function"),
    ("der(phi1) == omega1", "the crank angle; it keeps growing past 2 pi (the angles of other links count their turns)"),
    ("E_kin == 0.5*J(phi1)*omega1**2", "the kinetic energy of the whole mechanism"),
    ("E_kin - E_kin0 == W_motor + W_load + W_ext",
     "the energy balance the FMU's outputs close: the works are integrated with the motion"),
)
MOTOR_EQUATIONS = (
    ("M_motor == A - B*omega1", "the motor's working line, for omega1 > omega_switch"),
    ("M_motor == A_low - B_low*omega1", "its start-up line, for omega1 <= omega_switch"),
)
SPEED_EQUATIONS = (
    ("tau_drive == J(phi1)*der(omega1) + 0.5*J_prime(phi1)*omega1**2 - Q(phi1, omega1) - tau_e",
     "speed causality: the crank speed omega1 is an input; the FMU returns the torque the drive must give "
     "(inverse dynamics)"),
    ("der(phi1) == omega1", "the crank angle, integrated from the input"),
)
DRIVE_EQUATIONS = (
    ("u == K_p*e + K_i*x", "armature voltage from the PI controller; e = omega_set - omega"),
    ("L*der(i) == u - R*i - k_t*n_gear*omega", "the armature circuit; the motor turns n_gear times faster than the crank"),
    ("der(x) == e", "the controller's integral of the speed error"),
    ("tau == n_gear*k_t*i", "the torque on the crank (an ideal reducer)"),
)
DRIVE_SPEED_EQUATIONS = (
    ("J_drive*der(omega) == n_gear*k_t*i - tau_load",
     "speed causality: the drive carries the rotor and flywheel (J_drive at the crank) and outputs the speed"),
)
CUSHION_EQUATIONS = (
    ("F == -(k*(d - L_free) + c*der(d))", "the force on the ram along the port's axis; d = s - s_seat"),
)
SHAFT_EQUATIONS = (
    ("der(twist) == omega_a - omega_b", "the twist, phi_a - phi_b: side a is the drive's, side b the machine's crank"),
    ("tau == k*twist + c*(omega_a - omega_b)", "the torque passed from side a to side b: it drives b and loads a"),
)
RODSTRING_EQUATIONS = (
    ("rho*A*u_tt == dx(E*A*u_x) - c*rho*A*u_t + w_b",
     "Gibbs' damped wave equation for the rods' displacement u(x, t), downward positive, x the depth"),
    ("w_b == rho*A*g*(1 - rho_fluid/rho_steel)", "the buoyant weight per length"),
    ("c == pi*nu*a/(2*L)", "Gibbs' viscous damping: the fraction nu of critical on the first mode"),
)

#: the parameter groups of a mechanism FMU's page, in order, and the units that put a parameter there
GROUPS = ("geometry", "masses and inertias", "loads", "motor", "start", "solver", "other")
_UNIT_GROUP = {"m": "geometry", "rad": "geometry", "deg": "geometry", "kg": "masses and inertias",
               "kg/m": "masses and inertias", "kg.m2": "masses and inertias", "N": "loads", "N.m": "loads",
               "N.s/m": "loads", "N.m.s/rad": "loads", "m/s2": "loads", "1": "solver", "": "solver"}


def motor_parameters() -> set[str]:
    from ..dynamics.motor import MotorLine

    return {f.name for f in fields(MotorLine)}


def group_of(name: str, unit: str, motor: set[str]) -> str:
    """A parameter's group: the start values by name, the motor's by the motor model's fields, the
    rest by unit (lengths and angles: geometry; kg, kg/m, kg.m2: masses; forces and torques: loads)."""
    if name.endswith("_start"):
        return "start"
    if name in motor:
        return "motor"
    return _UNIT_GROUP.get(unit, "other")


def _equations(rows) -> str:
    return "\n".join(f'<div class="equation">{math(text)}<p class="note">{html.escape(why)}</p></div>'
                     for text, why in rows)


def _variables(model_description: bytes):
    """(the variable's element, an element with its start, min, max and unit) of each variable of an
    FMI 2.0 or 3.0 modelDescription (3.0: the unit from the variable or its declared type)."""
    root = ET.fromstring(model_description)
    if root.get("fmiVersion", "").startswith("3"):
        types = {t.get("name"): t.get("unit") for t in root.iter("Float64Type")}
        for v in root.find("ModelVariables"):
            if v.get("causality") in ("independent", "local"):
                continue
            real = ET.Element("Real", {k: v.get(k) for k in ("start", "min", "max") if v.get(k) is not None})
            unit = v.get("unit") or types.get(v.get("declaredType"))
            if unit:
                real.set("unit", unit)
            yield v, real
        return
    for sv in root.find("ModelVariables"):
        real = sv.find("Real")
        yield sv, (real if real is not None else ET.Element("Real"))


def what_it_is(model_description: bytes, about: dict) -> str:
    """A table: the build, the FMI version and interfaces, the platforms, what the host needs, the
    tables' checked error bound, the data files."""
    root = ET.fromstring(model_description)
    interfaces = [t for t in ("CoSimulation", "ModelExchange") if root.find(t) is not None]
    native = about.get("build") == "native"
    rows = [
        ("build", ("native: C, the model tabulated by crankfmu's C mechanism model when the FMU initialises, "
                   "at the values set, and stepped by crankfmu's C kernel"
                   if "table_error" in about else "native: C, the component's model compiled in "
                   "(crank_components.c, the C its Python FMU runs too)") if native
         else "Python: pythonfmu runs crankfmu's model in the host's Python"),
        ("FMI", f"{root.get('fmiVersion')}, {' and '.join(interfaces).replace('CoSimulation', 'Co-Simulation').replace('ModelExchange', 'Model Exchange')}"),
        ("platforms", ", ".join(about.get("platforms", [])) or "-"),
        ("the host needs", "nothing but the platform's C library" if native
         else "Python 3.10 to 3.13 with numpy, found as resources/python_env.txt says"),
        ("generated", f"by {root.get('generationTool', 'crankfmu')}"),
    ]
    if "table_error" in about:
        rows.append(("tables", f"cubics over the crank turn, each checked against the C model's own evaluation when "
                               f"built; at the file's values the largest relative error is {about['table_error']:.2g} "
                               "of each function's largest magnitude"))
    return "<table>" + "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in rows) + "</table>"


def parameter_tables(model_description: bytes, parameters: dict, grouped: bool) -> str:
    """The parameters, grouped, each with its value, unit, valid range, when it may change and what it is."""
    motor = motor_parameters()
    groups: dict[str, list[str]] = {}
    for sv, real in _variables(model_description):
        if sv.get("causality") != "parameter":
            continue
        name, unit = sv.get("name"), real.get("unit", "")
        p = parameters.get(name)
        built = real.get("min") is not None and real.get("min") == real.get("max") == real.get("start")
        if built:
            when = "fixed when the FMU was built (crankfmu fmu --native --set rebuilds it)"
            span = f"{real.get('start')} {unit}".strip()
        elif sv.get("variability") == "tunable":
            when = "tunable: between communication steps"
            span = p.range_text() if p is not None else ""
        else:
            when = "fixed: before initialisation (and after a reset)"
            span = p.range_text() if p is not None else ""
        description = (p.description if p is not None else sv.get("description", "")).strip()
        key = group_of(name, unit, motor) if grouped else "parameters"
        groups.setdefault(key, []).append(
            "<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in (name, real.get("start", ""), unit, span, when,
                                                                    description)) + "</tr>")
    head = "<tr><th>name</th><th>start</th><th>unit</th><th>valid range</th><th>when it may change</th><th>what it is</th></tr>"
    order = GROUPS if grouped else ("parameters",)
    return "\n".join((f"<h3>{html.escape(g.capitalize())}</h3>" if grouped else "")
                     + f"<table>{head}{''.join(groups[g])}</table>" for g in order if g in groups)


def signals_table(model_description: bytes) -> str:
    """The inputs and outputs: name, causality, unit, start, description."""
    rows = []
    for sv, real in _variables(model_description):
        if sv.get("causality") not in ("input", "output"):
            continue
        rows.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in (
            sv.get("name"), sv.get("causality"), real.get("unit", ""), real.get("start", ""),
            sv.get("description", ""))) + "</tr>")
    return ("<table><tr><th>name</th><th>causality</th><th>unit</th><th>start</th><th>what it is</th></tr>"
            + "".join(rows) + "</table>")


def experiment_plot(reference_csv: str, title: str) -> bytes:
    """PNG of the reference result over the default experiment: omega1 and the motor torque (phi1
    and the drive torque in speed causality); drawn once per result, title and code (the per-user
    cache keeps it: matplotlib's import and drawing are most of a native build without compilers)."""
    from ..cache import kept
    from .reference import code_digest

    key = hashlib.sha256(repr((reference_csv, title, code_digest())).encode()).hexdigest()[:24]
    return kept("figures", f"experiment_{key}.png", lambda: _experiment_plot(reference_csv, title))


def _experiment_plot(reference_csv: str, title: str) -> bytes:
    import numpy as np

    from ..plots import pyplot

    lines = reference_csv.strip().splitlines()
    header = [h.strip('"') for h in lines[0].split(",")]
    data = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    col = {h: data[:, i] for i, h in enumerate(header)}
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    # torque causality: omega1 and the motor torque; speed causality: phi1 and the drive torque
    first, unit = ("omega1", "rad/s") if "omega1" in col else ("phi1", "rad")
    torque = "M_motor" if "M_motor" in col else "tau_drive"
    a1.plot(col["time"], col[first], lw=1.3)
    a1.set_ylabel(f"{first} [{unit}]")
    a1.set_title(title, fontsize=10)
    a2.plot(col["time"], col[torque], lw=1.3, color="C1")
    if "J_red" in col:
        a2b = a2.twinx()
        a2b.plot(col["time"], col["J_red"], lw=1.0, color="C2")
        a2b.set_ylabel("J_red [kg.m2]", color="C2")
    a2.set_ylabel(f"{torque} [N.m]", color="C1")
    a2.set_xlabel("time [s]")
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()


def mechanism_png(scenario) -> bytes:
    """The scenario's drawing (its [drawing] angle and overlays) as PNG, drawn once per design and
    code (the per-user cache keeps it, as experiment_plot's)."""
    from ..cache import kept
    from .reference import design_digest

    return kept("figures", f"mechanism_{design_digest(scenario)}.png", lambda: _mechanism_png(scenario))


def _mechanism_png(scenario) -> bytes:
    from ..plots import pyplot
    from ..pictures.draw import draw_figure, drawing_section

    section = drawing_section(scenario)
    fig = draw_figure(scenario, float(section.get("at_deg", 0.0)), section.get("show", []),
                      trace=section.get("trace", []), caption=section.get("caption", ""))
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    pyplot().close(fig)
    return buf.getvalue()


def _experiment_text(experiment) -> str:
    return (f"start {experiment.start_time:g} s, stop {experiment.stop_time:g} s, communication step "
            f"{experiment.output_interval:g} s, relative tolerance {experiment.tolerance:g}")


def _use(name: str, native: bool) -> str:
    me = (f"\nfmpy simulate {name}.fmu --interface-type ModelExchange --solver CVode" if native else "")
    # each line runs as printed with fmpy alone (tests/test_documented_commands.py); fmpy's
    # --show-plot needs plotly and a browser, so the page writes a CSV instead
    return f"""<h2>Use</h2>
<pre>fmpy simulate {html.escape(name)}.fmu --output-file {html.escape(name)}_out.csv
fmpy simulate {html.escape(name)}.fmu --start-values J_flywheel 0.5{html.escape(me)}</pre>
<p>A refused value (out of its valid range, not finite, a fixed parameter after initialisation) returns
fmi2Error with one message naming the parameter and its valid range, whatever the host's logging setting;
the instance stays usable (set a good value, or reset it).</p>"""


def has_motor(scenario) -> bool:
    """Whether the scenario's motor line gives a torque (an engine's is zero: its gas drives it)."""
    return any(scenario.values.get(k, 0.0) != 0.0 for k in ("A", "B", "A_low", "B_low"))


def machine_words(scenario, speed: bool = False) -> str:
    """What the machine is, from its file: what drives the crank, its flywheel, its loads (their
    [[loads]] descriptions) and a machine cycle of several turns."""
    if speed:
        drive = "a planar mechanism whose crank speed is the input"
    else:
        drive = ("a planar mechanism driven by its crank's motor line" if has_motor(scenario)
                 else "a planar mechanism with no motor on its crank (its motor line is zero: the loads drive it)")
    J = scenario.values.get("J_flywheel", 0.0)
    flywheel = f"{J:g} kg.m2 of flywheel on the crank" if J else "no flywheel"
    weightless = scenario.values.get("g", 9.81) == 0.0           # an engine's file: its weights are nothing
    words = list(dict.fromkeys(w for w, spec in zip(scenario.load_words(), scenario.data.get("loads", []))
                               if not (weightless and spec.get("kind") == "weights")))
    loads = in_words(words, "no loads")
    cycle = (f"; the loads repeat over a machine cycle of {scenario.cycle_turns} turns "
             f"({360 * scenario.cycle_turns} deg)" if scenario.cycle_turns > 1 else "")
    return f"{drive}, {flywheel}, the loads: {loads}{cycle}"


def scenario_documentation(name: str, scenario, model_description: bytes, parameters: dict,
                           reference_csv, speed: bool = False, **about) -> dict[str, bytes]:
    """documentation/ files of a mechanism FMU: index.html, mechanism.png, default_experiment.png.
    ``reference_csv``: the reference run's CSV, None, or a function that waits for the run (called
    once the mechanism is drawn: the drawing is made while the run goes on beside it).
    ``speed``: the FMU is speed-causal. ``about``: ``build`` ("python" or "native"), ``platforms``,
    and a native FMU's ``table_error``."""
    definition = scenario.mechanism_definition()
    native = about.get("build") == "native"
    files = {"documentation/mechanism.png": mechanism_png(scenario)}
    if callable(reference_csv):
        reference_csv = reference_csv()
    contours = "\n".join(f'<div class="equation">{math(text + " == 0")}<p class="note">contour '
                         f"{html.escape(cname)}</p></div>" for cname, text in definition.contour_sources)
    plot = ""
    # (a speed-causal FMU whose input starts at 0 has no reference: a drive holding the crank still)
    if reference_csv:
        files["documentation/default_experiment.png"] = experiment_plot(
            reference_csv, f"{name}.fmu, default experiment (reference result)")
        plot = ('<p><img src="default_experiment.png" alt="the reference result over the default experiment"></p>')
    citation = scenario.data.get("citation") or scenario.data.get("source", definition.source)
    solver = ("The Co-Simulation interface integrates the movement equation with Dormand-Prince 5(4) (the C "
              "kernel) on the tables, locating every switch of the motor line and the slider forces inside a step; "
              "Model Exchange gives the host the same right-hand side and the switches as event indicators."
              if native else
              "The FMU integrates the movement equation with Dormand-Prince 5(4) (crankfmu's C kernel on the "
              "tabulated model, computed when the FMU initialises), locating every switch inside a step; the joint "
              "reactions come from Newton-Euler at the step's state.")
    body = f"""<h1>{html.escape(name)}.fmu</h1>
<p>{html.escape(scenario.title)}: {html.escape(machine_words(scenario, speed))}, as a Functional Mock-up Unit. Built by crankfmu from the scenario file <code>{html.escape(scenario.name)}</code>
and the mechanism file <code>{html.escape(definition.name)}</code> ({html.escape(definition.title)}); every value in SI units.
Source: {html.escape(citation)}.</p>
{what_it_is(model_description, about)}
<p><img src="mechanism.png" alt="the mechanism {html.escape(definition.name)}"></p>

<h2>Equations</h2>
<p>Positions: every link's position follows from the crank angle phi1 through the mechanism's independent
contours (closed vector chains, u(a) = (cos a, sin a)), solved on the assembly branch where
{html.escape(definition.branch)}:</p>
{contours}
<p>The reduced model, one coordinate (the crank angle):</p>
{_equations(MECHANISM_EQUATIONS if not speed else MECHANISM_EQUATIONS[:3] + SPEED_EQUATIONS)}
{"" if speed or not has_motor(scenario) else "<p>The motor:</p>" + _equations(MOTOR_EQUATIONS)}
<p>{html.escape(solver)}</p>

<h2>Parameters</h2>
{parameter_tables(model_description, parameters, grouped=True)}

<h2>Inputs and outputs</h2>
{signals_table(model_description)}

<h2>Default experiment</h2>
<p>{html.escape(_experiment_text(scenario.experiment))}.</p>
{plot}
<p>Reference result: <code>extra/org.fmi-standard.fmi-ls-ref/{html.escape(name)}_out.csv</code>, the default
experiment's outputs from crankfmu's in-process reference integrator (scipy's DOP853 on the contour
engine, rtol = atol = 1e-12), a method independent of the FMU's own.</p>
{_use(name, native)}
"""
    files["documentation/index.html"] = page(f"{name}.fmu", body)
    return files


def component_documentation(name: str, data_file, equations, role_html: str, model_description: bytes,
                            parameters: dict, **about) -> dict[str, bytes]:
    """documentation/index.html of an FMU that is not a mechanism (a drive, a cushion, a rod
    string): what it does for a mechanism FMU (``role_html``), its equations, what it is, its
    parameters, inputs and outputs, and default experiment."""
    body = f"""<h1>{html.escape(name)}.fmu</h1>
<p>{html.escape(data_file.title)}. Built by crankfmu from the file <code>{html.escape(data_file.name)}</code>;
every value in SI units. {role_html}</p>
{what_it_is(model_description, about)}
<h2>Equations</h2>
{_equations(equations)}
<h2>Parameters</h2>
{parameter_tables(model_description, parameters, grouped=False)}
<h2>Inputs and outputs</h2>
{signals_table(model_description)}
<h2>Default experiment</h2>
<p>{html.escape(_experiment_text(data_file.experiment))}.</p>
"""
    return {"documentation/index.html": page(f"{name}.fmu", body)}


def drive_documentation(name: str, drive_file, model_description: bytes, parameters: dict,
                        speed_causal: bool = False, **about) -> dict[str, bytes]:
    """documentation/index.html of Drive.fmu, or of its speed-causal variant."""
    role = ("It drives a speed-causal mechanism FMU through its <code>omega1</code> input and takes its "
            "<code>tau_drive</code> (FourBarDriveSpeed.ssp: <code>crankfmu ssp</code>)." if speed_causal else
            "It drives a mechanism FMU through its <code>tau_ext</code> input (FourBarDrive.ssp: "
            "<code>crankfmu ssp</code>).")
    equations = DRIVE_EQUATIONS + (DRIVE_SPEED_EQUATIONS if speed_causal else ())
    return component_documentation(name, drive_file, equations, role + " Between two communication points the "
                                   "inputs are held and the linear system is stepped exactly.", model_description,
                                   parameters, **about)


def cushion_documentation(name: str, cushion_file, model_description: bytes, parameters: dict,
                          **about) -> dict[str, bytes]:
    """documentation/index.html of the die cushion FMU."""
    return component_documentation(name, cushion_file, CUSHION_EQUATIONS, "It acts on a mechanism FMU's force port "
                                   "(PressCushion.ssp: <code>crankfmu ssp</code>).", model_description, parameters,
                                   **about)


def shaft_documentation(name: str, shaft_file, model_description: bytes, parameters: dict,
                        **about) -> dict[str, bytes]:
    """documentation/index.html of the elastic shaft FMU."""
    return component_documentation(name, shaft_file, SHAFT_EQUATIONS, "It sits between a drive in speed causality "
                                   "(side a: its <code>omega</code>, its <code>tau_load</code>) and a mechanism FMU in "
                                   "torque causality (side b: its <code>omega1</code>, its <code>tau_ext</code>): "
                                   "DriveShaftFourBar.ssp (<code>crankfmu ssp --system DriveShaftFourBar</code>). "
                                   "Over a step the twist is the integral of the speed difference, exactly, with "
                                   "the speeds held or, where the host gives their derivatives, lines in time.",
                                   model_description, parameters, **about)


def rodstring_documentation(name: str, well_file, model_description: bytes, parameters: dict,
                            **about) -> dict[str, bytes]:
    """documentation/index.html of RodString.fmu."""
    return component_documentation(name, well_file, RODSTRING_EQUATIONS, "It hangs from a pumping unit's rope port "
                                   "(PumpingWell.ssp: <code>crankfmu ssp --system PumpingWell</code>). The string is "
                                   "cut into segments stepped by the explicit central difference (stable for the "
                                   "Courant number a dt/dx at most 1), and the pump's set-valued law is solved "
                                   "exactly each step.", model_description, parameters, **about)
