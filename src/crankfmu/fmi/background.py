"""The reference run of an FMU's default experiment beside the rest of its build.

The reference (DOP853 on the Python contour engine, the FMU's ``<model>_ref.csv``) is the longest
single task of a build on an empty cache: about 3.2 s of CPU for the Shaper's and the pumping unit's.
It is Python under the GIL, so a thread would not run it beside the build's own Python work (the
C model's tables, the generated sources, pythonfmu's packing, the drawing of the mechanism); a
forked process does, from the moment the build starts until the documentation plots its result
(fmi.native.build, fmi.python.build). Where the
platform cannot fork (Windows), or the child fails, the run is made in process when the build
needs it, and says why it cannot as it always did.
"""

from __future__ import annotations

import functools
import multiprocessing
import warnings
from contextlib import contextmanager


@contextmanager
def reference_beside(run):
    """Start ``run()`` (the reference CSV's text, or None) in a forked process; yield a function
    that waits for it and returns its text, the same text however often it is called. The child is
    stopped if the build fails first."""
    if run is None:
        yield lambda: None
        return
    try:
        context = multiprocessing.get_context("fork")
    except ValueError:                          # no fork here: run in process, once, when asked
        yield functools.cache(run)
        return
    receive, send = context.Pipe(duplex=False)

    def child():
        try:
            send.send(("text", run()))
        except BaseException:                   # the parent runs it again, and says why
            send.send(("failed", None))
        finally:
            send.close()

    with warnings.catch_warnings():
        # Python 3.12 warns on fork in a process with threads (numpy's BLAS pool): the child runs
        # Python and numpy only, which both support a fork
        warnings.simplefilter("ignore", DeprecationWarning)
        process = context.Process(target=child, daemon=True)
        process.start()
    send.close()

    kept = []

    def result():
        if not kept:
            try:
                kind, text = receive.recv()
            except (EOFError, OSError):
                kind, text = "failed", None
            process.join()
            kept.append(text if kind == "text" else run())
        return kept[0]

    try:
        yield result
    finally:
        if process.is_alive():
            process.terminate()
        process.join()
        receive.close()
