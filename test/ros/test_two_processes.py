"""Two separate processes exchange a message over DDS on loopback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

PEER = Path(__file__).with_name("loopback_peer.py")


def test_message_crosses_process_boundary(children):
    sub = children.start([sys.executable, str(PEER), "sub"])
    pub = children.start([sys.executable, str(PEER), "pub"])
    try:
        out, err = sub.communicate(timeout=30.0)
    except subprocess.TimeoutExpired:
        children.stop(pub)
        children.stop(sub)
        pytest.fail("the subscriber received nothing within 30 s:\n"
                    f"sub stderr: {sub.stderr.read() if sub.stderr else ''}")
    assert sub.returncode == 0, err
    lines = [line for line in out.splitlines() if line.startswith("GOT")]
    assert lines, out
    _, robot_id, step, n = lines[0].split()
    assert (int(robot_id), int(n)) == (9, 1) and int(step) >= 1
    assert pub.poll() is None, "the publisher died early"
    children.stop(pub)
    assert pub.returncode is not None
