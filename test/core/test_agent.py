"""The one agent step: the parts made from the registry, the robot's own generator."""

from __future__ import annotations

import numpy as np

from phd_swarm.core import registry
from phd_swarm.core.agent import Agent, Team, robot_generator
from phd_swarm.core.controllers.base import Controller, Decision
from phd_swarm.core.estimators.base import Estimator
from phd_swarm.core.exchange.none import NoExchange
from phd_swarm.core.exchange.voronoi_phd.participant import Participant
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim import presets as sc
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


class _CountingEstimator(Estimator):
    """Test estimator: counts the scans it is given, remembers the last."""

    def __init__(self) -> None:
        self.calls: list[str] = []
        self.last = None

    def predict(self) -> None:
        self.calls.append("predict")

    def update(self, scan) -> None:
        self.calls.append("update")
        self.last = scan

    def estimates(self) -> np.ndarray:
        return np.empty((0, 2))

    def expected_count(self) -> float:
        return float(len(self.calls))


def test_an_estimator_of_its_own_is_driven_by_the_agent_before_the_exchange():
    names = {"estimator": "test_counting", "exchange": "test_silent",
             "controller": "test_sees_estimator"}
    seen = []

    class _Sees(Controller):
        def decide(self, knowledge, rng):
            seen.append((knowledge.step, knowledge.estimator.last.step,
                         len(knowledge.estimator.calls)))
            return Decision(goal=knowledge.position)

    registry.register("estimator", names["estimator"], lambda s, r: _CountingEstimator(),
                      description="test", provides=("grid_density",))
    registry.register("exchange", names["exchange"], lambda s, r: NoExchange(),
                      description="test")
    registry.register("controller", names["controller"], lambda s, r: _Sees(),
                      description="test")
    try:
        team = Team.build(_scenario().with_system(**names))
        agent = team.agent(0)
        for k in range(3):
            assert agent.start_step(k, np.array([1.0, 2.0]), np.array([[1.0, 1.0]])) == []
            assert agent.done
            agent.finish_step()
        assert seen == [(0, 0, 2), (1, 1, 4), (2, 2, 6)], "predict + update, then decide"
        assert agent.estimator.last.robot_id == 0
        np.testing.assert_array_equal(agent.estimator.last.sensor, [1.0, 2.0])
        # Dames' grid PHD is run by its exchange: the agent does not touch it.
        grid = Team.build(_scenario()).agent(0)
        assert not grid._runs_estimator
    finally:
        for role, name in names.items():
            registry._PARTS[role].pop(name)
