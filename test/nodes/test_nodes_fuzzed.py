"""Fuzzed bytes on the topics nodes take raw never escape a callback (issue 40).

A robot's inbox and measurement set and the monitor's team bundles are raw subscriptions:
the callback gets the bytes that arrived. Mutations of what a running team really sent are
fed to the callbacks of a running team (as rclpy would call them); each input must be
taken or rejected and counted, none may raise, and the team still finishes. Deterministic
(derandomised) and in lockstep.
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings

from phd_swarm.nodes import topics as T
from phd_swarm.nodes.qos import subscription_qos
from phd_swarm.testing import fuzzed_bytes, small_static_scenario, start_swarm
from phd_swarm_msgs.msg import InboxMessage, MeasurementSet, MessageBundle

#: Inputs fed to each callback.
EXAMPLES = 120


@pytest.mark.ros
def test_fuzzed_raw_inputs_are_rejected_and_counted_and_the_team_finishes(tmp_path):
    from phd_swarm.testing import InProcessRos

    scenario = small_static_scenario(robots=3, steps=16)
    with InProcessRos(executor="events") as ros:
        world, monitor, robots = start_swarm(ros, tmp_path, scenario)
        victim = robots[1]
        spy = ros.node("spy")
        seen: dict[str, list[bytes]] = {"inbox": [], "scan": [], "bundle": []}
        for key, typ, topic, qos in (
                ("inbox", InboxMessage, "/robot_1/inbox", "INBOX"),
                ("scan", MeasurementSet, "/robot_1/measurements", "STEP"),
                ("bundle", MessageBundle, T.TEAM_OUTPUTS, "STEP")):
            spy.create_subscription(typ, topic, seen[key].append, subscription_qos(qos),
                                    raw=True)
        assert ros.spin_until(lambda: victim.filter.step >= 3 and all(seen.values()),
                              timeout=90.0)
        rejected_before = sum(victim.rejections.values()), monitor.rejected
        feeds = {"inbox": victim._on_envelope, "scan": victim._on_scan,
                 "bundle": monitor._on_bundle}
        for key, feed in feeds.items():
            _fuzz(feed, seen[key][:8])
        rejected_after = sum(victim.rejections.values()), monitor.rejected
        assert rejected_after[0] > rejected_before[0] and rejected_after[1] > rejected_before[1]
        assert ros.spin_until(lambda: monitor.done, timeout=180.0)


def _fuzz(feed, seeds: list[bytes]) -> None:
    """Feed ``EXAMPLES`` fuzzed inputs to the callback ``feed``; any exception fails."""

    @settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(fuzzed_bytes(seeds, max_random=256))
    def survives(data: bytes) -> None:
        feed(data)  # a callback that raises would take its node down

    survives()
