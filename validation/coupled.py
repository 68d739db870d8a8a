"""The coupled scenes in ``crankfmu validate``: each scene of validation/scenes.py run by each master
of validation/cosim.py over a range of communication steps, against its one-model reference.

For each scene the harness reports the error against the step for every master (one figure a
scene), the observed order between the two smallest steps and the largest stable step, and holds
the figures the issue "Coupled, as good as alone (I)" set as bars (BARS). It runs where the scenes'
native FMI 2.0 FMUs are among the FMUs validated (``make fmu`` builds them): FourBar.fmu and
FourBarSpeed.fmu of seed 000, Drive.fmu and DriveSpeed.fmu of dc_pi. The quick subset (``--quick``)
runs the scenes and masters that have a bar, inputs held beside them, at 1 and 10 ms.
"""

from __future__ import annotations

import math
from pathlib import Path

from crankfmu.validation import scenes
from crankfmu.validation.cosim import observed_order

#: (scene name, its keyword arguments): the drive on the four-bar in torque causality, the flywheel
#: on the crank in speed causality, and the elastic shaft from soft to stiff
SCENES = (("FourBarDrive", {}), ("FlywheelOnCrank", {}), ("ShaftDrive", {"k": 1e3}), ("ShaftDrive", {"k": 1e4}),
          ("ShaftDrive", {"k": 1e5}))
#: (label, mode, theta)
MASTERS = (("hold", "hold", 0.5), ("extrapolate", "extrapolate", 0.5), ("implicit", "implicit", 0.5),
           ("implicit, theta 1", "implicit", 1.0), ("rollback", "rollback", 0.5))
STEPS = (3e-4, 1e-3, 3e-3, 1e-2, 3e-2)
QUICK_STEPS = (1e-3, 1e-2)
#: (scene label, master label, step): the largest error allowed (inf: stable is the bar)
BARS = {("FourBarDrive", "extrapolate", 1e-3): 2e-4, ("FourBarDrive", "implicit", 1e-3): 1e-4,
        ("FourBarDrive", "implicit", 1e-2): 1.2e-2, ("ShaftDrive k = 1e5", "implicit, theta 1", 1e-2): math.inf,
        ("FlywheelOnCrank", "rollback", 1e-2): 2e-2}


def label(name: str, kwargs: dict) -> str:
    return name + (f" k = {kwargs['k']:.0e}".replace("e+0", "e") if "k" in kwargs else "")


def coupled_fmus(kinds: dict) -> dict | None:
    """{scenes.BUILDS name: path} among ``kinds`` ({path: validation.fmu_runner.FmuKind}), or None
    where one of the scenes' FMUs is missing."""
    wanted = {("scenario", "seed000", "torque"): "FourBar", ("scenario", "seed000", "speed"): "FourBarSpeed",
              ("drive", "dc_pi", "torque"): "Drive", ("drive", "dc_pi", "speed"): "DriveSpeed"}
    found = {}
    for path, kind in kinds.items():
        name = wanted.get((kind.kind, kind.data, kind.causality))
        if name and kind.build == "native" and not kind.file:
            found[name] = Path(path)
    return found if len(found) == len(wanted) else None


def run(built: dict, out: Path, quick: bool, checks, progress=lambda label, fraction: None) -> dict:
    """The coupled scenes' section of the report: per scene, its rows (master, step, error, FMU
    steps, failure), orders, largest stable steps and figure; the bars held in ``checks``."""
    from .figures import plot_coupled

    steps = QUICK_STEPS if quick else STEPS
    plan = []
    for name, kwargs in SCENES:
        tag = label(name, kwargs)
        # the quick subset: the scenes and masters that have a bar, and inputs held beside them
        barred = {m for (t, m, _) in BARS if t == tag}
        masters = [m for m in MASTERS if not quick or m[0] in barred | {"hold"}]
        if masters and (not quick or barred):
            plan.append((name, kwargs, tag, masters))
    result = []
    total, done = sum(len(m) for *_, m in plan) * len(steps), 0
    for name, kwargs, tag, masters in plan:
        scene = scenes.scene(name, **kwargs)
        references, rows = {}, []
        for master, mode, theta in masters:
            for h in steps:
                progress(f"coupled {tag}, {master}", done / total)
                m = scenes.measure(scene, built, mode, h, theta=theta, references=references)
                rows.append({"master": master, "step": h, "error": m.error, "steps": m.steps, "failure": m.failure})
                done += 1
        summary = []
        for master, _, _ in masters:
            mine = sorted((r["step"], r["error"]) for r in rows if r["master"] == master)
            finite = [(h, e) for h, e in mine if math.isfinite(e)]
            smallest = mine[:2]
            order = observed_order(*zip(*smallest)) if len(smallest) == 2 and all(
                math.isfinite(e) and e > 0 for _, e in smallest) else math.nan
            summary.append({"master": master, "order": order,
                            "largest_stable": max((h for h, _ in finite), default=math.nan)})
        for (scene_label, master, h), bar in BARS.items():
            if scene_label != tag or h not in steps:
                continue
            error = next(r["error"] for r in rows if r["master"] == master and r["step"] == h)
            check = f"coupled.{tag.replace(' ', '_').replace('=', '')}.{master.replace(', ', '_').replace(' ', '_')}" \
                    f"_{h * 1e3:g}ms"
            if math.isinf(bar):
                checks.holds(f"{check}_stable", math.isfinite(error), note=f"error {error:.3g}")
            else:
                checks.at_most(f"{check}_error", error, bar)
        plot = plot_coupled(tag, rows, out / f"coupled_{tag.replace(' ', '_').replace('=', '')}.png")
        result.append({"scene": tag, "rows": rows, "summary": summary, "plot": plot.name})
    progress("", 1.0)
    return {"scenes": result, "steps": list(steps)}
