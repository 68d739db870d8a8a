"""The validation harness: every FMU against the in-process reference and the papers.

``crankfmu validate [--fmu PATH ...] [--out DIR] [--quick] [--junit FILE]`` drives each FMU with
fmpy (never an in-process shortcut), runs the same scenario file with the in-process reference
integrator, and prints one line per check, ``PASS|FAIL name measured expected bar`` (a published
number: ``DISAGREE``, ``FITTED``, ``NOTCOMP``; a check the FMU cannot take: ``SKIP``).

Modules, in the order data flows through them:

* ``fmu_runner``   an FMU under test: which scenario it implements, runs through fmpy
* ``reference``    the same scenario in process (and its periodic extension for long runs)
* ``compare``      errors between the two, and the invariants every run must satisfy
* ``checks``       a measured number against an expectation, one printed line each, and its status
* ``model_exchange``  how tightly CVode runs a Model Exchange FMU: no tighter than a case needs
* ``paper``        the numbers the papers publish, named in the scenario files
* ``cases``        the hard cases (``cases/<scenario>.toml``) and their expectations
* ``work_precision``  speed against error for the seed-000 case
* ``figures``      the report's PNG plots
* ``report``       report.md and report.html, checks.json
* ``junit``        the checks as JUnit XML for a CI system
* ``harness``      all of the above for every FMU; the command line entry point
"""

from .checks import Check, CheckList
from .harness import main, validate

__all__ = ["Check", "CheckList", "main", "validate"]
