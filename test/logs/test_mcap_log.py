"""MCAP log I/O: rosbag2-style schemas, round trips, metadata, truncated and foreign files."""

from __future__ import annotations

import logging
import os

import pytest
import yaml
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseStamped
from mcap.reader import make_reader
from mcap.writer import Writer
from mcap_ros2.decoder import DecoderFactory
from rclpy.duration import Infinite
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header
from visualization_msgs.msg import Marker, MarkerArray

from phd_swarm.logs import schemas
from phd_swarm.logs.mcap_log import (
    LogError,
    LogWriter,
    open_log,
    read_messages,
    read_metadata,
    summarize,
)
from phd_swarm.logs.qos_yaml import qos_yaml
from phd_swarm.logs.schemas import (
    SEPARATOR,
    DefinitionNotFoundError,
    installed_type_hash,
    message_definition,
)
from phd_swarm_msgs.msg import CellPolygon, ParticleTransfer, RobotStatus, TargetSet

SEC = 1_000_000_000
T0 = 1_700_000_000 * SEC


def _header(step: int) -> Header:
    return Header(stamp=Time(sec=step, nanosec=250_000_000), frame_id="map")


def _cell(step: int) -> CellPolygon:
    return CellPolygon(header=_header(step), robot_id=3, step=step,
                       generator=Point(x=1.5, y=2.25), power_weight=0.5,
                       vertices=[Point(x=0.0, y=0.0), Point(x=4.0, y=0.0),
                                 Point(x=4.0, y=3.0 + step)],
                       neighbour_ids=[1, 4], contact_ids=[1], contact_positions=[Point(x=9.0)],
                       contact_power_weights=[0.25], contact_cell_radii=[7.5])


def _examples(step: int) -> list[tuple[str, str, object]]:
    """(topic, type, message) of one step, several packages and nesting depths."""
    marker = Marker(header=_header(step), ns="robots", id=step, type=Marker.SPHERE,
                    points=[Point(x=1.0, y=2.0)])
    return [
        ("/clock", "rosgraph_msgs/msg/Clock", Clock(clock=Time(sec=step))),
        ("/world/truth", "phd_swarm_msgs/msg/TargetSet",
         TargetSet(header=_header(step), source_id=0xFFFFFFFF, step=step, ids=[5, 9],
                   positions=[Point(x=10.5, y=20.25), Point(x=-1.0, y=3.0)],
                   expected_cardinality=2.0)),
        ("/robot_3/cell", "phd_swarm_msgs/msg/CellPolygon", _cell(step)),
        ("/robot_3/status", "phd_swarm_msgs/msg/RobotStatus",
         RobotStatus(header=_header(step), state=RobotStatus.STATE_STEP_DONE, robot_id=3,
                     step=step, goal=Point(x=7.0, y=8.0), mass=1.25, dead_ids=[2])),
        ("/robot_3/inbox/particles", "phd_swarm_msgs/msg/ParticleTransfer",
         ParticleTransfer(header=_header(step), from_id=1, to_id=3, step=step,
                          kind=ParticleTransfer.KIND_PHANTOM, bin_indices=[4, 8],
                          weights=[0.5, 0.25])),
        ("/robot_3/pose", "geometry_msgs/msg/PoseStamped", PoseStamped(header=_header(step))),
        ("/world/markers", "visualization_msgs/msg/MarkerArray", MarkerArray(markers=[marker])),
    ]


def _write_log(path, steps: int = 3, compression: str = "zstd", chunk_size: int = 1 << 20):
    """Write ``steps`` rounds of :func:`_examples`; returns the (topic, message, time) list."""
    written = []
    with LogWriter(path, compression=compression, chunk_size=chunk_size) as log:
        log.add_metadata("phd_swarm.run", {"scenario": "dames_static", "seed": "1"})
        for step in range(steps):
            for i, (topic, typ, msg) in enumerate(_examples(step)):
                log.add_channel(topic, typ, qos_yaml(QoSProfile(depth=10)))
                t = T0 + step * SEC + i
                log.write(topic, serialize_message(msg), t, t - 5)
                written.append((topic, msg, t))
    return written


# ------------------------------------------------------------------------ schemas
def test_nested_schema_has_each_dependency_once_after_80_equals_and_msg_lines():
    text = message_definition("phd_swarm_msgs/msg/CellPolygon")
    blocks = text.split(f"\n{SEPARATOR}\n")
    assert blocks[0].startswith("# A robot's current cell")
    # rosbag2's order: dependencies sorted, depth first, each once.
    assert [b.splitlines()[0] for b in blocks[1:]] == [
        "MSG: geometry_msgs/Point", "MSG: std_msgs/Header", "MSG: builtin_interfaces/Time"]
    assert "uint32 nanosec" in blocks[3]


def test_schema_decodes_rclpy_cdr_with_mcap_ros2():
    schema = message_definition("phd_swarm_msgs/msg/CellPolygon")
    from mcap.records import Schema

    decoder = DecoderFactory().decoder_for(
        "cdr", Schema(id=1, name="phd_swarm_msgs/msg/CellPolygon", encoding="ros2msg",
                      data=schema.encode()))
    msg = decoder(serialize_message(_cell(4)))
    assert msg.header.stamp.sec == 4 and msg.header.frame_id == "map"
    assert [(p.x, p.y) for p in msg.vertices] == [(0.0, 0.0), (4.0, 0.0), (4.0, 7.0)]
    assert list(msg.neighbour_ids) == [1, 4] and msg.contact_cell_radii == [7.5]


@pytest.fixture
def fake_msgs(tmp_path, monkeypatch):
    """An ament prefix with package fake_msgs whose types use every field syntax."""
    prefix = tmp_path / "prefix"
    (prefix / "share/ament_index/resource_index/packages").mkdir(parents=True)
    (prefix / "share/ament_index/resource_index/packages/fake_msgs").write_text("")
    msg_dir = prefix / "share/fake_msgs/msg"
    msg_dir.mkdir(parents=True)
    (msg_dir / "Outer.msg").write_text(
        "# comment with geometry_msgs/Pose in it\n"
        "std_msgs/Header header  # trailing comment\n"
        "uint8 MODE_A=1\n"
        "string NAME=\"a#b\"\n"
        "Inner[] many\n"
        "Inner[<=3] few\n"
        "fake_msgs/Inner[2] pair\n"
        "string<=5[<=2] short_names\n"
        "int32[] values\n"
        "float64 scale 1.5\n")
    (msg_dir / "Inner.msg").write_text("geometry_msgs/Point p\nint8 k\n")
    (msg_dir / "Legacy.msg").write_text("Header header\nInner inner\n")
    monkeypatch.setenv("AMENT_PREFIX_PATH",
                       f"{prefix}{os.pathsep}{os.environ['AMENT_PREFIX_PATH']}")
    for fn in (message_definition, schemas._share_dir, schemas._msg_text):
        fn.cache_clear()
    yield
    for fn in (message_definition, schemas._share_dir, schemas._msg_text):
        fn.cache_clear()


def test_schema_handles_arrays_bounds_constants_and_comments(fake_msgs):
    from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic

    text = message_definition("fake_msgs/msg/Outer")
    msg_lines = [line for line in text.splitlines() if line.startswith("MSG:")]
    assert msg_lines == ["MSG: fake_msgs/Inner", "MSG: geometry_msgs/Point",
                         "MSG: std_msgs/Header", "MSG: builtin_interfaces/Time"]
    assert text.count(SEPARATOR) == 4
    value = {"header": {"stamp": {"sec": 3, "nanosec": 4}, "frame_id": "map"},
             "many": [{"p": {"x": 1.0, "y": 2.0, "z": 0.0}, "k": -1}],
             "few": [], "pair": [{"p": {"x": 0.0, "y": 0.0, "z": 0.0}, "k": 1}] * 2,
             "short_names": ["a", "bc"], "values": [7, 8], "scale": 2.5}
    data = serialize_dynamic("fake_msgs/msg/Outer", text)["fake_msgs/msg/Outer"](value)
    back = generate_dynamic("fake_msgs/msg/Outer", text)["fake_msgs/msg/Outer"](data)
    assert back.header.stamp.sec == 3 and back.many[0].p.y == 2.0 and back.many[0].k == -1
    assert list(back.short_names) == ["a", "bc"] and back.scale == 2.5


def test_bare_header_is_std_msgs_header(fake_msgs):
    text = message_definition("fake_msgs/Legacy")
    assert [line for line in text.splitlines() if line.startswith("MSG:")] == [
        "MSG: fake_msgs/Inner", "MSG: geometry_msgs/Point", "MSG: std_msgs/Header",
        "MSG: builtin_interfaces/Time"]


def test_unknown_type_raises_definition_not_found():
    with pytest.raises(DefinitionNotFoundError, match="no_such_pkg"):
        message_definition("no_such_pkg/msg/Thing")
    with pytest.raises(DefinitionNotFoundError, match="Nope"):
        message_definition("std_msgs/msg/Nope")
    with pytest.raises(DefinitionNotFoundError, match="not a message type name"):
        message_definition("Thing")


def test_qos_yaml_is_rosbag2_jazzy_layout():
    profile = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=7,
                         reliability=ReliabilityPolicy.BEST_EFFORT,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL, deadline=Infinite)
    text = qos_yaml(profile)
    assert text.startswith("- history: keep_last\n  depth: 7\n")
    (entry,) = yaml.safe_load(text)
    assert entry["reliability"] == "best_effort"
    assert entry["durability"] == "transient_local"
    assert entry["deadline"] == {"sec": 9223372036, "nsec": 854775807}
    assert entry["lifespan"] == {"sec": 0, "nsec": 0}
    assert entry["liveliness"] == "system_default"
    assert entry["avoid_ros_namespace_conventions"] is False

    class Plain:  # duck-typed: ints, no durations
        history, depth, reliability, durability = 2, 0, 1, 2

    assert yaml.safe_load(qos_yaml(Plain()))[0]["history"] == "keep_all"


# ------------------------------------------------------------------------ round trip
@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_round_trip_of_standard_and_custom_messages(tmp_path, compression):
    path = tmp_path / "run.mcap"
    written = _write_log(path, compression=compression)
    with open_log(path) as log:
        assert not log.truncated
        got = list(log.messages())
    assert [(r.topic, r.log_time_ns) for r in got] == [(t, ts) for t, _, ts in written]
    for rec, (_, msg, t) in zip(got, written, strict=True):
        assert rec.publish_time_ns == t - 5
        assert deserialize_message(rec.data, type(msg)) == msg
        assert rec.ros_type == f"{type(msg).__module__.split('.')[0]}/msg/{type(msg).__name__}"
    by_topic = {r.topic: r.msg for r in got}
    assert by_topic["/clock"].clock.sec == 2
    assert by_topic["/world/truth"].positions[0].y == 20.25
    assert by_topic["/robot_3/cell"].vertices[2].y == 5.0
    assert by_topic["/robot_3/status"].state == RobotStatus.STATE_STEP_DONE
    assert by_topic["/robot_3/inbox/particles"].kind == ParticleTransfer.KIND_PHANTOM
    assert by_topic["/world/markers"].markers[0].points[0].y == 2.0


def test_file_is_a_ros2_mcap_for_the_plain_mcap_reader(tmp_path):
    path = tmp_path / "run.mcap"
    _write_log(path, steps=1)
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary.statistics.message_count == 7 and summary.chunk_indexes
        channels = {c.topic: c for c in summary.channels.values()}
        truth = channels["/world/truth"]
        assert truth.message_encoding == "cdr"
        assert summary.schemas[truth.schema_id].encoding == "ros2msg"
        assert summary.schemas[truth.schema_id].name == "phd_swarm_msgs/msg/TargetSet"
        assert truth.metadata["topic_type_hash"] == installed_type_hash(
            "phd_swarm_msgs/msg/TargetSet")
        assert truth.metadata["topic_type_hash"].startswith("RIHS01_")
        assert yaml.safe_load(truth.metadata["offered_qos_profiles"])[0]["depth"] == 10
        decoded = {m.channel.topic: m.decoded_message for m in reader.iter_decoded_messages()}
    assert decoded["/world/truth"].ids == [5, 9]


def test_metadata_summary_and_filters(tmp_path):
    path = tmp_path / "run.mcap"
    written = _write_log(path, steps=4)
    assert read_metadata(path) == {"phd_swarm.run": {"scenario": "dames_static", "seed": "1"}}
    info = summarize(path)
    assert not info.truncated and info.message_count == len(written)
    assert info.start_ns == T0 and info.end_ns == T0 + 3 * SEC + 6
    truth = info.topics["/world/truth"]
    assert (truth.ros_type, truth.message_count) == ("phd_swarm_msgs/msg/TargetSet", 4)
    assert (truth.start_ns, truth.end_ns) == (T0 + 1, T0 + 3 * SEC + 1)
    some = list(read_messages(path, topics=["/clock", "/robot_3/cell"],
                              start_ns=T0 + SEC, end_ns=T0 + 3 * SEC, decode=False))
    assert [(r.topic, r.msg) for r in some] == [("/clock", None), ("/robot_3/cell", None)] * 2
    assert [r.log_time_ns // SEC for r in some] == [T0 // SEC + 1] * 2 + [T0 // SEC + 2] * 2


def test_writer_channels_are_idempotent_and_close_is_final(tmp_path):
    path = tmp_path / "run.mcap"
    log = LogWriter(path, compression="none")
    first = log.add_channel("/a", "std_msgs/msg/Header")
    assert log.add_channel("/a", "std_msgs/msg/Header", "ignored") == first
    assert log.add_channel("/b", "std_msgs/msg/Header") != first
    log.write("/a", serialize_message(_header(1)), T0, T0)
    log.close()
    log.close()
    with pytest.raises(LogError, match="after close"):
        log.write("/a", serialize_message(_header(1)), T0, T0)
    info = summarize(path)
    assert {t: s.message_count for t, s in info.topics.items()} == {"/a": 1, "/b": 0}
    with pytest.raises(ValueError, match="compression"):
        LogWriter(tmp_path / "x.mcap", compression="gzip")


# ------------------------------------------------------------------------ truncation
def _chunk_ranges(path):
    """(start offset, end offset, first log time) of each chunk of a complete log."""
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    return [(c.chunk_start_offset, c.chunk_start_offset + c.chunk_length, c.message_start_time)
            for c in summary.chunk_indexes]


def test_cut_file_yields_the_messages_of_complete_chunks(tmp_path, caplog):
    path = tmp_path / "run.mcap"
    written = _write_log(path, steps=30, compression="zstd", chunk_size=2048)
    data = path.read_bytes()
    chunks = _chunk_ranges(path)
    assert len(chunks) >= 5
    cuts = {
        "footer": (len(data) - 3, len(written)),
        "summary": (chunks[-1][1] + 40, len(written)),
        "mid-chunk": ((chunks[3][0] + chunks[3][1]) // 2, None),
        "record header": (chunks[3][0] + 4, None),
    }
    for name, (size, expected) in cuts.items():
        if expected is None:
            expected = sum(1 for _, _, t in written if t < chunks[3][2])
        cut = tmp_path / f"cut_{name.replace(' ', '_')}.mcap"
        cut.write_bytes(data[:size])
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="phd_swarm.logs.mcap_log"):
            with open_log(cut) as log:
                assert log.truncated, name
                got = list(log.messages())
        assert "truncated" in caplog.text, name
        assert [(r.topic, r.log_time_ns) for r in got] == \
            [(t, ts) for t, _, ts in written[:expected]], name
        assert got[-1].msg is not None
        info = summarize(cut)
        assert info.truncated and info.message_count == expected, name
        assert read_metadata(cut)["phd_swarm.run"]["seed"] == "1"


def test_writer_that_was_never_closed_leaves_its_finished_chunks_readable(tmp_path):
    path = tmp_path / "live.mcap"
    log = LogWriter(path, compression="lz4", chunk_size=1024)
    log.add_metadata("phd_swarm.run", {"robots": "1"})
    log.add_channel("/robot_0/cell", "phd_swarm_msgs/msg/CellPolygon")
    for step in range(40):
        log.write("/robot_0/cell", serialize_message(_cell(step)), T0 + step, T0 + step)
    try:
        with open_log(path) as reader:
            assert reader.truncated
            steps = [r.msg.step for r in reader.messages()]
        assert 0 < len(steps) < 40
        assert steps == list(range(len(steps)))
        assert read_metadata(path) == {"phd_swarm.run": {"robots": "1"}}
    finally:
        log.close()
    assert [r.msg.step for r in read_messages(path)] == list(range(40))


def test_empty_closed_log_has_no_messages(tmp_path):
    path = tmp_path / "empty.mcap"
    LogWriter(path).close()
    info = summarize(path)
    assert (info.truncated, info.message_count, info.topics) == (False, 0, {})
    assert list(read_messages(path)) == []


# ------------------------------------------------------------------------ bad files
def test_missing_file_raises_log_error_with_path(tmp_path):
    path = tmp_path / "nowhere.mcap"
    with pytest.raises(LogError, match=f"{path}: no such file"):
        open_log(path)
    with pytest.raises(LogError, match="no such file"):
        list(read_messages(path))


@pytest.mark.parametrize("content", [b"", b"hello", b"# a YAML file\nkey: value\n" * 10])
def test_non_mcap_file_raises_log_error_with_path(tmp_path, content):
    path = tmp_path / "notes.mcap"
    path.write_bytes(content)
    with pytest.raises(LogError) as err:
        summarize(path)
    assert str(err.value) == f"{path}: not an MCAP file (bad magic)"


def test_mcap_that_is_not_a_ros2_cdr_log_raises_log_error(tmp_path):
    other = tmp_path / "json.mcap"
    with open(other, "wb") as f:
        w = Writer(f)
        w.start("", "test")
        schema = w.register_schema("x", "jsonschema", b"{}")
        w.add_message(w.register_channel("/x", "json", schema), 1, b"{}", 1)
        w.finish()
    with pytest.raises(LogError, match=f"{other}: not a ROS 2 log"):
        open_log(other)

    json_in_ros2 = tmp_path / "json_ros2.mcap"
    with open(json_in_ros2, "wb") as f:
        w = Writer(f)
        w.start("ros2", "test")
        schema = w.register_schema("x", "jsonschema", b"{}")
        w.add_message(w.register_channel("/x", "json", schema), 1, b"{}", 1)
        w.finish()
    with pytest.raises(LogError, match="not a ROS 2 CDR log: topic /x"):
        open_log(json_in_ros2)


@pytest.mark.parametrize("compression", ["none", "zstd"])
def test_a_damaged_record_is_a_log_error_naming_the_file(tmp_path, compression):
    """A metadata name that is not UTF-8 (found by fuzzing, issue 40).

    It escaped as the mcap library's UnicodeDecodeError.
    """
    path = tmp_path / "run.mcap"
    with LogWriter(path, compression=compression) as log:
        log.add_metadata("phd_swarm.run", {"scenario": "dames_static"})
        log.add_channel("/a", "std_msgs/msg/Header")
        log.write("/a", serialize_message(_header(1)), T0, T0)
    data = path.read_bytes()
    # The record itself, not the metadata index of the summary (which names it too).
    path.write_bytes(data.replace(b"phd_swarm.run", b"phd_swarm\x8erun", 1))
    with pytest.raises(LogError, match=rf"{path}: damaged log \(UnicodeDecodeError"):
        read_metadata(path)
