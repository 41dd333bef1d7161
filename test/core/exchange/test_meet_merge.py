"""Meet and merge (Shirsat & Berman eq. 6): who hears whom, what is sent, what is merged."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.exchange.meet_merge import MeetMerge, RewardMsg
from phd_swarm.core.exchange.radio import RangeRadio, SameNodeRadio


class FakeEstimator:
    """A reward set, and the merges asked of it (sets by robot id)."""

    def __init__(self, robot_id: int, points) -> None:
        self.robot_id = robot_id
        self.points = np.asarray(points, dtype=float).reshape(-1, 2)
        self.merges: list[dict[int, np.ndarray]] = []

    def reward_set(self) -> np.ndarray:
        return self.points.copy()

    def merge_rewards(self, others) -> None:
        self.merges.append(dict(others))
        sets = {self.robot_id: self.points, **others}
        self.points = np.concatenate([sets[i] for i in sorted(sets)])


IDS = np.arange(4)
POSITIONS = np.array([[1.0, 1.0], [1.0, 1.0], [2.0, 1.0], [1.0, 1.0]])


def _robot(rid: int, radio=None) -> tuple[MeetMerge, FakeEstimator]:
    ex = MeetMerge(rid, radio or SameNodeRadio(), timeout_ticks=3)
    est = FakeEstimator(rid, [[10.0 * rid, 0.0]])
    ex.bind_estimator(est)
    return ex, est


def _start(ex: MeetMerge, step: int = 0, alive=(True, True, True, True)) -> list:
    ex.observe_team(step, IDS, POSITIONS, np.array(alive))
    return ex.start_step(step, POSITIONS[ex.robot_id], 0.0, np.empty((0, 2)))


def test_radios_join_the_live_robots_on_a_node_or_in_range():
    alive = np.array([True, True, True, False])
    assert SameNodeRadio().contacts(0, IDS, POSITIONS, alive).tolist() == [1]
    assert RangeRadio(1.0).contacts(0, IDS, POSITIONS, alive).tolist() == [1, 2]
    assert RangeRadio(0.99).contacts(2, IDS, POSITIONS, alive).tolist() == []
    with pytest.raises(ValueError, match="not in the team"):
        SameNodeRadio().contacts(9, IDS, POSITIONS, alive)
    with pytest.raises(ValueError, match="radio range"):
        RangeRadio(float("nan"))


def test_robots_on_one_node_send_one_set_each_and_merge_all_in_id_order():
    robots = [_robot(r) for r in range(4)]
    sent = {r: _start(ex) for r, (ex, _) in enumerate(robots)}
    assert [(e.src, e.dst) for e in sent[0]] == [(0, 1), (0, 3)]
    assert sent[2] == [] and robots[2][0].done      # alone on its node: done at once
    assert not robots[0][0].done
    # Delivered in different orders to robots 1 and 3; robot 0 gets them too.
    for dst, order in ((0, (3, 1)), (1, (3, 0)), (3, (0, 1))):
        ex, _ = robots[dst]
        for src in order:
            (env,) = [e for e in sent[src] if e.dst == dst]
            assert ex.receive(env.msg)
            ex.advance()
        assert ex.done and ex.met.tolist() == sorted(set(order))
    sets = [robots[r][1].points for r in (0, 1, 3)]
    assert all(np.array_equal(s, sets[0]) for s in sets), "everyone at the meeting agrees"
    np.testing.assert_array_equal(sets[0], [[0.0, 0.0], [10.0, 0.0], [30.0, 0.0]])
    assert robots[0][0].stats == {"meetings": 1, "sent": 2, "timeouts": 0}


def test_a_set_of_a_later_step_waits_and_a_repeat_is_not_news():
    (a, est_a), (b, _) = _robot(0), _robot(1)
    early = _start(b, step=1)
    _start(a, step=0, alive=(True, False, True, False))  # nobody else on its node
    assert a.done
    assert a.receive(early[0].msg) and not a.receive(early[0].msg)
    out = _start(a, step=1, alive=(True, True, True, False))
    assert a.done and len(out) == 1      # robot 1's set of step 1 was already in
    assert list(est_a.merges[-1]) == [1]
    assert not a.receive(RewardMsg(1, 0, np.zeros((1, 2)))), "a set of a past step"


def test_silent_contacts_are_given_up_after_timeout_ticks():
    ex, est = _robot(0)
    _start(ex)
    assert [ex.tick() for _ in range(2)] == [[], []] and not ex.done
    ex.tick()
    assert ex.done and ex.stats["timeouts"] == 2 and est.merges == []


def test_an_estimator_without_reward_sets_is_refused():
    with pytest.raises(ValueError, match="reward sets"):
        MeetMerge(0, SameNodeRadio()).bind_estimator(object())


class LabelledEstimator(FakeEstimator):
    """A reward set by label: its members' labels travel with it and reach the merge."""

    labelled = True

    def __init__(self, robot_id: int, points, labels) -> None:
        super().__init__(robot_id, points)
        self.labels = np.asarray(labels, dtype=np.int64)
        self.label_merges: list[dict[int, np.ndarray]] = []

    def reward_labels(self) -> np.ndarray:
        return self.labels.copy()

    def merge_rewards(self, others, labels=None) -> None:
        assert labels is not None and labels.keys() == others.keys()
        self.label_merges.append(dict(labels))
        super().merge_rewards(others)


def test_under_the_union_by_label_the_sets_travel_with_their_labels():
    robots = {}
    for rid in (0, 1):
        ex = MeetMerge(rid, SameNodeRadio(), timeout_ticks=3)
        est = LabelledEstimator(rid, [[rid, 0.0], [rid, 1.0]], [rid + 1, rid + 10])
        ex.bind_estimator(est)
        robots[rid] = ex, est
    assert robots[0][0].labelled
    sent = {rid: _start(ex, alive=(True, True, False, False)) for rid, (ex, _) in robots.items()}
    (msg,) = [e.msg for e in sent[0]]
    np.testing.assert_array_equal(msg.labels, [1, 10])
    # The labels' 4 bytes each and their length are counted on the wire.
    assert msg.wire_size() == RewardMsg(0, 0, msg.points).wire_size() + 4 + 2 * 4
    ex, est = robots[1]
    ex.receive(msg)
    ex.advance()
    assert ex.done
    np.testing.assert_array_equal(est.label_merges[0][0], [1, 10])


def test_under_the_union_by_position_no_labels_travel():
    ex, _ = _robot(0)
    assert not ex.labelled
    (env,) = [e for e in _start(ex) if e.dst == 1]
    assert env.msg.labels.shape == (0,)
