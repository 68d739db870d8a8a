"""crankfmu: planar crank mechanisms with motor, flywheel and loads, from first principles.

    >>> import crankfmu
    >>> scenario = crankfmu.load_scenario("seed000").with_params(A=380, J_flywheel=0.5)
    >>> result = crankfmu.simulate(scenario)            # reference integrator
    >>> result.time, result.omega1                       # s, rad/s

Data flows one way: geometry (mechanisms) -> kinematics (contour engine) -> reduced model
(dynamics) -> integrator (integrators) -> outputs (simulation, output).
"""

from .errors import (AssemblyError, CrankfmuError, DefinitionError, ParameterError, ScenarioNotFound,
                     SchemeError)
from .scenario import Scenario, available_scenarios, load_scenario
from .simulation import COLUMNS, Result, simulate

__version__ = "0.1.0"

__all__ = ["AssemblyError", "COLUMNS", "CrankfmuError", "DefinitionError", "ParameterError", "Result",
           "Scenario", "ScenarioNotFound", "SchemeError", "available_scenarios", "load_scenario", "simulate"]
