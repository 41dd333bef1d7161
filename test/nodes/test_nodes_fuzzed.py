"""Fuzzed bytes on the topics nodes take raw never escape a callback (issue 40).

A robot's inbox and measurement set, the monitor's team bundles and everything the recorder
takes are raw subscriptions: the callback gets the bytes that arrived. Mutations of what a
running team really sent are fed to the callbacks of that team (as rclpy would call them);
each input must be taken or rejected and counted, none may raise, and the team still
finishes. Deterministic (derandomised) and in lockstep.
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from rclpy.parameter import Parameter

from phd_swarm.nodes import topics as T
from phd_swarm.nodes.qos import subscription_qos
from phd_swarm.nodes.recorder import Recorder
from phd_swarm.testing import fuzzed_bytes, small_static_scenario, start_swarm
from phd_swarm_msgs.msg import InboxMessage, MeasurementSet, MessageBundle, RobotStatus

#: Inputs fed to each callback.
EXAMPLES = 120


@pytest.mark.ros
def test_fuzzed_raw_inputs_are_rejected_and_counted_and_the_team_finishes(tmp_path):
    from phd_swarm.testing import InProcessRos

    scenario = small_static_scenario(robots=3, steps=16)
    with InProcessRos(executor="events") as ros:
        world, monitor, robots = start_swarm(ros, tmp_path, scenario)
        recorder = ros.add(Recorder(context=ros.context, parameter_overrides=[
            Parameter("output", value=str(tmp_path / "run.mcap")),
            Parameter("params_file", value=str(tmp_path / "params.yaml"))]))
        victim = robots[1]
        spy = ros.node("spy")
        seen: dict[str, list[bytes]] = {"inbox": [], "scan": [], "bundle": [], "status": [],
                                        "world": []}
        for key, typ, topic, qos in (
                ("inbox", InboxMessage, "/robot_1/inbox", "INBOX"),
                ("scan", MeasurementSet, "/robot_1/measurements", "STEP"),
                ("bundle", MessageBundle, T.TEAM_OUTPUTS, "STEP"),
                ("status", RobotStatus, T.TEAM_STATUS, "STEP"),
                ("world", MessageBundle, T.WORLD_OUTPUTS, "STEP")):
            spy.create_subscription(typ, topic, seen[key].append, subscription_qos(qos),
                                    raw=True)
        assert ros.spin_until(lambda: victim.filter.step >= 3 and all(seen.values()),
                              timeout=90.0)
        def rejected() -> tuple[int, int, int]:
            return (sum(victim.rejections.values()), monitor.rejected,
                    sum(recorder.routes.rejected.values()))

        before = rejected()
        feeds = [(victim._on_envelope, "inbox"), (victim._on_scan, "scan"),
                 (monitor._on_bundle, "bundle")]
        feeds += [(recorder._subs[topic].callback, key) for topic, key in (
            (T.TEAM_OUTPUTS, "bundle"), (T.TEAM_STATUS, "status"), (T.WORLD_OUTPUTS, "world"),
            (T.WORLD_TRUTH, "status"), (T.MONITOR_METRICS, "status"))]
        for feed, key in feeds:
            _fuzz(feed, seen[key][:8])
        after = rejected()
        assert all(a > b for a, b in zip(after, before, strict=True)), (before, after)
        assert ros.spin_until(lambda: monitor.done, timeout=180.0)
        recorder.close()
        assert not recorder.finished  # it never stopped recording


def _fuzz(feed, seeds: list[bytes]) -> None:
    """Feed ``EXAMPLES`` fuzzed inputs to the callback ``feed``; any exception fails."""

    @settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(fuzzed_bytes(seeds, max_random=256))
    def survives(data: bytes) -> None:
        feed(data)  # a callback that raises would take its node down

    survives()
