"""Search planning, search control and search cooperation of Papaioannou et al. (Sec. V-B).

- Planning (V-B(a)): the integer program P1 (eq. 11-16) is replaced, as the paper does, by
  its greedy heuristic: from the agent's position, repeatedly add the least-cost edge from
  the last node added to a node not yet planned, until every unvisited node is planned
  (:func:`greedy_path`). The cost c(i, l) is the Euclidean distance; the minimum runs over
  all unvisited nodes, as Alg. 1 writes it (min_{l in V-bar} c(i, l)), so the search map
  is used as a complete graph.
- Cooperation (V-B(c), Alg. 1): the cooperating agents take turns, each adding its own
  nearest remaining node, until none remains (:func:`joint_paths`).
- Control (V-B(b)): the admissible action of eq. 4 whose position is nearest the next
  unvisited node of the plan (:func:`search_action`); a planned node is dropped once it has
  been inside the agent's sensing area (:class:`SearchPlan`).
- The random search baseline of Sec. VI-B (Fig. 1) (:func:`random_search_action`).

Ties: distances within :data:`TIE_TOLERANCE` of the minimum are ties, broken to the lowest
node index or action index, so every agent that runs the same computation on the same
inputs gets the same plan.

Reference: S. Papaioannou et al., "A cooperative multi-agent probabilistic framework for
search and track missions", IEEE T-CNS, Sec. V-B, Alg. 1, Sec. VI-B.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...estimators.papaioannou.search_map import SearchGrid, check_values

__all__ = ["TIE_TOLERANCE", "greedy_path", "joint_paths", "search_action", "SearchPlan",
           "random_search_action"]

#: Distances [m] within this of the minimum are a tie (broken to the lowest index), so that
#: rounding in positions such as 0.1 + 0.2 does not decide between equidistant nodes.
TIE_TOLERANCE = 1e-9

_FIRST = ("lowest", "literal")


def _first_nearest(points: np.ndarray, origin: np.ndarray, free: np.ndarray) -> int:
    """Index of the free point nearest ``origin``, ties (within the tolerance) to the lowest."""
    d = np.hypot(points[:, 0] - origin[0], points[:, 1] - origin[1])
    d[~free] = np.inf
    return int(np.argmax(d <= d.min() + TIE_TOLERANCE))


def _check_nodes(grid_positions: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray,
                                                                         np.ndarray]:
    """Node positions (S, 2) as floats and the targets as distinct ascending indices."""
    pos = np.asarray(grid_positions, dtype=float)
    if pos.ndim != 2 or pos.shape[1] != 2 or not np.isfinite(pos).all():
        raise ValueError(f"search plan: expected finite grid_positions of shape (S, 2), "
                         f"got shape {pos.shape}")
    t = np.asarray(targets)
    if t.ndim != 1 or (t.size and not np.issubdtype(t.dtype, np.integer)):
        raise ValueError(f"search plan: targets must be a 1-D array of node indices, "
                         f"got shape {t.shape} dtype {t.dtype}")
    t = t.astype(np.int64)
    if t.size and (t.min() < 0 or t.max() >= pos.shape[0]):
        raise ValueError(f"search plan: target node indices must be in [0, {pos.shape[0]}), "
                         f"got range [{t.min()}, {t.max()}]")
    u = np.unique(t)
    if u.size != t.size:
        raise ValueError("search plan: targets contain repeated node indices")
    return pos, u


def _round_robin(nodes: np.ndarray, points: np.ndarray, starts: np.ndarray,
                 first: int) -> list[list[int]]:
    """Alg. 1's loop: agents take turns from ``first``, each adding its nearest free node."""
    n = starts.shape[0]
    last = starts.copy()
    free = np.ones(nodes.size, dtype=bool)
    paths: list[list[int]] = [[] for _ in range(n)]
    turn = first
    for _ in range(nodes.size):
        k = _first_nearest(points, last[turn], free)
        free[k] = False
        paths[turn].append(int(nodes[k]))
        last[turn] = points[k]
        turn = (turn + 1) % n
    return paths


def greedy_path(grid_positions: np.ndarray, start_position: np.ndarray,
                targets: np.ndarray) -> np.ndarray:
    """The greedy heuristic that replaces P1 (Sec. V-B(a)): nearest unplanned node first.

    Starting at s_k, the path repeatedly appends the node of ``targets`` not yet in it that
    is nearest (Euclidean) the last node appended, ties to the lowest node index, until all
    are in it. One distance computation over the targets per appended node: O(K^2) work in
    K numpy passes.

    Parameters
    ----------
    grid_positions : np.ndarray, shape (S, 2)
        Node positions [m] (:attr:`SearchGrid.positions`).
    start_position : array_like, shape (2,)
        The agent's position s_k [m].
    targets : array_like of int, shape (K,)
        The nodes to visit, V-bar (e.g.
        :func:`~phd_swarm.core.estimators.papaioannou.search_map.unvisited`); distinct, any order.

    Returns
    -------
    np.ndarray of int, shape (K,)
        The node indices in visiting order.
    """
    s = np.asarray(start_position, dtype=float)
    if s.shape != (2,) or not np.isfinite(s).all():
        raise ValueError(f"search plan: expected a finite start_position of shape (2,), "
                         f"got {s.tolist()}")
    return joint_paths(grid_positions, [0], s[None, :], targets)[0]


def joint_paths(grid_positions: np.ndarray, agent_ids: Sequence[int],
                agent_positions: np.ndarray, targets: np.ndarray,
                first: str = "lowest") -> dict[int, np.ndarray]:
    """Joint search plans of the cooperating agents S-bar (Alg. 1, Sec. V-B(c)).

    The agents, in increasing id order, take turns; in its turn an agent appends to its
    path the remaining node nearest (Euclidean) the last node of its path (its position
    s_k^j before the first), ties to the lowest node index; the node is then removed. The
    loop ends when no node remains. The result depends only on the set of (id, position)
    pairs and the set of targets, not on the order they are listed in, so every agent that
    runs it on the same merged map gets the same plans.

    Alg. 1 prints ``delta = 0`` then, in the loop, ``delta = delta + 1, j = delta mod
    |S-bar|``: with the agents numbered 0 .. |S-bar| - 1 that is the second agent first
    (``first="literal"``); with them numbered 1 .. |S-bar| and j = 0 read as |S-bar|, it is
    the first agent first, the default ``first="lowest"``.

    Parameters
    ----------
    grid_positions : np.ndarray, shape (S, 2)
        Node positions [m].
    agent_ids : sequence of int, length N >= 1
        Distinct ids of the cooperating agents (this agent among them).
    agent_positions : np.ndarray, shape (N, 2)
        Their positions s_k^j [m], in the order of ``agent_ids``.
    targets : array_like of int, shape (K,)
        V-bar, the unvisited nodes of the merged map; distinct, any order. (Alg. 1's
        ``V-bar = V`` is ``targets = all nodes``.)
    first : {"lowest", "literal"}
        Whose turn comes first: the lowest id, or the second lowest as printed.

    Returns
    -------
    dict of int to np.ndarray of int
        Each agent's ordered node indices (possibly empty); keys as given.
    """
    pos, nodes = _check_nodes(grid_positions, targets)
    ids = list(agent_ids)
    if not ids:
        raise ValueError("search plan: joint_paths needs at least one agent")
    if len(set(ids)) != len(ids):
        raise ValueError(f"search plan: agent_ids must be distinct, got {ids}")
    starts = np.asarray(agent_positions, dtype=float)
    if starts.shape != (len(ids), 2) or not np.isfinite(starts).all():
        raise ValueError(f"search plan: expected finite agent_positions of shape "
                         f"({len(ids)}, 2), got shape {starts.shape}")
    if first not in _FIRST:
        raise ValueError(f"search plan: first must be one of {_FIRST}, got {first!r}")
    order = sorted(range(len(ids)), key=lambda i: ids[i])
    paths = _round_robin(nodes, pos[nodes], starts[order],
                         0 if first == "lowest" else 1 % len(ids))
    return {ids[i]: np.asarray(p, dtype=np.int64) for i, p in zip(order, paths, strict=True)}


def search_action(positions_of_actions: np.ndarray, admissible: np.ndarray,
                  next_node_position: np.ndarray) -> int:
    """Search control (Sec. V-B(b)): u* = argmin over admissible u of xi_search(u, v).

    xi_search is the Euclidean distance from the agent's position after action u to the
    next unvisited node v of its plan; ties go to the lowest action index (staying, index
    0 in :func:`.agent_moves.action_offsets`, wins a tie).

    Parameters
    ----------
    positions_of_actions : np.ndarray, shape (U, 2)
        The position each action leads to [m]
        (:func:`.agent_moves.admissible_positions`).
    admissible : np.ndarray of bool, shape (U,)
        Which actions are admissible; at least one.
    next_node_position : array_like, shape (2,)
        Position of v [m].

    Returns
    -------
    int
        The chosen action index.
    """
    pos, ok = _check_actions(positions_of_actions, admissible)
    v = np.asarray(next_node_position, dtype=float)
    if v.shape != (2,) or not np.isfinite(v).all():
        raise ValueError(f"search plan: expected a finite next_node_position of shape (2,), "
                         f"got {v.tolist()}")
    return _first_nearest(pos, v, ok)


def _check_actions(positions_of_actions: np.ndarray,
                   admissible: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    pos = np.asarray(positions_of_actions, dtype=float)
    ok = np.asarray(admissible)
    if pos.ndim != 2 or pos.shape[1] != 2 or pos.shape[0] < 1:
        raise ValueError(f"search plan: expected positions_of_actions of shape (U, 2), "
                         f"got {pos.shape}")
    if ok.dtype != bool or ok.shape != (pos.shape[0],):
        raise ValueError(f"search plan: admissible must be a bool mask of shape "
                         f"({pos.shape[0]},), got {ok.dtype} {ok.shape}")
    if not ok.any():
        raise ValueError("search plan: no admissible action")
    if not np.isfinite(pos[ok]).all():
        raise ValueError("search plan: admissible action positions must be finite")
    return pos, ok


class SearchPlan:
    """An agent's list of nodes to visit, in order (Sec. V-B(b)).

    A planned node is dropped once it is visited: once it has been inside the agent's
    sensing area. :meth:`advance` takes either that mask or the search values after the
    map's update (eq. 9), in which case a node with value 1 counts as visited: it was
    inside the sensing square now or at the previous step (eq. 7 does not decay it
    there), or, after a :func:`~phd_swarm.core.estimators.papaioannou.search_map.max_merge`, a
    peer's.

    Parameters
    ----------
    nodes : array_like of int, shape (K,)
        Distinct node indices in visiting order (:func:`greedy_path`, one entry of
        :func:`joint_paths`).
    """

    def __init__(self, nodes: np.ndarray) -> None:
        n = np.asarray(nodes)
        if n.ndim != 1 or (n.size and not np.issubdtype(n.dtype, np.integer)):
            raise ValueError(f"search plan: nodes must be a 1-D array of node indices, "
                             f"got shape {n.shape} dtype {n.dtype}")
        n = n.astype(np.int64)
        if n.size and n.min() < 0:
            raise ValueError("search plan: node indices must be >= 0")
        if np.unique(n).size != n.size:
            raise ValueError("search plan: nodes contain repeated node indices")
        self._nodes = n

    @property
    def nodes(self) -> np.ndarray:
        """The nodes still to visit, in order, shape (K,) (a copy)."""
        return self._nodes.copy()

    @property
    def done(self) -> bool:
        """Whether every planned node has been visited."""
        return self._nodes.size == 0

    def __len__(self) -> int:
        return int(self._nodes.size)

    def next_node(self) -> int:
        """The next node to visit, v of the search control; a ValueError when done."""
        if self.done:
            raise ValueError("search plan: the plan is done, there is no next node")
        return int(self._nodes[0])

    def advance(self, values_or_visited_mask: np.ndarray) -> int:
        """Drop the planned nodes that have been visited, wherever they are in the plan.

        Parameters
        ----------
        values_or_visited_mask : np.ndarray, shape (S,)
            A bool mask of the nodes visited (e.g. ``grid.inside(s_k)``), or the search
            values after the update (value 1 = visited).

        Returns
        -------
        int
            How many nodes were dropped.
        """
        arr = np.asarray(values_or_visited_mask)
        if arr.dtype == bool:
            if arr.ndim != 1:
                raise ValueError(f"search plan: expected a visited mask of shape (S,), "
                                 f"got {arr.shape}")
            visited = arr
        else:
            visited = check_values(arr, None) >= 1.0
        if self._nodes.size and self._nodes.max() >= visited.size:
            raise ValueError(f"search plan: a map of {visited.size} nodes does not hold "
                             f"planned node {int(self._nodes.max())}")
        keep = ~visited[self._nodes]
        dropped = int(self._nodes.size - keep.sum())
        self._nodes = self._nodes[keep]
        return dropped

    def __repr__(self) -> str:
        return f"SearchPlan({self._nodes.tolist()})"


def random_search_action(rng: np.random.Generator, positions_of_actions: np.ndarray,
                         admissible: np.ndarray, grid: SearchGrid, values: np.ndarray,
                         beta: float, side: float | None = None, stay: int = 0) -> int:
    """The random search baseline of Sec. VI-B (Fig. 1), as we read it.

    The paper: "each agent randomly selects and applies an admissible control action
    towards the unvisited regions", with no planning and no communication. Read here as:
    uniformly at random among the admissible actions whose sensing square at the new
    position contains at least one unvisited node (p_v <= beta); if none does, uniformly
    among the admissible moves, staying excluded unless it is the only admissible action.

    Parameters
    ----------
    rng : np.random.Generator
        The only source of randomness: one ``integers`` draw.
    positions_of_actions : np.ndarray, shape (U, 2)
        The position each action leads to [m].
    admissible : np.ndarray of bool, shape (U,)
        Which actions are admissible; at least one.
    grid : SearchGrid
    values : np.ndarray, shape (S,)
        The agent's search values.
    beta : float
        The unvisited threshold, in [0, 1], inclusive.
    side : float, optional
        Side of the sensing square [m]; ``grid.side`` by default.
    stay : int
        Index of the staying action (0 in :func:`.agent_moves.action_offsets`).

    Returns
    -------
    int
        The chosen action index.
    """
    pos, ok = _check_actions(positions_of_actions, admissible)
    v = check_values(values, grid.size)
    if not (np.isfinite(beta) and 0.0 <= beta <= 1.0):
        raise ValueError(f"search plan: threshold beta must be in [0, 1], got {beta!r}")
    if isinstance(stay, bool) or not (0 <= int(stay) < pos.shape[0]) or int(stay) != stay:
        raise ValueError(f"search plan: stay must be an action index in [0, {pos.shape[0]}), "
                         f"got {stay!r}")
    idx = np.flatnonzero(ok)
    sees = (grid.inside(pos[idx], side) & (v <= beta)).any(axis=1)
    candidates = idx[sees]
    if candidates.size == 0:
        candidates = idx[idx != stay] if idx.size > 1 else idx
    return int(candidates[rng.integers(candidates.size)])
