"""Shirsat & Berman's random-walk controller ``dtds_walk`` (eq. 4)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from phd_swarm.core import registry
from phd_swarm.core.controllers.base import Controller, Knowledge
from phd_swarm.core.controllers.dtds_walk.controller import DtdsWalk, setup
from phd_swarm.core.controllers.dtds_walk.grid_graph import GridGraph
from phd_swarm.core.geometry.centroids import next_position
from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.system import SystemConfig


def scenario_stub(speed: float = 1.0, dt: float = 1.0, side: float = 5.0):
    return SimpleNamespace(env=Environment(0.0, 0.0, side, side), dt=dt,
                           robot_max_speed=speed)


def graph(speed: float = 1.0, dt: float = 1.0, **options) -> GridGraph:
    return setup(scenario_stub(speed, dt), SimpleNamespace(options=tuple(options.items())))


def knowledge(position) -> Knowledge:
    return Knowledge(0, 0, np.asarray(position, dtype=float), np.empty((0, 2)))


def walk(controller: DtdsWalk, start, steps: int, rng: np.random.Generator,
         d_step: float) -> np.ndarray:
    """Positions q^0..q^steps under the world's rule (Chen eq. 3, clipped into the map)."""
    q = np.asarray(start, dtype=float)
    out = [q]
    lo, hi = controller.graph.positions.min(axis=0), controller.graph.positions.max(axis=0)
    for _ in range(steps):
        q = np.clip(next_position(q, controller.decide(knowledge(q), rng).goal, d_step),
                    lo, hi)
        out.append(q)
    return np.array(out)


def test_registered_with_its_options_and_capability():
    part = registry.lookup("controller", "dtds_walk")
    assert [o.name for o in part.options] == ["grid_spacing", "grid_neighbours"]
    assert all(o.description.startswith("dtds_walk:") for o in part.options)
    assert part.provides == frozenset({"grid_walk"})
    system = SystemConfig(controller="dtds_walk")
    assert dict(system.options)["grid_spacing"] == 1.0
    assert dict(system.options)["grid_neighbours"] == 4
    assert isinstance(part.make(graph(), 3), Controller)


def test_setup_builds_one_graph_over_the_map_from_the_options():
    g = graph(speed=1.5, grid_spacing=0.5, grid_neighbours=8)
    assert isinstance(g, GridGraph)
    assert g.bounds == (0.0, 0.0, 5.0, 5.0) and g.size == 121 and g.neighbours == 8
    part = registry.lookup("controller", "dtds_walk")
    a, b = part.make(g, 0), part.make(g, 1)
    assert a.graph is b.graph  # shared by the team


@pytest.mark.parametrize("options, speed, dt, numbers", [
    ({}, 0.5, 1.0, ["0.5 m", "1 m"]),  # 0.5 m per step, 1 m spacing
    ({"grid_spacing": 2.0}, 1.0, 1.5, ["1.5 m", "2 m"]),
    ({"grid_neighbours": 8}, 1.2, 1.0, ["1.2 m", "1.41421 m"]),  # the diagonal
])
def test_a_robot_that_cannot_make_a_move_in_one_step_is_refused(options, speed, dt, numbers):
    with pytest.raises(ValueError, match="dtds_walk") as err:
        graph(speed, dt, **options)
    for n in numbers:
        assert n in str(err.value)
    assert "robot_max_speed" in str(err.value)


def test_just_fast_enough_is_accepted():
    graph(speed=1.0, dt=1.0)  # exactly one spacing
    graph(speed=np.sqrt(2.0), dt=1.0, grid_neighbours=8)
    graph(speed=10.0, dt=0.1, grid_spacing=1.0)


@pytest.mark.parametrize("options, match", [
    ({"grid_neighbours": 6}, "grid_neighbours: expected 4 or 8"),
    ({"grid_spacing": 0.0}, "grid_spacing"),
    ({"grid_spacing": "1"}, "grid_spacing"),
])
def test_bad_options_are_refused(options, match):
    with pytest.raises(ValueError, match=match):
        graph(speed=100.0, **options)


@pytest.mark.parametrize("neighbours", [4, 8])
def test_goals_are_the_current_node_or_a_neighbour(neighbours):
    g = graph(speed=2.0, grid_neighbours=neighbours)
    c = DtdsWalk(g)
    path = walk(c, g.positions[7], 400, np.random.default_rng(3), d_step=2.0)
    nodes = g.node_of(path)
    assert np.array_equal(g.positions[nodes], path)  # the robot is always on a node
    moves = {(i, j) for i, j in zip(nodes[:-1], nodes[1:], strict=True)}
    edges = {tuple(e) for e in g.edges}
    assert moves <= edges
    stays = np.mean(nodes[:-1] == nodes[1:])
    assert 0.0 < stays < 0.5  # self-loops happen, but are not the rule
    assert len(set(nodes)) > g.size // 2  # it explores


def test_decisions_are_reproducible_from_the_seed():
    g = graph()
    a = walk(DtdsWalk(g), g.positions[14], 200, np.random.default_rng(11), 1.0)
    b = walk(DtdsWalk(g), g.positions[14], 200, np.random.default_rng(11), 1.0)
    c = walk(DtdsWalk(g), g.positions[14], 200, np.random.default_rng(12), 1.0)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_a_robot_off_the_grid_first_heads_for_its_nearest_node_without_a_draw():
    g = graph()
    c = DtdsWalk(g)
    rng = np.random.default_rng(0)
    before = rng.bit_generator.state
    d = c.decide(knowledge([2.3, 3.6]), rng)
    assert np.array_equal(d.goal, [2.0, 4.0]) and d.power_weight == 0.0
    assert rng.bit_generator.state == before
    d = c.decide(knowledge([2.0, 4.0]), rng)  # on the node: one draw
    assert rng.bit_generator.state != before
    node = int(g.node_of([2.0, 4.0]))
    assert int(g.node_of(d.goal)) in set(g.neighbours_of(node)) | {node}


def test_planned_path_is_the_goal():
    g = graph()
    c = DtdsWalk(g)
    assert c.planned_path().shape == (0, 2)
    d = c.decide(knowledge([1.0, 1.0]), np.random.default_rng(1))
    assert np.array_equal(c.planned_path(), d.goal.reshape(1, 2))
    c.planned_path()[0, 0] = 99.0  # a copy
    assert np.array_equal(c.planned_path(), d.goal.reshape(1, 2))


def test_the_walk_uses_eq4_probabilities():
    g = graph()
    c = DtdsWalk(g)
    rng = np.random.default_rng(4)
    corner = g.positions[0]
    goals = np.array([c.decide(knowledge(corner), rng).goal for _ in range(6000)])
    nodes = g.node_of(goals)
    counts = np.bincount(nodes, minlength=g.size)[[0, 1, 6]]  # itself, right, up
    assert counts.sum() == 6000
    assert np.all(np.abs(counts - 2000) < 5 * np.sqrt(6000 * (1 / 3) * (2 / 3)))
