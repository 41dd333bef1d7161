"""Papaioannou et al.'s system through ``scripts/run_swarm.sh``: four agents, recorded.

The session's 25-step run of ``config/papaioannou_small.yaml`` on the repository's Fast DDS
profile (``conftest.SYSTEM_RUNS``; its log's completeness is checked with every system's in
``test_run_swarm_systems.py``): the moves are those of eq. 4, an agent's search map only
fills up, and the agents talk.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from phd_swarm.logs.mcap_log import read_messages
from phd_swarm.nodes import topics as T

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def test_the_moves_are_eq_4_and_the_search_maps_fill_up(system_run):
    run = system_run("papaioannou")
    summary = json.loads((run / "summary.json").read_text())
    maps = [np.array(rec.msg.data) for rec in read_messages(
        run / "run.mcap", topics=[T.robot_topic(0, "search_map")])]
    assert all(((m >= 0.0) & (m <= 1.0)).all() for m in maps)
    seen = [int(np.count_nonzero(m)) for m in maps]          # searched nodes only decay
    assert all(a <= b for a, b in zip(seen, seen[1:], strict=False)) and seen[-1] > seen[0]
    goals = [rec.msg for rec in read_messages(run / "run.mcap",
                                              topics=[T.robot_topic(0, "goal")])]
    moves = [(a.pose.position.x - b.pose.position.x, a.pose.position.y - b.pose.position.y)
             for a, b in zip(goals[1:], goals[:-1], strict=True)]
    assert all(dx * dx + dy * dy <= 16.0 + 1e-9 for dx, dy in moves)   # eq. 4: <= 2 x 2 m
    assert summary["messages_per_robot_per_step"] > 0
