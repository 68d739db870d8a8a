"""FourBar.fmu: the seed-000 four-bar (shared/FMU_CONTRACT.md), a thin pythonfmu slave.

The physics and the life cycle are crankfmu's (shipped in the FMU's resources); this file only
names the scenario. pythonfmu's loader finds the class by `class <Name>(Fmi2Slave):`.
"""

from pythonfmu import Fmi2Slave

from crankfmu.fmu import FmuCore


class FourBar(Fmi2Slave):
    author = "crankfmu"
    description = "Four-bar with motor line, flywheel and technological moment (Badoiu, seed 000)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.core = FmuCore(self, "seed000")

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self.core.setup_experiment(start_time, stop_time, tolerance)

    def exit_initialization_mode(self):
        self.core.exit_initialization_mode()

    def do_step(self, current_time, step_size):
        return self.core.do_step(current_time, step_size)

    def _get_fmu_state(self):
        return self.core.get_state()

    def _set_fmu_state(self, state):
        self.core.set_state(state)
