"""Meeting times of robots on the DTDS random walk, exactly (Shirsat & Berman Sec. IV).

N robots walk independently on a
:class:`~phd_swarm.core.controllers.dtds_walk.grid_graph.GridGraph` by eq. 4; together they form
the composite chain psi_k = (Y_k^1, ..., Y_k^N) of eq. 7-8, with transition matrix Q = P ⊗ ... ⊗ P.
A *renewal epoch* is a step at which robots share a node (Sec. IV); this module gives three
readings of "meet", each a set A of composite states:

- ``pair``: two given robots share a node, A = {Y^1 = Y^2};
- ``robot``: a given robot shares its node with at least one of the other N - 1 (the
  inter-arrival times tau_j^{a_i} of Sec. IV), A = {exists j > 1: Y^j = Y^1};
- ``team``: some two robots share a node (the "any two robots a_m and a_n" of Fig. 5a),
  A = {exists i < j: Y^i = Y^j}.

Two different means. P is reversible with stationary pi_v ∝ d_v + 1
(:attr:`GridGraph.stationary`), so Q is reversible with stationary pi ⊗ ... ⊗ pi, and:

- **Mean inter-arrival time** (the renewal inter-arrival, Kac's lemma): started in A from
  stationarity conditioned on A, the mean time to the next visit to A is
  E_{pi_A}[tau_A^+] = 1 / pi(A), tau_A^+ = min{k >= 1: psi_k in A}. This is the long-run
  mean gap between successive renewal epochs, which is what averaging the inter-arrival
  times of a long run measures: *it is the paper's "mean inter-arrival time"*
  (E[tau_k] ~ 68 s, Table 1). :func:`mean_interarrival`.
- **Mean first meeting time from stationarity**, E_pi[tau_A^+]: the robots start
  independently from pi (or from a given start, e.g. uniformly at random nodes, as the
  paper's robots do) and wait for the first epoch. For a reversible chain
  P_pi(tau_A^+ = k) = pi(A) P_{pi_A}(tau_A^+ >= k), so E_pi[tau_A^+] =
  pi(A) E_{pi_A}[tau_A^+ (tau_A^+ + 1) / 2] (the inspection paradox): larger, because
  meetings come in bursts (two robots that have just met are likely to meet again at
  once). This is the delay of the first renewal only. :func:`first_meeting_distribution`
  (the whole distribution, by repeated sparse mat-vec on the composite chain) and
  :func:`mean_first_meeting` (the mean, by one sparse linear solve).

A third reading counts only *new* meetings, steps in A after a step outside it
(:func:`mean_time_between_entries`): two robots that stay together for several steps
then make one epoch, not several.

Note on Theorem IV.1: the gaps between successive visits to A are identically distributed
with mean 1 / pi(A) in stationarity, but not independent (the node where robots meet, and
where the others are, carries over), so T^{a_i}(k) is a Markov renewal process rather than
a renewal process in the iid sense; the long-run mean is 1 / pi(A) all the same.

Times are in steps; multiply by the seconds per step. Reference: A. Shirsat and S. Berman,
AIAA SciTech 2021, Sec. III-IV, eq. 1-8; M. Kac, "On the notion of recurrence in
discrete stochastic processes", Bull. AMS 53, 1947.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, cg

from ..controllers.dtds_walk.grid_graph import GridGraph

#: Readings of "robots meet" (see the module docstring).
EVENTS = ("pair", "robot", "team")

#: Named starts of the composite chain: stationary (pi ⊗ ... ⊗ pi), uniform over nodes
#: (each robot independently, the paper's "random positions on the grid"), and
#: stationary conditioned on a meeting (pi_A: Kac's start, the renewal inter-arrival).
STARTS = ("stationary", "uniform", "meeting")

#: Largest composite state space S^n the exact first-meeting functions accept by default.
MAX_STATES = 4_000_000


def _check_event(event: str) -> str:
    if event not in EVENTS:
        raise ValueError(f"event: expected one of {list(EVENTS)}, got {event!r}")
    return event


def _check_robots(robots: int) -> int:
    if isinstance(robots, bool) or not isinstance(robots, (int, np.integer)) or robots < 2:
        raise ValueError(f"robots: expected an integer >= 2, got {robots!r}")
    return int(robots)


def chain_robots(robots: int, event: str) -> int:
    """Robots the composite chain of ``event`` needs: 2 for ``pair``, else ``robots``."""
    return 2 if _check_event(event) == "pair" else _check_robots(robots)


# --- stationary meeting probabilities and Kac's means -------------------------------------


def pair_meeting_probability(graph: GridGraph) -> float:
    """pi(A) for two given robots: P(Y^1 = Y^2) = sum_v pi_v^2 in stationarity."""
    pi = graph.stationary
    return float(pi @ pi)


def robot_meeting_probability(graph: GridGraph, robots: int) -> float:
    """pi(A) for a given robot and any of the other N - 1.

    sum_v pi_v [1 - (1 - pi_v)^(N-1)]: the robot is at v with probability pi_v and each
    other robot, independently, is elsewhere with probability 1 - pi_v.
    """
    n = _check_robots(robots)
    pi = graph.stationary
    return float(np.sum(pi * -np.expm1((n - 1) * np.log1p(-pi))))


def elementary_symmetric(values: np.ndarray, order: int) -> float:
    """e_order(values), the sum over subsets of ``order`` distinct entries of their product.

    By the prefix recursion E_j[v] = E_j[v-1] + x_v E_{j-1}[v-1] (vectorised over v,
    ``order`` passes), which adds only non-negative terms for non-negative values.
    """
    x = np.asarray(values, dtype=float).ravel()
    e = np.ones(x.size + 1)
    for _ in range(order):
        e = np.concatenate([[0.0], np.cumsum(x * e[:-1])])
    return float(e[-1])


def team_meeting_probability(graph: GridGraph, robots: int) -> float:
    """pi(A) for "some two of the N robots share a node": 1 - N! e_N(pi).

    The N robots are on distinct nodes with probability sum over ordered N-tuples of
    distinct nodes of their pi product, N! times the elementary symmetric polynomial
    e_N(pi_1, ..., pi_S) (0 when N > S).
    """
    n = _check_robots(robots)
    e = elementary_symmetric(graph.stationary, n)
    distinct = 0.0 if e <= 0.0 else math.exp(math.lgamma(n + 1) + math.log(e))
    return float(1.0 - distinct)


def meeting_probability(graph: GridGraph, robots: int, event: str = "robot") -> float:
    """pi(A) of ``event`` (:data:`EVENTS`) for ``robots`` robots in stationarity."""
    if _check_event(event) == "pair":
        return pair_meeting_probability(graph)
    if event == "robot":
        return robot_meeting_probability(graph, robots)
    return team_meeting_probability(graph, robots)


def mean_interarrival(graph: GridGraph, robots: int, event: str = "robot") -> float:
    """Mean inter-arrival time between renewal epochs [steps]: 1 / pi(A) (Kac's lemma).

    The mean time between successive visits of the composite chain (eq. 7-8) to the set A
    of ``event``, started in A from stationarity; the long-run average of the gaps between
    renewal epochs (Sec. IV). Exact.
    """
    return 1.0 / meeting_probability(graph, robots, event)


def entry_probability(graph: GridGraph, robots: int, event: str = "robot") -> float:
    """P(psi_k not in A, psi_{k+1} in A) in stationarity: the rate of *new* meetings.

    ``pair``: sum_v pi_v^2 d_v / (d_v + 1) (both robots at v stay together with
    probability sum_w p_vw^2 = 1 / (d_v + 1)). ``robot``: pi(A) minus
    sum over edges (v, w) of pi_v p_vw [1 - a_v - a_w + b_vw], with
    a_v = (1 - pi_v)^(N-1) and b_vw = (1 - pi_v - pi_w + pi_v p_vw)^(N-1), the
    probabilities that none of the others meets the robot at k (at v), at k + 1 (at w),
    and at neither.

    Raises
    ------
    ValueError
        For ``team``, which has no closed form here.
    """
    if _check_event(event) == "team":
        raise ValueError("entry_probability: exact only for the pair and robot events")
    pi = graph.stationary
    d = graph.degrees
    if event == "pair":
        return float(np.sum(pi ** 2 * d / (d + 1)))
    n = _check_robots(robots)
    v, w = graph.edges[:, 0], graph.edges[:, 1]
    p = 1.0 / (d[v] + 1)
    a = (1.0 - pi) ** (n - 1)
    b = (1.0 - pi[v] - pi[w] + pi[v] * p) ** (n - 1)
    both = float(np.sum(pi[v] * p * (1.0 - a[v] - a[w] + b)))
    return robot_meeting_probability(graph, n) - both


def mean_time_between_entries(graph: GridGraph, robots: int, event: str = "robot") -> float:
    """Mean time between *new* meetings [steps]: 1 / :func:`entry_probability`.

    The reading in which robots that stay together count one renewal epoch, not one per
    step.
    """
    return 1.0 / entry_probability(graph, robots, event)


# --- the composite chain (eq. 7-8) ---------------------------------------------------------


def meeting_mask(size: int, robots: int, event: str) -> np.ndarray:
    """The set A of ``event`` over composite states, shape (S,) * n, n = chain robots.

    Axis r of the array is robot r's node; ``robot`` is robot 0 meeting any other.
    """
    n = chain_robots(robots, event)
    idx = np.indices((size,) * n, sparse=True)
    if event == "team":
        pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    else:
        pairs = [(0, j) for j in range(1, n)]
    mask = np.zeros((size,) * n, dtype=bool)
    for i, j in pairs:
        mask |= idx[i] == idx[j]
    return mask


def _outer(vector: np.ndarray, n: int) -> np.ndarray:
    """The outer power vector ⊗ ... ⊗ vector (n factors), shape (S,) * n."""
    out = vector
    for _ in range(n - 1):
        out = np.multiply.outer(out, vector)
    return out


def composite_start(graph: GridGraph, robots: int, event: str,
                    start: str | np.ndarray = "stationary") -> np.ndarray:
    """The composite chain's initial distribution, shape (S,) * n, n = chain robots.

    Parameters
    ----------
    start : str or array_like of int
        ``stationary``, ``uniform``, ``meeting`` (:data:`STARTS`), or the robots' start
        nodes (n of them, or ``robots`` of which the first n are taken).
    """
    n = chain_robots(robots, event)
    s = graph.size
    if isinstance(start, str):
        if start not in STARTS:
            raise ValueError(f"start: expected one of {list(STARTS)} or start nodes, "
                             f"got {start!r}")
        if start == "uniform":
            return np.full((s,) * n, float(s) ** -n)
        mu = _outer(graph.stationary, n)
        if start == "meeting":
            mu = np.where(meeting_mask(s, robots, event), mu, 0.0)
            mu /= mu.sum()
        return mu
    nodes = np.asarray(start, dtype=np.int64).ravel()
    if nodes.size < n or np.any((nodes < 0) | (nodes >= s)):
        raise ValueError(f"start: expected {n} node indices in 0..{s - 1}, got {start!r}")
    mu = np.zeros((s,) * n)
    mu[tuple(nodes[:n])] = 1.0
    return mu


def _along_axes(tensor: np.ndarray, mat: sp.csr_matrix) -> np.ndarray:
    """``mat`` applied along every axis of ``tensor`` (S x S on each): (⊗ mat) tensor.

    Each pass multiplies the leading axis and rotates it to the back, so after n passes
    the axes are in their order again.
    """
    s = tensor.shape[0]
    shape = tensor.shape
    for _ in range(tensor.ndim):
        tensor = (mat @ tensor.reshape(s, -1)).T.reshape(shape)
    return tensor


def _check_states(size: int, n: int, max_states: int) -> None:
    if float(size) ** n > max_states:
        raise ValueError(f"the composite chain has {size}^{n} = {float(size) ** n:.3g} "
                         f"states, more than max_states = {max_states}")


@dataclass(frozen=True)
class FirstMeeting:
    """The distribution of the first meeting time tau = min{k >= 1: psi_k in A} [steps].

    Attributes
    ----------
    pmf : np.ndarray, shape (K + 1,)
        P(tau = k) for k = 0..K (entry 0 is 0: tau >= 1).
    survival : np.ndarray, shape (K + 1,)
        P(tau > k) for k = 0..K, the mass still outside A after k steps.
    """

    pmf: np.ndarray
    survival: np.ndarray

    @property
    def remaining(self) -> float:
        """P(tau > K): the mass left when the iteration stopped."""
        return float(self.survival[-1])

    @property
    def mean(self) -> float:
        """E[tau] = sum_{k >= 0} P(tau > k), the tail beyond K extrapolated geometrically.

        The survival decays like lambda^k, lambda the largest eigenvalue of Q restricted to
        the states outside A; lambda is estimated from the last two survival values and
        adds P(tau > K) lambda / (1 - lambda), at most ~1e-12 of a time for the default
        tolerance.
        """
        s = self.survival
        tail = 0.0
        if s.size >= 2 and s[-2] > 0:
            lam = min(s[-1] / s[-2], 1.0 - 1e-12)
            tail = s[-1] * lam / (1.0 - lam)
        return float(np.sum(s) + tail)


def first_meeting_distribution(graph: GridGraph, robots: int = 2, event: str = "pair",
                               start: str | np.ndarray = "stationary", tol: float = 1e-12,
                               max_steps: int = 1_000_000,
                               max_states: int = MAX_STATES) -> FirstMeeting:
    """The first-passage distribution of the composite chain (eq. 7-8) into A.

    The mass outside A is pushed one step with Q = P ⊗ ... ⊗ P (a sparse mat-vec along
    each robot's axis), the part landing in A is P(tau = k) and is removed; the iteration
    stops once the remaining mass P(tau > k) is below ``tol``.

    Parameters
    ----------
    graph : GridGraph
    robots : int
        N; ``pair`` uses the two robots 0 and 1 only (the others do not affect them).
    event : {"pair", "robot", "team"}
        The set A (module docstring); ``robot`` is robot 0 meeting any other.
    start : str or array_like of int
        :func:`composite_start`; ``meeting`` gives the renewal inter-arrival distribution,
        whose mean is Kac's 1 / pi(A).
    tol : float
        Stop when P(tau > k) < tol.
    max_steps : int
        Stop after this many steps regardless (see :attr:`FirstMeeting.remaining`).
    max_states : int
        Refuse composite chains with more states (S^n numbers are held).

    Returns
    -------
    FirstMeeting
    """
    n = chain_robots(robots, event)
    _check_states(graph.size, n, max_states)
    mask = meeting_mask(graph.size, robots, event)
    v = composite_start(graph, robots, event, start).copy()
    pt = graph.transition_matrix.T.tocsr()
    pmf, survival = [0.0], [1.0]
    for _ in range(max_steps):
        v = _along_axes(v, pt)
        pmf.append(float(np.sum(v, where=mask)))
        v[mask] = 0.0
        survival.append(float(v.sum()))
        if survival[-1] < tol:
            break
    return FirstMeeting(np.array(pmf), np.array(survival))


def mean_first_meeting(graph: GridGraph, robots: int = 2, event: str = "pair",
                       start: str | np.ndarray = "stationary", rtol: float = 1e-10,
                       max_states: int = MAX_STATES) -> float:
    """E[tau], tau = min{k >= 1: psi_k in A}, by one sparse linear solve [steps].

    The hitting times h(x) = E_x[min{k >= 0: psi_k in A}] solve h = 0 on A and
    h = 1 + Q h outside it; then E_mu[tau] = 1 + mu Q h. Q is reversible with respect to
    Pi = pi ⊗ ... ⊗ pi, so with y = Pi^(1/2) h the system is
    (I - M Q~ M) y = M Pi^(1/2) 1, Q~ = Pi^(1/2) Q Pi^(-1/2) = ⊗ (D^(1/2) P D^(-1/2))
    symmetric and M the indicator of the states outside A: symmetric positive definite,
    solved by conjugate gradients with Q~ applied along each axis (never formed).

    Parameters
    ----------
    graph, robots, event, start
        As in :func:`first_meeting_distribution`.
    rtol : float
        Relative residual of the solve.
    max_states : int
        Refuse composite chains with more states.

    Raises
    ------
    RuntimeError
        If the solve does not converge.
    """
    n = chain_robots(robots, event)
    _check_states(graph.size, n, max_states)
    s = graph.size
    shape = (s,) * n
    root = np.sqrt(graph.stationary)
    psym = sp.csr_matrix(sp.diags(root) @ graph.transition_matrix @ sp.diags(1.0 / root))
    keep = (~meeting_mask(s, robots, event)).astype(float)
    root_n = _outer(root, n)

    def matvec(x: np.ndarray) -> np.ndarray:
        x = x.reshape(shape)
        return (x - keep * _along_axes(keep * x, psym)).ravel()

    op = LinearOperator((s ** n, s ** n), matvec=matvec, dtype=float)
    y, info = cg(op, (keep * root_n).ravel(), rtol=rtol, atol=0.0, maxiter=100 * s ** n)
    if info != 0:
        raise RuntimeError(f"mean_first_meeting: conjugate gradients did not converge "
                           f"(info {info})")
    qh = _along_axes(keep * y.reshape(shape), psym) / root_n
    mu = composite_start(graph, robots, event, start)
    return float(1.0 + np.sum(mu * qh))


__all__ = ["EVENTS", "MAX_STATES", "STARTS", "FirstMeeting", "chain_robots",
           "composite_start", "elementary_symmetric", "entry_probability",
           "first_meeting_distribution", "mean_first_meeting", "mean_interarrival",
           "mean_time_between_entries", "meeting_mask", "meeting_probability",
           "pair_meeting_probability", "robot_meeting_probability",
           "team_meeting_probability"]
