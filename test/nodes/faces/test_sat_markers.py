"""A search-and-track agent's markers: sensing square by mode, plan, estimates."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from visualization_msgs.msg import Marker

from phd_swarm.nodes.faces.sat_markers import MODE_COLOURS, sat_markers

STAMP = Time(sec=3)


def test_square_plan_and_estimates_under_the_agents_prefix():
    out = sat_markers(STAMP, "map", 2, np.array([10.0, 20.0]), 10.0, "track",
                      np.array([[12.0, 20.0], [np.nan, 0.0], [15.0, 25.0]]),
                      np.array([[11.0, 21.0]]))
    ns = {m.ns: m for m in out.markers}
    assert set(ns) == {"robot_2/robot", "robot_2/sensing", "robot_2/plan",
                       "robot_2/estimates"}
    sq = ns["robot_2/sensing"]
    assert sq.type == Marker.LINE_STRIP and len(sq.points) == 5
    xs = sorted({p.x for p in sq.points})
    assert xs == [5.0, 15.0] and (sq.color.r, sq.color.g) == pytest.approx(
        MODE_COLOURS["track"][:2])
    plan = ns["robot_2/plan"]
    assert [(p.x, p.y) for p in plan.points] == [(10.0, 20.0), (12.0, 20.0), (15.0, 25.0)]
    assert len(ns["robot_2/estimates"].points) == 1


def test_modes_colour_the_square_and_a_bad_mode_is_refused():
    colours = {m: sat_markers(STAMP, "map", 0, np.zeros(2), 10.0, m, np.empty((0, 2)),
                              np.empty((0, 2))).markers[1].color.r for m in MODE_COLOURS}
    assert len(set(colours.values())) == 3
    with pytest.raises(ValueError, match="mode"):
        sat_markers(STAMP, "map", 0, np.zeros(2), 10.0, "idle", np.empty((0, 2)),
                    np.empty((0, 2)))
