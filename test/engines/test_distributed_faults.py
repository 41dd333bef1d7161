"""The distributed filter over lossy links, and robots that die and rejoin (the engine)."""

from __future__ import annotations

import numpy as np
import pytest

import phd_swarm.engines.distributed as engine_module
from phd_swarm.core.exchange.faults import LinkFaults
from phd_swarm.core.models import DiskDetection, PhdModels, UniformClutter
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim import presets as sc

pytestmark = pytest.mark.slow



def _traffic(engine: DistributedEngine) -> list:
    return [(dict(t.messages), dict(t.bytes), t.lost, t.dropped, t.delayed)
            for t in engine.traffic]


def _static(robots: int = 10, seed: int = 2):
    return sc.dames_static(robots=robots, targets=20).with_overrides(seed=seed)


def test_links_without_faults_change_nothing():
    scenario = sc.dames_moving(robots=10, targets=10).with_overrides(seed=1)
    plain = DistributedEngine(scenario, "phd")
    off = DistributedEngine(scenario, "phd", faults=LinkFaults(seed=4))
    plain.run(30)
    off.run(30)
    assert np.array_equal(plain.team_weights(), off.team_weights())
    assert np.array_equal(plain.world.robot_positions, off.world.robot_positions)
    assert _traffic(plain) == _traffic(off), "the same messages, step by step"
    assert off.counters() == {}


@pytest.mark.parametrize("faults", [LinkFaults(drop=0.01, seed=1), LinkFaults(drop=0.05, seed=2),
                                    LinkFaults(drop=0.10, seed=3),
                                    LinkFaults(delay=0.05, max_delay_rounds=2, seed=4)],
                         ids=["drop1", "drop5", "drop10", "delay5"])
def test_the_team_keeps_stepping_over_lossy_links(faults):
    engine = DistributedEngine(_static(seed=5), "phd", faults=faults)
    for k in range(40):
        engine.step()
        assert all(r.step == k and r.done for r in engine.robots.values())
    counts = engine.ownership_counts()
    assert counts.min() == 1 and counts.max() == 1
    assert np.all(np.isfinite(engine.team_weights()))
    lossy = sum(t.dropped for t in engine.traffic) + sum(t.delayed for t in engine.traffic)
    assert lossy > 100
    assert engine.counters()["resent"] > 0


@pytest.mark.parametrize("drop", [0.01, 0.05])
def test_lost_messages_are_recovered_without_declaring_live_robots_dead(drop):
    # 60 steps of 10 robots: thousands of messages lost at 5 %. Re-sends answer the
    # keep-alives, nobody is taken for dead, and since every sum is taken in robot-id order
    # the team computes exactly the loss-free team PHD.
    scenario = _static(seed=2)
    engine = DistributedEngine(scenario, "phd", faults=LinkFaults(drop=drop, seed=7))
    engine.run(60)
    assert all(not r.dead for r in engine.robots.values())
    stats = engine.counters()
    assert stats.get("timeouts", 0) == 0 and stats.get("orphan_bins", 0) == 0
    dropped = sum(t.dropped for t in engine.traffic)
    assert dropped > 100 * drop / 0.01
    assert stats["resent"] > dropped / 2
    reference = DistributedEngine(scenario, "phd")
    reference.run(60)
    assert np.array_equal(engine.team_weights(), reference.team_weights())
    assert np.array_equal(engine.world.robot_positions, reference.world.robot_positions)


def test_delays_and_a_shuffled_delivery_give_the_loss_free_result():
    scenario = sc.dames_moving(robots=10, targets=10).with_overrides(seed=3)
    faults = LinkFaults(drop=0.02, delay=0.1, max_delay_rounds=3, seed=1)
    engine = DistributedEngine(scenario, "phd", delivery_seed=5, faults=faults)
    engine.run(30)
    reference = DistributedEngine(scenario, "phd")
    reference.run(30)
    assert engine.counters().get("timeouts", 0) == 0
    assert sum(t.delayed for t in engine.traffic) > 100
    assert np.array_equal(engine.team_weights(), reference.team_weights())


def test_a_lossy_run_is_reproducible_from_its_seeds():
    runs = []
    for _ in range(2):
        engine = DistributedEngine(_static(seed=1), "phd", delivery_seed=3,
                                faults=LinkFaults(drop=0.1, delay=0.05, seed=8))
        engine.run(20)
        runs.append((engine.team_weights(), _traffic(engine), engine.counters()))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert runs[0][1] == runs[1][1] and runs[0][2] == runs[1][2]
    other = DistributedEngine(_static(seed=1), "phd", delivery_seed=3,
                           faults=LinkFaults(drop=0.1, delay=0.05, seed=9))
    other.run(20)
    assert _traffic(other) != runs[0][1]


def test_every_message_delivered_twice_is_applied_once(monkeypatch):
    # Moving targets: phantom mass too. Duplicates are what re-sends produce.
    scenario = sc.dames_moving(robots=10, targets=10).with_overrides(seed=4)
    reference = DistributedEngine(scenario, "phd")
    reference.run(15)
    engine = DistributedEngine(scenario, "phd")
    original = engine_module.DistributedEngine._hand_out

    def twice(self, batch, traffic):
        return original(self, batch + batch, traffic)

    monkeypatch.setattr(engine_module.DistributedEngine, "_hand_out", twice)
    engine.run(15)
    kinds = {k for t in engine.traffic for c in t.messages.values() for k in c}
    assert "PhantomTransfer" in kinds and "EtaTotal" in kinds
    assert engine.counters()["duplicates"] > 0
    assert np.array_equal(engine.team_weights(), reference.team_weights())


def test_a_death_over_lossy_links_costs_the_dead_robot_only():
    engine = DistributedEngine(_static(seed=4), "phd", faults=LinkFaults(drop=0.03, seed=2))
    engine.run(10)
    engine.kill(6)
    engine.run(20)
    live = engine.live_ids()
    assert all(engine.robots[r].dead == {6} for r in live)
    counts = engine.ownership_counts()
    assert counts.min() == 1 and counts.max() == 1


# ----------------------------------------------------------------------------- rejoin
@pytest.mark.parametrize("restart", [True, False], ids=["restarted", "slow"])
def test_a_dead_robot_rejoins_and_gets_its_bins_back(restart):
    engine = DistributedEngine(_static(robots=12, seed=4), "phd")
    victim = 5
    engine.run(10)
    engine.kill(victim)
    engine.run(10)
    assert engine.robots[victim].step == 9
    with pytest.raises(ValueError, match="not dead"):
        engine.revive(3)
    engine.revive(victim, restart=restart)
    assert engine.world.alive[victim]
    engine.step()
    robot = engine.robots[victim]
    assert robot.step == 20 and robot.bins.size > 0
    assert robot.stats["rejoins"] == 1
    engine.run(19)
    live = engine.live_ids()
    assert len(live) == 12 and engine.step_index == 40
    counts = engine.ownership_counts()
    assert counts.min() == 1 and counts.max() == 1
    assert all(not engine.robots[r].dead for r in live), "nobody else declared dead"
    stats = engine.counters()
    assert stats["rejoins"] == 1 and stats["revived_peers"] == 11
    assert stats["world_dead"] == 11 and stats.get("timeouts", 0) == 0
    assert all(victim in engine.robots[c].contacts for c in robot.contacts)


def test_reviving_needs_a_step_without_the_robot():
    engine = DistributedEngine(_static(robots=6, seed=1), "phd")
    engine.run(2)
    engine.kill(2)
    with pytest.raises(ValueError, match="run a step without it"):
        engine.revive(2)
    engine.step()
    engine.revive(2, restart=True)
    engine.run(3)
    assert engine.robots[2].step == 5


@pytest.mark.parametrize("restart", [True, False], ids=["restarted", "slow"])
def test_the_rejoin_hand_over_conserves_mass(restart):
    # No detections, no clutter, static targets: only hand-overs change who holds what.
    # Unequal masses, so that a bin re-initialised to the prior would show.
    blind = PhdModels(detection=DiskDetection(p_d=0.0), clutter=UniformClutter(density=0.0))
    scenario = sc.dames_static(robots=20, targets=10).with_overrides(models=blind, seed=2)
    engine = DistributedEngine(scenario, "uniform")
    rng = np.random.default_rng(0)
    for robot in engine.robots.values():
        robot.weights = rng.random(robot.bins.size)
    engine.run(10)
    victims = (4, 13)
    for v in victims:
        engine.kill(v)
    engine.run(10)
    total = engine.team_weights().sum()
    orphans = engine.counters().get("orphan_bins", 0)
    assert orphans > 0, "the deaths orphaned the victims' bins"
    for v in victims:
        engine.revive(v, restart=restart)
    engine.step()
    assert engine.counters().get("orphan_bins", 0) == orphans, "the rejoin orphaned nothing"
    assert engine.team_weights().sum() == pytest.approx(total, rel=1e-12)
    assert all(engine.robots[v].bins.size > 0 for v in victims)
    engine.run(19)
    assert engine.team_weights().sum() == pytest.approx(total, rel=1e-12)
    counts = engine.ownership_counts()
    assert counts.min() == 1 and counts.max() == 1


def test_robots_taken_for_dead_on_lost_messages_are_admitted_again():
    # At 20 % loss some live robots time each other out. The world says they are alive,
    # so the next step admits them again: nobody stays dead, every bin has one owner.
    engine = DistributedEngine(_static(seed=1), "phd", faults=LinkFaults(drop=0.2, seed=1))
    engine.run(30)
    stats = engine.counters()
    assert stats["timeouts"] > 0 and stats["revived_peers"] > 0
    engine.faults = None
    engine.links = None
    engine.run(2)
    assert all(not r.dead for r in engine.robots.values())
    counts = engine.ownership_counts()
    assert counts.min() == 1 and counts.max() == 1


def test_a_robot_stopped_mid_step_rejoins_as_it_was(monkeypatch):
    # Robot 8 stops in the middle of step 15, waiting for cells (a slow robot, not
    # restarted): its filter is left half-way through the step when it rejoins at step 18.
    engine = DistributedEngine(_static(robots=12, seed=0), "phd")
    engine.run(15)
    original = engine_module.message_type

    def stop_at_first_cell(msg):
        name = original(msg)
        if name == "CellPolygon" and 8 not in engine.killed:
            engine.kill(8)
        return name

    monkeypatch.setattr(engine_module, "message_type", stop_at_first_cell)
    engine.step()
    monkeypatch.setattr(engine_module, "message_type", original)
    assert not engine.robots[8].done, "stopped half-way through the step"
    with pytest.raises(ValueError, match="run a step without it"):
        engine.revive(8)
    engine.run(2)
    engine.revive(8, restart=False)
    engine.run(10)
    counts = engine.ownership_counts()
    assert counts.min() == 1 and counts.max() == 1
    assert engine.robots[8].bins.size > 0 and engine.robots[8].step == 27
    assert all(not engine.robots[r].dead for r in engine.live_ids())
