"""Every custom message type round-trips through rclpy's CDR serialisation."""

from __future__ import annotations

import math

import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Header

from phd_swarm_msgs.msg import (
    CellPolygon,
    DensityGrid,
    EtaPartial,
    EtaTotal,
    GaussianMixture,
    InboxMessage,
    MeasurementSet,
    MessageBundle,
    ParticleTransfer,
    RewardSet,
    RobotState,
    RobotStatus,
    SatState,
    TargetSet,
    TeamMetrics,
    TeamState,
    TrackSet,
)


def _header(step: int) -> Header:
    return Header(stamp=Time(sec=12, nanosec=500_000_000 + step), frame_id="map")


def _points(n: int, scale: float) -> list[Point]:
    return [Point(x=scale * i + 0.125, y=-scale * i - 1e-9, z=0.0) for i in range(n)]


EXAMPLES = [
    RobotState(header=_header(1), robot_id=7, step=1, position=Point(x=12.5, y=-3.25),
               power_weight=2.75, cell_radius=14.125),
    CellPolygon(header=_header(2), robot_id=3, step=2, generator=Point(x=1.0, y=2.0),
                power_weight=0.5, vertices=_points(5, 3.3), neighbour_ids=[0, 4, 19],
                contact_ids=[0, 4, 19, 22], contact_positions=_points(4, 2.5),
                contact_power_weights=[0.0, 1.5, 0.25, 5.0],
                contact_cell_radii=[3.0, 7.5, 11.0, 0.0]),
    MeasurementSet(header=_header(3), robot_id=4294967294, step=3,
                   sensor_position=Point(x=50.0, y=50.0), measurements=_points(4, 0.7)),
    MeasurementSet(header=_header(4), robot_id=0, step=4, sensor_position=Point(x=0.0, y=0.0),
                   measurements=[]),
    EtaPartial(header=_header(5), sender_id=2, active_id=1, step=5,
               values=[1e-300, 0.0, 3.66e-3, 123.456]),
    EtaTotal(header=_header(6), active_id=1, step=6, values=[0.25, 1e12]),
    ParticleTransfer(header=_header(7), from_id=1, to_id=2, step=7,
                     kind=ParticleTransfer.KIND_PHANTOM, bin_indices=[0, 9999, 999_999],
                     weights=[1e-4, 0.5, 2.0 / 3.0], alpha=[0.0, 3.0, 1.0],
                     observation_count=[0.0, 10.0, 2.0]),
    ParticleTransfer(header=_header(7), from_id=3, to_id=2, step=7,
                     kind=ParticleTransfer.KIND_OWNERSHIP, bin_indices=[5], weights=[0.25],
                     radius_ids=[0, 2, 9], cell_radii=[12.5, 0.0, 71.25]),
    DensityGrid(header=_header(8), owner_id=5, step=8, x_min=-50.0, y_min=-50.0,
                resolution=0.1, origin_col=10, origin_row=20, width=3, height=2,
                data=[0.0, 1e-4, math.pi, 1.0 / 3.0, 7.5e-12, 0.05]),
    TargetSet(header=_header(9), source_id=0xFFFFFFFF, step=9, ids=[3, 1, 2],
              positions=_points(3, 10.0), expected_cardinality=2.875),
    TeamState(header=_header(10), step=10, robot_ids=[0, 1, 5], positions=_points(3, 1.5),
              alive=[True, False, True]),
    RobotStatus(header=_header(11), state=RobotStatus.STATE_STEP_DONE, robot_id=5, step=11,
                goal=Point(x=3.5, y=99.0), power_weight=1.25, owned_bins=812, mass=2.5e-3,
                messages_received=61, messages_sent=58, rejected_messages=2,
                dropped_messages=1, timeouts=1, orphan_bins=40, dead_ids=[3]),
    TeamMetrics(header=_header(12), step=12, ospa=4.25, ospa_localisation=1.0,
                ospa_cardinality=3.25, ospa_c=10.0, ospa_p=1.0, cardinality_true=30,
                cardinality_estimated=27, expected_cardinality=28.5, robots_alive=19,
                robots_reported=19, messages_per_robot=55.5),
    GaussianMixture(header=_header(13), source_id=0, step=13, dim=2, weights=[1.0, 1e-3],
                    means=[10.5, -3.25, 149.0, 0.0625],
                    covariances=[50.0, 0.5, 0.5, 50.0, 1.0, 0.0, 0.0, 2.0 / 3.0]),
    GaussianMixture(header=_header(14), source_id=0, step=14, dim=2),
    TrackSet(header=_header(15), source_id=0, step=15, track_ids=[0, 7], life=[3, 1],
             confirmed=[True, False], weights=[0.98, 0.5], positions=_points(2, 12.0),
             covariances=[1.0, 0.25, 0.25, 2.0, 3.0, 0.0, 0.0, 3.0]),
    RewardSet(header=_header(16), source_id=4, step=16, met_ids=[1, 7],
              positions=_points(3, 1.25)),
    SatState(header=_header(17), source_id=2, step=17, position=_points(1, 3.0)[0],
             tracking=True, predicted=_points(2, 4.5), search=[0.0, 0.5, 1.0],
             plan_members=[0, 2]),
    InboxMessage(sender=3, kinds=["state", "cell"], offsets=[0, 4, 9],
                 data=[0, 1, 0, 0, 7, 0, 1, 0, 0]),
    MessageBundle(header=_header(18), sender=-1, step=18,
                  topics=["/robot_0/pose", "/robot_1/pose"], offsets=[0, 4, 9],
                  data=[0, 1, 0, 0, 7, 0, 1, 0, 0]),
]


@pytest.mark.parametrize("msg", EXAMPLES, ids=lambda m: type(m).__name__)
def test_roundtrip_preserves_every_field(msg):
    data = serialize_message(msg)
    assert data[:2] in (b"\x00\x01", b"\x00\x00")  # CDR encapsulation header
    back = deserialize_message(data, type(msg))
    assert back == msg
    # Not byte equality: CDR alignment padding is not guaranteed to be zeroed.
    assert deserialize_message(serialize_message(back), type(msg)) == msg


def test_every_message_type_has_an_example():
    import phd_swarm_msgs.msg as msgs

    defined = {name for name in dir(msgs) if not name.startswith("_")
               and isinstance(getattr(msgs, name), type)}
    assert defined == {type(m).__name__ for m in EXAMPLES}


def test_particle_transfer_kinds_are_distinct_constants():
    assert ParticleTransfer.KIND_OWNERSHIP != ParticleTransfer.KIND_PHANTOM
