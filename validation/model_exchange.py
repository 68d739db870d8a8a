"""How tightly the harness runs CVode on a Model Exchange FMU: no tighter than a case needs.

A Model Exchange FMU has no stepper of its own: fmpy's CVode integrates its derivatives, and what
CVode leaves is the host's error, not the FMU's. A fixed rtol fails a correct FMU whose case is
hard (many turns, a peaky load) and wastes time on an easy one. So each Model Exchange run starts
at ``START_RTOL`` and, while its comparison with the reference misses its bar, is run again at a
tenth of the rtol, down to ``FLOOR_RTOL``. A correct FMU converges to the reference as rtol falls;
a wrong one does not (its error is the model's, not CVode's) and still fails at the floor. The
rtol used, every rtol tried with its error, and CVode's own error estimate (the difference between
the last two runs, which needs no reference) are printed beside the check.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

START_RTOL = 1e-10
#: CVode's BDF in double precision: below 1e-12 its steps grow no smaller error but take much longer
FLOOR_RTOL = 1e-12


@dataclass
class Tightened:
    """A Model Exchange run at the rtol its case needed: the run, that rtol, and each try."""

    run: object
    rtol: float
    tries: list[tuple[float, float]] = field(default_factory=list)   # (rtol, worst error / bar)
    cvode_estimate: float | None = None     # max |omega1(last) - omega1(previous)| / max |omega1|

    def note(self) -> str:
        tried = ", ".join(f"{r:.0e}: {x:.2g} of the bar" for r, x in self.tries)
        text = f"CVode rtol {self.rtol:.0e} (tried {tried}; floor {FLOOR_RTOL:.0e})"
        if self.cvode_estimate is not None:
            text += f"; CVode's own error estimate {self.cvode_estimate:.1e} (the last two rtols' difference)"
        return text


def tightened_run(run_at, worst_of, start: float = START_RTOL) -> Tightened:
    """``run_at(rtol)`` until ``worst_of(run)`` (the worst error over its bar, 1 is the bar) is at
    most 1 or rtol reaches the floor. A run that fails (``run.error``) is returned as it is."""
    rtol = min(start, START_RTOL)
    run = run_at(rtol)
    if run.error:
        return Tightened(run, rtol)
    tries = [(rtol, worst_of(run))]
    estimate = None
    while tries[-1][1] > 1.0 and rtol / 10 >= FLOOR_RTOL * 0.999:
        previous, rtol = run, rtol / 10
        run = run_at(rtol)
        if run.error:
            return Tightened(run, rtol, tries)
        tries.append((rtol, worst_of(run)))
        if "omega1" in run.values and previous.time.shape == run.time.shape:
            scale = float(np.max(np.abs(run["omega1"]))) or 1.0
            estimate = float(np.max(np.abs(run["omega1"] - previous["omega1"]))) / scale
    return Tightened(run, rtol, tries, estimate)
