"""What the FMUs' coupling features buy a master (the issue "Coupled, as good as alone (I)"): the
coupled scenes of validation/scenes.py run by validation/cosim.py's master on the native FMI 2.0
FMUs, against their one-model references (DOP853). Error: max |omega1 - reference| / max omega1.

- FourBarDrive: inputs held are first order; extrapolated from the FMUs' output derivatives second
  order (<= 2e-4 at 1 ms); the linearly implicit step from their directional derivatives second
  order (<= 1e-4 at 1 ms, <= 1.2e-2 at 10 ms), one doStep per FMU per step.
- The elastic shaft (k = 1e5 N.m/rad, 5 % damping) between DriveSpeed and FourBar: inputs held
  diverge at 10 ms (stable below 2c/k = 0.2 ms); the linearly implicit step, the inputs held at
  their end values (theta = 1, L-stable), is stable at 10 ms.
- The flywheel on the crank side in speed causality: inputs held diverge at every step; the step
  iterated with rollback is stable at 10 ms within 2e-2, second order.

The figures are printed for the closing note and docs/coupling.md."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from crankfmu.validation import scenes
from crankfmu.validation.cosim import observed_order


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    return scenes.build(tmp_path_factory.mktemp("scenes"))


def table(name, results):
    for (mode, step), m in sorted(results.items()):
        print(f"{name} {mode:11s} H = {step * 1e3:5.1f} ms: error {m.error:.3e} ({m.steps} FMU steps)"
              + (f" diverged: {m.failure[:80]}" if m.failure else ""))


def test_fourbardrive_second_order_from_output_and_directional_derivatives(built, tmp_path):
    scene = scenes.scene("FourBarDrive")
    references = {}
    results = {(mode, h): scenes.measure(scene, built, mode, h, folder=tmp_path / f"{mode}{h}", references=references)
               for mode in ("hold", "extrapolate", "implicit") for h in (1e-2, 2e-3, 1e-3)}
    table("FourBarDrive", results)
    steps = (2e-3, 1e-3)
    order = {mode: observed_order(steps, [results[mode, h].error for h in steps])
             for mode in ("hold", "extrapolate", "implicit")}
    print(f"FourBarDrive observed orders: {order}")
    assert 0.9 < order["hold"] < 1.2
    assert order["extrapolate"] >= 1.9 and results["extrapolate", 1e-3].error <= 2e-4
    assert order["implicit"] >= 1.9 and results["implicit", 1e-3].error <= 1e-4
    assert results["implicit", 1e-2].error <= 1.2e-2
    assert results["implicit", 1e-3].steps == results["hold", 1e-3].steps == 2000, "one doStep per FMU per step"


def test_a_stiff_shaft_is_stable_at_10_ms_with_the_linearly_implicit_step(built, tmp_path):
    scene = scenes.scene("ShaftDrive", k=1e5)
    results = {("hold", 1e-2): scenes.measure(scene, built, "hold", 1e-2, folder=tmp_path / "hold"),
               ("implicit", 1e-2): scenes.measure(scene, built, "implicit", 1e-2, theta=1.0, folder=tmp_path / "imp")}
    table("ShaftDrive k = 1e5", results)
    assert results["hold", 1e-2].error == np.inf, "held inputs are stable only below 2c/k"
    assert results["implicit", 1e-2].error < 5e-2
    assert results["implicit", 1e-2].steps == 200


def test_the_flywheel_on_the_crank_is_stable_at_10_ms_with_rollback(built, tmp_path):
    scene = scenes.scene("FlywheelOnCrank")
    references = {}
    results = {("hold", 1e-2): scenes.measure(scene, built, "hold", 1e-2, folder=tmp_path / "hold")}
    for h in (1e-2, 5e-3):
        results["rollback", h] = scenes.measure(scene, built, "rollback", h, folder=tmp_path / f"r{h}",
                                                references=references)
    table("FlywheelOnCrank", results)
    assert results["hold", 1e-2].error == np.inf, "held inputs diverge at every step"
    assert results["rollback", 1e-2].error <= 2e-2
    assert observed_order((1e-2, 5e-3), [results["rollback", h].error for h in (1e-2, 5e-3)]) >= 1.8

