"""A progress bar on stderr for runs longer than a few seconds, and a build's stage line."""

from __future__ import annotations

import sys
import threading
import time


def is_terminal(stream) -> bool:
    """Whether ``stream`` is a terminal (a line can be redrawn in place) rather than a log or pipe."""
    return bool(getattr(stream, "isatty", lambda: False)())


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
        self.tty = is_terminal(self.stream)
        self.granularity = 0.01 if self.tty else 0.1

    def __call__(self, value: float):
        elapsed = time.perf_counter() - self.t0
        if elapsed < self.delay:
            return
        frac = min(max((value - self.start) / (self.total - self.start), 0.0), 1.0)
        if frac - self.last < self.granularity and frac < 1.0:
            return
        if frac >= 1.0 and self.last >= 1.0:       # finished once: one final line, however often told
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


class StageLine:
    """A build's progress on a terminal: the FMU, the stage it is in and the time so far on one
    line, redrawn four times a second from ``delay`` s on (a build takes 2 to 10 s; a warm one
    says nothing). Called with (fmu, stage) as each stage starts (fmi.stages.watching_stages); a
    stream that is not a terminal (a log, a pipe, a test) gets nothing, so an error stays the
    only line there."""

    def __init__(self, stream=None, delay: float = 1.0):
        self.stream = sys.stderr if stream is None else stream
        self.delay, self.t0 = delay, time.perf_counter()
        self.text, self.width = "", 0          # the stage (one assignment: the ticker reads it whole)
        self._stop = threading.Event()
        self._ticker = None
        if is_terminal(self.stream):
            self._ticker = threading.Thread(target=self._tick, daemon=True)
            self._ticker.start()

    def __call__(self, fmu: str, what: str):
        self.text = f"{fmu}.fmu: {what}"

    def _tick(self):
        while not self._stop.wait(0.25):
            elapsed, text = time.perf_counter() - self.t0, self.text
            if elapsed < self.delay or not text:
                continue
            line = f"{text} ({elapsed:.1f} s)"
            self.stream.write("\r" + line.ljust(self.width))
            self.stream.flush()
            self.width = max(self.width, len(line))

    def close(self):
        """Stop, and clear the line for what the command prints next."""
        if self._ticker is None:
            return
        self._stop.set()
        self._ticker.join()
        if self.width:
            self.stream.write("\r" + " " * self.width + "\r")
            self.stream.flush()
