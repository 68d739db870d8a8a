"""The harness's status line says what each worker does: a run at 100 % is over, and the worker is
checking its results, which has no fraction (it showed "100%" for the 50 s the checks took)."""

from __future__ import annotations

import io

from validation.harness import StatusLine


def test_a_finished_run_reads_as_checking_not_as_a_bar_at_100_percent():
    stream = io.StringIO()
    line = StatusLine(total=4, stream=stream)
    line.show(1, {1: ("seed000 reference", 0.42), 2: ("engine4 speed against error", 1.0)}, force=True)
    text = stream.getvalue()
    assert "1/4 groups" in text
    assert "seed000 reference  42%" in text
    assert "engine4 speed against error done, checking" in text and "100%" not in text
