"""PumpingWell.ssp: PumpJack.fmu (its motor line, counterweights and geometry of the RP 11L well)
with RodString.fmu hanging from its rope port, run by two third-party masters, the ecos C++
command and libcosim, against the well as one model (crankfmu.well.CoupledWell) with the same
string grid and string step: the co-simulation differs from it by the coupling's O(H) error
alone, and the two masters agree."""

from __future__ import annotations

import math

import numpy as np
import pytest

from crankfmu.cli import main
from crankfmu.dynamics.rodstring import grid
from crankfmu.dynamics.well import load_well
from crankfmu.fmi.ssp import WELL
from crankfmu.well import CoupledWell, unit_scenario

pytest.importorskip("ecospy")
pytest.importorskip("libcosimpy")

STOP = 10.0


@pytest.fixture(scope="module")
def ssp(tmp_path_factory):
    out = tmp_path_factory.mktemp("pumping_well")
    assert main(["fmu", "pumpjack", "--out", str(out)]) == 0
    assert main(["fmu", WELL, "--well", "--out", str(out)]) == 0
    assert main(["ssp", "--fmus", str(out), "--out", str(out), "--system", "well"]) == 0
    return out


def reference(step: float):
    """The one model with RodString.fmu's string step at this communication step."""
    well = load_well(WELL)
    design = well.design()
    dt = step / math.ceil(step / grid(design).dt_max - 1e-9)
    cw = CoupledWell(unit_scenario(well), design, dt=dt)
    rows = [(0.0, cw.y[1], cw.load_end)]
    while cw.t < STOP - 1e-9:
        cw.step()
        rows.append((cw.t, cw.y[1], cw.load_end))
    return np.array(rows).T


def test_the_co_simulated_well_matches_the_one_model_well(ssp):
    """At 10 ms and 1 ms in both masters: max |omega1 - reference| falls with the step at order
    1 (each FMU holds its inputs over a step; the string's top follows s + v t), measured 3.4e-3
    and 3.6e-4 rad/s (and 3.6e-5 at 0.1 ms, 5 min, not run here), bounded by 0.5 H rad/s/s; the
    polished rod load likewise (3.1e-3 and 2.4e-4 of its peak, bounded by 0.5 H/s). The masters
    agree to ecos's 6 decimals."""
    from crankfmu.validation import masters

    errors, runs = {}, {}
    for step in (1e-2, 1e-3):
        t, omega, load = reference(step)
        for master in ("ecos", "libcosim"):
            run = masters.run(master, ssp / "PumpingWell.ssp", STOP, step, ["PumpJack.omega1", "RodString.F"],
                              parameter_set="coupled")
            assert not run.error, run.error
            runs[(master, step)] = run
            errors[(master, step)] = float(np.max(np.abs(run["PumpJack.omega1"] - np.interp(run.time, t, omega))))
            load_error = np.max(np.abs(run["RodString.F"] - np.interp(run.time, t, load))) / np.max(load)
            assert errors[(master, step)] <= 0.5 * step, (master, step, errors[(master, step)])
            assert load_error <= 0.5 * step, (master, step, load_error)
    for master in ("ecos", "libcosim"):
        order = math.log10(errors[(master, 1e-2)] / errors[(master, 1e-3)])
        assert 0.8 <= order <= 1.3, (master, order)
    for step in (1e-2, 1e-3):
        assert masters.largest_difference(runs[("ecos", step)], runs[("libcosim", step)], "PumpJack.omega1", step) <= 2e-6


def test_the_rod_string_fmu_is_valid_and_refuses_a_bad_courant(ssp):
    """RodString.fmu passes fmpy's validation; a Courant number above 1 (the explicit scheme's
    limit) is refused with fmi2Error, with logging off, in a fresh process as a host runs it."""
    import subprocess
    import sys

    from fmpy.validation import validate_fmu

    fmu = ssp / "RodString.fmu"
    assert validate_fmu(str(fmu)) == []
    script = ("import fmpy, sys\n"
              "try:\n"
              f"    fmpy.simulate_fmu({str(fmu)!r}, stop_time=0.1, output_interval=0.01, start_values={{'courant': 1.5}})\n"
              "except Exception as exc:\n"
              "    print('refused:', exc); sys.exit(0)\n"
              "sys.exit(3)\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, (done.returncode, done.stdout, done.stderr[-2000:])
    assert "status 3 (error)" in done.stdout      # fmi2Error at fmi2SetReal
