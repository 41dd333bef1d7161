"""Team topics: the bundle codec and the recorder's routes (bundle.py, team_routes.py)."""

from __future__ import annotations

import pytest
from builtin_interfaces.msg import Time
from hypothesis import given, settings
from rclpy.serialization import serialize_message
from std_msgs.msg import Header

from phd_swarm.nodes import bundle, cdr
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm.nodes.team_routes import TeamRoutes, status_robot, status_state
from phd_swarm.testing import fuzzed_bytes
from phd_swarm_msgs.msg import MessageBundle, RobotStatus


def _pieces(robot: int = 3) -> list[tuple[str, bytes]]:
    return [(T.robot_topic(robot, "estimates"), b"\x00\x01\x00\x00abcde"),
            (T.robot_topic(robot, "goal"), b""),
            (T.robot_topic(robot, "density"), bytes(range(13)))]


@pytest.mark.parametrize("frame", ["", "map", "a_longer_frame"])
def test_the_hand_written_bundle_is_the_codecs(frame):
    pieces = _pieces()
    data = bundle.pack_cdr(4, 500, frame, 3, 8, pieces)
    body = b"".join(b for _, b in pieces)
    assert data == cdr.encode(MessageBundle, {
        "header": {"stamp": {"sec": 4, "nanosec": 500}, "frame_id": frame}, "sender": 3,
        "step": 8, "topics": [t for t, _ in pieces], "offsets": [0, 9, 9, 22],
        "data": list(body)})
    assert bundle.unpack_cdr(data) == (3, 8, pieces)
    assert bundle.unpack_cdr(bundle.pack_cdr(0, 0, frame, bundle.WORLD, 0, [])) == (-1, 0, [])


@settings(max_examples=500, deadline=None, derandomize=True, database=None)
@given(fuzzed_bytes([bundle.pack_cdr(1, 0, frame, 3, 1, _pieces()[:n])
                     for frame in ("", "map", "abcde") for n in range(4)]))
def test_the_hand_cut_reads_what_the_codec_reads(data):
    """On any bytes: the same fields as the general codec, or a refusal where it refuses."""
    try:
        b = cdr.decode(MessageBundle, data)
    except cdr.CdrError:
        b = None
    try:
        got = bundle.unpack_cdr(data)
    except InvalidMessage:
        got = None
    if got is not None:
        # What the hand cut accepts, the codec reads the same way (the codec may also
        # accept bytes whose offsets the cut refuses).
        assert b is not None and got[:2] == (b["sender"], b["step"])
        assert [t for t, _ in got[2]] == b["topics"]
        assert b"".join(m for _, m in got[2]) == b["data"].tobytes()
    elif b is not None:
        offsets = b["offsets"].tolist()
        assert not (len(offsets) == len(b["topics"]) + 1 and offsets[:1] == [0]
                    and offsets[-1] == b["data"].size and sorted(offsets) == offsets)


def test_a_malformed_bundle_is_refused_by_name():
    good = cdr.decode(MessageBundle, bundle.pack_cdr(1, 0, "map", 3, 1, _pieces()))
    bad = dict(good, offsets=[0, 9, 30, 22])
    with pytest.raises(InvalidMessage, match="offsets .* do not cut 22 bytes into 3"):
        bundle.unpack_cdr(cdr.encode(MessageBundle, bad))
    with pytest.raises(InvalidMessage, match="not a message bundle"):
        bundle.unpack_cdr(b"\x00\x01\x00\x00\x01")


@pytest.mark.parametrize("frame", ["", "m", "map", "abcd", "a_longer_frame_id"])
def test_a_status_robot_id_and_state_are_read_from_its_cdr(frame):
    for state in (RobotStatus.STATE_READY, RobotStatus.STATE_STEP_DONE):
        for robot in (0, 7, 70_000):
            data = serialize_message(RobotStatus(
                header=Header(stamp=Time(sec=3), frame_id=frame), state=state,
                robot_id=robot, step=3))
            assert (status_robot(data), status_state(data)) == (robot, state)


def test_routes_write_each_message_under_its_topic_and_count_the_rest():
    written: list[tuple[str, bytes]] = []
    warned: list[str] = []
    routes = TeamRoutes(warned.append)
    for topic, _ in _pieces(3):
        routes.add(T.TEAM_OUTPUTS, topic, lambda d, t=topic: written.append((t, d)))
    routes.add(T.TEAM_STATUS, T.robot_topic(3, "status"),
               lambda d: written.append(("status", d)))
    routes.add(T.WORLD_OUTPUTS, T.robot_topic(3, "pose"), lambda d: written.append(("pose", d)))
    assert routes.team_topics == [T.TEAM_OUTPUTS, T.TEAM_STATUS, T.WORLD_OUTPUTS]
    assert T.robot_topic(3, "pose") in routes.topics

    routes.callback(T.TEAM_OUTPUTS)(bundle.pack_cdr(1, 0, "map", 3, 1, _pieces(3)))
    assert written == _pieces(3)
    # Robot 4 writing robot 3's topics, and a topic that is not the run's: not written.
    routes.callback(T.TEAM_OUTPUTS)(bundle.pack_cdr(1, 0, "map", 4, 1, _pieces(3)))
    routes.callback(T.TEAM_OUTPUTS)(bundle.pack_cdr(
        1, 0, "map", 3, 1, [(T.robot_topic(3, "nothing"), b"")]))
    routes.callback(T.TEAM_OUTPUTS)(b"garbage!")
    assert len(written) == 3 and routes.rejected == {T.TEAM_OUTPUTS: 5}
    assert "sender 4" in warned[0] and "/robot_3/estimates" in warned[0]

    status = serialize_message(RobotStatus(state=RobotStatus.STATE_READY, robot_id=3))
    routes.callback(T.TEAM_STATUS)(status)
    routes.callback(T.TEAM_STATUS)(serialize_message(RobotStatus(robot_id=9)))
    assert written[-1] == ("status", status) and routes.rejected[T.TEAM_STATUS] == 1

    routes.callback(T.WORLD_OUTPUTS)(bundle.pack_cdr(
        1, 0, "map", bundle.WORLD, 1, [(T.robot_topic(3, "pose"), b"p")]))
    assert written[-1] == ("pose", b"p")
