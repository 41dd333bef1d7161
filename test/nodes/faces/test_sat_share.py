"""The sat_share wire: a SatMsg travels exactly, and a bad SatState is refused naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.exchange.sat_share import SatMsg
from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm.nodes.faces.sat_share import WIRE, sat_state


def _msg():
    return SatMsg(3, 12, np.array([10.5, 20.25]), True, np.array([[1.0, 2.0], [3.5, 4.0]]),
                  np.array([0.0, 0.25, 1.0]), (1, 3))


def test_a_sat_msg_travels_exactly():
    back = WIRE.from_ros(WIRE.to_ros(_msg(), 1.0, "map"), None, 100)
    ref = _msg()
    assert (back.src, back.step, back.tracking, back.plan_members) == (3, 12, True, (1, 3))
    for a, b in ((back.position, ref.position), (back.predicted, ref.predicted),
                 (back.search, ref.search)):
        np.testing.assert_array_equal(a, b)
    assert WIRE.kind(ref) == "sat" and WIRE.sender(ref) == 3


@pytest.mark.parametrize("field, value, match", [
    ("search", [0.5, 1.5], "search: values must lie in"),
    ("search", [np.nan], "search: non-finite"),
])
def test_bad_search_values_are_refused(field, value, match):
    ros = sat_state(_msg(), 1.0, "map")
    setattr(ros, field, value)
    with pytest.raises(InvalidMessage, match=match):
        WIRE.from_ros(ros, None, 100)


def test_a_non_finite_position_is_refused():
    ros = sat_state(_msg(), 1.0, "map")
    ros.position.x = float("inf")
    with pytest.raises(InvalidMessage, match="position"):
        WIRE.from_ros(ros, None, 100)
