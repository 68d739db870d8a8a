"""crankfmu: planar crank mechanisms with motor, flywheel and loads, from first principles.

    >>> import crankfmu
    >>> scenario = crankfmu.load_scenario("seed000").with_params(A=380, J_flywheel=0.5)
    >>> result = crankfmu.simulate(scenario)            # reference integrator
    >>> result.time, result.omega1                       # s, rad/s

Data flows one way, and imports with it: contract and data files -> mechanisms (contour engine)
-> dynamics (reduced model, loads, motor, hybrid rules) -> integrators (one interface) ->
scenario and simulation -> the FMI shell (fmi), the CLI and the studies (studies) -> the reports
(output, plots, pictures).
"""

from .contract import COLUMNS
from .errors import (AssemblyError, CrankfmuError, DefinitionError, ParameterError, ScenarioNotFound,
                     SchemeError)
from .scenario import Scenario, available_scenarios, load_scenario

__version__ = "0.1.0"


def __getattr__(name):
    # simulate() brings the integrators that need scipy; the FMUs ship the core without them
    # and import this package, so it is loaded on first use only
    if name in ("Result", "simulate"):
        from . import simulation
        return getattr(simulation, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = ["AssemblyError", "COLUMNS", "CrankfmuError", "DefinitionError", "ParameterError", "Result",
           "Scenario", "ScenarioNotFound", "SchemeError", "available_scenarios", "load_scenario", "simulate"]
