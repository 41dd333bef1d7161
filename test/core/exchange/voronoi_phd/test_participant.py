"""Participant rejects bad input with errors that name the problem."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.exchange.voronoi_phd.mailbox import mail_route
from phd_swarm.core.exchange.voronoi_phd.messages import (
    CellMsg,
    EtaPartialMsg,
    EtaTotalMsg,
    StateMsg,
    TransferKind,
    TransferMsg,
    sender_of,
)
from phd_swarm.core.exchange.voronoi_phd.participant import (
    FilterContext,
    Participant,
    Phase,
    ProtocolError,
)
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.models import PhdModels
from phd_swarm.core.scan import Scan

CTX = FilterContext(Grid(Environment(0.0, 0.0, 20.0, 20.0), 1.0), PhdModels())
POS = np.array([[5.0, 5.0], [15.0, 5.0], [10.0, 15.0]])


def _robot(rid: int = 0) -> Participant:
    robot = Participant(rid, CTX)
    robot.initialise([0, 1, 2], POS)
    return robot


def test_initialise_rejects_duplicate_and_unknown_ids():
    with pytest.raises(ValueError, match="unique"):
        Participant(0, CTX).initialise([0, 1, 1], POS)
    with pytest.raises(ValueError, match="not among the team ids"):
        Participant(7, CTX).initialise([0, 1, 2], POS)


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
        (1, "scan"): Scan(4, 1, np.zeros(2), np.empty((0, 2))),
        (1, "partial", 9): EtaPartialMsg(4, 9, 1, empty),
        (1, "total", 4): EtaTotalMsg(4, 1, empty),
        (1, "own"): TransferMsg(4, 9, 1, TransferKind.OWNERSHIP, empty, empty),
        (1, "phantom"): TransferMsg(4, 9, 1, TransferKind.PHANTOM, empty, empty),
    }
    for key, msg in messages.items():
        assert mail_route(msg) == (sender_of(msg), key) == (4, key)
    with pytest.raises(TypeError, match="not a protocol message"):
        mail_route(object())


def _waiting_for_cells() -> Participant:
    """Robot 0 at step 0 with the states of robots 1 and 2, waiting for their cells."""
    robot = Participant(0, FilterContext(CTX.grid, CTX.models, timeout_ticks=2))
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
    for tick in range(1, 6):
        contacts = sorted(robot.contacts)
        out = robot.tick()
        # Every tick re-sends the own state of the step to every peer it waits for (here
        # every contact), twice from the second tick of the wait on.
        states = [e for e in out if isinstance(e.msg, StateMsg)]
        assert sorted(set(e.dst for e in states)) == contacts == [1, 2]
        assert len(states) == (2 if tick > 1 else 1) * len(contacts)
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


#: Close enough for every field of view (5 m) to meet every cell.
NEAR = np.array([[8.0, 8.0], [12.0, 8.0], [10.0, 12.0]])
#: Detections of every robot, in every cell.
Z = {0: np.array([[9.0, 9.0]]), 1: np.array([[11.0, 9.0], [9.5, 8.0]]),
     2: np.array([[10.0, 11.0]])}


def _team() -> dict[int, Participant]:
    robots = {rid: Participant(rid, CTX) for rid in range(3)}
    for robot in robots.values():
        robot.initialise([0, 1, 2], NEAR)
    return robots


def _run_step(robots: dict[int, Participant], step: int, z: dict[int, np.ndarray]) -> list:
    """One step of the team, delivering everything in order; returns every envelope."""
    queue, sent = [], []
    for rid, robot in robots.items():
        queue.extend(robot.start_step(step, NEAR[rid], 0.0, z.get(rid, np.empty((0, 2)))))
    while queue:
        sent.extend(queue)
        batch, queue = queue, []
        for _src, dst, msg in batch:
            robots[dst].receive(msg)
            queue.extend(robots[dst].advance())
    assert all(r.done for r in robots.values())
    return sent


def test_a_keep_alive_gets_the_messages_of_that_step_again_even_after_the_step():
    # Every robot detects something that every other robot's bins see, so every phase
    # sends messages.
    robots = _team()
    sent = _run_step(robots, 0, Z)
    to_1 = [e for e in sent if e.src == 0 and e.dst == 1 and not isinstance(e.msg, StateMsg)]
    assert [type(e.msg) for e in to_1] == [CellMsg, TransferMsg, Scan, EtaTotalMsg,
                                           EtaPartialMsg]
    robot = robots[0]
    assert robot.phase is Phase.DONE
    # Robot 1's state again: a keep-alive (a robot that lost a message would send it).
    # Robot 1's own messages show it had all but robot 0's totals: its partial sums for
    # robot 0's update needed robot 0's scan, its totals needed robot 0's partial sums.
    assert robot.receive(StateMsg(1, 0, NEAR[1], 0.0)) is False
    assert [(e.dst, e.msg) for e in robot.advance()] == [(1, to_1[3].msg)]
    assert robot.advance() == []  # once per keep-alive
    # In the next step the mail of step 0 is gone: everything of step 0 again.
    robot.start_step(1, NEAR[0], 0.0, np.empty((0, 2)))
    assert robot.receive(StateMsg(1, 0, NEAR[1], 0.0)) is False
    assert [(e.dst, e.msg) for e in robot.advance()] == [(1, e.msg) for e in to_1]
    assert robot.stats["resent"] == 1 + len(to_1)


def test_a_keep_alive_mid_step_gets_only_what_the_peer_can_still_miss():
    robot = _waiting_for_cells()
    # Robot 0 sent its state and cell; robot 1 has not yet sent its cell, so it may miss
    # robot 0's cell (not the state: keep-alives carry states).
    robot.receive(StateMsg(1, 0, POS[1], 0.0))
    again = robot.advance()
    assert [(e.dst, type(e.msg)) for e in again] == [(1, CellMsg)]
    # Robot 1's cell shows it had all states, not yet all cells: the cell again.
    robot.receive(CellMsg(1, 0, POS[1], 0.0, np.empty((0, 2)), ()))
    robot.advance()
    robot.receive(StateMsg(1, 0, POS[1], 0.0))
    assert [type(e.msg) for e in robot.advance()] == [CellMsg]
    # Robot 2's cell completes the phase: robot 0 hands over (empty transfers). Robot 1's
    # transfer shows it had every cell: only the transfer again.
    robot.receive(CellMsg(2, 0, POS[2], 0.0, np.empty((0, 2)), ()))
    assert [type(e.msg) for e in robot.advance()] == [TransferMsg, TransferMsg]
    robot.receive(TransferMsg(1, 0, 0, TransferKind.OWNERSHIP, np.empty(0, np.int64),
                              np.empty(0)))
    robot.advance()
    robot.receive(StateMsg(1, 0, POS[1], 0.0))
    assert [(e.dst, type(e.msg)) for e in robot.advance()] == [(1, TransferMsg)]


def test_a_message_received_twice_is_applied_once():
    # Every message delivered twice (as re-sends do) gives the same team as once.
    once, twice = _team(), _team()
    _run_step(once, 0, Z)
    queue = []
    for rid, robot in twice.items():
        queue.extend(robot.start_step(0, NEAR[rid], 0.0, Z[rid]))
    while queue:
        batch, queue = queue, []
        for _src, dst, msg in batch + batch:
            twice[dst].receive(msg)
            queue.extend(twice[dst].advance())
    for rid in once:
        assert np.array_equal(once[rid].bins, twice[rid].bins)
        assert np.array_equal(once[rid].weights, twice[rid].weights)
    assert sum(r.stats["duplicates"] for r in twice.values()) > 0


def test_rejoin_drops_the_old_state_and_takes_contacts_from_the_team_state():
    robot = _robot(2)
    robot.start_step(0, POS[2], 0.0, np.empty((0, 2)))  # stopped mid-step
    alive = np.array([True, False, True])
    with pytest.raises(ValueError, match="already started step 0"):
        robot.rejoin(0, [0, 1, 2], POS, alive)
    with pytest.raises(ValueError, match="does not list it alive"):
        robot.rejoin(5, [0, 1, 2], POS, np.array([True, True, False]))
    robot.rejoin(5, [0, 1, 2], POS, alive)
    assert robot.bins.size == 0 and robot.done and robot.dead == {1}
    assert robot.contacts == (0,) and robot.stats["rejoins"] == 1
    out = robot.start_step(5, POS[2], 0.0, np.empty((0, 2)))
    assert [(e.dst, type(e.msg)) for e in out] == [(0, StateMsg)]


def test_observe_team_declares_the_dead_at_once_and_admits_them_again_symmetrically():
    robot = _robot(0)
    robot.observe_team(0, [0, 1, 2], POS, np.ones(3, dtype=bool))
    assert robot.dead == set() and dict(robot.stats) == {}  # nothing to do
    robot.observe_team(1, [0, 1, 2], POS, np.array([True, True, False]))
    assert robot.dead == {2} and 2 not in robot.contacts
    assert robot.stats["world_dead"] == 1 and robot.stats["timeouts"] == 0
    robot.observe_team(2, [0, 1, 2], POS, np.ones(3, dtype=bool))
    assert robot.dead == set() and 2 in robot.contacts
    assert robot.stats["revived_peers"] == 1


def test_a_rejoining_robot_and_the_others_agree_on_who_is_a_contact():
    # Five robots in a row, 20 m apart: contacts reach two hops, not three.
    ctx = FilterContext(Grid(Environment(0.0, 0.0, 100.0, 10.0), 1.0), PhdModels())
    ids, pos = np.arange(5), np.array([[5.0 + 20 * i, 5.0] for i in range(5)])
    robots = {rid: Participant(rid, ctx) for rid in ids}
    for robot in robots.values():
        robot.initialise(ids, pos)
    alive = np.array([True, True, True, True, False])
    for rid in range(4):
        robots[rid].observe_team(1, ids, pos, alive)
    robots[4] = Participant(4, ctx)  # a restarted process
    robots[4].rejoin(2, ids, pos)
    for rid in range(4):
        robots[rid].observe_team(2, ids, pos, np.ones(5, dtype=bool))
    assert robots[4].contacts == (2, 3)
    for rid in range(4):
        assert (4 in robots[rid].contacts) == (rid in robots[4].contacts)
        assert robots[rid].dead == set() and robots[rid].stats["revived_peers"] == 1


def test_observe_team_keeps_dead_the_robots_it_is_told_to_and_admits_the_rest():
    robot = _robot(0)
    robot.observe_team(1, [0, 1, 2], POS, np.array([True, False, False]))
    assert robot.dead == {1, 2} and robot.dead_peers == frozenset({1, 2})
    robot.observe_team(2, [0, 1, 2], POS, np.ones(3, dtype=bool), keep_dead=frozenset({2}))
    assert robot.dead == {2} and 2 not in robot.contacts and 1 in robot.contacts
    assert robot.stats["revived_peers"] == 1
    robot.observe_team(3, [0, 1, 2], POS, np.ones(3, dtype=bool))
    assert robot.dead == set() and 2 in robot.contacts
