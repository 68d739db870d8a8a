"""A check: a measured number against an expectation, printed as one line.

    PASS name measured expected tolerance

Every kind of check is printed in that form: ``close`` passes when |measured - expected| <=
tolerance; ``at_most`` is ``close`` with expected 0 for a non-negative error; ``below`` and
``above`` are one-sided (expected printed as ``<bound`` or ``>bound``, tolerance ``0``); ``holds``
records a yes/no expectation (measured 1 or 0, expected 1); ``skip`` records a check that cannot
be made here, with its reason (``SKIP name: reason``), counted apart. A NaN measurement never passes.

A published number gets one of four verdicts (``Check.verdict``), each its own status and count:
``agrees`` is a pass (independent evidence within its tolerance); ``disagrees`` (the value, the
paper's, and the reason; the value this data set gives is checked so a change shows) and
``fitted`` (the data set was chosen to give it) are neither a pass nor a failure and are counted
apart; ``not comparable`` (why) likewise. A published number that changed, or disagrees without a
stated reason, is a failure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

#: every status a check can end in, in the order the closing line counts them; only "failed" fails a run
STATUSES = ("passed", "failed", "disagrees", "fitted", "not comparable", "skipped")
#: the line's first word for each status
TAGS = {"passed": "PASS", "failed": "FAIL", "disagrees": "DISAGREE", "fitted": "FITTED",
        "not comparable": "NOTCOMP", "skipped": "SKIP"}


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


@dataclass
class Check:
    name: str
    measured: float
    expected: str
    tolerance: str
    passed: bool
    unit: str = ""
    note: str = ""
    skipped: bool = False          # not run, for the reason in note: counted apart, never a pass
    verdict: str = ""              # a published number's: agrees, disagrees, fitted, not comparable, changed
    published: str = ""            # the published value with its unit
    ratio: float | None = None     # |measured - expected| / tolerance (close and at_most): 1 is the bar
    status: str = ""               # one of STATUSES; set from passed/skipped when not given

    def __post_init__(self):
        if not self.status:
            self.status = "skipped" if self.skipped else "passed" if self.passed else "failed"

    def set_status(self, status: str):
        """A published number's verdict decides its status (disagrees, fitted, not comparable)."""
        if status not in STATUSES:
            raise ValueError(f"unknown status {status!r} (known: {', '.join(STATUSES)})")
        self.status = status
        self.passed, self.skipped = status == "passed", status == "skipped"

    def line(self) -> str:
        tag = TAGS[self.status]
        if self.skipped or (self.status == "not comparable" and not math.isfinite(self.measured)):
            return f"{tag} {self.name}: {self.note}"
        unit = f" {self.unit}" if self.unit not in ("", "1") else ""
        line = f"{tag} {self.name} {_fmt(self.measured)} {self.expected} {self.tolerance}{unit}"
        if self.status in ("disagrees", "fitted") and self.published:
            line += f" (published {self.published})"
        return line


def count(items) -> dict[str, int]:
    """How many checks of ``items`` ended in each status."""
    counts = dict.fromkeys(STATUSES, 0)
    for c in items:
        counts[c.status] += 1
    return counts


def summary_of(counts: dict[str, int]) -> str:
    """``N passed, M failed`` and every other status that occurred: "3 disagree, 1 fitted, 2 skipped"."""
    words = {"disagrees": "disagree", "fitted": "fitted", "not comparable": "not comparable", "skipped": "skipped"}
    text = f"{counts['passed']} passed, {counts['failed']} failed"
    return text + "".join(f", {counts[s]} {w}" for s, w in words.items() if counts[s])


@dataclass
class CheckList:
    """Checks in the order made; ``echo`` (print by default) gets each line as it is decided."""

    echo: Callable[[str], None] | None = print
    items: list[Check] = field(default_factory=list)

    def _add(self, check: Check) -> Check:
        self.items.append(check)
        if self.echo is not None:
            self.echo(check.line())
        return check

    def close(self, name, measured, expected, tolerance, unit="", note="") -> Check:
        m, tol = float(measured), float(tolerance)
        ok = math.isfinite(m) and abs(m - float(expected)) <= tol
        ratio = abs(m - float(expected)) / tol if tol > 0 and math.isfinite(m) else None
        return self._add(Check(name, m, _fmt(float(expected)), _fmt(tol), ok, unit, note, ratio=ratio))

    def at_most(self, name, error, limit, unit="", note="") -> Check:
        return self.close(name, abs(float(error)), 0.0, limit, unit, note)

    def below(self, name, measured, bound, unit="", note="") -> Check:
        m = float(measured)
        return self._add(Check(name, m, f"<{_fmt(float(bound))}", "0", math.isfinite(m) and m < bound, unit, note))

    def above(self, name, measured, bound, unit="", note="") -> Check:
        m = float(measured)
        return self._add(Check(name, m, f">{_fmt(float(bound))}", "0", math.isfinite(m) and m > bound, unit, note))

    def holds(self, name, ok: bool, note="") -> Check:
        return self._add(Check(name, 1.0 if ok else 0.0, "1", "0", bool(ok), "", note))

    def skip(self, name, reason: str) -> Check:
        """A check that cannot be made here, with the reason: listed and counted as skipped."""
        return self._add(Check(name, float("nan"), "-", "-", False, "", reason, skipped=True))

    def extend(self, items):
        """Checks made elsewhere (a worker process), echoed as they are added."""
        for check in items:
            self._add(check)

    def counts(self) -> dict[str, int]:
        return count(self.items)

    @property
    def passed(self) -> int:
        return self.counts()["passed"]

    @property
    def skipped(self) -> int:
        return self.counts()["skipped"]

    @property
    def failed(self) -> int:
        return self.counts()["failed"]

    def summary(self) -> str:
        return summary_of(self.counts())
