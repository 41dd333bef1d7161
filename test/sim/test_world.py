"""Tests for the simulated world: reproducibility, robot kinematics, scans."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phd_swarm.core.models import DiskDetection, PhdModels, UniformClutter
from phd_swarm.sim.presets import chen_clustered, dames_moving, dames_static
from phd_swarm.sim.scenario import TargetConfig
from phd_swarm.sim.world import World


def _run(world: World, steps: int):
    """Scans and truth over ``steps`` steps, robots driven towards fixed goals."""
    goals = {r: np.array([10.0 + 3 * r, 90.0 - 2 * r]) for r in world.robot_ids}
    log = []
    for _ in range(steps):
        ids, x = world.truth()
        z = world.scans()
        log.append((ids, x, z, world.robot_positions))
        world.apply_goals(goals)
        world.advance()
    return log


def _same(a, b) -> bool:
    for (ia, xa, za, qa), (ib, xb, zb, qb) in zip(a, b, strict=True):
        if not (np.array_equal(ia, ib) and np.array_equal(xa, xb) and np.array_equal(qa, qb)
                and za.keys() == zb.keys()
                and all(np.array_equal(za[k], zb[k]) for k in za)):
            return False
    return True


@pytest.mark.parametrize("preset", [dames_static, dames_moving, chen_clustered])
def test_same_seed_same_world_different_seed_different_world(preset):
    s = preset(robots=8).with_overrides(seed=11)
    a = _run(World(s), 50)
    b = _run(World(s), 50)
    assert _same(a, b)
    c = _run(World(s.with_overrides(seed=12)), 50)
    assert not _same(a, c)


def test_passing_the_seeded_generator_gives_the_same_world():
    s = dames_moving(robots=5).with_overrides(seed=3)
    assert _same(_run(World(s), 20), _run(World(s, np.random.default_rng(3)), 20))


def test_target_trajectories_do_not_depend_on_the_team():
    s = dames_moving(robots=4).with_overrides(seed=5)
    a = World(s)
    b = World(s.with_overrides(robots=30))
    for _ in range(100):
        a.scans()
        b.scans()
        b.scans()
        a.advance()
        b.advance()
        ia, xa = a.truth()
        ib, xb = b.truth()
        assert np.array_equal(ia, ib) and np.array_equal(xa, xb)


def test_robots_start_inside_the_start_box():
    s = chen_clustered(robots=200)
    w = World(s)
    q = w.robot_positions
    x0, y0, x1, y1 = s.robot_start_box
    assert q.shape == (200, 2)
    assert np.all((q[:, 0] >= x0) & (q[:, 0] <= x1) & (q[:, 1] >= y0) & (q[:, 1] <= y1))
    assert np.array_equal(w.robot_ids, np.arange(200))
    assert w.alive.all() and w.step_index == 0 and w.time == 0.0


def test_apply_goals_respects_max_speed_and_stops_at_the_goal():
    s = dames_static(robots=2)  # 2 m/s, dt 0.5 s: 1 m per step
    w = World(s)
    q0 = w.robot_positions
    far = q0[0] + np.array([30.0, 40.0])  # 50 m away
    near = q0[1] + np.array([0.3, 0.4])  # 0.5 m away
    w.apply_goals({0: far, 1: near})
    q1 = w.robot_positions
    assert np.linalg.norm(q1[0] - q0[0]) == pytest.approx(1.0)
    assert np.allclose((q1[0] - q0[0]), [0.6, 0.8])
    assert np.array_equal(q1[1], near)  # lands exactly on a goal within reach
    for _ in range(60):
        w.apply_goals({0: far})
    assert np.array_equal(w.robot_positions[0], far)
    assert np.array_equal(w.robot_positions[1], near)  # no goal: stays


def test_goals_outside_the_map_are_clipped_into_it():
    w = World(dames_static(robots=1))
    for _ in range(20):
        w.apply_goals({0: np.array([50.0, -30.0])})
    q = w.robot_positions[0]
    assert q[1] == 0.0 and 0.0 <= q[0] <= 100.0


def test_dead_robots_get_no_scan_and_do_not_move():
    w = World(dames_static(robots=3))
    q0 = w.robot_positions
    w.kill(1)
    assert w.alive.tolist() == [True, False, True]
    assert sorted(w.scans()) == [0, 2]
    w.apply_goals({r: np.array([50.0, 50.0]) for r in range(3)})
    assert np.array_equal(w.robot_positions[1], q0[1])
    assert not np.array_equal(w.robot_positions[0], q0[0])


def test_unknown_robot_ids_are_rejected():
    w = World(dames_static(robots=3))
    with pytest.raises(ValueError, match="unknown robot id"):
        w.apply_goals({3: np.zeros(2)})
    with pytest.raises(ValueError, match="unknown robot id"):
        w.kill(-1)


def test_a_robot_on_a_target_with_perfect_sensing_sees_it():
    models = PhdModels(detection=DiskDetection(p_d=1.0, radius=5.0),
                       clutter=UniformClutter(density=0.0))
    s = dames_static(robots=2).with_overrides(models=models)
    w = World(s)
    _, x = w.truth()
    assert len(x) > 0
    for _ in range(200):  # at most 1 m per step on a 100 m map
        w.apply_goals({0: x[0]})
    assert np.array_equal(w.robot_positions[0], x[0])
    z = w.scans()
    near = np.linalg.norm(x - x[0], axis=1) <= 5.0
    assert z[0].shape == (near.sum(), 2)  # every target in the disk, no clutter
    assert np.min(np.linalg.norm(z[0] - x[0], axis=1)) < 2.5  # 5 sd of the 0.5 m noise


def test_scans_follow_the_sensor_model():
    # Clutter only (no targets): Poisson(0.287) per scan inside the 5 m disk (Dames eq. 11).
    s = dames_static(robots=10).with_overrides(
        targets=TargetConfig(kind="static", count=0, draw_box=(-10, -10, 110, 110)))
    w = World(s)
    q = w.robot_positions
    sizes = []
    for _ in range(500):
        z = w.scans()
        for r, zr in z.items():
            assert np.all(np.linalg.norm(zr - q[r], axis=1) <= 5.0)
            sizes.append(len(zr))
    assert np.mean(sizes) == pytest.approx(3.66e-3 * np.pi * 25, abs=0.04)


def test_advance_moves_targets_and_the_clock():
    w = World(chen_clustered(robots=1))
    _, x0 = w.truth()
    w.advance()
    w.advance()
    _, x2 = w.truth()
    assert w.step_index == 2 and w.time == 1.0
    assert not np.array_equal(x0, x2)
    assert not w.done
    short = World(dataclasses.replace(chen_clustered(robots=1), duration=1.0))
    short.advance()
    short.advance()
    assert short.done


def test_default_starts_are_the_uniform_draw_of_the_start_stream_bit_for_bit():
    s = dames_static(robots=9).with_overrides(seed=21)
    assert s.robot_start_grid is None
    rng = np.random.default_rng(np.random.SeedSequence(21).spawn(3)[0])
    box = np.asarray(s.robot_start_box)
    expected = box[:2] + rng.random((9, 2)) * (box[2:] - box[:2])
    assert np.array_equal(World(s).robot_positions, expected)


def test_robots_start_on_grid_nodes_inside_the_box_when_asked():
    from phd_swarm.core.controllers.dtds_walk.grid_graph import GridGraph

    s = dames_static(robots=400).with_overrides(robot_start_grid=2.5, seed=4)
    q = World(s).robot_positions
    x0, y0, x1, y1 = s.robot_start_box  # 40..60 x 0..10: 9 x 5 nodes at 2.5 m
    assert np.all((q[:, 0] >= x0) & (q[:, 0] <= x1) & (q[:, 1] >= y0) & (q[:, 1] <= y1))
    g = GridGraph(s.env.xmin, s.env.ymin, s.env.xmax, s.env.ymax, 2.5)
    assert np.array_equal(g.positions[g.node_of(q)], q)  # exactly on the walk's nodes
    nodes, counts = np.unique(g.node_of(q), return_counts=True)
    assert len(nodes) == 45  # every node of the box is drawn (400 robots, 45 nodes)
    assert counts.max() < 3 * 400 / 45
    # Reproducible from the seed, a different seed draws other nodes; the targets' stream
    # is untouched.
    assert np.array_equal(World(s).robot_positions, q)
    assert not np.array_equal(World(s.with_overrides(seed=5)).robot_positions, q)
    a, b = World(s).truth(), World(s.with_overrides(robot_start_grid=None)).truth()
    assert np.array_equal(a[1], b[1])


def test_a_robot_started_on_the_grid_walks_on_it():
    from phd_swarm.core.controllers.base import Knowledge
    from phd_swarm.core.controllers.dtds_walk.controller import DtdsWalk
    from phd_swarm.core.controllers.dtds_walk.controller import setup as walk_setup
    from phd_swarm.core.system import SystemConfig

    s = dames_static(robots=3).with_overrides(robot_start_grid=1.0,
                                              robot_start_box=(0.0, 0.0, 5.0, 5.0))
    system = SystemConfig(controller="dtds_walk")
    g = walk_setup(s, system)
    w = World(s)
    walks = [DtdsWalk(g) for _ in range(3)]
    rngs = [np.random.default_rng(r) for r in range(3)]
    for k in range(30):
        q = w.robot_positions
        assert np.array_equal(g.positions[g.node_of(q)], q)
        w.apply_goals({r: walks[r].decide(Knowledge(r, k, q[r], np.empty((0, 2))),
                                          rngs[r]).goal for r in range(3)})
        w.advance()


def test_a_layout_seed_gives_the_same_targets_whatever_the_run_seed():
    from phd_swarm.sim.presets import shirsat_berman

    base = shirsat_berman(side=15.0, robots=20, targets=10)
    fixed = [World(base.with_overrides(seed=s)).truth()[1] for s in (0, 1)]
    np.testing.assert_array_equal(fixed[0], fixed[1])
    free = base.with_overrides(targets=dataclasses.replace(base.targets, layout_seed=None))
    drawn = [World(free.with_overrides(seed=s)).truth()[1] for s in (0, 1)]
    assert not np.array_equal(drawn[0], drawn[1])
    with pytest.raises(ValueError, match="targets.layout_seed"):
        dataclasses.replace(base.targets, layout_seed=-1)
