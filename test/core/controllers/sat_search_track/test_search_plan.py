"""Search planning, control and cooperation of Papaioannou et al. (Sec. V-B, Alg. 1, VI-B)."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from phd_swarm.core.controllers.sat_search_track.agent_moves import (
    action_offsets,
    admissible_positions,
)
from phd_swarm.core.controllers.sat_search_track.search_plan import (
    TIE_TOLERANCE,
    SearchPlan,
    greedy_path,
    joint_paths,
    random_search_action,
    search_action,
)
from phd_swarm.core.estimators.papaioannou.search_map import (
    SearchGrid,
    initial_values,
    predict,
    searched_fraction,
    unvisited,
    update,
)


def line(n: int) -> np.ndarray:
    """Nodes 0 .. n-1 at x = 0 .. n-1 [m], y = 0."""
    return np.column_stack([np.arange(n, dtype=float), np.zeros(n)])


def reference_joint_paths(points, ids, starts, targets, first="lowest"):
    """Alg. 1 written out with Python loops and math.hypot, for comparison."""
    order = sorted(range(len(ids)), key=lambda i: ids[i])
    remaining = sorted(int(t) for t in targets)
    last = {i: tuple(starts[i]) for i in order}
    paths = {ids[i]: [] for i in order}
    turn = 0 if first == "lowest" else 1 % len(ids)
    while remaining:
        i = order[turn]
        d = [math.hypot(points[t][0] - last[i][0], points[t][1] - last[i][1])
             for t in remaining]
        best = min(d)
        k = next(j for j, dj in enumerate(d) if dj <= best + TIE_TOLERANCE)
        node = remaining.pop(k)
        paths[ids[i]].append(node)
        last[i] = tuple(points[node])
        turn = (turn + 1) % len(ids)
    return paths


# --- greedy_path (the heuristic for P1) -----------------------------------------------------

def test_greedy_path_on_a_line_by_hand():
    # From x = 2.2: node 2 (0.2 m); then 1 and 3 tie at 1 m -> 1 (lowest index); then 0
    # (1 m, against 3 at 2 m); then 3, 4, 5.
    assert greedy_path(line(6), (2.2, 0.0), np.arange(6)).tolist() == [2, 1, 0, 3, 4, 5]


def test_greedy_path_visits_only_the_targets_in_any_given_order():
    # From 2.2: 3 (0.8 m); from 3: 5 (2 m) before 0 (3 m).
    assert greedy_path(line(6), (2.2, 0.0), [5, 0, 3]).tolist() == [3, 5, 0]
    assert greedy_path(line(6), (2.2, 0.0), [3, 0, 5]).tolist() == [3, 5, 0]
    out = greedy_path(line(6), (2.2, 0.0), np.array([], dtype=int))
    assert out.shape == (0,) and out.dtype == np.int64


def test_greedy_path_tie_within_rounding_goes_to_the_lowest_index():
    # Start at 0.1 + 0.2 = 0.30000000000000004: node 0 (x = -1.7) is 2.0 m away and
    # node 1 (x = 2.3) 1.9999999999999998 m, both 2 m in exact arithmetic.
    points = np.array([[-1.7, 0.0], [2.3, 0.0]])
    s = 0.1 + 0.2
    assert abs(points[1, 0] - s) < abs(s - points[0, 0])
    assert greedy_path(points, (s, 0.0), [0, 1]).tolist() == [0, 1]


def test_greedy_path_in_2d_by_hand():
    # A 3 x 3 grid of 1 m, nodes 0..8 row by row; from (0.9, 0.1) the nearest is node 1
    # at (1, 0); then 0, 2, 4 tie at 1 m -> 0; then 3 (1 m); 4 and 6 tie -> 4; 5 and 7
    # tie -> 5; 2 and 8 tie -> 2; then 8 (2 m, against 7 at sqrt 5), 7, 6.
    xs, ys = np.meshgrid(np.arange(3.0), np.arange(3.0))
    points = np.column_stack([xs.ravel(), ys.ravel()])
    assert greedy_path(points, (0.9, 0.1), np.arange(9)).tolist() == [1, 0, 3, 4, 5, 2, 8,
                                                                       7, 6]


def test_greedy_path_matches_the_reference_on_random_cases():
    rng = np.random.default_rng(7)
    for _ in range(20):
        points = rng.uniform(0.0, 100.0, size=(60, 2))
        targets = rng.choice(60, size=35, replace=False)
        start = rng.uniform(0.0, 100.0, size=2)
        ref = reference_joint_paths(points.tolist(), [0], [start.tolist()], targets)[0]
        assert greedy_path(points, start, targets).tolist() == ref


# --- joint_paths (Alg. 1) -------------------------------------------------------------------

def test_two_agents_at_both_ends_of_a_line_split_it_in_halves():
    paths = joint_paths(line(10), [1, 2], np.array([[-1.0, 0.0], [10.0, 0.0]]),
                        np.arange(10))
    assert paths[1].tolist() == [0, 1, 2, 3, 4]
    assert paths[2].tolist() == [9, 8, 7, 6, 5]


def test_alg1_order_lowest_id_first_versus_the_literal_second_agent_first():
    # Nodes at x = 0..3; agent 1 at x = 0, agent 2 at x = 0.4.
    starts = np.array([[0.0, 0.0], [0.4, 0.0]])
    lowest = joint_paths(line(4), [1, 2], starts, np.arange(4))
    # 1 takes 0; 2 (at 0.4) takes 1; 1 (at 0) takes 2; 2 (at 1) takes 3.
    assert {k: v.tolist() for k, v in lowest.items()} == {1: [0, 2], 2: [1, 3]}
    literal = joint_paths(line(4), [1, 2], starts, np.arange(4), first="literal")
    # 2 takes 0; 1 (at 0) takes 1; 2 (at 0) takes 2; 1 (at 1) takes 3.
    assert {k: v.tolist() for k, v in literal.items()} == {1: [1, 3], 2: [0, 2]}


def test_alg1_literal_order_with_three_agents_starts_at_the_second_lowest_id():
    points = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    starts = np.array([[1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    lowest = joint_paths(points, [5, 7, 9], starts, [0, 1, 2])
    assert {k: v.tolist() for k, v in lowest.items()} == {5: [0], 7: [1], 9: [2]}
    # 7 first takes 0 (2 m); 9 takes 1 (7 m); 5 takes 2.
    literal = joint_paths(points, [5, 7, 9], starts, [0, 1, 2], first="literal")
    assert {k: v.tolist() for k, v in literal.items()} == {5: [2], 7: [0], 9: [1]}
    # One agent: the literal order is the only one.
    one = joint_paths(points, [4], starts[:1], [0, 1, 2], first="literal")
    assert one[4].tolist() == [0, 1, 2]


def test_alg1_with_more_agents_than_nodes_leaves_some_paths_empty():
    paths = joint_paths(line(2), [3, 1, 2], np.array([[5.0, 0], [0.0, 0], [1.0, 0]]),
                        [0, 1])
    assert {k: v.tolist() for k, v in paths.items()} == {1: [0], 2: [1], 3: []}
    empty = joint_paths(line(2), [1, 2], np.zeros((2, 2)), [])
    assert empty[1].size == 0 and empty[2].size == 0


def test_two_agents_computing_alg1_independently_get_the_same_plans():
    rng = np.random.default_rng(11)
    g = SearchGrid(0.0, 0.0, 100.0, 100.0, node_size=5.0, side=10.0)
    values = rng.uniform(0.0, 1.0, g.size)
    targets = unvisited(values, 0.5)
    ids = [4, 2, 9]
    positions = rng.uniform(0.0, 100.0, size=(3, 2))
    # Agent 4 lists itself first; agent 9 lists the team in another order and the
    # targets shuffled.
    mine = joint_paths(g.positions, ids, positions, targets)
    perm = [2, 0, 1]
    theirs = joint_paths(g.positions, [ids[i] for i in perm], positions[perm],
                         rng.permutation(targets))
    assert mine.keys() == theirs.keys()
    for k in mine:
        assert np.array_equal(mine[k], theirs[k])
    # The paths partition the targets, and match the loop reference.
    together = np.concatenate(list(mine.values()))
    assert np.array_equal(np.sort(together), targets)
    ref = reference_joint_paths(g.positions.tolist(), ids, positions.tolist(), targets)
    assert {k: v.tolist() for k, v in mine.items()} == ref
    ref_lit = reference_joint_paths(g.positions.tolist(), ids, positions.tolist(), targets,
                                    "literal")
    lit = joint_paths(g.positions, ids, positions, targets, first="literal")
    assert {k: v.tolist() for k, v in lit.items()} == ref_lit


def test_a_single_agent_alg1_is_the_greedy_path():
    rng = np.random.default_rng(5)
    points = rng.uniform(0.0, 50.0, size=(40, 2))
    start = np.array([25.0, 25.0])
    assert np.array_equal(joint_paths(points, [3], start[None], np.arange(40))[3],
                          greedy_path(points, start, np.arange(40)))


def test_alg1_on_400_nodes_and_5_agents_is_fast():
    g = SearchGrid(0.0, 0.0, 100.0, 100.0, node_size=5.0, side=10.0)
    positions = np.random.default_rng(2).uniform(0.0, 100.0, size=(5, 2))
    t0 = time.perf_counter()
    paths = joint_paths(g.positions, [0, 1, 2, 3, 4], positions, np.arange(g.size))
    assert time.perf_counter() - t0 < 0.5
    assert sum(p.size for p in paths.values()) == 400


# --- search_action (search control) ---------------------------------------------------------

def test_search_action_moves_closest_to_the_next_node():
    offsets = action_offsets(2.0, 2, 8)
    positions, ok = admissible_positions(np.array([50.0, 50.0]), offsets,
                                         (0.0, 0.0, 100.0, 100.0))
    # Ring 2 (indices 9..16), direction 0: (54, 50) is nearest (60, 50).
    assert search_action(positions, ok, (60.0, 50.0)) == 9
    # Straight up: ring 2, direction 2 (pi / 2).
    assert search_action(positions, ok, (50.0, 80.0)) == 11
    # Without action 9 the two 45-degree moves of ring 2 tie; the lowest index wins.
    ok2 = ok.copy()
    ok2[9] = False
    assert search_action(positions, ok2, (60.0, 50.0)) == 10
    # A node on the agent: staying.
    assert search_action(positions, ok, (50.0, 50.0)) == 0


def test_search_action_ties_go_to_the_lowest_admissible_index():
    positions = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 3.0]])
    assert search_action(positions, np.array([True, True, True]), (0.0, -5.0)) == 0
    assert search_action(positions, np.array([False, True, True]), (0.0, -5.0)) == 1
    # Only admissible actions count, however close the others are.
    assert search_action(positions, np.array([False, False, True]), (0.0, -5.0)) == 2


def test_search_action_near_a_region_edge_uses_only_admissible_moves():
    offsets = action_offsets(2.0, 2, 8)
    positions, ok = admissible_positions(np.array([98.0, 50.0]), offsets,
                                         (0.0, 0.0, 100.0, 100.0))
    # (102, 50), action 9, would be nearest (120, 50) but is outside; (100, 50) is on the
    # closed edge.
    assert not ok[9] and ok[1]
    assert search_action(positions, ok, (120.0, 50.0)) == 1
    # From (99, 50) no move gets closer than staying.
    positions, ok = admissible_positions(np.array([99.0, 50.0]), offsets,
                                         (0.0, 0.0, 100.0, 100.0))
    assert search_action(positions, ok, (120.0, 50.0)) == 0


# --- SearchPlan -----------------------------------------------------------------------------

def test_search_plan_drops_visited_nodes_wherever_they_are():
    plan = SearchPlan([3, 1, 2, 0])
    assert len(plan) == 4 and plan.next_node() == 3 and not plan.done
    visited = np.zeros(6, dtype=bool)
    visited[[1, 5]] = True
    assert plan.advance(visited) == 1
    assert plan.nodes.tolist() == [3, 2, 0]
    values = np.array([0.2, 0.5, 0.1, 1.0, 0.999, 0.0])  # only node 3 has value 1
    assert plan.advance(values) == 1
    assert plan.nodes.tolist() == [2, 0] and plan.next_node() == 2
    assert plan.advance(np.ones(6)) == 2
    assert plan.done
    with pytest.raises(ValueError, match="done"):
        plan.next_node()


def test_a_plan_followed_with_search_control_visits_every_node():
    """Plan, control and map together: one agent sweeps a 40 x 40 m area."""
    g = SearchGrid(0.0, 0.0, 40.0, 40.0, node_size=5.0, side=10.0)
    offsets = action_offsets(2.0, 2, 8)
    s = np.array([1.0, 1.0])
    values = update(initial_values(g), g, s)
    plan = SearchPlan(greedy_path(g.positions, s, unvisited(values, 0.5)))
    seen = values >= 1.0
    for _ in range(400):
        plan.advance(values)
        if plan.done:
            break
        positions, ok = admissible_positions(s, offsets, g.bounds)
        u = search_action(positions, ok, g.positions[plan.next_node()])
        previous, s = s, positions[u]
        values = update(predict(values, g, previous), g, s)
        seen |= g.inside(s)
    assert plan.done
    assert seen.all()
    assert searched_fraction(values) > 0.8


# --- random_search_action (the baseline of Fig. 1) ------------------------------------------

@pytest.fixture
def baseline():
    """Agent at (10, 10) in a 20 x 20 m map of 1 m nodes, sensing side 2 m.

    Everything is searched (value 1) except node (14.5, 10.5), seen only from (14, 10)
    (action 9: ring 2, direction 0), and node (5.5, 9.5), seen only from (6, 10) (action
    13: ring 2, direction 4).
    """
    g = SearchGrid(0.0, 0.0, 20.0, 20.0, node_size=1.0, side=2.0)
    values = np.ones(g.size)
    values[g.node_of(np.array([[14.5, 10.5], [5.5, 9.5]]))] = 0.3
    positions, ok = admissible_positions(np.array([10.0, 10.0]), action_offsets(2.0, 2, 8),
                                         g.bounds)
    return g, values, positions, ok


def test_random_search_picks_only_admissible_actions_that_see_unvisited_nodes(baseline):
    g, values, positions, ok = baseline
    sees = (g.inside(positions) & (values <= 0.5)).any(axis=1)
    assert np.flatnonzero(sees).tolist() == [9, 13]
    rng = np.random.default_rng(0)
    picks = [random_search_action(rng, positions, ok, g, values, 0.5) for _ in range(200)]
    assert set(picks) == {9, 13}
    assert 60 < picks.count(9) < 140
    ok2 = ok.copy()
    ok2[9] = False
    assert {random_search_action(rng, positions, ok2, g, values, 0.5)
            for _ in range(50)} == {13}
    # beta is inclusive: at beta = 0.3 the two nodes are still unvisited.
    assert {random_search_action(rng, positions, ok, g, values, 0.3)
            for _ in range(50)} == {9, 13}


def test_random_search_is_reproducible_from_the_seed(baseline):
    g, values, positions, ok = baseline
    values = np.full(g.size, 0.9)  # every move sees unvisited nodes at beta = 0.95

    def run(seed):
        rng = np.random.default_rng(seed)
        return [random_search_action(rng, positions, ok, g, values, 0.95)
                for _ in range(30)]

    assert run(42) == run(42)
    assert run(42) != run(43)


def test_random_search_without_unvisited_nodes_in_reach_moves_at_random(baseline):
    g, values, positions, ok = baseline
    rng = np.random.default_rng(1)
    # At beta = 0.2 nothing is unvisited: uniform over the 16 moves, never staying.
    picks = [random_search_action(rng, positions, ok, g, values, 0.2) for _ in range(800)]
    assert set(picks) == set(range(1, 17))
    # The custom side can make the square see the nodes again.
    wide = {random_search_action(rng, positions, ok, g, values, 0.5, side=40.0)
            for _ in range(100)}
    assert wide == set(range(17))
    # When staying is the only admissible action it is taken.
    only = np.zeros(17, dtype=bool)
    only[0] = True
    assert random_search_action(rng, positions, only, g, values, 0.2) == 0
    # A different staying index is respected.
    assert 5 not in {random_search_action(rng, positions, ok, g, values, 0.2, stay=5)
                     for _ in range(300)}


# --- errors ---------------------------------------------------------------------------------

def test_bad_arguments_are_refused_naming_the_problem(baseline):
    g, values, positions, ok = baseline
    pts = line(4)
    with pytest.raises(ValueError, match="distinct"):
        joint_paths(pts, [1, 1], np.zeros((2, 2)), [0])
    with pytest.raises(ValueError, match="at least one agent"):
        joint_paths(pts, [], np.zeros((0, 2)), [0])
    with pytest.raises(ValueError, match="agent_positions"):
        joint_paths(pts, [1, 2], np.zeros((3, 2)), [0])
    with pytest.raises(ValueError, match="first"):
        joint_paths(pts, [1], np.zeros((1, 2)), [0], first="second")
    with pytest.raises(ValueError, match=r"in \[0, 4\)"):
        greedy_path(pts, (0.0, 0.0), [0, 4])
    with pytest.raises(ValueError, match="repeated"):
        greedy_path(pts, (0.0, 0.0), [1, 1])
    with pytest.raises(ValueError, match="node indices"):
        greedy_path(pts, (0.0, 0.0), [0.5])
    with pytest.raises(ValueError, match="grid_positions"):
        greedy_path(pts[:, :1], (0.0, 0.0), [0])
    with pytest.raises(ValueError, match="start_position"):
        greedy_path(pts, (0.0, np.nan), [0])
    with pytest.raises(ValueError, match="no admissible"):
        search_action(positions, np.zeros(17, dtype=bool), (0.0, 0.0))
    with pytest.raises(ValueError, match="bool mask"):
        search_action(positions, ok.astype(int), (0.0, 0.0))
    with pytest.raises(ValueError, match="next_node_position"):
        search_action(positions, ok, (0.0, 0.0, 0.0))
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="beta"):
        random_search_action(rng, positions, ok, g, values, 1.5)
    with pytest.raises(ValueError, match="stay"):
        random_search_action(rng, positions, ok, g, values, 0.5, stay=17)
    with pytest.raises(ValueError, match="shape"):
        random_search_action(rng, positions, ok, g, values[:10], 0.5)
    with pytest.raises(ValueError, match="repeated"):
        SearchPlan([1, 2, 1])
    with pytest.raises(ValueError, match=">= 0"):
        SearchPlan([-1])
    with pytest.raises(ValueError, match="does not hold"):
        SearchPlan([7]).advance(np.zeros(5, dtype=bool))
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        SearchPlan([1]).advance(np.full(5, 2.0))
