"""The voronoi_phd wire's CDR path gives what the ROS-message path gives, checks included.

``WIRE.encode`` / ``WIRE.decode`` (core message <-> CDR bytes, :mod:`phd_swarm.nodes.cdr`)
against ``to_ros`` + ``serialize_message`` / ``deserialize_message`` + ``from_ros``: the same
bytes as far as rclpy can tell, the same core messages back, and every check of
``from_ros`` refusing the same message with the same words.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from geometry_msgs.msg import Point
from rclpy.serialization import deserialize_message, serialize_message

import phd_swarm_msgs.msg as ros_msgs
from phd_swarm.core.exchange.voronoi_phd import messages as core
from phd_swarm.core.scan import Scan
from phd_swarm.nodes import convert
from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm.nodes.faces import voronoi_codec
from phd_swarm.nodes.faces.voronoi_phd import WIRE
from phd_swarm.sim import presets as sc

GRID = sc.dames_static().grid
MAX_MEASUREMENTS = 50


def _messages():
    rng = np.random.default_rng(4)
    own, phantom = core.TransferKind.OWNERSHIP, core.TransferKind.PHANTOM
    bins = np.sort(rng.choice(GRID.size, 500, False))
    return [
        core.StateMsg(3, 7, np.array([1.5, -2.25]), 0.125, 4.5),
        core.CellMsg(3, 7, np.array([1.5, -2.25]), 0.5, rng.normal(size=(8, 2)), (1, 4, 9),
                     tuple(range(10)), rng.normal(size=(10, 2)), rng.random(10),
                     rng.random(10)),
        core.CellMsg(0, 0, np.array([0.0, 0.0]), 0.0, np.empty((0, 2)), ()),
        Scan(3, 7, np.array([10.0, 20.0]), rng.normal(size=(5, 2))),
        Scan(3, 7, np.array([10.0, 20.0]), np.empty((0, 2))),
        core.EtaPartialMsg(3, 5, 7, rng.random(4)),
        core.EtaTotalMsg(5, 7, rng.random(6)),
        core.EtaTotalMsg(5, 7, np.empty(0)),
        core.TransferMsg(3, 5, 7, own, bins, rng.random(500), rng.random(500),
                         rng.random(500) * 4, (1, 2), np.array([3.0, 4.0])),
        core.TransferMsg(3, 5, 7, phantom, np.array([1, 2]), np.array([0.1, 0.2])),
        core.TransferMsg(3, 5, 7, own, np.empty(0, np.int64), np.empty(0)),
    ]


def _assert_same(got, want) -> None:
    assert type(got) is type(want)
    for f in dataclasses.fields(want):
        a, b = getattr(got, f.name), getattr(want, f.name)
        if isinstance(b, np.ndarray):
            assert isinstance(a, np.ndarray) and a.dtype == b.dtype, f.name
            assert a.shape == b.shape and np.array_equal(a, b), f.name
        else:
            assert type(a) is type(b) and a == b, f.name


def _pts(xy) -> list[Point]:
    return [Point(x=x, y=y) for x, y in np.asarray(xy, float).reshape(-1, 2).tolist()]


def _expected_ros(msg):
    """The ROS message of ``msg`` built field by field with rclpy's classes."""
    h = convert.header(msg.step, 0.5, "map")
    if isinstance(msg, core.StateMsg):
        return ros_msgs.RobotState(header=h, robot_id=msg.robot_id, step=msg.step,
                                   position=_pts(msg.position)[0],
                                   power_weight=msg.power_weight, cell_radius=msg.cell_radius)
    if isinstance(msg, core.CellMsg):
        return ros_msgs.CellPolygon(
            header=h, robot_id=msg.robot_id, step=msg.step, generator=_pts(msg.generator)[0],
            power_weight=msg.power_weight, vertices=_pts(msg.vertices),
            neighbour_ids=list(msg.neighbour_ids), contact_ids=list(msg.contact_ids),
            contact_positions=_pts(msg.contact_positions),
            contact_power_weights=msg.contact_power_weights.tolist(),
            contact_cell_radii=msg.contact_cell_radii.tolist())
    if isinstance(msg, Scan):
        return ros_msgs.MeasurementSet(header=h, robot_id=msg.robot_id, step=msg.step,
                                       sensor_position=_pts(msg.sensor)[0],
                                       measurements=_pts(msg.z))
    if isinstance(msg, core.EtaPartialMsg):
        return ros_msgs.EtaPartial(header=h, sender_id=msg.sender_id, active_id=msg.active_id,
                                   step=msg.step, values=msg.values.tolist())
    if isinstance(msg, core.EtaTotalMsg):
        return ros_msgs.EtaTotal(header=h, active_id=msg.active_id, step=msg.step,
                                 values=msg.values.tolist())
    cum = msg.alpha is not None
    return ros_msgs.ParticleTransfer(
        header=h, from_id=msg.from_id, to_id=msg.to_id, step=msg.step, kind=int(msg.kind),
        bin_indices=msg.bins.tolist(), weights=msg.weights.tolist(),
        alpha=msg.alpha.tolist() if cum else [],
        observation_count=msg.count.tolist() if cum else [],
        radius_ids=list(msg.radius_ids), cell_radii=msg.cell_radii.tolist())


@pytest.mark.parametrize("msg", _messages(), ids=lambda m: WIRE.kind(m))
def test_the_cdr_path_matches_the_ros_message_path(msg):
    kind = WIRE.kind(msg)
    data = WIRE.encode(msg, 0.5, "map")
    expected = _expected_ros(msg)
    assert deserialize_message(data, WIRE.types[kind]) == expected
    assert WIRE.to_ros(msg, 0.5, "map") == expected
    got = WIRE.decode(kind, data, GRID, MAX_MEASUREMENTS)
    _assert_same(got, msg)
    _assert_same(got, WIRE.from_ros(expected, GRID, MAX_MEASUREMENTS))
    _assert_same(WIRE.decode(kind, serialize_message(expected), GRID, MAX_MEASUREMENTS), msg)
    wire_bytes = np.frombuffer(data, np.uint8)
    for f in dataclasses.fields(got):
        value = getattr(got, f.name)
        if isinstance(value, np.ndarray):  # the core may write into them
            assert value.flags.writeable and not np.shares_memory(value, wire_bytes), f.name


def test_the_ros_message_path_keeps_its_conversions():
    ros = WIRE.to_ros(_messages()[0], 0.5, "map")
    assert (ros.position, ros.header.stamp.sec, ros.header.stamp.nanosec) == (
        Point(x=1.5, y=-2.25), 3, 500_000_000)
    back = WIRE.from_ros(ros, GRID, MAX_MEASUREMENTS)
    assert back.position.tolist() == [1.5, -2.25] and back.cell_radius == 4.5


def _ros(inbox_kind: str, **changes):
    """The ROS message of the first message of ``inbox_kind`` in :func:`_messages`, changed."""
    msg = next(m for m in _messages() if WIRE.kind(m) == inbox_kind)
    ros = WIRE.to_ros(msg, 0.5, "map")
    for name, value in changes.items():
        setattr(ros, name, value)
    return ros


NAN = math.nan
BAD = [
    (_ros("state", position=Point(x=NAN, y=1.0)), r"position: non-finite coordinate \(nan"),
    (_ros("state", power_weight=-1.0), "power_weight: -1.0 is not a finite number >= 0.0"),
    (_ros("state", cell_radius=math.inf), "cell_radius: inf is not a finite number"),
    (_ros("cell", contact_cell_radii=[1.0]), "contact table: 10 ids but 10 positions, 10 power "
                                             "weights, 1 radii"),
    (_ros("cell", contact_power_weights=[NAN] * 10), "contact_power_weights: non-finite"),
    (_ros("cell", contact_cell_radii=[-1.0] * 10), "contact table: negative power weight"),
    (_ros("cell", generator=Point(x=1.0, y=math.inf)), "generator: non-finite coordinate"),
    (_ros("cell", power_weight=NAN), "power_weight: nan is not a finite number"),
    (_ros("cell", vertices=[Point(x=NAN)]), "vertices: non-finite coordinate"),
    (_ros("cell", contact_positions=[Point(y=NAN)] * 10), "contact_positions: non-finite"),
    (_ros("measurements", measurements=[Point()] * (MAX_MEASUREMENTS + 1)),
     "measurements: 51 measurements, more than max_measurements = 50"),
    (_ros("measurements", sensor_position=Point(x=NAN)), "sensor_position: non-finite"),
    (_ros("measurements", measurements=[Point(x=-math.inf)]), "measurements: non-finite"),
    (_ros("eta_partial", values=[0.0] * 51), "values: 51 values, more than max_measurements"),
    (_ros("eta_partial", values=[NAN]), "values: non-finite value"),
    (_ros("eta_total", values=[-0.5]), "values: negative normalisation sum"),
    (_ros("particles", kind=7), "kind: unknown transfer kind 7"),
    (_ros("particles", weights=[0.5]), "500 bin indices but 1 weights"),
    (_ros("particles", weights=[-0.5] * 500), "weights: negative PHD mass"),
    (_ros("particles", weights=[NAN] * 500), "weights: non-finite value"),
    (_ros("particles", bin_indices=[GRID.size], weights=[0.1], alpha=[], observation_count=[]),
     f"bin_indices: index {GRID.size} is off the grid of {GRID.size} bins"),
    (_ros("particles", alpha=[1.0]), "500 bins but 1 alpha and 500 observation counts"),
    (_ros("particles", observation_count=[-1.0] * 500), "alpha / observation_count: negative"),
    (_ros("particles", alpha=[NAN] * 500), "alpha: non-finite value"),
    (_ros("particles", radius_ids=[1]), "1 radius ids but 2 cell radii"),
    (_ros("particles", cell_radii=[-1.0, 1.0]), "cell_radii: negative radius"),
]


@pytest.mark.parametrize("ros, match", BAD, ids=[m for _, m in BAD])
def test_decode_refuses_what_from_ros_refuses_in_the_same_words(ros, match):
    kind = next(k for k, t in WIRE.types.items() if isinstance(ros, t))
    with pytest.raises(InvalidMessage, match=match) as via_ros:
        WIRE.from_ros(ros, GRID, MAX_MEASUREMENTS)
    with pytest.raises(InvalidMessage) as via_cdr:
        WIRE.decode(kind, serialize_message(ros), GRID, MAX_MEASUREMENTS)
    assert str(via_cdr.value) == str(via_ros.value)


@pytest.mark.parametrize("kind", sorted(WIRE.types))
def test_bytes_that_do_not_decode_are_invalid_messages_naming_the_type(kind):
    data = serialize_message(WIRE.types[kind]())
    name = WIRE.types[kind].__name__
    for bad in (data[:10], b"\x00\x00\x00\x00" + data[4:]):
        with pytest.raises(InvalidMessage, match=f"does not deserialise: .*{name}"):
            WIRE.decode(kind, bad, GRID, MAX_MEASUREMENTS)


def test_from_ros_refuses_what_is_not_a_protocol_message():
    with pytest.raises(InvalidMessage, match="not a protocol message: Point"):
        voronoi_codec.from_ros(Point(), GRID, MAX_MEASUREMENTS)
