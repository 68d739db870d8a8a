import pytest

import crankfmu


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
