"""The figures of joint friction (dynamics.friction, docs/friction.md) from the equilibrium
study: each joint's friction power over the machine's cycle at a constant crank speed, and the
drive torque that starts the machine from rest at each crank angle, with and without friction."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..atomic import save_figure
from ..plots import legend_outside, pyplot, turn_axis


def plot_friction_power(scenario, r, path: Path) -> Path:
    """``friction_<w>.png``: each joint's friction power (W, <= 0) over the cycle at the speed of
    ``r`` (equilibrium.SpeedResult), its cycle mean in the legend."""
    plt = pyplot()
    reactions = r.reactions
    deg = np.degrees(reactions.phi1)
    fig, ax = plt.subplots(figsize=(9.5, 4.2), constrained_layout=True)
    total = np.zeros_like(deg)
    for joint, power in reactions.friction_power.items():
        total = total + power
        ax.plot(deg, power, lw=1.2, label=f"{joint} ({reactions.kind[joint]}): mean {np.mean(power):.2f} W")
    ax.plot(deg, total, lw=1.6, color="k", label=f"all joints: mean {np.mean(total):.2f} W")
    turn_axis(ax, cycle=r.cycle_angle)
    ax.set_ylabel("friction power [W]")
    ax.set_title(f"{scenario.name}: the joints' friction power at omega1 = {r.omega1:g} rad/s", fontsize=10)
    legend_outside(ax)
    save_figure(fig, path, dpi=120, scenario=scenario.name,
                caption=f"Each joint's friction power over the cycle at the constant crank speed {r.omega1:g} rad/s "
                        "(the friction's moment or force times the joint's relative speed; never positive), from the "
                        "reactions with friction; the means are over the crank angle.")
    plt.close(fig)
    return path


def plot_startup(scenario, startup, path: Path) -> Path:
    """``startup.png``: the drive torque that starts the crank forward from rest at each angle,
    with the joints' static friction and without, the largest of each marked."""
    plt = pyplot()
    deg = np.degrees(startup.phi1)
    s = startup.summary()
    fig, ax = plt.subplots(figsize=(9.5, 4.2), constrained_layout=True)
    ax.plot(deg, startup.with_friction, lw=1.6, color="C3", label=f"with joint friction: largest "
                                                                  f"{s['startup_torque']:.2f} N.m at {s['at_deg']:.1f} deg")
    ax.plot(deg, startup.without, lw=1.2, ls="--", color="C0",
            label=f"without friction: largest {s['startup_torque_without_friction']:.2f} N.m "
                  f"at {s['without_friction_at_deg']:.1f} deg")
    ax.axhline(0.0, color="0.5", lw=0.8)
    turn_axis(ax, cycle=float(startup.phi1[-1] + startup.phi1[1] - startup.phi1[0]))
    ax.set_ylabel("torque to start forward [N.m]")
    ax.set_title(f"{scenario.name}: the drive torque that starts the crank from rest", fontsize=10)
    legend_outside(ax)
    save_figure(fig, path, dpi=120, scenario=scenario.name,
                caption="The drive torque that starts the crank forward from rest at each crank angle: the static "
                        "equilibrium moment with the loads of a forward start, with the joints' static friction "
                        f"opposing it and without; sampled every {s['grid_deg']:g} deg.")
    plt.close(fig)
    return path
