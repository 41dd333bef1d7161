"""The ROS face of reward sets: the ``meet_merge`` wire (inbox kind ``rewards``), ``reward_set``.

A robot's reward set travels to each robot it meets as a ``phd_swarm_msgs/RewardSet`` of
kind ``rewards`` in its inbox message (:mod:`phd_swarm.core.exchange.meet_merge`,
:data:`WIRE`); the same type carries the robot's own set of the step on ``reward_set``
(:data:`REWARD_SET`, declared by the estimators that keep one).
"""

from __future__ import annotations

import numpy as np

from phd_swarm.core.exchange.meet_merge import RewardMsg
from phd_swarm.nodes.convert import InvalidMessage, header, points, u32, xy
from phd_swarm.nodes.face import Face, Step
from phd_swarm.nodes.wire import Wire
from phd_swarm_msgs.msg import RewardSet

#: Most targets a reward set may hold (bigger sets are refused).
MAX_REWARDS = 100_000


def reward_set(source_id: int, step: int, positions: np.ndarray, dt: float, frame_id: str,
               met: np.ndarray = ()) -> RewardSet:
    """A ``RewardSet`` of ``positions`` (K, 2) [m]; ``met``: the robots merged at the step."""
    return RewardSet(header=header(step, dt, frame_id), source_id=int(source_id),
                     step=int(step), met_ids=u32(np.asarray(met, dtype=np.int64)),
                     positions=points(positions))


def reward_points(msg: RewardSet, max_rewards: int = MAX_REWARDS) -> np.ndarray:
    """The checked positions (K, 2) of a ``RewardSet``; InvalidMessage naming the problem."""
    if len(msg.positions) > max_rewards:
        raise InvalidMessage(f"positions: {len(msg.positions)} targets, more than "
                             f"{max_rewards}")
    return xy(msg.positions, "positions")


def _to_ros(msg: RewardMsg, dt: float, frame_id: str) -> RewardSet:
    return reward_set(msg.src, msg.step, msg.points, dt, frame_id)


def _from_ros(msg: RewardSet, grid, max_measurements: int) -> RewardMsg:
    return RewardMsg(int(msg.source_id), int(msg.step), reward_points(msg))


WIRE = Wire(types={"rewards": RewardSet}, kind=lambda msg: "rewards", to_ros=_to_ros,
            from_ros=_from_ros, sender=lambda msg: msg.src, addressee=lambda msg: None)


def _own_reward_set(step: Step, memo: dict) -> RewardSet:
    return reward_set(step.robot_id, step.k, step.agent.estimator.reward_set(), step.dt,
                      step.frame_id, getattr(step.agent.exchange, "met", ()))


def _read_reward_set(msg: RewardSet) -> tuple[np.ndarray, np.ndarray]:
    return reward_points(msg), np.array(msg.met_ids, dtype=np.int64)


#: Output ``reward_set``: the robot's own reward set M_k and the robots met at the step;
#: read back as (positions (K, 2), robots met).
REWARD_SET = Face(RewardSet, _own_reward_set, read=_read_reward_set)
