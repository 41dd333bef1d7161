"""The one agent step: the parts made from the registry, the robot's own generator."""

from __future__ import annotations

import numpy as np

from phd_swarm.core import registry
from phd_swarm.core.agent import Agent, Team, robot_generator
from phd_swarm.core.controllers.base import Controller, Decision
from phd_swarm.core.exchange.voronoi_phd.participant import Participant
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim import scenario as sc
from phd_swarm.sim.world import World


class _Jitter(Controller):
    """Test controller: a random step from the robot's generator; remembers what it saw."""

    def __init__(self) -> None:
        self.seen: list[int] = []

    def decide(self, knowledge, rng):
        self.seen.append(knowledge.step)
        return Decision(goal=knowledge.position + rng.normal(0.0, 1.0, 2))


def _scenario(seed: int = 2):
    return sc.dames_static(robots=4, targets=8).with_overrides(duration=4.0, seed=seed)


def test_robot_generators_are_their_own_streams():
    a = robot_generator(5, 0).random(4)
    assert np.array_equal(a, robot_generator(5, 0).random(4))
    assert not np.array_equal(a, robot_generator(5, 1).random(4))
    assert not np.array_equal(a, robot_generator(6, 0).random(4))
    # Not one of the world's streams (children 0-2 of the same seed).
    world = [np.random.default_rng(c).random(4)
             for c in np.random.SeedSequence(5).spawn(3)]
    assert all(not np.array_equal(a, w) for w in world)


def test_an_agent_is_made_of_the_registered_parts():
    team = Team.build(_scenario().with_system(controller="chen_o"), timeout_ticks=4)
    agent = team.agent(2)
    assert isinstance(agent, Agent) and isinstance(agent.exchange, Participant)
    assert agent.exchange.ctx.timeout_ticks == 4 and agent.exchange.ctx.cumulative
    assert agent.exchange is not team.agent(2).exchange, "one instance per robot"


def test_the_engine_steps_every_robot_through_its_agent_with_its_generator():
    registry.register("controller", "test_jitter", lambda setup, rid: _Jitter(),
                      description="test")
    try:
        runs = []
        for _ in range(2):
            engine = DistributedEngine(_scenario(), controller="test_jitter")
            engine.run()
            runs.append(engine.world.robot_positions.copy())
            assert all(a.controller.seen == list(range(8)) for a in engine.agents.values())
        assert np.array_equal(runs[0], runs[1]), "reproducible from the seed"
        start = World(_scenario()).robot_positions
        steps = runs[0] - start
        assert np.all(np.abs(steps) > 0), "every robot moved"
        assert len({tuple(np.round(s, 9)) for s in steps}) == 4, "each its own stream"
    finally:
        registry._PARTS["controller"].pop("test_jitter")
