"""The figure of a run's contacts: each load with kinks (a foot on the ground, a tool on its
workpiece, a stop; user_loads.KinkedLoad) over one crank turn, with the switch angles every path
steps onto marked.

Such a load is a function of the position only, so over a turn it is the same curve in every
cycle: it is drawn on a fine grid of crank angles (the run's output samples would be too coarse to
show where it touches), and its torque on the crank beside it, the part of M_load it gives.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..atomic import save_figure
from ..plots import legend_outside, pyplot, turn_axis

#: the components a kinked load may have, and their units
_COMPONENTS = (("fx", "N"), ("fy", "N"), ("moment", "N.m"))


def kinked_loads(model) -> list:
    from ..dynamics.user_loads import KinkedLoad

    return [load for load in model.reduced.loads if isinstance(load, KinkedLoad)]


def plot_contacts(result, out_dir: Path) -> list[Path]:
    """``contacts.png``: each kinked load's components and torque on the crank over a turn, or
    nothing for a scenario without one."""
    loads = kinked_loads(result.model)
    if not loads:
        return []
    plt = pyplot()
    mechanism = result.model.mechanism
    phi = np.linspace(0.0, 2 * math.pi, 7201)            # 0.05 deg: a kink between two samples is plain
    kin = mechanism.kinematics(phi)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8.5, 6.5), sharex=True, constrained_layout=True)
    facts, units = [], set()
    for n, load in enumerate(loads):
        (applied,) = load.applied(kin)
        values = {"fx": applied.fx, "fy": applied.fy, "moment": applied.moment}
        at = f" at {load.point}" if load.point else ""
        for key, unit in _COMPONENTS:
            if key not in load.increasing:
                continue
            v = np.broadcast_to(np.asarray(values[key], dtype=float), phi.shape)
            if not np.any(v):
                continue                                 # a component written as "0"
            units.add(unit)
            top.plot(np.degrees(phi), v, lw=1.4, label=f"{key} on {load.link}{at} [{unit}]:\n"
                                                       f"{load.increasing[key].source}")
            k = int(np.argmax(np.abs(v)))
            facts.append(f"{key} on {load.link}{at} peaks at {v[k]:.4g} {unit} at phi1 = {math.degrees(phi[k]):.1f} deg")
        bottom.plot(np.degrees(phi), load.torque(kin), lw=1.4, color=f"C{n}",
                    label=f"load on {load.link}{at}")
        angles = sorted({round(a % (2 * math.pi), 13) for a in load.switch_angles(mechanism)})
        for a in angles:
            for ax in (top, bottom):
                ax.axvline(math.degrees(a), color="0.45", ls="--", lw=0.8, zorder=0)
            top.annotate(f"{math.degrees(a):.2f} deg", (math.degrees(a), 1.0), xycoords=("data", "axes fraction"),
                         xytext=(3, -12), textcoords="offset points", fontsize=8, color="0.3")
        facts.append(f"{', '.join(load.calls)} switch{'es' if len(load.calls) == 1 else ''} at phi1 = "
                     + (", ".join(f"{math.degrees(a):.2f}" for a in angles) + " deg" if angles
                        else "no angle (one side all the turn)"))
    top.set_ylabel(" or ".join(f"{'force' if u == 'N' else 'couple'} [{u}]" for u in sorted(units)))
    top.set_title(f"{result.scenario.name}: the loads with kinks over a turn (dashed: the located switch angles)")
    top.grid(alpha=0.3)
    legend_outside(top)
    bottom.set_ylabel("torque on the crank [N.m]")
    turn_axis(bottom)
    legend_outside(bottom)
    path = Path(out_dir) / "contacts.png"
    save_figure(fig, path, dpi=120, scenario=result.scenario.name,
                caption="The loads written with max, min, abs or sign (a contact), over a crank turn: their "
                        "components (top) and their torque on the crank (bottom), a function of the position "
                        "only, so the same in every cycle. Dashed: where a kink's argument crosses zero, found "
                        "by root finding; every path (fast, reference, the FMUs) steps onto those angles. "
                        + "; ".join(facts) + ".")
    plt.close(fig)
    return [path]
