import subprocess
import sys
from pathlib import Path

import pytest

import crankfmu

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def scenario():
    return crankfmu.load_scenario("seed000")


@pytest.fixture(scope="session")
def model(scenario):
    return scenario.build()


@pytest.fixture(scope="session")
def reference(scenario):
    """The seed-000 run with the reference integrator over the scenario's 2 s."""
    return crankfmu.simulate(scenario)


@pytest.fixture(scope="session")
def fmu_path():
    """build/fmus/FourBar.fmu: `make test` builds it first; built here when pytest runs alone."""
    fmu = ROOT / "build" / "fmus" / "FourBar.fmu"
    if not fmu.exists():
        subprocess.run([sys.executable, str(ROOT / "fmu_build" / "build.py")], check=True)
    return str(fmu)


def assert_two_integrators_agree_and_energy_closes(scenario_file):
    """A user's scenario run by the fast path (compiled Dormand-Prince on the tabulated model) and
    the reference (DOP853 on the contour engine, rtol 1e-12) over its experiment: both reach about
    1e-8 rad/s at their default tolerances on the packaged examples; 1e-6 relative leaves room for
    a user's load switches. The reference closes the energy balance to 1e-8 of the work done."""
    import numpy as np

    scenario = crankfmu.load_scenario(str(scenario_file))
    times = np.linspace(0.0, scenario.experiment.stop_time, 3001)
    fast = crankfmu.simulate(scenario, method="fast", output_times=times)
    reference = crankfmu.simulate(scenario, method="reference", output_times=times)
    assert np.max(np.abs(fast.omega1 - reference.omega1)) < 1e-6 * np.max(np.abs(reference.omega1))
    e = reference.summary()["energy_balance"]
    assert abs(e["residual"]) < 1e-8 * (abs(e["W_motor"]) + abs(e["W_load"]) + 1.0)
