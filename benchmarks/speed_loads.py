"""A load of the speed against the motor line (issue 58): the four-stroke engine of
tests/data/user/engine4s_scenario.toml with its brake on the motor line (M = -B omega1) and its
twin with the brake as a couple -c_brake*omega1 on the crank (engine4s_couple_scenario.toml), the
same motion to 1e-9; and (issue 68) its brake as a fan, -c_fan*omega1*abs(omega1) with the
brake's torque at the start speed (a load of degree 2 in omega1: its parts per power of omega1 are
columns of the tables, the kernel multiplying them by omega1's powers); and its brake as a general
law of the speed, -c_brake*240*tanh(omega1/240)/tanh(1), the brake's torque at the start speed (no
polynomial: its column is multiplied by the law, which the native FMU's program evaluates at each
step and the Python FMU's expression, through a callback). Each FMU's cost per 1 ms
step, measured in this run: the native FMI 2 FMU in the plain C driver (the fastest of several
processes) and the Python FMU's step loop through fmpy (the fastest of several runs). Targets: the
couple's step and the fan's at most 1.3x the motor line's, the law's at most 3x."""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FILES = {"motor line": ROOT / "tests" / "data" / "user" / "engine4s_scenario.toml",
         "couple of omega1": ROOT / "tests" / "data" / "user" / "engine4s_couple_scenario.toml"}
IDENTIFIERS = {"motor line": "Engine4S", "couple of omega1": "Engine4SCouple", "fan": "Engine4SFan",
               "law": "Engine4SLaw"}
#: the brake's other forms, each with the brake's torque at the start speed (240 rad/s)
FORMS = {"fan": "-c_brake/240*omega1*abs(omega1)", "law": "-c_brake*240*tanh(omega1/240)/tanh(1)"}


def form_file(folder: Path, what: str) -> Path:
    """The couple's twin with the brake as ``FORMS[what]``."""
    text = FILES["couple of omega1"].read_text()
    text = text.replace('moment = "-c_brake*omega1"', f'moment = "{FORMS[what]}"')
    text = text.replace('fmu = "Engine4SCouple"', f'fmu = "{IDENTIFIERS[what]}"')
    path = folder / f"engine4s_{what}_scenario.toml"
    path.write_text(text)
    return path


def python_per_step(fmu: Path, step: float, stop: float, repeats: int) -> float:
    """us per step of the Python FMU's step loop through fmpy (fmu_step.step_loop): the fastest of
    ``repeats`` runs."""
    from fmu_step import step_loop

    return 1e6 * min(step_loop(fmu, step, stop)[0] for _ in range(repeats))


def measure(repeats: int = 5, stop: float = 1.0, step: float = 1e-3) -> dict:
    from native_step import c_driver_per_step

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for what, path in {**FILES, **{what: form_file(Path(tmp), what) for what in FORMS}}.items():
            for kind, extra in (("native", ["--native"]), ("python", [])):
                folder = Path(tmp) / kind / IDENTIFIERS[what]
                subprocess.run([sys.executable, "-m", "crankfmu", "fmu", str(path), "--out", str(folder), *extra],
                               check=True, capture_output=True)
                fmu = folder / f"{IDENTIFIERS[what]}.fmu"
                out[(kind, what)] = (c_driver_per_step(fmu, step, stop, repeats)["us_per_step"] if kind == "native"
                                     else python_per_step(fmu, step, stop, repeats))
    return {f"{kind} {what}": us for (kind, what), us in out.items()}


def targets(measured: dict) -> list[tuple[str, str, bool]]:
    rows = []
    for kind in ("native", "python"):
        motor = measured[f"{kind} motor line"]
        for what, name, bound in (("couple of omega1", "a couple of omega1 (affine)", 1.3),
                                  ("fan", "a fan, -c omega1 |omega1| (degree 2)", 1.3),
                                  ("law", "a general law, tanh(omega1/240)", 3.0)):
            load = measured[f"{kind} {what}"]
            rows.append((f"{kind} Engine4S FMU per 1 ms step: the brake as {name} <= {bound:g}x the brake on the "
                         "motor line", f"{load:.2f} vs {motor:.2f} us/step, ratio {load / motor:.2f}",
                         load / motor <= bound))
    return rows


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    found = measure()
    for target, figure, met in targets(found):
        print(f"| {target} | {figure} | {'MET' if met else 'NOT MET'} |")
