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
