"""Shirsat & Berman's system through ``scripts/run_swarm.sh``: three robots, recorded.

The session's run of ``config/shirsat_small.yaml`` (``conftest.SYSTEM_RUNS``; seed 4:
meetings at steps 2, 30, 32, 33; its log's completeness is checked with every system's in
``test_run_swarm_systems.py``): the log records the meetings, each robot's set equal to the
others' after one, and the monitor and the world draw them.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from phd_swarm.logs.mcap_log import read_messages
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.faces.meet_merge import reward_points

pytestmark = [pytest.mark.ros, pytest.mark.slow]


@pytest.fixture(scope="module")
def shirsat_run(system_run):
    return system_run("shirsat")


def test_the_log_records_the_meetings_and_the_merged_sets(shirsat_run):
    summary = json.loads((shirsat_run / "summary.json").read_text())
    assert set(summary["figures"]) >= {"reward_mean", "all_found", "robots_meeting"}
    sets: dict[int, dict[int, tuple[list[int], np.ndarray]]] = {}
    for rec in read_messages(shirsat_run / "run.mcap",
                             topics=[T.robot_topic(r, "reward_set") for r in range(3)]):
        sets.setdefault(int(rec.msg.step), {})[int(rec.msg.source_id)] = (
            list(rec.msg.met_ids), reward_points(rec.msg))
    met = {k: {r: ids for r, (ids, _) in by.items() if ids} for k, by in sets.items()}
    assert sorted(k for k, m in met.items() if m) == [2, 30, 32, 33]
    for k, m in met.items():
        for r, ids in m.items():
            for other in ids:  # robots that met hold the same set after the meeting
                assert r in sets[k][other][0]
                np.testing.assert_array_equal(sets[k][r][1], sets[k][other][1])
    assert summary["messages_per_robot_per_step"] == pytest.approx(
        sum(len(ids) for m in met.values() for ids in m.values()) / (3 * 60))


def test_the_monitor_draws_the_grid_and_the_meetings(shirsat_run):
    """/monitor/markers: the walk's grid at step 0, a sphere per robot at each meeting."""
    grid_points, meeting_points = {}, {}
    for rec in read_messages(shirsat_run / "run.mcap", topics=[T.MONITOR_MARKERS]):
        step = round((rec.msg.markers[0].header.stamp.sec
                      + rec.msg.markers[0].header.stamp.nanosec * 1e-9) / 1.0)
        for m in rec.msg.markers:
            if m.ns == "grid":
                grid_points[step] = len(m.points)
            elif m.ns == "meetings":
                meeting_points[step] = len(m.points)
    assert grid_points == {0: 11 * 11}                       # 5 x 5 m at 0.5 m: 11 x 11 nodes
    assert len(meeting_points) == 60
    assert {k for k, n in meeting_points.items() if n} == {2, 30, 32, 33}
    assert all(n >= 2 for n in meeting_points.values() if n)


def test_the_world_draws_every_robot_and_every_target(shirsat_run):
    """/world/markers, written as CDR by the world, draws the team and the truth.

    At each step: a sphere at each robot's pose, its id label and field of view, and a cube
    at each true target.
    """
    from phd_swarm.nodes.convert import target_positions
    from phd_swarm.nodes.markers import FOV_SEGMENTS

    def step_of(stamp) -> int:
        return round((stamp.sec + stamp.nanosec * 1e-9) / 1.0)

    poses: dict[int, dict[int, tuple[float, float]]] = {}
    for r in range(3):
        for rec in read_messages(shirsat_run / "run.mcap", topics=[T.robot_topic(r, "pose")]):
            p = rec.msg.pose.position
            poses.setdefault(step_of(rec.msg.header.stamp), {})[r] = (p.x, p.y)
    truth = {int(rec.msg.step): target_positions(rec.msg)
             for rec in read_messages(shirsat_run / "run.mcap", topics=[T.WORLD_TRUTH])}
    drawn = 0
    for rec in read_messages(shirsat_run / "run.mcap", topics=[T.WORLD_MARKERS]):
        k = step_of(rec.msg.markers[0].header.stamp)
        ns = {}
        for m in rec.msg.markers:
            ns.setdefault(m.ns, []).append(m)
        (robots,) = ns["robots"]
        np.testing.assert_array_equal([(p.x, p.y) for p in robots.points],
                                      [poses[k][r] for r in range(3)])
        assert [m.text for m in ns["robot_ids"]] == ["0", "1", "2"]
        assert len(ns["fov"][0].points) == 3 * 2 * FOV_SEGMENTS
        (cubes,) = ns["targets"]
        np.testing.assert_array_equal([(p.x, p.y) for p in cubes.points], truth[k])
        drawn += 1
    assert drawn == 60
