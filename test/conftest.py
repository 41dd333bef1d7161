"""Shared fixtures: in-process ROS contexts and child processes, both loopback-only."""

from __future__ import annotations

import os

import pytest

# Every ROS process a test starts stays on loopback, whatever the caller's shell says.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


def pytest_addoption(parser):
    parser.addoption("--full", action="store_true",
                     help="also run the tests marked full (the 50-process run)")


def pytest_collection_modifyitems(config, items):
    """Tests marked ``full`` run only with ``--full`` (``scripts/test.sh --full``)."""
    if config.getoption("--full"):
        return
    skip = pytest.mark.skip(reason="marked full: run with --full (scripts/test.sh --full)")
    for item in items:
        if "full" in item.keywords:
            item.add_marker(skip)


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
