"""The swarm's process bookkeeping: :class:`phd_swarm.tools.processes.Stepping`."""

from __future__ import annotations

import time

from phd_swarm.tools.processes import Stepping


def test_stepping_takes_the_cpu_between_the_worlds_ready_and_done_lines():
    started = time.monotonic()
    stepping = Stepping(started=started, ready_line="READY", done_line="DONE")
    marks = stepping.marks()
    stepping.note({"world": 1.0, "robot_0": 2.0})
    assert stepping.figures({"world": 1.0}) == {}  # never ready: no figures
    marks["READY"].set()
    stepping.note({"world": 1.5, "robot_0": 3.0})
    assert stepping.ready_at is not None and stepping.ready_at >= started
    marks["DONE"].set()
    stepping.note({"world": 2.25, "robot_0": 7.0, "monitor": 0.5})
    # Samples after the done line do not count.
    figures = stepping.figures({"world": 9.0, "robot_0": 9.0, "monitor": 9.0})
    assert figures["cpu_s_stepping"] == {"monitor": 0.5, "robot_0": 4.0, "world": 0.75}
    assert figures["startup_s"] == round(stepping.ready_at - started, 2)


def test_stepping_without_a_done_line_counts_to_the_last_sample():
    stepping = Stepping(started=0.0, ready_line="READY", done_line="DONE")
    stepping.marks()["READY"].set()
    stepping.note({"world": 1.0})
    assert stepping.figures({"world": 4.0})["cpu_s_stepping"] == {"world": 3.0}
