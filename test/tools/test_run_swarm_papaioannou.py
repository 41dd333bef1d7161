"""Papaioannou et al.'s system through ``scripts/run_swarm.sh``: four agents, recorded.

A 25-step run of ``config/papaioannou_small.yaml`` on the repository's Fast DDS profile
(``--dds profile``, UDP bound to 127.0.0.1; the other run_swarm tests use LOCALHOST): the
log is complete for the system's own topics (estimates, goals, search maps, the agents'
states and plans; no cell, density or components), the moves are those of eq. 4, and an
agent's search map only fills up.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from phd_swarm.logs.mcap_log import read_messages
from phd_swarm.nodes import topics as T

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def test_a_short_run_records_every_step_and_the_agents_estimates(tmp_path, record_swarm):
    run = record_swarm(tmp_path, "papaioannou_small.yaml", "--duration", "25", "--dds",
                       "profile")
    summary = json.loads((run / "summary.json").read_text())
    assert summary["complete"] and summary["steps"] == 25 and summary["dead_robots"] == []
    topics = summary["log_completeness"]["topics"]
    for r in range(4):
        for kind in ("estimates", "goal", "search_map", "sat_state", "plan"):
            assert topics[T.robot_topic(r, kind)]["recorded"] == 25, kind
    maps = [np.array(rec.msg.data) for rec in read_messages(
        run / "run.mcap", topics=[T.robot_topic(0, "search_map")])]
    assert all(((m >= 0.0) & (m <= 1.0)).all() for m in maps)
    seen = [int(np.count_nonzero(m)) for m in maps]          # searched nodes only decay
    assert all(a <= b for a, b in zip(seen, seen[1:], strict=False)) and seen[-1] > seen[0]
    assert not any(t.endswith(("/cell", "/density", "/components")) for t in topics)
    goals = [rec.msg for rec in read_messages(run / "run.mcap",
                                              topics=[T.robot_topic(0, "goal")])]
    moves = [(a.pose.position.x - b.pose.position.x, a.pose.position.y - b.pose.position.y)
             for a, b in zip(goals[1:], goals[:-1], strict=True)]
    assert all(dx * dx + dy * dy <= 16.0 + 1e-9 for dx, dy in moves)   # eq. 4: <= 2 x 2 m
    assert summary["messages_per_robot_per_step"] > 0
