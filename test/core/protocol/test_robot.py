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
    Phase,
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


def _waiting_for_cells() -> RobotFilter:
    """Robot 0 at step 0 with the states of robots 1 and 2, waiting for their cells."""
    robot = RobotFilter(0, FilterContext(CTX.grid, CTX.models, timeout_ticks=2))
    robot.initialise([0, 1, 2], POS)
    robot.start_step(0, POS[0], 0.0, np.empty((0, 2)))
    for rid in (1, 2):
        assert robot.receive(StateMsg(rid, 0, POS[rid], 0.0)) is True
    robot.advance()
    assert robot.phase is Phase.CELLS
    return robot


def test_a_waiting_robot_sends_keep_alives_and_times_out_only_silent_peers():
    # Robot 0 has the states of 1 and 2 and waits for their cells. Robot 1 is blocked
    # elsewhere (on a robot that died) and keeps re-sending its state, a keep-alive;
    # robot 2 sends nothing more: only robot 2 is declared dead.
    robot = _waiting_for_cells()
    for _ in range(5):
        contacts = sorted(robot.contacts)
        out = robot.tick()
        # Every tick re-sends the own state of the step to every contact.
        states = [e for e in out if isinstance(e.msg, StateMsg)]
        assert sorted(e.dst for e in states) == contacts == [1, 2]
        assert all(e.msg.step == 0 and e.msg.robot_id == 0 for e in states)
        assert robot.receive(StateMsg(1, 0, POS[1], 0.0)) is False  # a repeat, not new
        if robot.dead:
            break
    assert robot.dead == {2} and robot.stats["timeouts"] == 1
    assert robot.phase is Phase.CELLS  # still waiting for robot 1, which is alive


def test_a_wait_that_cannot_end_times_out_every_awaited_peer():
    # Robot 1 keeps sending keep-alives but never the cell robot 0 waits for: after
    # 3 x timeout_ticks rounds without progress it is declared dead all the same.
    robot = _waiting_for_cells()
    cells = {rid: CellMsg(rid, 0, POS[rid], 0.0, np.empty((0, 2)), ()) for rid in (1, 2)}
    robot.receive(cells[2])
    robot.advance()
    rounds = 0
    while not robot.dead:
        rounds += 1
        robot.tick()
        robot.receive(StateMsg(1, 0, POS[1], 0.0))
        assert rounds <= 6
    assert robot.dead == {1} and rounds == 6
