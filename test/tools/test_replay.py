"""Replay of a recorded run: QoS from the log, timing, selection, bytes on the wire, bad files."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest
from mcap.writer import Writer
from rclpy.duration import Infinite
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)

from phd_swarm.logs.mcap_log import read_messages, summarize
from phd_swarm.logs.qos_yaml import qos_yaml
from phd_swarm.nodes.qos import CLOCK, LATCHED, STEP_PUB
from phd_swarm.tools.replay import Pacer, main
from phd_swarm.tools.replay_log import offered_qos

ROOT = Path(__file__).resolve().parents[2]
REPLAY = str(ROOT / "scripts" / "replay.sh")
SEC = 1_000_000_000

#: Reader profile of the in-process subscriber: deep enough for a whole --fast replay.
DEEP = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                  reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
DEEP_LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                          reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)


# ------------------------------------------------------------------------ no ROS
@pytest.mark.parametrize("profile", [
    STEP_PUB, LATCHED, CLOCK, qos_profile_sensor_data,
    QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=0, deadline=Infinite,
               reliability=ReliabilityPolicy.RELIABLE),
], ids=["step", "latched", "clock", "sensor", "keep_all"])
def test_offered_qos_reads_back_what_the_recorder_wrote(profile):
    back = offered_qos(qos_yaml(profile))
    assert back.reliability == profile.reliability
    assert back.durability == profile.durability
    assert back.history == profile.history
    if profile.history == HistoryPolicy.KEEP_LAST:
        assert back.depth == profile.depth
    assert back.deadline == profile.deadline


def test_offered_qos_serves_every_recorded_publisher_and_reads_old_numbers():
    best_effort = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
    both = offered_qos(qos_yaml(best_effort) + "\n" + qos_yaml(LATCHED))
    assert both.reliability == ReliabilityPolicy.RELIABLE
    assert both.durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert both.depth == 5
    humble = "- history: 1\n  depth: 3\n  reliability: 2\n  durability: 1\n"
    old = offered_qos(humble)
    assert (old.history, old.depth) == (HistoryPolicy.KEEP_LAST, 3)
    assert old.reliability == ReliabilityPolicy.BEST_EFFORT
    assert old.durability == DurabilityPolicy.TRANSIENT_LOCAL
    unknown = offered_qos("")
    assert unknown.reliability == ReliabilityPolicy.RELIABLE
    assert unknown.durability == DurabilityPolicy.VOLATILE
    with pytest.raises(ValueError, match="not a list"):
        offered_qos("history: keep_last")


def test_pacer_spaces_messages_by_log_time_over_rate():
    now = [100.0]
    pacer = Pacer(4.0, clock=lambda: now[0])
    t0 = 1_700_000_000 * SEC
    assert pacer.due(t0) == 100.0
    now[0] = 170.0  # the clock at later calls does not move the schedule
    assert pacer.due(t0 + 2 * SEC) == pytest.approx(100.5)
    assert pacer.due(t0 + 10 * SEC) == pytest.approx(102.5)
    assert pacer.due(t0 - SEC) < 100.0  # an earlier log time is due at once
    fast = Pacer(None, clock=lambda: now[0])
    assert fast.due(t0) == fast.due(t0 + 100 * SEC) == 170.0
    with pytest.raises(ValueError):
        Pacer(0.0)


def test_usage_errors_exit_2(tmp_path, capsys):
    assert main(["x.mcap", "--rate", "0"]) == 2
    assert main(["x.mcap", "--rate", "2", "--fast"]) == 2
    assert main([]) == 2
    assert "usage" in capsys.readouterr().err


def _script(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    """Run replay.sh without ROS (only the paths that fail before rclpy starts)."""
    return subprocess.run([REPLAY, *args], capture_output=True, text=True, timeout=timeout)


def test_bad_files_exit_1_naming_the_file_and_the_problem(tmp_path):
    text = tmp_path / "notes.txt"
    text.write_text("not a log\n")
    missing = tmp_path / "missing.mcap"
    other = tmp_path / "other.mcap"
    with open(other, "wb") as f:
        writer = Writer(f)
        writer.start(profile="x-custom", library="test")
        writer.finish()
    for path, problem in ((text, "not an MCAP file (bad magic)"), (missing, "no such file"),
                          (other, "not a ROS 2 log")):
        proc = _script(str(path), "--fast")
        assert proc.returncode == 1, proc.stderr
        assert proc.stderr.startswith(f"replay.sh: {path}: {problem}"), proc.stderr
        assert "Traceback" not in proc.stderr


def test_view_of_a_log_without_a_drawn_topic_is_refused_before_anything_starts(tmp_path,
                                                                               capsys):
    from builtin_interfaces.msg import Time
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock

    from phd_swarm.logs.mcap_log import LogWriter

    log = tmp_path / "clock_only.mcap"
    with LogWriter(log) as writer:
        writer.add_channel("/clock", "rosgraph_msgs/msg/Clock", qos_yaml(CLOCK))
        writer.write("/clock", serialize_message(Clock(clock=Time(sec=1))), 10, 10)
    assert main([str(log), "--fast", "--view"]) == 2
    err = capsys.readouterr().err
    assert f"replay.sh: error: {log}: no topic the view draws" in err


# ------------------------------------------------------------------------ recorded run
def _dry_run(capsys, *args: str) -> dict[str, tuple[str, int, str, str]]:
    """``--dry-run`` lines by topic: (type, count, first_s, last_s); checks the exit code."""
    assert main([*args, "--dry-run"]) == 0
    rows = {}
    for line in capsys.readouterr().out.splitlines():
        if not line.startswith("#"):
            topic, ros_type, count, first, last, *_ = line.split()
            rows[topic] = (ros_type, int(count), first, last)
    return rows


@pytest.mark.ros
def test_topics_start_and_end_select_a_log_time_window(recorded_run, capsys):
    log = recorded_run / "run.mcap"
    origin = summarize(log).start_ns
    clock = [r.log_time_ns for r in read_messages(log, ["/clock"], decode=False)]
    start_s, end_s = (clock[5] - origin) / SEC, (clock[15] - origin) / SEC
    rows = _dry_run(capsys, str(log), "--topics", "/world/truth", "/clock",
                    "--start", repr(start_s), "--end", repr(end_s))
    assert set(rows) == {"/clock", "/world/truth"}
    for topic, row in rows.items():
        times = [r.log_time_ns for r in read_messages(log, [topic], decode=False)
                 if clock[5] <= r.log_time_ns < clock[15]]
        assert row[1] == len(times) > 0
        assert float(row[2]) == pytest.approx((times[0] - origin) / SEC, abs=1e-6)
        assert float(row[3]) == pytest.approx((times[-1] - origin) / SEC, abs=1e-6)
    assert rows["/clock"][:2] == ("rosgraph_msgs/msg/Clock", 10)

    everything = _dry_run(capsys, str(log))
    assert everything.keys() == summarize(log).topics.keys()

    assert main([str(log), "--topics", "/clock", "/no/such", "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert "no topic /no/such in the log" in err and "/world/truth" in err
    assert main([str(log), "--start", "3", "--end", "2", "--dry-run"]) == 2


def _subscribe(node, log: Path, topics: dict[str, QoSProfile]):
    """Raw subscriptions to ``topics`` (topic -> reader QoS); returns (bytes, arrival times)."""
    from phd_swarm.nodes.record_topics import message_class

    types = {t: s.ros_type for t, s in summarize(log).topics.items()}
    got: dict[str, list[bytes]] = {t: [] for t in topics}
    arrivals: list[float] = []

    def callback(topic):
        def on_message(data: bytes) -> None:
            got[topic].append(data)
            arrivals.append(time.monotonic())
        return on_message

    for topic, qos in topics.items():
        node.create_subscription(message_class(types[topic]), topic, callback(topic), qos,
                                 raw=True)
    return got, arrivals


def _finish(children, proc) -> tuple[int, str]:
    try:
        _, err = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        children.stop(proc)
        raise
    return proc.returncode, err


@pytest.mark.ros
def test_the_docs_example_receives_every_metric(recorded_run, monkeypatch):
    """docs/replay.md's example, on this session's recorded run instead of the demo's."""
    (code,) = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "replay.md").read_text(),
                         re.S)
    steps = str(json.loads((recorded_run / "summary.json").read_text())["steps"])
    assert code.count("runs/demo/run.mcap") == 1 and code.count("240") == 2
    code = code.replace("runs/demo/run.mcap", str(recorded_run / "run.mcap")).replace(
        "240", steps)
    monkeypatch.chdir(ROOT)
    exec(compile(code, "replay.md[0]", "exec"), {})  # noqa: S102 - our own docs


@pytest.mark.ros
@pytest.mark.slow
def test_replay_delivers_the_logged_bytes_in_order_with_the_recorded_qos(recorded_run,
                                                                          children):
    from phd_swarm.testing import InProcessRos

    log = recorded_run / "run.mcap"
    topics = {"/clock": DEEP, "/world/truth": DEEP_LATCHED, "/monitor/metrics": DEEP}
    expected = {t: [r.data for r in read_messages(log, [t], decode=False)] for t in topics}
    with InProcessRos(domain_id=children.domain_id) as ros:
        node = ros.node("probe")
        proc = children.start([REPLAY, str(log), "--fast", "--topics", *topics,
                               "--wait-subscribers", "1"])
        # The replay waits for our subscriptions, so its publishers can be looked at first
        # (the node's name reaches the graph a little after its endpoints).
        def replay_publishes_all() -> bool:
            infos = [node.get_publishers_info_by_topic(t) for t in topics]
            return all(len(i) == 1 and i[0].node_name == "replay" for i in infos)

        assert ros.spin_until(replay_publishes_all, timeout=20.0), proc.poll()
        (truth,) = node.get_publishers_info_by_topic("/world/truth")
        assert truth.topic_type == "phd_swarm_msgs/msg/TargetSet"
        assert truth.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
        (clock,) = node.get_publishers_info_by_topic("/clock")
        assert clock.qos_profile.durability == DurabilityPolicy.VOLATILE

        got, _ = _subscribe(node, log, topics)
        total = sum(map(len, expected.values()))
        ros.spin_until(lambda: sum(map(len, got.values())) >= total, timeout=20.0)
        code, err = _finish(children, proc)
    assert code == 0, err
    assert f"done: sent {total} messages" in err
    for topic in topics:
        assert len(got[topic]) == len(expected[topic]) > 20, topic
        assert got[topic] == expected[topic], topic


@pytest.mark.ros
@pytest.mark.slow
def test_nodes_with_use_sim_time_follow_the_replayed_clock(recorded_run, children):
    from rclpy.parameter import Parameter

    from phd_swarm.testing import InProcessRos

    log = recorded_run / "run.mcap"
    clocks = [r.msg.clock for r in read_messages(log, ["/clock"])]
    last_ns = clocks[-1].sec * SEC + clocks[-1].nanosec
    assert last_ns > 0
    with InProcessRos(domain_id=children.domain_id) as ros:
        node = ros.node("follower", parameter_overrides=[Parameter("use_sim_time",
                                                                   value=True)])
        assert node.get_clock().now().nanoseconds == 0  # no /clock yet
        # At 10x the recorded pace, not --fast: rclpy's /clock subscription is best effort
        # with depth 1, and a burst of clock messages on a loaded machine can lose the last.
        proc = children.start([REPLAY, str(log), "--rate", "10", "--topics", "/clock",
                               "--wait-subscribers", "1"])
        ros.spin_until(lambda: node.get_clock().now().nanoseconds == last_ns, timeout=30.0)
        code, err = _finish(children, proc)
        # On a loaded machine the replay may still have been sending when the wait above
        # ended; what it sent since is in the subscription's queue: take it.
        ros.spin_until(lambda: node.get_clock().now().nanoseconds == last_ns, timeout=10.0)
        assert node.get_clock().now().nanoseconds == last_ns, f"replay said: {err}"
    assert code == 0, err


@pytest.mark.ros
@pytest.mark.slow
def test_rate_scales_the_recorded_timing(recorded_run, children):
    from phd_swarm.testing import InProcessRos

    log = recorded_run / "run.mcap"
    topics = {"/world/robots": DEEP, "/clock": DEEP}
    times = sorted(r.log_time_ns for r in read_messages(log, list(topics), decode=False))
    span = (times[-1] - times[0]) / SEC
    # 24 lockstep steps of 4 robot processes take far longer than 0.2 s on any machine.
    assert span > 0.2, f"the recorded run lasted only {span:.3f} s: nothing to time"
    # A rate 4x away from 1 (slower for a quick recording, faster for a slow one), so that a
    # replay at the recorded pace, ignoring --rate, falls outside the band checked below.
    rate = 0.25 if span < 2.0 else 4.0
    wall = span / rate
    with InProcessRos(domain_id=children.domain_id) as ros:
        node = ros.node("probe")
        got, arrivals = _subscribe(node, log, topics)
        proc = children.start([REPLAY, str(log), "--rate", repr(rate), "--topics", *topics,
                               "--wait-subscribers", "1"])
        ros.spin_until(lambda: len(arrivals) >= len(times), timeout=20.0 + wall)
        code, err = _finish(children, proc)
    assert code == 0, err
    assert len(arrivals) == len(times)
    assert 0.5 * wall <= arrivals[-1] - arrivals[0] <= 1.5 * wall, (arrivals[-1]
                                                                    - arrivals[0])


@pytest.mark.ros
@pytest.mark.slow
def test_truncated_log_replays_its_complete_records_with_a_warning(recorded_run, tmp_path,
                                                                   children, capsys):
    data = (recorded_run / "run.mcap").read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:int(len(data) * 0.6)])
    complete = list(read_messages(cut, decode=False))
    assert 0 < len(complete) < summarize(recorded_run / "run.mcap").message_count

    rows = _dry_run(capsys, str(cut))
    assert sum(row[1] for row in rows.values()) == len(complete)

    proc = children.start([REPLAY, str(cut), "--fast"])
    code, err = _finish(children, proc)
    assert code == 0, err
    assert re.search(rf"replay.sh: warning: {re.escape(str(cut))}: log is truncated", err), err
    assert f"done: sent {len(complete)} messages" in err


@pytest.mark.ros
@pytest.mark.slow
def test_sigterm_stops_a_replay_cleanly(recorded_run, children):
    proc = children.start([REPLAY, str(recorded_run / "run.mcap"), "--rate", "0.01"])
    line = proc.stderr.readline()
    assert "replaying" in line, line + proc.stderr.read()
    time.sleep(0.5)
    sent = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    code, err = _finish(children, proc)
    assert code == 0, err
    assert time.monotonic() - sent < 5.0
    assert "stopped by signal: sent" in err
