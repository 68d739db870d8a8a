"""Two pieces of drawing at once on a machine with two cores: ``both(first, second)`` draws
``first`` in a forked process while this one draws ``second`` (the well's card and torque figures
beside its animation: half its end-to-end time was drawing). Each writes its own files, whole or
not at all (atomic.replacing), so there is nothing to send back but success or one line of error.
Where fork is missing (Windows) or one core is all there is, the two run one after the other."""

from __future__ import annotations

import os
import sys

from ..errors import CrankfmuError


def _cores() -> int:
    """The cores this process may run on (taskset, a container's limit), not the machine's."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def _can_fork() -> bool:
    return hasattr(os, "fork") and _cores() > 1 and sys.platform != "darwin"


def both(first, second):
    """``first()`` and ``second()``, at the same time where the machine allows; returns second's
    result. A failure of either is raised here (the forked one's as a CrankfmuError naming it)."""
    if not _can_fork():
        first()
        return second()
    from ..plots import pyplot

    pyplot()                                   # imported once, before the fork: both sides have it
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:                               # the child: draw, say how it went, leave at once
        os.close(read)
        code, message = 0, b""
        try:
            first()
        except BaseException as exc:           # noqa: BLE001 - reported to the parent in one line
            code, message = 1, f"{type(exc).__name__}: {exc}".encode("utf-8", "replace")
        finally:
            os.write(write, message[:4000])
            os.close(write)
            os._exit(code)
    os.close(write)
    try:
        result = second()
    finally:
        with os.fdopen(read, "rb") as pipe:
            message = pipe.read().decode("utf-8", "replace")
        _, status = os.waitpid(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise CrankfmuError(f"drawing the figures failed: {message or 'the drawing process ended abnormally'}")
    return result
