"""The run's key: sealed messages, the key file, and keyed robots (phd_swarm.nodes.auth)."""

from __future__ import annotations

import os

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from phd_swarm.nodes import auth, cdr, convert, inbox
from phd_swarm.nodes.convert import InvalidMessage, Unauthenticated
from phd_swarm_msgs.msg import InboxMessage, MeasurementSet

KEY, OTHER = b"k" * auth.KEY_BYTES, b"o" * auth.KEY_BYTES


def _envelope(key):
    return inbox.pack_cdr(2, [("state", b"\x00\x01\x00\x00abc"), ("cell", b"xy")], key)


def test_a_sealed_envelope_is_a_valid_inbox_message_with_its_mac():
    data = _envelope(KEY)
    fields = cdr.decode(InboxMessage, data)
    assert fields["mac"].tobytes() == data[-auth.MAC_SIZE:] and len(fields["mac"]) == 16
    msg = deserialize_message(data, InboxMessage)  # rclpy reads it as well
    assert msg.sender == 2 and list(msg.kinds) == ["state", "cell"]
    assert inbox.unpack_cdr(data, {"state", "cell"}, KEY) == (
        2, [("state", b"\x00\x01\x00\x00abc"), ("cell", b"xy")])
    # Without a key: an empty mac, read by anyone, and the same bytes as the codec's.
    plain = _envelope(None)
    assert cdr.decode(InboxMessage, plain)["mac"].size == 0
    assert plain == cdr.encode(InboxMessage, cdr.decode(InboxMessage, plain))


@pytest.mark.parametrize("forge", [
    lambda d: _envelope(None),                                        # unsigned
    lambda d: _envelope(OTHER),                                       # another key
    lambda d: d[:8] + bytes([d[8] ^ 1]) + d[9:],                      # a bit changed
    lambda d: d[:-1],                                                 # cut
    lambda d: d + b"\0\0\0\0",                                        # grown
])
def test_anything_but_the_senders_exact_bytes_is_unauthenticated(forge):
    data = forge(_envelope(KEY))
    with pytest.raises(Unauthenticated, match="not signed with this run's key"):
        inbox.unpack_cdr(data, {"state", "cell"}, KEY)


def test_measurement_sets_are_sealed_by_the_world_and_checked_by_the_robot():
    z = np.array([[1.0, 2.0], [3.0, 4.5]])
    data = convert.encode_scan(7, 0.5, "map", 3, np.array([5.0, 6.0]), z, KEY)
    scan = convert.decode_scan(data, 100, KEY)
    assert (scan.robot_id, scan.step) == (3, 7)
    np.testing.assert_array_equal(scan.sensor, [5.0, 6.0])
    np.testing.assert_array_equal(scan.z, z)
    msg = deserialize_message(data, MeasurementSet)
    assert msg.header.stamp.sec == 3 and msg.header.stamp.nanosec == 500_000_000
    assert len(msg.mac) == 16
    for forged in (convert.encode_scan(7, 0.5, "map", 3, np.array([5.0, 6.0]), z, None),
                   convert.encode_scan(8, 0.5, "map", 3, np.array([5.0, 6.0]), z, OTHER)):
        with pytest.raises(Unauthenticated):
            convert.decode_scan(forged, 100, KEY)
    empty = convert.encode_scan(0, 0.5, "map", 0, np.zeros(2), np.zeros((0, 2)), KEY)
    assert convert.decode_scan(empty, 100, KEY).z.shape == (0, 2)
    # A robot without a key takes either.
    assert convert.decode_scan(data, 100).step == 7


def test_an_unauthenticated_message_is_an_invalid_one():
    assert issubclass(Unauthenticated, InvalidMessage)


def test_the_key_file_is_private_random_and_checked(tmp_path):
    path = auth.write_key(tmp_path / "run" / "run.key")
    assert os.stat(path).st_mode & 0o777 == 0o600
    key = auth.read_key(path)
    assert len(key) == auth.KEY_BYTES
    assert auth.read_key(auth.write_key(path)) != key  # a new one each time
    assert auth.read_key("") is None
    os.chmod(path, 0o644)
    with pytest.raises(ValueError, match=r"run.key: the run's key is readable by others "
                                         r"\(mode 644\); it must be 600"):
        auth.read_key(path)
    os.chmod(path, 0o600)
    path.write_text("not hex")
    with pytest.raises(ValueError, match=r"run.key: not a key \(32 bytes in hex\)"):
        auth.read_key(path)
    with pytest.raises(ValueError, match=r"missing.key: cannot read the run's key"):
        auth.read_key(tmp_path / "missing.key")


@pytest.mark.ros
def test_a_keyed_team_rejects_forgeries_and_steps_as_an_unkeyed_one(tmp_path):
    from phd_swarm.testing import small_static_scenario

    scenario = small_static_scenario(robots=3, steps=12)
    key_file = auth.write_key(tmp_path / "run.key")
    plain = _team_series(tmp_path / "plain", scenario, None)
    keyed = _team_series(tmp_path / "keyed", scenario, key_file)
    assert len(keyed) == scenario.steps and keyed == plain


def _team_series(where, scenario, key_file):
    """(step, OSPA, estimated count) of an in-process run; forgeries sent to a keyed one."""
    from phd_swarm.testing import InProcessRos, start_swarm

    where.mkdir()
    with InProcessRos(executor="events") as ros:
        world, monitor, robots = start_swarm(
            ros, where, scenario, shared={"auth_key_file": str(key_file)} if key_file else None)
        if key_file is not None:
            assert robots[1].key == auth.read_key(key_file) and world.key == robots[1].key
            _forge(ros, robots[1], scenario.dt)
        assert ros.spin_until(lambda: monitor.done, timeout=120.0)
        return [(r["step"], r["ospa"], r["cardinality_est"]) for r in monitor.series]


def _forge(ros, victim, dt):
    """Envelopes and scans for ``victim``, unsigned and signed with another key: rejected."""
    from geometry_msgs.msg import Point

    from phd_swarm.nodes.qos import publisher_qos
    from phd_swarm_msgs.msg import RobotState

    assert ros.spin_until(lambda: victim.filter.step >= 2, timeout=60.0)
    evil = ros.node("evil")
    envelopes = evil.create_publisher(InboxMessage, "/robot_1/inbox", publisher_qos("INBOX"))
    scans = evil.create_publisher(MeasurementSet, "/robot_1/measurements",
                                  publisher_qos("STEP"))
    assert ros.spin_until(lambda: envelopes.get_subscription_count() > 0
                          and scans.get_subscription_count() > 0, timeout=10.0)
    k = victim.filter.step + 1
    state = serialize_message(RobotState(header=convert.header(k, dt, "map"), robot_id=0,
                                         step=k, position=Point(x=1.0, y=1.0),
                                         power_weight=0.0, cell_radius=1.0))
    for key in (None, OTHER):
        envelopes.publish(inbox.pack_cdr(0, [("state", state)], key))
        scans.publish(convert.encode_scan(k + 1, dt, "map", 1, np.array([20.0, 20.0]),
                                          np.array([[21.0, 21.0]]), key))
    assert ros.spin_until(lambda: victim.rejections["unauthenticated"] == 4,
                          timeout=10.0), dict(victim.rejections)


@pytest.mark.ros
def test_a_robot_refuses_a_key_file_others_can_read(tmp_path):
    from rclpy.parameter import Parameter

    from phd_swarm.config import RunConfig
    from phd_swarm.nodes.robot import RobotNode
    from phd_swarm.nodes.ros_params import ParameterError
    from phd_swarm.testing import InProcessRos, small_static_scenario

    key = auth.write_key(tmp_path / "run.key")
    os.chmod(key, 0o644)
    params = RunConfig(small_static_scenario(robots=2), {"auth_key_file": str(key)}
                       ).write_params(tmp_path / "params.yaml")
    with InProcessRos() as ros, pytest.raises(
            ParameterError, match=r"robot: parameter auth_key_file: .*run.key: the run's key "
                                  r"is readable by others \(mode 644\)"):
        RobotNode(context=ros.context, namespace="/robot_0",
                  cli_args=["--ros-args", "--params-file", str(params)],
                  parameter_overrides=[Parameter("robot_id", value=0)])
