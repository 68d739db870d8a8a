"""A check: a measured number against an expectation, printed as one line.

    PASS name measured expected tolerance

Every kind of check is printed in that form: ``close`` passes when |measured - expected| <=
tolerance; ``at_most`` is ``close`` with expected 0 for a non-negative error; ``below`` and
``above`` are one-sided (expected printed as ``<bound`` or ``>bound``, tolerance ``0``); ``holds``
records a yes/no expectation (measured 1 or 0, expected 1); ``skip`` records a check that cannot
be made here, with its reason (``SKIP name: reason``), counted apart. A NaN measurement never passes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable


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
    verdict: str = ""              # a published number's: agrees, disagrees (and why), not comparable
    published: str = ""            # the published value with its unit
    ratio: float | None = None     # |measured - expected| / tolerance (close and at_most): 1 is the bar

    def line(self) -> str:
        if self.skipped:
            return f"SKIP {self.name}: {self.note}"
        unit = f" {self.unit}" if self.unit not in ("", "1") else ""
        return (f"{'PASS' if self.passed else 'FAIL'} {self.name} {_fmt(self.measured)} {self.expected} "
                f"{self.tolerance}{unit}")


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

    @property
    def passed(self) -> int:
        return sum(c.passed for c in self.items)

    @property
    def skipped(self) -> int:
        return sum(c.skipped for c in self.items)

    @property
    def failed(self) -> int:
        return len(self.items) - self.passed - self.skipped

    def summary(self) -> str:
        return f"{self.passed} passed, {self.failed} failed" + (f", {self.skipped} skipped" if self.skipped else "")
