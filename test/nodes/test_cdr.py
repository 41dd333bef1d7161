"""The numpy CDR codec reads and writes exactly what rclpy's serialisation does.

Every ``phd_swarm_msgs`` type, plus ``std_msgs/Header`` and ``geometry_msgs/PoseStamped``:
seeded random messages go both ways against ``rclpy.serialization``; every truncation and
corrupt length of a valid message is refused with :class:`CdrError`, never another
exception.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import Point, PoseStamped
from rclpy.serialization import deserialize_message, serialize_message
from rosidl_parser.definition import (
    AbstractNestedType,
    AbstractString,
    Array,
    BasicType,
    NamespacedType,
)
from std_msgs.msg import Header

import phd_swarm_msgs.msg as msgs
from phd_swarm.nodes import cdr
from phd_swarm.nodes.cdr import CdrError
from phd_swarm_msgs.msg import CellPolygon, InboxMessage, ParticleTransfer, RobotState

MSG_DIR = Path(__file__).resolve().parents[2] / "msg_defs" / "msg"
TYPES = [getattr(msgs, p.stem) for p in sorted(MSG_DIR.glob("*.msg"))] + [Header, PoseStamped]
IDS = [t.__name__ for t in TYPES]

#: Struct code of each rosidl basic type our messages use (the test's own table).
CODES = {"boolean": "?", "uint8": "B", "int32": "i", "uint32": "I", "double": "d",
         "float": "f", "int8": "b", "int16": "h", "uint16": "H", "int64": "q", "uint64": "Q"}
WORDS = ["map", "odom", "карта", "Straße/β", "地图", "🚀 frame", ""]


# ------------------------------------------------------------------ random messages
def _class(t: NamespacedType) -> type:
    return getattr(__import__(".".join(t.namespaces), fromlist=[t.name]), t.name)


def _is_vector(typ: type) -> bool:
    return all(isinstance(s, BasicType) and s.typename == "double" for s in typ.SLOT_TYPES)


def _scalar(rng: np.random.Generator, typename: str):
    code = CODES[typename]
    if code == "?":
        return bool(rng.random() < 0.5)
    if code in "fd":
        x = float(rng.normal(0.0, 1e3))
        return float(np.float32(x)) if code == "f" else x
    bits = 8 * struct.calcsize(code)
    lo, hi = (0, 2**bits - 1) if code.isupper() else (-(2**(bits - 1)), 2**(bits - 1) - 1)
    return int(rng.choice([lo, hi, int(rng.integers(0, min(hi, 1000)))]))


def _string(rng: np.random.Generator) -> str:
    if rng.random() < 0.2:
        return "long/" + "é" * int(rng.integers(200, 2000))
    return WORDS[int(rng.integers(len(WORDS)))] * int(rng.integers(1, 4))


def _count(rng: np.random.Generator) -> int:
    return 0 if rng.random() < 0.3 else int(rng.integers(1, 40))


def random_fields(rng: np.random.Generator, typ: type) -> dict:
    """Random values of every field of ``typ``, in the codec's representation."""
    out = {}
    for name, t in zip(typ.get_fields_and_field_types(), typ.SLOT_TYPES, strict=True):
        if isinstance(t, BasicType):
            out[name] = _scalar(rng, t.typename)
        elif isinstance(t, AbstractString):
            out[name] = _string(rng)
        elif isinstance(t, NamespacedType):
            sub = _class(t)
            out[name] = (rng.normal(0, 100, len(sub.SLOT_TYPES)) if _is_vector(sub)
                         else random_fields(rng, sub))
        else:
            assert isinstance(t, AbstractNestedType) and not isinstance(t, Array)
            n, v = _count(rng), t.value_type
            if isinstance(v, AbstractString):
                out[name] = [_string(rng) for _ in range(n)]
            elif isinstance(v, NamespacedType) and _is_vector(_class(v)):
                out[name] = rng.normal(0, 100, (n, len(_class(v).SLOT_TYPES)))
            elif isinstance(v, NamespacedType):
                out[name] = [random_fields(rng, _class(v)) for _ in range(min(n, 4))]
            else:
                dtype = np.dtype("<" + CODES[v.typename])
                out[name] = np.array([_scalar(rng, v.typename) for _ in range(n)], dtype)
    return out


def ros_message(typ: type, fields: dict):
    """The ROS message of ``typ`` with ``fields``, built with rclpy's own classes."""
    kwargs = {}
    for name, t in zip(typ.get_fields_and_field_types(), typ.SLOT_TYPES, strict=True):
        value = fields[name]
        if isinstance(t, NamespacedType):
            sub = _class(t)
            kwargs[name] = (sub(**dict(zip(sub.get_fields_and_field_types(), value.tolist(),
                                           strict=True)))
                            if _is_vector(sub) else ros_message(sub, value))
        elif isinstance(t, AbstractNestedType):
            v = t.value_type
            if isinstance(v, NamespacedType) and not _is_vector(_class(v)):
                kwargs[name] = [ros_message(_class(v), item) for item in value]
            elif isinstance(v, NamespacedType):
                sub = _class(v)
                keys = list(sub.get_fields_and_field_types())
                kwargs[name] = [sub(**dict(zip(keys, row, strict=True)))
                                for row in value.tolist()]
            else:
                kwargs[name] = list(value) if isinstance(v, AbstractString) else value.tolist()
        else:
            kwargs[name] = value
    return typ(**kwargs)


def assert_fields_equal(got, want, path="") -> None:
    if isinstance(want, dict):
        assert isinstance(got, dict) and list(got) == list(want), path
        for k in want:
            assert_fields_equal(got[k], want[k], f"{path}.{k}")
    elif isinstance(want, list) and want and isinstance(want[0], dict):
        assert isinstance(got, list) and len(got) == len(want), path
        for i, (g, w) in enumerate(zip(got, want, strict=True)):
            assert_fields_equal(g, w, f"{path}[{i}]")
    elif isinstance(want, np.ndarray):
        assert isinstance(got, np.ndarray) and got.dtype == want.dtype, path
        assert got.shape == want.shape and np.array_equal(got, want), path
    else:
        assert type(got) is type(want) and got == want, path


def _samples(typ: type, count: int, seed: int = 21):
    rng = np.random.default_rng([seed, TYPES.index(typ)])
    return [random_fields(rng, typ) for _ in range(count)]


# ---------------------------------------------------------------------- round trips
def test_every_message_definition_is_covered():
    assert len(TYPES) == len(list(MSG_DIR.glob("*.msg"))) + 2 >= 18


@pytest.mark.parametrize("typ", TYPES, ids=IDS)
def test_rclpy_reads_what_the_codec_writes(typ):
    for fields in _samples(typ, 20):
        assert deserialize_message(cdr.encode(typ, fields), typ) == ros_message(typ, fields)


@pytest.mark.parametrize("typ", TYPES, ids=IDS)
def test_the_codec_reads_what_rclpy_writes(typ):
    for fields in _samples(typ, 20):
        got = cdr.decode(typ, serialize_message(ros_message(typ, fields)))
        assert_fields_equal(got, fields)


def test_the_layout_is_plain_little_endian_cdr_with_zero_padding():
    fields = {"header": {"stamp": {"sec": 3, "nanosec": 5}, "frame_id": "ab"}, "robot_id": 7,
              "step": 9, "position": np.array([1.0, 2.0]), "power_weight": 0.5,
              "cell_radius": 4.0}
    # Header: sec, nanosec, "ab" with its NUL (length 3), pad to 4; two uint32; then the
    # point aligned to 8 (offset 24 after the encapsulation header: no pad), two doubles.
    want = (b"\x00\x01\x00\x00" + struct.pack("<iiI", 3, 5, 3) + b"ab\x00" + b"\x00"
            + struct.pack("<II", 7, 9) + struct.pack("<5d", 1.0, 2.0, 0.0, 0.5, 4.0))
    assert cdr.encode(RobotState, fields) == want
    transfer = cdr.encode(ParticleTransfer, {"header": {"frame_id": "m"}, "kind": 1,
                                             "bin_indices": [5], "weights": [0.25]})
    # ... kind (uint8) at 28, pad to 32; bins: count 1 at 32, 5 at 36; weights: count 1 at
    # 40, pad to 48, 0.25; four empty sequences.
    assert transfer[4:] == (struct.pack("<iiI", 0, 0, 2) + b"m\x00\x00\x00"
                            + struct.pack("<III", 0, 0, 0) + b"\x01\x00\x00\x00"
                            + struct.pack("<IIII", 1, 5, 1, 0) + struct.pack("<d", 0.25)
                            + bytes(16))


def test_missing_fields_take_the_ros_defaults():
    assert deserialize_message(cdr.encode(PoseStamped, {}), PoseStamped) == PoseStamped()
    assert cdr.decode(PoseStamped, cdr.encode(PoseStamped, {}))["pose"]["orientation"] \
        .tolist() == [0.0, 0.0, 0.0, 1.0]
    partial = cdr.encode(CellPolygon, {"header": {"frame_id": "map"}, "step": 3})
    assert deserialize_message(partial, CellPolygon) == CellPolygon(
        header=Header(frame_id="map"), step=3)


def test_points_may_be_given_in_the_plane():
    fields = {"generator": np.array([1.0, 2.0]), "vertices": np.array([[1.0, 2.0], [3.0, 4.0]]),
              "contact_positions": np.empty((0, 2))}
    got = deserialize_message(cdr.encode(CellPolygon, fields), CellPolygon)
    assert got.generator == Point(x=1.0, y=2.0)
    assert got.vertices == [Point(x=1.0, y=2.0), Point(x=3.0, y=4.0)]
    assert got.contact_positions == []


def test_tuples_and_lists_encode_as_arrays_do():
    want = cdr.encode(CellPolygon, {"neighbour_ids": np.array([1, 2, 2**32 - 1], np.uint32),
                                    "contact_power_weights": np.array([0.5, 1.0])})
    for seq in (tuple, list):
        assert cdr.encode(CellPolygon, {"neighbour_ids": seq([1, 2, 2**32 - 1]),
                                        "contact_power_weights": seq([0.5, 1])}) == want


def test_decoded_arrays_are_read_only_views():
    fields = _samples(CellPolygon, 1)[0] | {"vertices": np.ones((3, 3))}
    got = cdr.decode(CellPolygon, cdr.encode(CellPolygon, fields))
    assert not got["vertices"].flags.writeable and not got["generator"].flags.writeable


@pytest.mark.parametrize("fields, match", [
    ({"robot_idd": 1}, "no field 'robot_idd'"),
    ({"robot_id": -1}, "field robot_id"),
    ({"robot_id": 2**32}, "field robot_id"),
    ({"step": 1.5}, "field step"),
    ({"header": {"frame_id": "a\x00b"}}, "field header.frame_id: a NUL"),
    ({"header": {"frame_id": 3}}, "field header.frame_id"),
    ({"vertices": np.ones((2, 4))}, "field vertices: shape"),
    ({"generator": np.ones(4)}, "field generator: shape"),
    ({"neighbour_ids": np.array([-1, 2])}, "field neighbour_ids: values outside uint32"),
    ({"neighbour_ids": np.array([2**32])}, "field neighbour_ids: values outside uint32"),
    ({"neighbour_ids": (3, -1)}, "field neighbour_ids"),
    ({"neighbour_ids": [1, 2.5]}, "field neighbour_ids"),
    ({"power_weight": "x"}, "field power_weight"),
    ({"neighbour_ids": np.array([1.5])}, "field neighbour_ids: float64 values"),
    ({"contact_power_weights": np.ones((2, 2))}, "field contact_power_weights: shape"),
])
def test_a_value_that_does_not_fit_is_refused_naming_the_field(fields, match):
    with pytest.raises(CdrError, match=match):
        cdr.encode(CellPolygon, fields)


# --------------------------------------------------------------------- bad bytes
@pytest.mark.parametrize("typ", TYPES, ids=IDS)
def test_every_truncation_is_refused(typ):
    for fields in _samples(typ, 3, seed=5):
        data = cdr.encode(typ, fields)
        assert_fields_equal(cdr.decode(typ, data), fields)
        for cut in range(len(data)):
            with pytest.raises(CdrError, match=cdr.type_name(typ)):
                cdr.decode(typ, data[:cut])


@pytest.mark.parametrize("typ", TYPES, ids=IDS)
def test_corrupt_words_never_raise_anything_but_cdr_error(typ):
    """Each 4-byte word of valid messages overwritten with absurd lengths, and random bytes."""
    rng = np.random.default_rng(7)
    for fields in _samples(typ, 3, seed=6):
        data = cdr.encode(typ, fields)
        for pos in range(4, len(data) - 3, 4):
            for word in (0xFFFFFFFF, 0x7FFFFFFF, len(data), 1 << 28):
                bad = data[:pos] + struct.pack("<I", word) + data[pos + 4:]
                try:
                    cdr.decode(typ, bad)
                except CdrError:
                    pass
        for _ in range(200):
            bad = bytearray(data)
            at = rng.integers(4, len(bad), size=3)
            bad[at[0]:at[0] + 1] = bytes([int(rng.integers(256))])
            bad[at[1]], bad[at[2]] = 0xFF, 0x80
            try:
                cdr.decode(typ, bytes(bad))
            except CdrError:
                pass


def _cell_bytes() -> bytes:
    return cdr.encode(CellPolygon, {"header": {"frame_id": "map"},
                                    "vertices": np.ones((4, 3)), "neighbour_ids": [1, 2]})


@pytest.mark.parametrize("mutate, match", [
    # CellPolygon with frame "map": vertices' count at 56 (+4), neighbour ids' at 160 (+4).
    (lambda b: b[:60] + struct.pack("<I", 0xFFFFFFFF) + b[64:],
     r"CellPolygon: field vertices: 4294967295 elements of 24 bytes"),
    (lambda b: b[:60] + struct.pack("<I", 5) + b[64:],
     r"CellPolygon: field \w+: .*left"),
    (lambda b: b[:164] + struct.pack("<I", 1 << 30) + b[168:],
     r"field neighbour_ids: 1073741824 elements"),
    (lambda b: b"\x00\x00\x00\x00" + b[4:], "encapsulation header 00 00 00 00"),
    (lambda b: b"\x00\x01", "encapsulation header 00 01 is not"),
    (lambda b: b"", "encapsulation header missing"),
    (lambda b: b[:16] + b"ma\x00\x00" + b[20:], "field header.frame_id: a NUL inside"),
    (lambda b: b[:16] + b"map\x01" + b[20:], "field header.frame_id: string without its "
                                             "terminating NUL"),
    (lambda b: b[:16] + b"m\xff\xfe\x00" + b[20:], "field header.frame_id: string is not "
                                                   "UTF-8"),
    (lambda b: b[:12] + struct.pack("<I", 10**9) + b[16:],
     "field header.frame_id: string needs 1000000000 bytes"),
])
def test_bad_bytes_are_refused_naming_type_and_field(mutate, match):
    good = _cell_bytes()
    assert struct.unpack_from("<I", good, 60)[0] == 4
    assert struct.unpack_from("<I", good, 164)[0] == 2
    with pytest.raises(CdrError, match=match):
        cdr.decode(CellPolygon, mutate(good))


def test_bytes_after_the_last_field_are_ignored_as_by_fast_cdr():
    data = cdr.encode(RobotState, {"robot_id": 3})
    assert cdr.decode(RobotState, data + b"\xaa" * 8)["robot_id"] == 3


def test_string_sequences_are_checked_string_by_string():
    data = serialize_message(InboxMessage(kinds=["state", "cell"]))
    assert cdr.decode(InboxMessage, data)["kinds"] == ["state", "cell"]
    # sender (4), count 2 (4), "state" length 6 at offset 8 (+4 for the encapsulation).
    bad = data[:12] + struct.pack("<I", 100) + data[16:]
    with pytest.raises(CdrError, match="InboxMessage: field kinds: string needs 100 bytes"):
        cdr.decode(InboxMessage, bad)


def test_sequences_of_messages_go_both_ways():
    """MarkerArray: a sequence of Markers, each with sequences of points and of colours."""
    from visualization_msgs.msg import MarkerArray

    rng = np.random.default_rng(3)
    for _ in range(6):
        fields = random_fields(rng, MarkerArray)
        ours = cdr.encode(MarkerArray, fields)
        want = ros_message(MarkerArray, fields)
        assert deserialize_message(ours, MarkerArray) == want
        assert_fields_equal(cdr.decode(MarkerArray, ours), fields)
        assert_fields_equal(cdr.decode(MarkerArray, serialize_message(want)), fields)


def test_a_bad_message_in_a_sequence_is_named_by_its_index():
    from visualization_msgs.msg import Marker, MarkerArray

    good = {"ns": "a", "points": np.zeros((2, 3))}
    with pytest.raises(CdrError, match=r"MarkerArray: cannot encode field markers\.1\.id"):
        cdr.encode(MarkerArray, {"markers": [good, {"id": 2**40}]})
    data = cdr.encode(MarkerArray, {"markers": [good, good]})
    assert [m.ns for m in deserialize_message(data, MarkerArray).markers] == ["a", "a"]
    for cut in range(4, len(data)):  # every truncation after the encapsulation header
        with pytest.raises(CdrError, match="MarkerArray: field markers"):
            cdr.decode(MarkerArray, data[:cut])
    # A count of markers larger than the bytes left is refused before any is decoded.
    with pytest.raises(CdrError, match="markers: 4294967295 elements"):
        cdr.decode(MarkerArray, data[:4] + struct.pack("<I", 0xFFFFFFFF) + data[8:])
    assert cdr.decode(Marker, cdr.encode(Marker, good))["ns"] == "a"


def test_unsupported_fields_fail_when_the_codec_is_built():
    from std_msgs.msg import Byte

    with pytest.raises(NotImplementedError, match="Byte.data: octet is not supported"):
        cdr.encode(Byte, {})
