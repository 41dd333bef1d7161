"""rosbag2 metadata.yaml for run logs: rosbags' AnyReader opens the run directory."""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from mcap.reader import make_reader
from rclpy.duration import Infinite
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import QosDurability, QosHistory, QosReliability
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header, String

from phd_swarm.logs import bag_metadata as bm
from phd_swarm.logs.mcap_log import LogError, LogWriter, summarize
from phd_swarm.logs.qos_yaml import qos_yaml
from phd_swarm.logs.schemas import installed_type_hash
from phd_swarm_msgs.msg import CellPolygon, RobotStatus

SEC = 1_000_000_000
T0 = 1_700_000_000 * SEC

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL, deadline=Infinite)

#: Top-level keys in the order rosbag2's YAML converter writes them.
ROSBAG2_KEYS = ["version", "storage_identifier", "duration", "starting_time", "message_count",
                "topics_with_message_count", "compression_format", "compression_mode",
                "relative_file_paths", "files", "custom_data", "ros_distro"]


def _cell(step: int) -> CellPolygon:
    # Every sequence is non-empty on purpose: for a message that ends with empty float64
    # sequences, rclpy's serialize_message (rmw_fastrtps) returns Fast-CDR's size estimate,
    # up to 8 uninitialised bytes longer than the CDR, and rosbags rejects more than 3
    # trailing bytes. The recorder logs the bytes that arrive, which are exact.
    return CellPolygon(header=Header(stamp=Time(sec=step), frame_id="map"), robot_id=2,
                       step=step, generator=Point(x=1.5, y=2.0),
                       vertices=[Point(x=0.0), Point(x=4.0), Point(x=4.0, y=3.0 + step)],
                       neighbour_ids=[1, 3], contact_ids=[1], contact_positions=[Point(x=9.0)],
                       contact_power_weights=[0.25], contact_cell_radii=[7.5])


def _messages(step: int) -> list[tuple[str, str, object, QoSProfile]]:
    return [
        ("/clock", "rosgraph_msgs/msg/Clock", Clock(clock=Time(sec=step)), QoSProfile(depth=10)),
        ("/robot_2/cell", "phd_swarm_msgs/msg/CellPolygon", _cell(step), QoSProfile(depth=5)),
        ("/robot_2/status", "phd_swarm_msgs/msg/RobotStatus",
         RobotStatus(robot_id=2, step=step, goal=Point(x=7.0, y=8.0), mass=1.25), LATCHED),
        ("/notes", "std_msgs/msg/String", String(data=f"step {step}"), QoSProfile(depth=10)),
    ]


def _write_log(path: Path, steps: int = 4, compression: str = "zstd",
               chunk_size: int = 1 << 20, close: bool = True):
    """Write ``steps`` rounds of :func:`_messages` (and an idle topic); (topic, time) list."""
    written = []
    log = LogWriter(path, compression=compression, chunk_size=chunk_size)
    log.add_channel("/idle", "std_msgs/msg/String", qos_yaml(QoSProfile(depth=1)))
    for step in range(steps):
        for i, (topic, typ, msg, qos) in enumerate(_messages(step)):
            log.add_channel(topic, typ, qos_yaml(qos))
            t = T0 + step * SEC + 10 * i
            log.write(topic, serialize_message(msg), t, t - 3)
            written.append((topic, t))
    if close:
        log.close()
    return written


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_anyreader_opens_the_run_directory_and_decodes_every_message(tmp_path, compression):
    run = tmp_path / "demo"
    run.mkdir()
    written = _write_log(run / "run.mcap", compression=compression)
    assert bm.write_bag_metadata(run / "run.mcap") == run / "metadata.yaml"

    with AnyReader([run]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts == {"/idle": 0, "/clock": 4, "/robot_2/cell": 4, "/robot_2/status": 4,
                          "/notes": 4}
        assert {c.topic: c.msgtype for c in reader.connections}["/robot_2/cell"] == \
            "phd_swarm_msgs/msg/CellPolygon"
        assert reader.message_count == len(written)
        assert reader.start_time == written[0][1]
        assert reader.end_time == written[-1][1] + 1  # rosbags' end is exclusive
        status = next(c for c in reader.connections if c.topic == "/robot_2/status")
        assert status.digest == installed_type_hash("phd_swarm_msgs/msg/RobotStatus")
        (qos,) = status.ext.offered_qos_profiles
        assert (qos.history, qos.depth, qos.reliability, qos.durability) == \
            (QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL)
        assert (qos.deadline.sec, qos.deadline.nsec) == (9223372036, 854775807)

        got = [(c.topic, t, reader.deserialize(raw, c.msgtype))
               for c, t, raw in reader.messages()]
    assert [(topic, t) for topic, t, _ in got] == written
    cells = [msg for topic, _, msg in got if topic == "/robot_2/cell"]
    assert [m.step for m in cells] == [0, 1, 2, 3]
    assert cells[3].header.frame_id == "map" and cells[3].vertices[2].y == 6.0
    assert list(cells[0].neighbour_ids) == [1, 3] and list(cells[0].contact_cell_radii) == [7.5]
    assert [m.data for topic, _, m in got if topic == "/notes"][-1] == "step 3"
    assert [m.clock.sec for topic, _, m in got if topic == "/clock"] == [0, 1, 2, 3]


def test_metadata_yaml_has_rosbag2_v9_layout(tmp_path):
    path = tmp_path / "run.mcap"
    written = _write_log(path, steps=2)
    (tmp_path / "metadata.yaml").write_text("stale: true\n")
    target = bm.write_bag_metadata(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metadata.yaml", "run.mcap"]

    doc = yaml.safe_load(target.read_text())
    assert list(doc) == ["rosbag2_bagfile_information"]
    info = doc["rosbag2_bagfile_information"]
    assert list(info) == ROSBAG2_KEYS
    assert info == bm.bag_metadata(path)
    start, end = written[0][1], written[-1][1]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert info["starting_time"] == {"nanoseconds_since_epoch": start}
    assert info["duration"] == {"nanoseconds": end - start}
    assert info["message_count"] == len(written)
    assert (info["compression_format"], info["compression_mode"]) == ("", "")
    assert info["relative_file_paths"] == ["run.mcap"]
    assert info["files"] == [{"path": "run.mcap",
                              "starting_time": {"nanoseconds_since_epoch": start},
                              "duration": {"nanoseconds": end - start},
                              "message_count": len(written)}]
    assert info["custom_data"] is None and info["ros_distro"] == "jazzy"

    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert list(topics) == sorted(topics)
    status = topics["/robot_2/status"]
    assert status["message_count"] == 2
    meta = status["topic_metadata"]
    assert list(meta) == ["name", "type", "serialization_format", "offered_qos_profiles",
                          "type_description_hash"]
    assert meta["type"] == "phd_swarm_msgs/msg/RobotStatus"
    assert meta["serialization_format"] == "cdr"
    assert meta["type_description_hash"].startswith("RIHS01_")
    # Version 9: a list of mappings with policies by name, not version 8's YAML string.
    assert meta["offered_qos_profiles"] == [{
        "history": "keep_last", "depth": 1, "reliability": "reliable",
        "durability": "transient_local", "deadline": {"sec": 9223372036, "nsec": 854775807},
        "lifespan": {"sec": 0, "nsec": 0}, "liveliness": "system_default",
        "liveliness_lease_duration": {"sec": 0, "nsec": 0},
        "avoid_ros_namespace_conventions": False}]
    assert topics["/idle"]["message_count"] == 0


def test_channel_without_type_hash_gets_an_empty_hash(tmp_path):
    path = tmp_path / "run.mcap"
    with LogWriter(path) as log:
        log.add_channel("/notes", "std_msgs/msg/String", "", type_hash="")
        log.write("/notes", serialize_message(String(data="x")), T0, T0)
    (topic,) = bm.bag_metadata(path)["topics_with_message_count"]
    assert topic["topic_metadata"]["type_description_hash"] == ""
    assert topic["topic_metadata"]["offered_qos_profiles"] == []
    bm.write_bag_metadata(path)
    with AnyReader([tmp_path]) as reader:
        assert [reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()] \
            == ["x"]


def test_empty_log_has_zero_counts_and_opens(tmp_path):
    path = tmp_path / "run.mcap"
    LogWriter(path).close()
    info = bm.bag_metadata(path)
    assert (info["message_count"], info["topics_with_message_count"]) == (0, [])
    assert info["starting_time"] == {"nanoseconds_since_epoch": 0}
    assert info["duration"] == {"nanoseconds": 0}
    bm.write_bag_metadata(path)
    with AnyReader([tmp_path]) as reader:
        assert reader.message_count == 0 and list(reader.messages()) == []


def test_qos_profiles_accepts_version_8_integers_and_rejects_garbage():
    v8 = ("- history: 1\n  depth: 3\n  reliability: 2\n  durability: 1\n"
          "  deadline:\n    sec: 0\n    nsec: 0\n  lifespan:\n    sec: 0\n    nsec: 0\n"
          "  liveliness: 1\n  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n"
          "  avoid_ros_namespace_conventions: false")
    (entry,) = bm.qos_profiles(v8)
    assert (entry["history"], entry["reliability"], entry["durability"], entry["liveliness"]) \
        == ("keep_last", "best_effort", "transient_local", "automatic")
    assert bm.qos_profiles(qos_yaml(LATCHED)) == yaml.safe_load(qos_yaml(LATCHED))
    two = qos_yaml(QoSProfile(depth=1)) + "\n" + qos_yaml(LATCHED)
    assert [e["durability"] for e in bm.qos_profiles(two)] == ["volatile", "transient_local"]
    assert bm.qos_profiles("") == [] and bm.qos_profiles("  \n") == []
    for bad in ("history: keep_last", "- [1, 2]", "- {history: keep_last\n"):
        with pytest.raises(ValueError):
            bm.qos_profiles(bad)


def test_bad_qos_in_a_channel_is_a_log_error_naming_the_topic(tmp_path):
    path = tmp_path / "run.mcap"
    with LogWriter(path) as log:
        log.add_channel("/notes", "std_msgs/msg/String", "reliability: reliable")
    with pytest.raises(LogError, match="/notes.*offered_qos_profiles"):
        bm.bag_metadata(path)
    assert not (tmp_path / "metadata.yaml").exists()


# ------------------------------------------------------------------------ truncated logs
def _cut(src: Path, dst_dir: Path, fraction: float) -> Path:
    """A copy of ``src`` in ``dst_dir`` named run.mcap, cut inside the chunk at ``fraction``."""
    with open(src, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    chunk = chunks[int(len(chunks) * fraction)]
    dst_dir.mkdir()
    dst = dst_dir / "run.mcap"
    dst.write_bytes(src.read_bytes()[:chunk.chunk_start_offset + chunk.chunk_length // 2])
    return dst


def test_truncated_log_gets_metadata_of_its_complete_records_but_rosbags_refuses_it(
        tmp_path, caplog):
    full = tmp_path / "full.mcap"
    written = _write_log(full, steps=30, chunk_size=1024)
    cut = _cut(full, tmp_path / "cut", 0.5)
    with caplog.at_level(logging.WARNING, logger="phd_swarm.logs.mcap_log"):
        target = bm.write_bag_metadata(cut)
    assert "truncated" in caplog.text

    info = yaml.safe_load(target.read_text())["rosbag2_bagfile_information"]
    expected = summarize(cut)
    assert 0 < info["message_count"] == expected.message_count < len(written)
    assert info["starting_time"]["nanoseconds_since_epoch"] == written[0][1]
    assert info["duration"]["nanoseconds"] == expected.end_ns - expected.start_ns
    counts = {t["topic_metadata"]["name"]: t["message_count"]
              for t in info["topics_with_message_count"]}
    assert counts == {name: t.message_count for name, t in expected.topics.items()}
    qos = {t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"]
           for t in info["topics_with_message_count"]}
    assert qos["/robot_2/status"][0]["durability"] == "transient_local"  # scanned channels

    # rosbags reads MCAP files only through their footer: a clear error, not wrong data.
    with pytest.raises(AnyReaderError, match="end magic"), AnyReader([cut.parent]):
        pass


def test_writer_still_open_gives_metadata_of_its_finished_chunks(tmp_path):
    path = tmp_path / "run.mcap"
    log = LogWriter(path, chunk_size=2048)
    try:
        log.add_channel("/robot_2/cell", "phd_swarm_msgs/msg/CellPolygon",
                        qos_yaml(QoSProfile(depth=5)))
        for step in range(40):
            log.write("/robot_2/cell", serialize_message(_cell(step)), T0 + step, T0 + step)
        info = bm.bag_metadata(path)
        assert 0 < info["message_count"] < 40
        (topic,) = info["topics_with_message_count"]
        assert topic["topic_metadata"]["offered_qos_profiles"][0]["depth"] == 5
    finally:
        log.close()


# ------------------------------------------------------------------------ CLI
def test_cli_writes_and_prints_the_path(tmp_path, capsys):
    path = tmp_path / "run.mcap"
    _write_log(path, steps=1)
    assert bm.main([str(path)]) == 0
    assert capsys.readouterr().out.strip() == str(tmp_path / "metadata.yaml")
    assert (tmp_path / "metadata.yaml").is_file()


def test_cli_on_a_missing_or_foreign_file_exits_nonzero_with_a_message(tmp_path, capsys):
    missing = tmp_path / "nowhere.mcap"
    assert bm.main([str(missing)]) == 1
    err = capsys.readouterr().err
    assert "error" in err and str(missing) in err and "no such file" in err

    foreign = tmp_path / "notes.mcap"
    foreign.write_text("not an mcap file\n")
    assert bm.main([str(foreign)]) == 1
    assert "not an MCAP file" in capsys.readouterr().err
    assert not (tmp_path / "metadata.yaml").exists()


def test_python_dash_m_entry_point(tmp_path):
    missing = tmp_path / "nowhere.mcap"
    proc = subprocess.run([sys.executable, "-m", "phd_swarm.logs.bag_metadata", str(missing)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1
    assert f"{missing}: no such file" in proc.stderr and proc.stdout == ""


def test_a_finished_log_is_described_from_its_summary_as_a_scan_would(tmp_path, monkeypatch):
    path = tmp_path / "run.mcap"
    _write_log(path, steps=6)
    from_summary = bm.bag_metadata(path)
    assert from_summary["message_count"] == 6 * len(_messages(0))
    monkeypatch.setattr(bm, "_summary_statistics", lambda p: None)
    assert bm.bag_metadata(path) == from_summary
