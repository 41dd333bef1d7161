"""Recorder: in-process recording read back, discovery, and clean / killed processes."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from mcap.reader import make_reader
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header, String
from visualization_msgs.msg import Marker, MarkerArray

from phd_swarm.config import load_run_config
from phd_swarm.logs.mcap_log import open_log, read_messages, read_metadata, summarize
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.qos import publisher_qos, subscription_qos
from phd_swarm.nodes.record_topics import accepts, adapted_qos, starts_with_stamp, table_spec
from phd_swarm.nodes.recorder import Recorder
from phd_swarm.nodes.ros_params import ParameterError
from phd_swarm.nodes.team_routes import status_state
from phd_swarm_msgs.msg import RobotStatus, TargetSet, TeamState

ROOT = Path(__file__).resolve().parents[2]
SEC = 1_000_000_000


def _config(tmp_path: Path, robots: int = 1, **recorder) -> Path:
    """A resolved run config for ``robots`` robots with recorder parameters ``recorder``."""
    rc = load_run_config(ROOT / "config" / "dames_static.yaml")
    rc = rc.with_overrides(scenario=dataclasses.replace(rc.scenario, robots=robots),
                           recorder=recorder)
    return rc.write_params(tmp_path / "config.yaml")


def _recorder(ros, **params) -> Recorder:
    overrides = [Parameter(name, value=value) for name, value in params.items()]
    return ros.add(Recorder(context=ros.context, parameter_overrides=overrides))


def _stamp(step: int) -> Header:
    return Header(stamp=Time(sec=step, nanosec=500), frame_id="map")


def _status(step: int, robot_id: int = 0) -> RobotStatus:
    return RobotStatus(header=_stamp(step), state=RobotStatus.STATE_STEP_DONE,
                       robot_id=robot_id, step=step, goal=Point(x=1.0 + step, y=2.0))


def _matched(ros, pubs, timeout: float = 20.0) -> None:
    assert ros.spin_until(lambda: all(p.get_subscription_count() > 0 for p in pubs),
                          timeout=timeout), "the recorder's subscriptions did not match"


# ------------------------------------------------------------------------ pure helpers
def test_stamp_detection_and_table_lookup():
    assert starts_with_stamp("phd_swarm_msgs/msg/RobotStatus")
    assert starts_with_stamp("phd_swarm_msgs/msg/ParticleTransfer")  # constants after header
    assert starts_with_stamp("rosgraph_msgs/msg/Clock")
    assert not starts_with_stamp("visualization_msgs/msg/MarkerArray")
    assert not starts_with_stamp("geometry_msgs/msg/Point")
    assert table_spec("/robot_12/inbox") == ("phd_swarm_msgs/msg/InboxMessage", "INBOX")
    assert table_spec("/world/truth") == ("phd_swarm_msgs/msg/TargetSet", "STEP")
    assert table_spec("/robot_1/unknown") is None and table_spec("/robot_x/status") is None


def test_status_state_is_read_from_the_cdr_bytes():
    from rclpy.serialization import serialize_message

    for frame in ("", "map", "a_longer_frame_id"):
        for state in (RobotStatus.STATE_READY, RobotStatus.STATE_STEP_DONE, 7):
            msg = RobotStatus(header=Header(stamp=Time(sec=3), frame_id=frame), state=state,
                              robot_id=4, step=3)
            assert status_state(serialize_message(msg)) == state


def test_qos_follows_the_publishers_offers():
    reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)
    best_effort = qos_profile_sensor_data
    both = adapted_qos([reliable, best_effort])
    assert (both.reliability, both.durability) == (ReliabilityPolicy.BEST_EFFORT,
                                                   DurabilityPolicy.VOLATILE)
    latched = adapted_qos([reliable])
    assert (latched.reliability, latched.durability, latched.depth) == (
        ReliabilityPolicy.RELIABLE, DurabilityPolicy.TRANSIENT_LOCAL, 100)
    assert adapted_qos([]).reliability == ReliabilityPolicy.RELIABLE
    assert accepts(subscription_qos("STEP"), [publisher_qos("STEP")])
    assert not accepts(subscription_qos("STEP"), [QoSProfile(depth=10)])  # volatile writer
    assert not accepts(subscription_qos("CLOCK"), [best_effort])


# ------------------------------------------------------------------------ in process
@pytest.mark.ros
def test_records_the_run_topics_of_a_config_and_its_metadata(ros, tmp_path):
    cfg = _config(tmp_path)
    out = tmp_path / "run.mcap"
    rec = _recorder(ros, output=str(out), params_file=str(cfg), discover=False,
                    compression="lz4", wait_for_world=False)
    # The protocol inboxes only when asked (record_inboxes); of the declared outputs only
    # the system's (Dames: density, density_grid and cell), so no reader waits on a topic
    # nobody writes.
    # The team topics carry robot topics (bundle.py): the log holds those, not them.
    assert len(rec.topics) == len(T.TEAM_TOPICS) - len(T.TEAM_TRANSPORT) \
        + len(T.ROBOT_TOPICS) - 1 + 3
    assert not set(T.TEAM_TRANSPORT) & set(rec.topics)
    assert not any(t.endswith("/inbox") for t in rec.topics)
    assert {"/robot_0/density", "/robot_0/density_grid", "/robot_0/cell",
            T.DIAGNOSTICS} <= set(rec.topics)
    assert not any(t.endswith(("/components", "/plan", "/markers")) for t in rec.topics
                   if t.startswith("/robot_"))
    talker = ros.node("talker")
    truth = talker.create_publisher(TargetSet, T.WORLD_TRUTH, publisher_qos("STEP"))
    status = talker.create_publisher(RobotStatus, T.TEAM_STATUS, publisher_qos("STEP"))
    clock = talker.create_publisher(Clock, T.CLOCK, publisher_qos("CLOCK"))
    _matched(ros, [truth, status, clock])

    before = time.time_ns()
    for k in range(5):
        clock.publish(Clock(clock=Time(sec=k)))
        truth.publish(TargetSet(header=_stamp(k), source_id=0xFFFFFFFF, step=k, ids=[3, 4],
                                positions=[Point(x=1.0), Point(y=float(k))]))
        status.publish(_status(k))
    assert ros.spin_until(lambda: rec.message_count == 15, timeout=10.0), rec.message_count
    after = time.time_ns()
    rec.close()
    rec.close()

    info = summarize(out)
    assert not info.truncated and info.message_count == 15
    assert {t: s.message_count for t, s in info.topics.items() if s.message_count} == {
        "/clock": 5, "/world/truth": 5, "/robot_0/status": 5}
    assert len(info.topics) == len(rec.topics)
    records = list(read_messages(out))
    assert all(before <= r.log_time_ns <= after for r in records)
    by_topic: dict[str, list] = {}
    for r in records:
        by_topic.setdefault(r.topic, []).append(r)
    assert [r.msg.step for r in by_topic["/robot_0/status"]] == list(range(5))
    assert [r.msg.goal.x for r in by_topic["/robot_0/status"]] == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert [r.msg.positions[1].y for r in by_topic["/world/truth"]] == [0.0, 1.0, 2.0, 3.0,
                                                                        4.0]
    # publish time: the header stamp (sim time), or the clock's value
    assert [r.publish_time_ns for r in by_topic["/world/truth"]] == [
        k * SEC + 500 for k in range(5)]
    assert [r.publish_time_ns for r in by_topic["/clock"]] == [k * SEC for k in range(5)]

    meta = read_metadata(out)
    assert meta["phd_swarm.config"] == {"params_yaml": cfg.read_text(), "source": str(cfg)}
    assert meta["phd_swarm.run"] == {"scenario": "dames_static", "seed": "1", "robots": "1"}
    assert meta["phd_swarm.recorder"]["compression"] == "lz4"
    with open(out, "rb") as f:
        channels = {c.topic: c for c in make_reader(f).get_summary().channels.values()}
    (offer,) = yaml.safe_load(channels["/robot_0/status"].metadata["offered_qos_profiles"])
    assert (offer["durability"], offer["depth"]) == ("transient_local",
                                                     publisher_qos("STEP").depth)


@pytest.mark.ros
def test_the_truth_is_subscribed_once_every_world_writer_matched(ros, tmp_path):
    """The world counts the recorder by its truth subscription: that comes last."""
    from phd_swarm_msgs.msg import MessageBundle

    rec = _recorder(ros, output=str(tmp_path / "run.mcap"),
                    params_file=str(_config(tmp_path, robots=2)), discover=False)
    assert T.WORLD_TRUTH not in rec.topics
    world = ros.node("world")
    types = {"rosgraph_msgs/msg/Clock": Clock, "phd_swarm_msgs/msg/TeamState": TeamState,
             "visualization_msgs/msg/MarkerArray": MarkerArray,
             T.BUNDLE_TYPE: MessageBundle}
    # The robots' poses and measurement sets reach the recorder inside /world/outputs.
    specs = [t for t in T.run_topics(range(2)) if t.publisher == "world"
             and t.name != T.WORLD_TRUTH and not t.via]
    assert {t.name for t in specs} == {"/clock", "/world/robots", "/world/markers",
                                       T.WORLD_OUTPUTS}
    last = next(t for t in specs if t.name == T.WORLD_OUTPUTS)
    pubs = [world.create_publisher(types[t.type], t.name, publisher_qos(t.qos))
            for t in specs if t is not last]
    _matched(ros, pubs)
    ros.spin_until(lambda: False, timeout=1.0)
    assert T.WORLD_TRUTH not in rec.topics, "subscribed before the last writer matched"
    world.create_publisher(MessageBundle, last.name, publisher_qos(last.qos))
    assert ros.spin_until(lambda: T.WORLD_TRUTH in rec.topics, timeout=20.0)
    rec.close()


@pytest.mark.ros
def test_discovers_new_topics_with_table_or_adapted_qos(ros, tmp_path):
    out = tmp_path / "run.mcap"
    rec = _recorder(ros, output=str(out))
    talker = ros.node("talker")
    markers = talker.create_publisher(MarkerArray, T.WORLD_MARKERS,
                                      publisher_qos("OBSERVATION"))
    custom = talker.create_publisher(String, "/robot_2/custom", QoSProfile(depth=10))
    volatile_status = talker.create_publisher(RobotStatus, "/robot_1/status",
                                              QoSProfile(depth=10))
    talker.create_publisher(String, "/elsewhere/chatter", QoSProfile(depth=10))
    # /diagnostics too: the recorder reports there itself (and records the others' reports)
    wanted = {T.WORLD_MARKERS, "/robot_2/custom", "/robot_1/status", T.DIAGNOSTICS}
    assert ros.spin_until(lambda: wanted <= set(rec.topics), timeout=10.0), rec.topics
    _matched(ros, [markers, custom, volatile_status])
    rec.discover()
    assert set(rec.topics) == wanted

    markers.publish(MarkerArray(markers=[Marker(ns="robots", id=1)]))
    custom.publish(String(data="hello"))
    volatile_status.publish(_status(3, robot_id=1))
    assert ros.spin_until(lambda: rec.message_count == 3, timeout=10.0)
    rec.close()

    got = {r.topic: r for r in read_messages(out)}
    assert got["/robot_2/custom"].msg.data == "hello"
    assert got["/robot_1/status"].msg.robot_id == 1
    assert got["/robot_1/status"].publish_time_ns == 3 * SEC + 500
    marker = got[T.WORLD_MARKERS]
    assert marker.msg.markers[0].ns == "robots"
    assert marker.publish_time_ns == marker.log_time_ns  # no stamp: receive time
    with open(out, "rb") as f:
        channels = {c.topic: c for c in make_reader(f).get_summary().channels.values()}
    (offer,) = yaml.safe_load(channels["/robot_1/status"].metadata["offered_qos_profiles"])
    assert (offer["reliability"], offer["durability"]) == ("reliable", "volatile")


@pytest.mark.ros
def test_bad_params_file_or_output_is_a_parameter_error(ros, tmp_path):
    out = tmp_path / "run.mcap"
    with pytest.raises(ParameterError, match="params_file: .*nowhere.yaml"):
        Recorder(context=ros.context, parameter_overrides=[
            Parameter("output", value=str(out)),
            Parameter("params_file", value=str(tmp_path / "nowhere.yaml"))])
    assert not out.exists()
    with pytest.raises(ParameterError, match="parameter output: .*no_dir"):
        Recorder(context=ros.context, parameter_overrides=[
            Parameter("output", value=str(tmp_path / "no_dir" / "run.mcap"))])


# ------------------------------------------------------------------------ processes
def _start(children, ros, argv: list[str]) -> subprocess.Popen:
    return children.start(argv, env={"ROS_DOMAIN_ID": str(ros.domain_id)}, cwd=str(ROOT))


def _recorder_argv(cfg: Path, out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "phd_swarm.nodes.recorder", "--ros-args",
            "--params-file", str(cfg), "-p", f"params_file:={cfg}", "-p", f"output:={out}",
            *extra]


def _publish_statuses(ros, n: int):
    """Publish ``n`` statuses of robot 0 in a burst and wait until the recorder has them.

    The writer keeps all ``n`` (the table's STEP writer keeps 8, one per step in a run).
    """
    talker = ros.node("talker")
    deep = QoSProfile(depth=n, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)
    pub = talker.create_publisher(RobotStatus, T.TEAM_STATUS, deep)
    _matched(ros, [pub], timeout=30.0)
    for k in range(n):
        pub.publish(_status(k))
    assert pub.wait_for_all_acked(Duration(seconds=10))


@pytest.mark.ros
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_stop_signal_closes_the_file_with_summary_and_footer(ros, children, tmp_path, sig):
    out = tmp_path / "run.mcap"
    cfg = _config(tmp_path, discover=False)
    proc = _start(children, ros, _recorder_argv(cfg, out))
    _publish_statuses(ros, 50)
    os.killpg(proc.pid, sig)
    stdout, stderr = proc.communicate(timeout=20.0)
    assert proc.returncode == 0, stderr
    assert "wrote 50 messages" in stderr, stderr
    with open(out, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics.message_count == 50
    with open_log(out) as log:
        assert not log.truncated
        assert [r.msg.step for r in log.messages(topics=["/robot_0/status"])] == \
            list(range(50))
    assert read_metadata(out)["phd_swarm.run"]["robots"] == "1"


@pytest.mark.ros
def test_sigkill_leaves_every_finished_chunk_readable(ros, children, tmp_path):
    out = tmp_path / "run.mcap"
    cfg = _config(tmp_path, discover=False)
    proc = _start(children, ros, _recorder_argv(cfg, out, "-p", "chunk_size:=1024"))
    n = 200
    _publish_statuses(ros, n)
    # A 1 KiB chunk holds < 10 statuses: once they are processed, all but the last few are
    # in finished chunks on disk.
    assert ros.spin_until(lambda: summarize(out).message_count >= n - 20, timeout=20.0)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=10.0)

    with open_log(out) as log:
        assert log.truncated
        steps = [r.msg.step for r in log.messages()]
    assert n - 20 <= len(steps) <= n and steps == list(range(len(steps)))
    info = summarize(out)
    assert info.truncated and info.topics["/robot_0/status"].message_count == len(steps)
    assert read_metadata(out)["phd_swarm.config"]["source"] == str(cfg)


@pytest.mark.ros
def test_record_sh_checks_the_config_and_records(ros, children, tmp_path):
    out = tmp_path / "run.mcap"
    bad = tmp_path / "bad.yaml"
    bad.write_text("/**: {ros__parameters: {scenario: {preset: nope}}}\n")
    check = subprocess.run(["bash", str(ROOT / "scripts/record.sh"), str(out), str(bad)],
                           capture_output=True, text=True, timeout=60, cwd=str(tmp_path))
    assert check.returncode != 0 and str(bad) in check.stderr and not out.exists()

    cfg = _config(tmp_path, discover=False, output=str(tmp_path / "elsewhere.mcap"))
    proc = _start(children, ros, ["bash", str(ROOT / "scripts/record.sh"), str(out),
                                  str(cfg), "-p", "recorder:compression:=none"])
    _publish_statuses(ros, 3)
    children.stop(proc)
    assert proc.returncode == 0, proc.stderr.read()
    info = summarize(out)
    assert not info.truncated and info.topics["/robot_0/status"].message_count == 3
    meta = read_metadata(out)
    assert meta["phd_swarm.config"]["source"] == str(cfg)
    assert meta["phd_swarm.recorder"]["compression"] == "none"


@pytest.mark.ros
def test_inboxes_are_recorded_only_when_asked(ros, tmp_path):
    cfg = _config(tmp_path, robots=2)
    rec = _recorder(ros, output=str(tmp_path / "run.mcap"), params_file=str(cfg),
                    discover=False, record_inboxes=True)
    assert {T.robot_topic(r, "inbox") for r in range(2)} <= set(
        rec.topics)
    rec.close()
    assert read_metadata(tmp_path / "run.mcap")["phd_swarm.recorder"]["record_inboxes"] \
        == "true"


@pytest.mark.ros
def test_completeness_names_the_missing_steps_and_is_stored_in_the_log(ros, tmp_path):
    """A report names exactly the steps that are missing, and expects nothing more.

    Two robots, 4 steps; robot 1 dies during step 1 and robot 0's status of step 2 is never
    published.
    """
    cfg = _config(tmp_path, robots=2)
    out = tmp_path / "run.mcap"
    rec = _recorder(ros, output=str(out), params_file=str(cfg), discover=False,
                    wait_for_world=False)
    talker = ros.node("talker")
    pubs = {name: talker.create_publisher(typ, name, publisher_qos("STEP")) for name, typ in [
        (T.WORLD_ROBOTS, TeamState), (T.TEAM_STATUS, RobotStatus)]}
    _matched(ros, list(pubs.values()))
    dt = load_run_config(cfg).scenario.dt
    steps = 4

    def stamp(k):
        ns = int(round(k * dt * SEC))
        return Header(stamp=Time(sec=ns // SEC, nanosec=ns % SEC), frame_id="map")

    for k in range(steps + 1):
        alive = [True, k <= 1]
        pubs[T.WORLD_ROBOTS].publish(TeamState(header=stamp(k), step=k, robot_ids=[0, 1],
                                               positions=[Point(), Point()], alive=alive))
        for r in (0, 1):
            if k == 0:
                pubs[T.TEAM_STATUS].publish(RobotStatus(
                    header=stamp(0), state=RobotStatus.STATE_READY, robot_id=r))
            if k < steps and alive[r] and (r, k) != (0, 2) and (r, k) != (1, 1):
                pubs[T.TEAM_STATUS].publish(RobotStatus(
                    header=stamp(k), state=RobotStatus.STATE_STEP_DONE, robot_id=r, step=k))
    assert ros.spin_until(lambda: rec.message_count == 5 + 2 + 3 + 1, timeout=10.0), \
        rec.message_count
    rec.close()
    report = rec.report
    assert report.steps == steps and not report.complete
    assert report.topics[T.robot_topic(0, "status")].missing == (2,)
    # Robot 1 reported step 0; it died during step 1 (dead in the team state of step 2), so
    # its status of step 1 is not expected.
    assert report.topics[T.robot_topic(1, "status")].expected == 1
    assert report.topics[T.robot_topic(1, "status")].missing == ()
    assert report.topics[T.WORLD_ROBOTS].missing == ()
    assert report.topics[T.WORLD_TRUTH].missing == tuple(range(steps))
    meta = read_metadata(out)["phd_swarm.completeness"]
    assert meta["complete"] == "false" and int(meta["missing"]) == report.missing
    from phd_swarm.nodes.completeness import Completeness

    assert Completeness.from_dict(json.loads(meta["report"])) == report


@pytest.mark.ros
def test_a_message_too_short_for_its_stamp_is_recorded_stamped_on_receipt(ros, tmp_path):
    """Bytes from a stranger on a stamped topic used to raise inside the callback."""
    out = tmp_path / "run.mcap"
    rec = _recorder(ros, output=str(out), discover=False)
    rec.subscribe("/robot_1/status", "phd_swarm_msgs/msg/RobotStatus", QoSProfile(depth=10))
    pub = ros.node("stranger").create_publisher(RobotStatus, "/robot_1/status",
                                                QoSProfile(depth=10))
    _matched(ros, [pub])
    pub.publish(b"\x00\x01\x00\x00\x07")
    pub.publish(_status(2, robot_id=1))
    assert ros.spin_until(lambda: rec.message_count == 2, timeout=10.0)
    assert not rec.finished
    rec.close()
    short, good = (r for r in open_log(out).messages(decode=False))
    assert short.data == b"\x00\x01\x00\x00\x07" and short.publish_time_ns == short.log_time_ns
    assert good.publish_time_ns == 2 * SEC + 500


@pytest.mark.ros
def test_a_full_disk_stops_the_recording_and_keeps_the_finished_chunks(ros, tmp_path):
    out = tmp_path / "run.mcap"
    rec = _recorder(ros, output=str(out), discover=False, chunk_size=2048)
    rec.subscribe("/robot_0/status", "phd_swarm_msgs/msg/RobotStatus", QoSProfile(depth=100))
    pub = ros.node("talker").create_publisher(RobotStatus, "/robot_0/status",
                                              QoSProfile(depth=100))
    _matched(ros, [pub])
    for k in range(40):  # ~4 chunks of 2 kB
        pub.publish(_status(k))
    assert ros.spin_until(lambda: rec.message_count == 40, timeout=10.0)
    written = out.stat().st_size

    def full(data: bytes) -> int:
        raise OSError(28, "No space left on device")

    rec.log._file.write = full
    for k in range(40, 100):
        pub.publish(_status(k))
    assert ros.spin_until(lambda: rec.finished, timeout=10.0)
    assert rec.exit_code == 1 and "No space left on device" in rec.log.failure
    rec.close()  # as spin_nodes does next: nothing more is written, nothing raises
    assert out.stat().st_size == written
    with open_log(out) as log:
        assert log.truncated
        steps = [r.msg.step for r in log.messages()]
    assert steps == list(range(len(steps))) and 20 <= len(steps) <= 40


@pytest.mark.ros
def test_a_team_state_it_cannot_read_is_recorded_counted_and_the_recorder_goes_on(ros,
                                                                                 tmp_path):
    """Found by fuzzing the recorder's callbacks (issue 40): the step bookkeeping raised."""
    out = tmp_path / "run.mcap"
    rec = _recorder(ros, output=str(out), params_file=str(_config(tmp_path)), discover=False,
                    wait_for_world=False)
    team = ros.node("stranger").create_publisher(TeamState, T.WORLD_ROBOTS,
                                                 publisher_qos("STEP"))
    _matched(ros, [team])
    team.publish(b"\x00\x01\x00\x00\x07")                        # not a team state
    team.publish(TeamState(header=_stamp(1), step=1, robot_ids=[0, 1], alive=[True]))
    team.publish(TeamState(header=_stamp(2), step=2, robot_ids=[0], alive=[True]))
    assert ros.spin_until(lambda: rec.message_count == 3, timeout=10.0)
    assert rec.unreadable == 2 and not rec.finished
    assert rec.health().rejected == 2 and rec.health().last_step == 2
    rec.close()
    assert len(list(open_log(out).messages(topics=[T.WORLD_ROBOTS], decode=False))) == 3
