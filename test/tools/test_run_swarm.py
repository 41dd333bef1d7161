"""scripts/run_swarm.sh end to end: processes, MCAP log, summary.json, graph, a killed robot."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from phd_swarm.tools.mcap_log import read_messages, read_metadata, summarize
from phd_swarm.tools.run_swarm import WALL_CLOCK_FIELDS

ROOT = Path(__file__).resolve().parents[2]
RUN_SWARM = str(ROOT / "scripts" / "run_swarm.sh")
CONFIG = str(ROOT / "config" / "dames_static.yaml")

#: summary.json fields DESIGN.md requires.
DESIGN_FIELDS = ("scenario", "seed", "robots", "steps", "sim_duration_s", "wall_duration_s",
                 "ospa_final", "ospa_mean_last_half", "ospa_series", "cardinality_true_final",
                 "cardinality_est_final", "messages_per_robot_per_step")

ROBOTS, STEPS = 4, 16


def _start(children, out: Path, name: str, *extra: str, config: str = CONFIG):
    return children.start([RUN_SWARM, config, "--robots", str(ROBOTS), "--targets", "10",
                           "--duration", str(STEPS * 0.5), "--seed", "3", "--out", str(out),
                           "--name", name, *extra])


def _finish(children, proc, timeout: float = 240.0) -> str:
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        children.stop(proc)
        raise
    assert proc.returncode == 0, f"run_swarm failed:\n{out}\n{err}"
    return out


@pytest.mark.ros
@pytest.mark.slow
def test_run_swarm_writes_a_valid_log_and_summary_and_repeats_itself(tmp_path, children):
    first = _start(children, tmp_path, "a")
    out = _finish(children, first)
    assert "results in" in out
    second = _start(children, tmp_path, "b")
    _finish(children, second)

    run = tmp_path / "a"
    summary = json.loads((run / "summary.json").read_text())
    for key in DESIGN_FIELDS:
        assert key in summary, key
    assert summary["steps"] == STEPS and summary["robots"] == ROBOTS
    assert summary["seed"] == 3 and summary["scenario"] == "dames_static"
    assert len(summary["ospa_series"]) == STEPS and summary["dead_robots"] == []
    assert 0 < summary["messages_per_robot_per_step"] < 100

    again = json.loads((tmp_path / "b" / "summary.json").read_text())
    for key in WALL_CLOCK_FIELDS:
        summary.pop(key, None)
        again.pop(key, None)
    assert summary == again

    info = summarize(run / "run.mcap")
    assert not info.truncated
    counts = {t: s.message_count for t, s in info.topics.items()}
    assert counts["/world/truth"] == STEPS
    assert counts["/monitor/metrics"] == STEPS
    assert counts["/clock"] == STEPS + 1
    assert counts["/world/robots"] == STEPS + 1
    for i in range(ROBOTS):
        assert counts[f"/robot_{i}/measurements"] == STEPS
        assert counts[f"/robot_{i}/density"] == STEPS
        assert counts[f"/robot_{i}/status"] == STEPS + 1      # READY, then one per step
        assert counts[f"/robot_{i}/inbox/state"] > 0
    assert info.topics["/world/truth"].ros_type == "phd_swarm_msgs/msg/TargetSet"
    meta = read_metadata(run / "run.mcap")
    assert "scenario" in meta["phd_swarm.config"]["params_yaml"]
    metrics = [r.msg for r in read_messages(run / "run.mcap", topics=["/monitor/metrics"])]
    assert [m.step for m in metrics] == list(range(STEPS))
    assert [round(m.ospa, 9) for m in metrics] == [round(v, 9) for _, v in
                                                  summary["ospa_series"]]


def _pid_of(run_dir: Path, robot_id: int) -> int | None:
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmd = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        args = [a.decode(errors="replace") for a in cmd]
        if f"robot_id:={robot_id}" in args and any(str(run_dir) in a for a in args):
            return int(entry.name)
    return None


@pytest.mark.ros
@pytest.mark.slow
def test_killing_a_robot_process_mid_run_leaves_the_others_running(tmp_path, children):
    config = tmp_path / "fast_timeouts.yaml"
    config.write_text(Path(CONFIG).read_text().replace(
        "    step_timeout: 15.0", "    step_timeout: 3.0").replace(
        "    controller: phd", "    controller: phd\n    tick_period: 0.2\n"
        "    timeout_ticks: 5").replace("progress_every: 20", "progress_every: 2"))
    steps = 40
    proc = children.start([RUN_SWARM, str(config), "--robots", str(ROBOTS), "--duration",
                           str(steps * 0.5), "--seed", "5", "--out", str(tmp_path), "--name",
                           "kill"])
    run = tmp_path / "kill"
    log = run / "logs" / "monitor.log"
    deadline = time.monotonic() + 120.0
    while not (log.exists() and "step 11/" in log.read_text()):
        assert proc.poll() is None and time.monotonic() < deadline, "the run did not start"
        time.sleep(0.2)
    pid = _pid_of(run, 2)
    assert pid is not None
    os.kill(pid, signal.SIGKILL)
    _finish(children, proc)
    summary = json.loads((run / "summary.json").read_text())
    assert summary["steps"] == steps and summary["complete"]
    assert 2 in summary["dead_robots"]
    assert "robot 2 did not report" in (run / "logs" / "world.log").read_text()
    metrics = [r.msg for r in read_messages(run / "run.mcap", topics=["/monitor/metrics"])]
    assert metrics[-1].robots_reported == ROBOTS - 1
    assert metrics[-1].step == steps - 1
