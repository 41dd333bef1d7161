"""RobotFilter rejects bad input with errors that name the problem."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.grid import Environment, Grid
from phd_swarm.core.models import PhdModels
from phd_swarm.core.protocol.messages import (
    CellMsg,
    EtaPartialMsg,
    EtaTotalMsg,
    ScanMsg,
    StateMsg,
    TransferKind,
    TransferMsg,
    sender_of,
)
from phd_swarm.core.protocol.robot import (
    FilterContext,
    ProtocolError,
    RobotFilter,
    _mail_route,
)

CTX = FilterContext(Grid(Environment(0.0, 0.0, 20.0, 20.0), 1.0), PhdModels())
POS = np.array([[5.0, 5.0], [15.0, 5.0], [10.0, 15.0]])


def _robot(rid: int = 0) -> RobotFilter:
    robot = RobotFilter(rid, CTX)
    robot.initialise([0, 1, 2], POS)
    return robot


def test_initialise_rejects_duplicate_and_unknown_ids():
    with pytest.raises(ValueError, match="unique"):
        RobotFilter(0, CTX).initialise([0, 1, 1], POS)
    with pytest.raises(ValueError, match="not among the team ids"):
        RobotFilter(7, CTX).initialise([0, 1, 2], POS)


def test_initialise_takes_the_own_cell_with_the_prior():
    robot = _robot(1)
    assert robot.bins.size > 0
    assert np.all(robot.weights == CTX.prior_mass)
    assert set(robot.contacts) == {0, 2}


def test_start_step_rejects_non_finite_input_and_out_of_order_steps():
    robot = _robot()
    with pytest.raises(ValueError, match="non-finite"):
        robot.start_step(0, np.array([np.nan, 1.0]), 0.0, np.empty((0, 2)))
    with pytest.raises(ValueError, match="non-finite"):
        robot.start_step(0, POS[0], 0.0, np.array([[1.0, np.inf]]))
    robot.start_step(0, POS[0], 0.0, np.empty((0, 2)))
    with pytest.raises(ProtocolError, match="started while step 0"):
        robot.start_step(1, POS[0], 0.0, np.empty((0, 2)))


def test_messages_from_dead_robots_or_past_steps_are_dropped_and_counted():
    robot = _robot()
    robot.start_step(3, POS[0], 0.0, np.empty((0, 2)))
    robot.receive(StateMsg(1, 2, POS[1], 0.0))  # a past step
    robot.dead.add(2)
    robot.receive(StateMsg(2, 3, POS[2], 0.0))  # a dead robot
    assert robot.stats["dropped"] == 2
    assert not robot.done  # still waiting for robot 1's state of step 3


def test_mailbox_routes_name_the_sender_as_sender_of_does():
    empty = np.empty(0)
    messages = {
        (1, "state"): StateMsg(4, 1, np.zeros(2), 0.0),
        (1, "cell"): CellMsg(4, 1, np.zeros(2), 0.0, np.empty((0, 2)), ()),
        (1, "scan"): ScanMsg(4, 1, np.zeros(2), np.empty((0, 2))),
        (1, "partial", 9): EtaPartialMsg(4, 9, 1, empty),
        (1, "total", 4): EtaTotalMsg(4, 1, empty),
        (1, "own"): TransferMsg(4, 9, 1, TransferKind.OWNERSHIP, empty, empty),
        (1, "phantom"): TransferMsg(4, 9, 1, TransferKind.PHANTOM, empty, empty),
    }
    for key, msg in messages.items():
        assert _mail_route(msg) == (sender_of(msg), key) == (4, key)
    with pytest.raises(TypeError, match="not a protocol message"):
        _mail_route(object())
