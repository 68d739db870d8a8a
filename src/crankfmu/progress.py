"""A progress bar on stderr for runs longer than a few seconds."""

from __future__ import annotations

import sys
import time


class ProgressBar:
    """Call with the quantity reached (e.g. simulated time); shows itself after ``delay`` s."""

    def __init__(self, total: float, label: str = "", start: float = 0.0, delay: float = 2.0,
                 stream=None, width: int = 30):
        self.total, self.start, self.label = float(total), float(start), label
        self.delay, self.width = delay, width
        self.stream = sys.stderr if stream is None else stream
        self.t0 = time.perf_counter()
        self.shown = False
        self.last = -1.0
        # a log file (CI) gets a line every 10 %, a terminal every 1 %
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.granularity = 0.01 if self.tty else 0.1

    def __call__(self, value: float):
        elapsed = time.perf_counter() - self.t0
        if elapsed < self.delay:
            return
        frac = min(max((value - self.start) / (self.total - self.start), 0.0), 1.0)
        if frac - self.last < self.granularity and frac < 1.0:
            return
        self.last = frac
        filled = int(round(frac * self.width))
        line = f"{self.label} [{'#' * filled}{'.' * (self.width - filled)}] {100 * frac:5.1f}% {elapsed:6.1f} s"
        self.stream.write(f"\r{line}" if self.tty else f"{line}\n")
        self.stream.flush()
        self.shown = True

    def close(self):
        if self.shown and self.tty:
            self.stream.write("\n")
            self.stream.flush()
