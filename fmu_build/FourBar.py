"""FourBar.fmu: the seed-000 four-bar (shared/FMU_CONTRACT.md), a thin pythonfmu slave.

The physics and the life cycle are crankfmu's. The build ships the package in the FMU's resources
under the private name ``crankfmu_FourBar``, so the FMU runs its own copy whatever the host
process has imported or installed (an editable install's import hook, another FMU of another
version). This file only names the scenario.
"""

import importlib
import sys
from pathlib import Path

from pythonfmu import Fmi2Slave

PACKAGE = "crankfmu_FourBar"   # build.py ships crankfmu under this name


def _add_build_site_packages(resources: Path):
    """Append the site-packages of the environment the FMU was built in (recorded by the build in
    python_env.txt after the libpython path): an interpreter embedded in a C host sees only its
    base installation's. Appended, so a Python host's own environment keeps precedence."""
    try:
        lines = (resources / "python_env.txt").read_text().splitlines()[1:]
    except OSError:
        return
    for line in lines:
        if line and line not in sys.path:
            sys.path.append(line)


def _core_class(resources):
    """FmuCore from the package in *this* instance's resources.

    The embedded interpreter outlives an FMU instance: a host that frees the FMU and loads it again
    from a new extraction directory (fmpy does, and deletes the old one) would otherwise reuse the
    package cached from the old directory, whose data files are gone.
    """
    if resources:
        _add_build_site_packages(Path(resources))
        wanted = Path(resources).resolve() / PACKAGE
        cached = sys.modules.get(PACKAGE)
        if cached is not None and Path(cached.__file__).resolve().parent != wanted:
            for key in [k for k in sys.modules if k == PACKAGE or k.startswith(PACKAGE + ".")]:
                del sys.modules[key]
        if str(wanted.parent) not in sys.path:
            sys.path.insert(0, str(wanted.parent))
    return importlib.import_module(PACKAGE + ".fmu").FmuCore


class FourBar(Fmi2Slave):
    author = "crankfmu"
    description = "Four-bar with motor line, flywheel and technological moment (Badoiu, seed 000)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.core = _core_class(kwargs.get("resources"))(self, "seed000")

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
