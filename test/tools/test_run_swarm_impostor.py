"""No impersonation: a stranger flooding forged envelopes and scans changes nothing (issue 40).

Two lockstep runs of ``run_swarm.sh`` with the same seed, the second with an impostor on the
domain (``impostor.py``) from before the team starts to after it ends, speaking as every
robot to every other and as the world to every robot. The run's key (``run.key``) makes all
of it unauthenticated: the team's result is the same, step by step (the robots' density
windows, value for value, and the summary), and the impostor shows in the summary and on
``/diagnostics``.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from phd_swarm.logs.mcap_log import read_messages
from phd_swarm.nodes import cdr
from phd_swarm.testing import wait_for_text
from phd_swarm.tools.run_swarm import WALL_CLOCK_FIELDS
from phd_swarm_msgs.msg import DensityGrid

ROOT = Path(__file__).resolve().parents[2]
RUN_SWARM = str(ROOT / "scripts" / "run_swarm.sh")
CONFIG = str(ROOT / "config" / "dames_static.yaml")
IMPOSTOR = str(Path(__file__).with_name("impostor.py"))
ROBOTS = 3

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.full]


def _run(children, out: Path, name: str) -> Path:
    proc = children.start([RUN_SWARM, CONFIG, "--robots", str(ROBOTS), "--targets", "8",
                           "--duration", "20", "--seed", "4", "--out", str(out),
                           "--name", name])
    try:
        stdout, stderr = proc.communicate(timeout=240.0)
    except subprocess.TimeoutExpired:
        children.stop(proc)
        raise
    assert proc.returncode == 0, f"{stdout}\n{stderr}"
    return out / name


def _windows(run: Path) -> dict[str, list[tuple]]:
    """Each robot's density windows: step, window and values (CDR padding is not compared)."""
    topics = [f"/robot_{r}/density" for r in range(ROBOTS)]
    out: dict[str, list[tuple]] = {t: [] for t in topics}
    for rec in read_messages(run / "run.mcap", topics=topics, decode=False):
        f = cdr.decode(DensityGrid, rec.data)
        out[rec.topic].append((f["step"], f["origin_col"], f["origin_row"], f["width"],
                               f["height"], f["data"].tobytes()))
    return out


def _comparable(summary: dict) -> dict:
    return {k: v for k, v in summary.items()
            if k not in WALL_CLOCK_FIELDS and k not in ("run_dir", "rejected_messages_robots")}


def test_an_impostor_on_the_domain_changes_nothing_and_is_counted(tmp_path, children):
    alone = _run(children, tmp_path, "alone")
    impostor = children.start([sys.executable, IMPOSTOR, str(ROBOTS)],
                              stdout=(tmp_path / "impostor.log").open("w"),
                              stderr=subprocess.STDOUT)
    wait_for_text(tmp_path / "impostor.log", "impostor: up", impostor, timeout=60.0)
    attacked = _run(children, tmp_path, "attacked")
    wait_for_text(tmp_path / "impostor.log", "forged", impostor)
    assert impostor.poll() is None, "the impostor flooded throughout"
    children.stop(impostor)

    a = json.loads((alone / "summary.json").read_text())
    b = json.loads((attacked / "summary.json").read_text())
    assert _comparable(b) == _comparable(a)
    assert a["rejected_messages_robots"] == 0 and b["rejected_messages_robots"] > 0
    windows = _windows(attacked)
    assert windows == _windows(alone) and all(len(w) == 40 for w in windows.values())
    rejected = {s.name: {v.key: v.value for v in s.values}
                for rec in read_messages(attacked / "run.mcap", topics=["/diagnostics"])
                for s in rec.msg.status}
    counts = [int(v["rejected_messages"]) for name, v in rejected.items()
              if name.startswith("phd_swarm: robot")]
    assert counts and max(counts) > 0, rejected.keys()
    robot_log = (attacked / "logs" / "robot_0.log").read_text()
    assert "not signed with this run's key" in robot_log
