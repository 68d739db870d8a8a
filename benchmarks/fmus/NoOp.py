"""An FMU whose step does nothing: the floor a pythonfmu FMU cannot go below."""

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class NoOp(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.omega1 = 0.0
        self.register_variable(Real("omega1", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous))

    def do_step(self, current_time, step_size):
        return True
