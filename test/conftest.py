"""Shared fixtures: in-process ROS contexts and child processes, both loopback-only."""

from __future__ import annotations

import os

import pytest

# Every ROS process a test starts stays on loopback, whatever the caller's shell says.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


@pytest.fixture
def ros():
    """A private rclpy context on a fresh domain id with a single-threaded executor."""
    from phd_swarm.testing import InProcessRos

    with InProcessRos() as harness:
        yield harness


@pytest.fixture
def children():
    """Child processes started on loopback and stopped by PID at teardown."""
    from phd_swarm.testing import ChildProcesses

    with ChildProcesses() as procs:
        yield procs
