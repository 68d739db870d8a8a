"""A build's stages: each names itself in any failure inside it (the CLI prints one line), and
whoever watches (the CLI's progress line on a terminal) hears of each as it starts."""

from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar

from ..errors import CrankfmuError


class StageFailed(CrankfmuError):
    """A build's failure, named by the stage it happened in."""


#: who is told of each stage of a build as it starts (the CLI's progress line on a terminal)
_ON_STAGE: ContextVar = ContextVar("crankfmu_on_stage", default=None)


@contextmanager
def watching_stages(told):
    """Inside the block, ``told(fmu, what)`` hears of each build stage as it starts."""
    token = _ON_STAGE.set(told)
    try:
        yield
    finally:
        _ON_STAGE.reset(token)


@contextmanager
def stage(fmu: str, what: str):
    """Name the stage of the build in any failure inside it: the CLI prints one line. A stage inside
    another (the reference run, waited for by the documentation that plots it) names itself only."""
    told = _ON_STAGE.get()
    if told is not None:
        told(fmu, what)
    try:
        yield
    except StageFailed:
        raise
    except CrankfmuError as exc:
        raise StageFailed(f"{fmu}.fmu: {what}: {exc}") from exc
    except Exception as exc:        # anything else is a bug or the machine: the message says which stage
        raise StageFailed(f"{fmu}.fmu: {what} failed: {type(exc).__name__}: {exc}") from exc
