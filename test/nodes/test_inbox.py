"""One inbox message per contact and tick: pack and unpack are inverse; bad ones are refused."""

from __future__ import annotations

from array import array

import numpy as np
import pytest
from geometry_msgs.msg import Point
from hypothesis import given, settings
from rclpy.serialization import deserialize_message, serialize_message

from phd_swarm.core.exchange.voronoi_phd.messages import StateMsg
from phd_swarm.nodes import convert, inbox
from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm.nodes.faces.voronoi_phd import WIRE
from phd_swarm.testing import fuzzed_bytes
from phd_swarm_msgs.msg import InboxMessage, MeasurementSet, RobotState


def _state(step: int, x: float) -> RobotState:
    return RobotState(header=convert.header(step, 0.5, "map"), robot_id=4, step=step,
                      position=Point(x=x, y=5.0), power_weight=0.25, cell_radius=1.5)


def _scan(step: int, n: int) -> MeasurementSet:
    return MeasurementSet(header=convert.header(step, 0.5, "map"), robot_id=4, step=step,
                          sensor_position=Point(x=1.0, y=2.0),
                          measurements=[Point(x=float(i), y=-float(i)) for i in range(n)])


def _pieces(messages):
    return [(kind, serialize_message(m)) for kind, m in messages]


def test_unpack_returns_what_was_packed_in_order():
    sent = [("state", _state(3, 1.0)), ("measurements", _scan(3, 5)), ("state", _state(4, 2.0))]
    env = inbox.pack(4, _pieces(sent))
    assert env.sender == 4 and list(env.kinds) == ["state", "measurements", "state"]
    assert list(env.offsets)[0] == 0 and list(env.offsets)[-1] == len(env.data)
    assert inbox.unpack(env, WIRE.types) == _pieces(sent)
    got = inbox.messages(env, WIRE.types)
    assert [k for k, _ in got] == [k for k, _ in sent]
    assert [m for _, m in got] == [m for _, m in sent]


def test_what_the_wire_encodes_rclpy_reads_back_from_the_envelope():
    state = StateMsg(4, 3, np.array([1.0, 5.0]), 0.25, 1.5)
    env = inbox.pack(4, [("state", WIRE.encode(state, 0.5, "map"))])
    assert inbox.messages(env, WIRE.types) == [("state", _state(3, 1.0))]


def test_an_empty_envelope_holds_nothing():
    assert inbox.unpack(inbox.pack(2, []), WIRE.types) == []
    assert inbox.messages(inbox.pack(2, []), WIRE.types) == []


@pytest.mark.parametrize("change, match", [
    ({"kinds": ["gossip"]}, "unknown inbox kind 'gossip'"),
    ({"offsets": [0, 3]}, r"do not cut \d+ bytes into 1 messages"),
    ({"offsets": [0]}, "into 1 messages"),
    ({"offsets": [0, 3], "data": array("B", b"\x00\x01\x00")},
     r"message 0 \(state\) does not deserialise"),
])
def test_a_malformed_envelope_is_refused_with_the_reason(change, match):
    good = inbox.pack(4, _pieces([("state", _state(3, 1.0))]))
    fields = {"sender": 4, "kinds": list(good.kinds), "offsets": list(good.offsets),
              "data": good.data, **change}
    bad = InboxMessage(**fields)
    with pytest.raises(InvalidMessage, match=match):
        inbox.messages(bad, WIRE.types)
    if "deserialise" in match:
        # Cutting it is fine: whether a piece decodes is the wire's to say.
        assert inbox.unpack(bad, WIRE.types) == [("state", b"\x00\x01\x00")]
        with pytest.raises(InvalidMessage, match="does not deserialise"):
            WIRE.decode("state", b"\x00\x01\x00", None, 100)
    else:
        with pytest.raises(InvalidMessage, match=match):
            inbox.unpack(bad, WIRE.types)
    if "deserialise" not in match:
        with pytest.raises(InvalidMessage, match=match):
            inbox.unpack_cdr(serialize_message(bad), WIRE.types)


def test_the_serialised_envelope_is_the_same_message():
    """What a robot publishes (CDR bytes) is the InboxMessage pack builds, and back."""
    sent = _pieces([("state", _state(3, 1.0)), ("measurements", _scan(3, 5))])
    data = inbox.pack_cdr(4, sent)
    assert deserialize_message(data, InboxMessage) == inbox.pack(4, sent)
    assert inbox.unpack_cdr(data, WIRE.types) == (4, sent)
    assert inbox.unpack_cdr(serialize_message(inbox.pack(7, sent)), WIRE.types) == (7, sent)
    assert inbox.unpack_cdr(inbox.pack_cdr(2, []), WIRE.types) == (2, [])


@pytest.mark.parametrize("cut", [0, 3, 8, 20, -1])
def test_bytes_that_are_not_an_envelope_are_refused(cut):
    data = inbox.pack_cdr(4, _pieces([("state", _state(3, 1.0))]))
    with pytest.raises(InvalidMessage, match="not an inbox message"):
        inbox.unpack_cdr(data[:cut] if cut >= 0 else b"\x01" + data[1:], WIRE.types)


@pytest.mark.parametrize("pieces", [
    [], [("state", b"\x01" * 7)], [("eta_partial", b"a" * 33), ("cell", b""), ("particles", b"z")],
])
def test_the_hand_written_envelope_is_the_codecs_byte_for_byte(pieces):
    from phd_swarm.nodes import cdr

    offsets = np.cumsum([0, *(len(b) for _, b in pieces)]).astype(np.uint32)
    expected = cdr.encode(InboxMessage, {
        "sender": 9, "kinds": [k for k, _ in pieces], "offsets": offsets,
        "data": np.frombuffer(b"".join(b for _, b in pieces), np.uint8)})
    assert inbox.pack_cdr(9, pieces) == expected


_SEEDS = [inbox.pack_cdr(4, pieces, key) for key in (None, b"k" * 32)
          for pieces in ([], [("state", b"\x00\x01\x00\x00abc")],
                         [("cell", b"xy" * 9), ("transfer", b""), ("state", b"\x07")])]


@settings(max_examples=500, deadline=None, derandomize=True, database=None)
@given(fuzzed_bytes(_SEEDS))
def test_the_hand_cut_reads_what_the_codec_reads(data):
    """On any bytes: the codec's sender and pieces, or a refusal where the codec refuses."""
    from phd_swarm.nodes import cdr

    kinds = {"state", "cell", "transfer"}
    try:
        env = cdr.decode(InboxMessage, data)
    except cdr.CdrError:
        env = None
    try:
        got = inbox.unpack_cdr(data, kinds)
    except InvalidMessage:
        got = None
    if got is not None:
        assert env is not None and got[0] == env["sender"]
        assert [k for k, _ in got[1]] == env["kinds"]
        assert b"".join(p for _, p in got[1]) == env["data"].tobytes()
    elif env is not None:
        # The codec reads it; the cut refuses it only for what unpack refuses too.
        with pytest.raises(InvalidMessage):
            inbox._cut(env["kinds"], env["offsets"].tolist(), env["data"].tobytes(), kinds)
