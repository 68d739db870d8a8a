"""Each FMU's ``documentation/index.html`` (FMI 2.0's place for it; fmpy's GUI shows it): the
mechanism drawing, the equations the FMU integrates, every variable with its unit, range and
description, the default experiment with its plot, and where the reference result comes from.

Built with the FMU (``fmi.build``), from the same sources the FMU is: the variables from the
completed modelDescription, the ranges from the slave's parameters, the equations from the
model modules' own docstrings, the contours from the mechanism file, the plot from the reference
result the FMU carries. Nothing here runs inside the FMU.
"""

from __future__ import annotations

import html
import io
from xml.etree import ElementTree as ET

STYLE = """body { font-family: sans-serif; max-width: 60em; margin: 1em auto; line-height: 1.4; }
table { border-collapse: collapse; font-size: 0.9em; } td, th { border: 1px solid #bbb; padding: 2px 6px; }
th { background: #eee; } pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; }
img { max-width: 100%; }"""


def _docstring_block(module) -> str:
    """A model module's docstring up to its first blank line after the equations (the physics)."""
    return (module.__doc__ or "").strip()


def variables_table(model_description: bytes, parameters: dict) -> str:
    """An HTML table of every variable: name, causality, variability, unit, start, range, description."""
    root = ET.fromstring(model_description)
    rows = []
    for sv in root.find("ModelVariables"):
        real = sv.find("Real")
        unit = start = ""
        if real is not None:
            unit, start = real.get("unit", ""), real.get("start", "")
        name = sv.get("name")
        p = parameters.get(name)
        if p is not None:
            span = p.range_text()
        elif real is not None and (real.get("min") or real.get("max")):
            span = f"[{real.get('min', '-inf')}, {real.get('max', 'inf')}] {unit}"
        else:
            span = ""
        rows.append("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in (
            name, sv.get("causality", "local"), sv.get("variability", "continuous"), unit, start, span,
            sv.get("description", ""))) + "</tr>")
    head = "".join(f"<th>{h}</th>" for h in ("name", "causality", "variability", "unit", "start", "valid range",
                                             "description"))
    return f"<table><tr>{head}</tr>\n" + "\n".join(rows) + "\n</table>"


def experiment_plot(reference_csv: str, title: str) -> bytes:
    """PNG of the reference result over the default experiment: omega1 and the motor torque (phi1
    and the drive torque in speed causality)."""
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
    a2.plot(col["time"], col[torque], lw=1.3, color="C1", label=torque)
    if "J_red" in col:
        a2b = a2.twinx()
        a2b.plot(col["time"], col["J_red"], lw=1.0, color="C2", label="J_red")
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
    """The scenario's drawing (its [drawing] angle and overlays) as PNG."""
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


def scenario_documentation(name: str, scenario, model_description: bytes, parameters: dict,
                           reference_csv: str | None) -> dict[str, bytes]:
    """documentation/ files of a mechanism FMU: index.html, mechanism.png, default_experiment.png."""
    from ..dynamics import equation, motor, reduced

    definition = scenario.mechanism_definition()
    files = {"documentation/mechanism.png": mechanism_png(scenario)}
    contours = "\n".join(f"{cname}:  {text} = 0" for cname, text in definition.contour_sources)
    plot = ""
    if reference_csv is not None:
        files["documentation/default_experiment.png"] = experiment_plot(
            reference_csv, f"{name}.fmu, default experiment (reference result)")
        plot = ('<p><img src="default_experiment.png" alt="omega1, motor torque and reduced inertia over the '
                'default experiment"></p>')
    body = f"""<h1>{html.escape(name)}.fmu</h1>
<p>{html.escape(scenario.title)}. Mechanism: {html.escape(definition.title)}.
Source: {html.escape(scenario.data.get("source", definition.source))}.
Built by crankfmu from the scenario file <code>{html.escape(scenario.name)}</code> and the mechanism file
<code>{html.escape(definition.name)}</code>; all values in SI units.</p>
<p><img src="mechanism.png" alt="the mechanism {html.escape(definition.name)}"></p>

<h2>Equations</h2>
<p>The position of every link follows from the crank angle phi1 through the mechanism's independent
contours (closed vector chains, <code>u(a) = (cos a, sin a)</code>), solved exactly on the assembly branch
"{html.escape(definition.branch)}":</p>
<pre>{html.escape(contours)}</pre>
<p>The reduced model (one coordinate, the crank angle):</p>
<pre>{html.escape(_docstring_block(reduced))}</pre>
<p>The FMU integrates the movement equation (Dormand-Prince 5(4) in C with located mode switches):</p>
<pre>{html.escape(_docstring_block(equation))}</pre>
<p>The motor:</p>
<pre>{html.escape(_docstring_block(motor) + chr(10) + (motor.MotorLine.__doc__ or "").strip())}</pre>

<h2>Variables</h2>
{variables_table(model_description, parameters)}

<h2>Default experiment</h2>
<p>{html.escape(_experiment_text(scenario.experiment))}.</p>
{plot}
<p>Reference: <code>extra/org.fmi-standard.fmi-ls-ref/{html.escape(name)}_out.csv</code>, the default
experiment's outputs from crankfmu's in-process reference integrator (scipy's DOP853 on the contour
engine, rtol = atol = 1e-12), an independent method from the FMU's own stepper.</p>

<h2>Use</h2>
<pre>fmpy simulate {html.escape(name)}.fmu --show-plot
fmpy simulate {html.escape(name)}.fmu --start-values J_flywheel 0.5</pre>
<p>A refused value (out of range, non-finite, a fixed parameter after initialisation) returns fmi2Error
with a message naming the parameter and its valid range, whatever the host's logging setting.</p>
"""
    files["documentation/index.html"] = _page(f"{name}.fmu", body)
    return files


def component_documentation(name: str, data_file, module, role_html: str, model_description: bytes,
                            parameters: dict) -> dict[str, bytes]:
    """documentation/index.html of an FMU that is not a mechanism (a drive, a cushion): what it
    does for a mechanism FMU (``role_html``), the equations of ``module``'s docstring, its variables
    and default experiment."""
    body = f"""<h1>{html.escape(name)}.fmu</h1>
<p>{html.escape(data_file.title)}. Built by crankfmu from the file <code>{html.escape(data_file.name)}</code>;
all values in SI units. {role_html}</p>
<h2>Equations</h2>
<pre>{html.escape(_docstring_block(module))}</pre>
<h2>Variables</h2>
{variables_table(model_description, parameters)}
<h2>Default experiment</h2>
<p>{html.escape(_experiment_text(data_file.experiment))}.</p>
"""
    return {"documentation/index.html": _page(f"{name}.fmu", body)}


def drive_documentation(name: str, drive_file, model_description: bytes, parameters: dict,
                        speed_causal: bool = False) -> dict[str, bytes]:
    """documentation/index.html of Drive.fmu, or of its speed-causal variant."""
    from ..dynamics import drive

    role = ("It drives a speed-causal mechanism FMU through its <code>omega1</code> input and takes its "
            "<code>tau_drive</code> (FourBarDriveSpeed.ssp: <code>crankfmu ssp</code>)." if speed_causal else
            "It drives a mechanism FMU through its <code>tau_ext</code> input (FourBarDrive.ssp: "
            "<code>crankfmu ssp</code>).")
    return component_documentation(name, drive_file, drive, role, model_description, parameters)


def cushion_documentation(name: str, cushion_file, model_description: bytes, parameters: dict) -> dict[str, bytes]:
    """documentation/index.html of the die cushion FMU."""
    from ..dynamics import cushion

    return component_documentation(name, cushion_file, cushion, "It acts on a mechanism FMU's force port "
                                   "(PressCushion.ssp: <code>crankfmu ssp</code>).", model_description, parameters)


def rodstring_documentation(name: str, well_file, model_description: bytes, parameters: dict) -> dict[str, bytes]:
    """documentation/index.html of RodString.fmu."""
    from ..dynamics import rodstring

    return component_documentation(name, well_file, rodstring, "It hangs from a pumping unit's rope port "
                                   "(PumpingWell.ssp: <code>crankfmu ssp --system PumpingWell</code>).",
                                   model_description, parameters)


def _page(title: str, body: str) -> bytes:
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
            f"<style>{STYLE}</style></head>\n<body>\n{body}</body></html>\n").encode()

