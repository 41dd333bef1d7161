"""Meetings of robots on a grid walk, simulated with a seeded generator (Shirsat & Berman).

The Monte Carlo side of :mod:`.renewal_exact`: robots walking the grid graph's chain from their
start nodes, the steps at which a meeting event (a given pair, a robot with any other, the
whole team) happens, and the window averages of the time between them, to check the exact
renewal results (Kac's lemma, eq. 7-8) against. Randomness only from the generator passed
in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..controllers.dtds_walk.grid_graph import GridGraph
from .renewal_exact import _check_event, _check_robots


def start_nodes(graph: GridGraph, rng: np.random.Generator, shape: tuple[int, ...],
                start: str | np.ndarray = "stationary") -> np.ndarray:
    """Start nodes for many robots: drawn from pi, uniformly, or given (broadcast).

    ``meeting`` is not a simulation start (run from ``stationary`` and measure the gaps).
    """
    if isinstance(start, str):
        if start == "stationary":
            return rng.choice(graph.size, size=shape, p=graph.stationary)
        if start == "uniform":
            return rng.integers(0, graph.size, size=shape)
        raise ValueError(f"start: expected 'stationary', 'uniform' or start nodes, "
                         f"got {start!r}")
    return np.broadcast_to(np.asarray(start, dtype=np.int64), shape).copy()


def meeting_events(nodes: np.ndarray, event: str) -> np.ndarray:
    """Which units meet at this step, for many runs at once.

    Parameters
    ----------
    nodes : np.ndarray of int, shape (runs, N)
        Each run's robots' nodes.
    event : {"pair", "robot", "team"}
        Units: every pair i < j (in ``np.triu_indices`` order), every robot, or the team.

    Returns
    -------
    np.ndarray of bool, shape (runs, U)
        U = N (N - 1) / 2, N or 1.
    """
    n = nodes.shape[1]
    same = nodes[:, :, None] == nodes[:, None, :]
    if _check_event(event) == "pair":
        i, j = np.triu_indices(n, 1)
        return same[:, i, j]
    if event == "robot":
        return same.sum(axis=2) > 1
    return (same.sum(axis=(1, 2)) > n)[:, None]


@dataclass(frozen=True)
class SimulatedMeetings:
    """What :func:`simulate_meetings` measured, per independent run.

    Attributes
    ----------
    event : str
    steps : int
        The window: gaps that start (with a meeting) at times 0..steps-1 are counted.
    walked : int
        Steps actually walked: past ``steps`` until every counted gap and every first
        meeting was complete, or the limit.
    interval_sums : np.ndarray, shape (runs,)
        Sum of the counted gaps between successive meetings of each unit [steps].
    interval_counts : np.ndarray of int, shape (runs,)
        Number of those gaps.
    first : np.ndarray of int, shape (runs, U)
        Each unit's first meeting time tau = min{k >= 1 : meets} [steps]; -1 if it did not
        meet by the end (censored).
    pending : int
        Gaps started in the window that had not ended at the limit (not counted).
    """

    event: str
    steps: int
    walked: int
    interval_sums: np.ndarray
    interval_counts: np.ndarray
    first: np.ndarray
    pending: int = 0

    @property
    def censored(self) -> int:
        """Units that had not met by the end of their run."""
        return int(np.sum(self.first < 0))

    def interarrival(self, z: float = 1.959963984540054) -> tuple[float, float]:
        """Mean gap between meetings and the half-width of its confidence interval.

        The ratio estimator R = sum of gaps / number of gaps over all runs; the runs are
        independent, the gaps within one run are not, so the interval is the delta
        method's over runs: var R = n / (n - 1) sum_r (s_r - R c_r)^2 / (sum c)^2.
        ``z`` = 1.96: 95 %. From a stationary start each counted gap starts at a meeting
        of the stationary chain, so it has the law of tau_A^+ under pi_A and R estimates
        Kac's 1 / pi(A) without the bias of gaps cut by the end of a window.

        Raises
        ------
        ValueError
            With fewer than 2 runs, no gap, or gaps left pending at the walk's limit.
        """
        if self.pending:
            raise ValueError(f"interarrival: {self.pending} gaps had not ended at the limit")
        s = self.interval_sums.astype(float)
        c = self.interval_counts.astype(float)
        n = s.size
        if n < 2 or c.sum() == 0:
            raise ValueError("interarrival: needs at least 2 runs with meetings")
        r = s.sum() / c.sum()
        var = n / (n - 1) * np.sum((s - r * c) ** 2) / c.sum() ** 2
        return float(r), float(z * np.sqrt(var))

    def first_meeting(self, z: float = 1.959963984540054) -> tuple[float, float]:
        """Mean first meeting time and the half-width of its confidence interval.

        The mean over runs of each run's mean over its units (t-free normal interval over
        the independent runs).

        Raises
        ------
        ValueError
            If a unit is censored (simulate longer) or there are fewer than 2 runs.
        """
        if self.censored:
            raise ValueError(f"first_meeting: {self.censored} units had not met by step "
                             f"{self.steps}; simulate longer")
        per_run = self.first.mean(axis=1)
        if per_run.size < 2:
            raise ValueError("first_meeting: needs at least 2 runs")
        return (float(per_run.mean()),
                float(z * per_run.std(ddof=1) / np.sqrt(per_run.size)))


def simulate_meetings(graph: GridGraph, rng: np.random.Generator, robots: int, steps: int,
                      runs: int = 1, event: str = "robot",
                      start: str | np.ndarray = "stationary",
                      max_steps: int | None = None) -> SimulatedMeetings:
    """Walk ``runs`` independent teams of ``robots`` and time their meetings.

    Every gap between successive meetings of a unit that starts at a time 0..steps-1 is
    counted; the walk goes on past ``steps`` until each of those gaps, and each unit's first
    meeting, has ended (at most ``max_steps`` steps in all), so no counted time is cut
    short. Vectorised over runs and robots (one :meth:`GridGraph.step` per time step for
    all of them); the statistics are accumulated as the walk goes, so memory is
    O(runs N^2).

    Parameters
    ----------
    graph : GridGraph
    rng : np.random.Generator
        The only source of randomness (start draw, then the moves).
    robots : int
        N >= 2.
    steps : int
        Steps after the start.
    runs : int
        Independent teams.
    event : {"pair", "robot", "team"}
        What counts as a meeting, for each unit (:func:`meeting_events`).
    start : str or array_like of int
        ``stationary``, ``uniform`` or start nodes (:func:`start_nodes`).
    max_steps : int, optional
        Limit of the walk; default ``100 steps + 100000``.

    Returns
    -------
    SimulatedMeetings
    """
    n = _check_robots(robots)
    _check_event(event)
    nodes = start_nodes(graph, rng, (int(runs), n), start)
    units = meeting_events(nodes, event).shape[1]
    last = np.full((runs, units), -1, dtype=np.int64)
    first = np.full((runs, units), -1, dtype=np.int64)
    sums = np.zeros(runs, dtype=np.int64)
    counts = np.zeros(runs, dtype=np.int64)
    steps = int(steps)
    limit = 100 * steps + 100_000 if max_steps is None else int(max_steps)
    k = 0
    while True:
        if k:
            nodes = graph.step(rng, nodes)
        hit = meeting_events(nodes, event)
        gap = hit & (last >= 0) & (last < steps)
        sums += np.where(gap, k - last, 0).sum(axis=1)
        counts += gap.sum(axis=1)
        last[hit] = k
        if k:
            first[hit & (first < 0)] = k
        pending = int(np.sum((last >= 0) & (last < steps)))
        if k >= limit or (k >= steps and not pending and not np.any(first < 0)):
            break
        k += 1
    return SimulatedMeetings(event, steps, k, sums, counts, first, pending)


def window_averages(graph: GridGraph, rng: np.random.Generator, robots: int, steps: int,
                    runs: int, event: str = "pair",
                    start: str | np.ndarray = "uniform") -> np.ndarray:
    """Each run's average inter-arrival time over a window of ``steps`` steps [steps].

    The estimate of one finite run (Sec. VI: "the average inter-arrival time over this
    simulation run"): the inter-arrival times that end within the window, the first
    measured from time 0 (S_0 = 0, eq. 5), pooled over the run's units (its pairs, robots
    or the team, :func:`meeting_events`); the interval still open at the end is dropped.
    For a window not much longer than the mean gap this is biased low and widely spread
    (long gaps are cut off); the expectation it estimates for long windows is Kac's.

    Parameters
    ----------
    graph, rng, robots, event, start
        As in :func:`simulate_meetings` (default start: uniform, the paper's).
    steps : int
        The window, times 1..steps after the start.
    runs : int
        Independent runs.

    Returns
    -------
    np.ndarray, shape (runs,)
        NaN for a run without any completed interval.
    """
    n = _check_robots(robots)
    nodes = start_nodes(graph, rng, (int(runs), n), start)
    units = meeting_events(nodes, event).shape[1]
    last = np.zeros((runs, units), dtype=np.int64)
    sums = np.zeros(runs, dtype=np.int64)
    counts = np.zeros(runs, dtype=np.int64)
    for k in range(1, int(steps) + 1):
        nodes = graph.step(rng, nodes)
        hit = meeting_events(nodes, event)
        sums += np.where(hit, k - last, 0).sum(axis=1)
        counts += hit.sum(axis=1)
        last[hit] = k
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
