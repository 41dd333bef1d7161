"""An exchange's wire format is looked up from its registration, not known to the node."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.exchange.voronoi_phd.messages import (
    EtaPartialMsg,
    StateMsg,
    TransferKind,
    TransferMsg,
)
from phd_swarm.core.registry import Part, lookup
from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm.nodes.faces.voronoi_phd import WIRE
from phd_swarm.nodes.wire import wire_for
from phd_swarm.sim import presets as sc


def test_voronoi_phd_names_its_wire_and_it_round_trips_addressed_messages():
    wire = wire_for(lookup("exchange", "voronoi_phd"))
    assert wire is WIRE and set(wire.types) == {"state", "cell", "measurements",
                                                 "eta_partial", "eta_total", "particles"}
    grid = sc.dames_static().grid
    transfer = TransferMsg(3, 5, 7, TransferKind.OWNERSHIP, np.array([1, 2]),
                           np.array([0.1, 0.2]))
    back = wire.from_ros(wire.to_ros(transfer, 0.5, "map"), grid, 100)
    assert wire.kind(back) == "particles"
    assert (wire.sender(back), wire.addressee(back)) == (3, 5)
    assert np.array_equal(back.bins, [1, 2]) and np.array_equal(back.weights, [0.1, 0.2])
    partial = EtaPartialMsg(4, 9, 7, np.array([0.5]))
    assert (wire.sender(partial), wire.addressee(partial)) == (4, 9)
    state = StateMsg(2, 7, np.array([1.0, 2.0]), 0.0, 1.0)
    assert wire.kind(state) == "state" and wire.addressee(state) is None


def test_a_wire_without_a_codec_of_its_own_goes_through_ros_messages():
    from rclpy.serialization import deserialize_message

    from phd_swarm.core.exchange.sat_share import SatMsg
    from phd_swarm.nodes.faces.sat_share import WIRE as SAT
    from phd_swarm_msgs.msg import SatState

    msg = SatMsg(3, 12, np.array([10.5, 20.25]), True, np.array([[1.0, 2.0]]),
                 np.array([0.25]), (1, 3))
    data = SAT.encode(msg, 1.0, "map")
    assert deserialize_message(data, SatState) == SAT.to_ros(msg, 1.0, "map")
    back = SAT.decode("sat", data, None, 100)
    assert (back.src, back.step, back.plan_members) == (3, 12, (1, 3))
    assert np.array_equal(back.predicted, [[1.0, 2.0]])
    with pytest.raises(InvalidMessage, match="does not deserialise"):
        SAT.decode("sat", data[:10], None, 100)


def test_an_exchange_without_a_wire_cannot_run_on_ros():
    part = Part("exchange", "nowire", lambda s, r: None, lambda *a, **k: None, "test")
    with pytest.raises(ValueError, match="no ROS wire format"):
        wire_for(part)
    bad = Part("exchange", "badwire", lambda s, r: None, lambda *a, **k: None, "test",
               wire="phd_swarm.nodes.convert:no_such_wire")
    with pytest.raises(ValueError, match="cannot be loaded"):
        wire_for(bad)
