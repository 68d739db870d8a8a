"""Errors crankfmu raises. Every message names the offending item and what is valid, its numbers
as their user wrote them (:func:`format_value`)."""


def format_value(value) -> str:
    """A number as its user wrote it: the shortest text that reads back as the same double, as
    Python's repr writes it (``0.1``, not ``0.10000000000000001``; ``1e-11``, not
    ``9.999999999999999e-12``; ``2.0``); the native FMU's messages write it the same way
    (fmi2_shell.c: shortest). Anything else as ``str``."""
    try:
        return repr(float(value))
    except (TypeError, ValueError):
        return str(value)


def did_you_mean(name: str, valid) -> str:
    """" (did you mean X?)" with X the valid name closest to a misspelt ``name``, or "" when none
    is close (difflib's ratio at least 0.6: ``rr`` finds ``r``, ``kk_g`` finds ``k_g``)."""
    import difflib

    close = difflib.get_close_matches(str(name), [str(v) for v in valid], n=1, cutoff=0.6)
    return f" (did you mean {close[0]}?)" if close else ""


class CrankfmuError(Exception):
    """Base class of every error crankfmu raises on purpose."""


class DefinitionError(CrankfmuError, ValueError):
    """A mechanism or scenario file is malformed (unknown name, bad expression, ...)."""


class ParameterError(CrankfmuError, ValueError):
    """A parameter value is outside its valid range, or the name is unknown.

    ``parameter`` is the offending name (or a comma-separated list of names).
    """

    def __init__(self, message: str, parameter: str | None = None):
        super().__init__(message)
        self.parameter = parameter


class AssemblyError(ParameterError):
    """The geometry cannot be assembled over the whole crank turn."""


class ScenarioNotFound(CrankfmuError, LookupError):
    """No scenario of that name or path."""


class SchemeError(CrankfmuError, RuntimeError):
    """A numerical scheme cannot run this case (e.g. a crank-angle scheme at omega1 <= 0)."""
