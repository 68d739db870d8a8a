"""Command line: ``crankfmu simulate SCENARIO --out DIR [--method M] [--set NAME=VALUE ...]``,
``crankfmu schemes SCENARIO --out DIR``, ``crankfmu draw SCENARIO --at DEG --out FILE.png``,
``crankfmu animate SCENARIO --out FILE.gif [--result DIR]``,
``crankfmu validate [--fmu PATH ...] [--out DIR] [--quick]`` and the studies (``crankfmu --help``).

``parser`` declares the commands; ``studies``, ``fmus`` and ``pictures`` run them; here, ``main``
turns every failure into one line.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ..errors import CrankfmuError
from .parser import build_parser


#: the commands whose --out is a file (its folder must be writable), not a folder
_OUT_IS_FILE = ("draw", "animate", "page")


def check_output(path, is_file: bool = False) -> Path:
    """CrankfmuError, before anything is computed, when ``path`` (a folder, or a file's folder)
    cannot be created or written: an existing file where a folder must be, or no write permission
    on the nearest existing folder. Nothing is created."""
    path = Path(path)
    folder = path.parent if is_file else path
    if is_file and path.is_dir():
        raise CrankfmuError(f"--out {path}: is a folder; give a file name ({path / 'out.png'}, say)")
    probe = folder
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise CrankfmuError(f"--out {path}: {probe} is a file, not a folder: it cannot hold the output")
    if probe.exists() and not os.access(probe, os.W_OK | os.X_OK):
        raise CrankfmuError(f"--out {path}: no permission to write in {probe}")
    if probe.is_dir():
        # access() says yes to root everywhere, /proc included: a file made and removed at once is
        # the real test of whether the folder (or one inside it) can be written
        import tempfile

        try:
            fd, name = tempfile.mkstemp(dir=probe, prefix=".crankfmu-probe-")
            os.close(fd)
            os.unlink(name)
        except OSError as exc:
            raise CrankfmuError(f"--out {path}: cannot write in {probe}: {exc.strerror or exc}") from None
    return path


def main(argv=None) -> int:
    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    delegate = getattr(args, "delegate", None)  # validate, hosts: their module parses the rest
    if rest and not delegate:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    try:
        if getattr(args, "out", None) is not None:
            check_output(args.out, is_file=args.command in _OUT_IS_FILE)
        if delegate:
            import importlib

            return importlib.import_module(delegate).main(rest)
        return args.func(args)
    except CrankfmuError as exc:
        show_traceback()
        print(f"crankfmu: error: {_one_line(exc)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("crankfmu: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:     # a bug or the machine (disk full, permissions): one line, not a traceback
        if show_traceback():
            raise
        print(f"crankfmu: error: {type(exc).__name__}: {_one_line(exc)} (CRANKFMU_TRACEBACK=1 shows where)",
              file=sys.stderr)
        return 1


def show_traceback() -> bool:
    """With CRANKFMU_TRACEBACK=1, the traceback of the failure being handled goes to stderr before
    its one line (for a bug report); every command that turns a failure into one line calls it."""
    if not os.environ.get("CRANKFMU_TRACEBACK"):
        return False
    import traceback

    traceback.print_exc(file=sys.stderr)
    return True


def _one_line(exc) -> str:
    """An error's message on one line (a compiler's output, a multi-line cause)."""
    return " | ".join(line.strip() for line in str(exc).splitlines() if line.strip()) or type(exc).__name__
