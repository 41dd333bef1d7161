"""Tracking cooperation of Papaioannou et al. (Sec. V-C b): detecting a tracking overlap.

Two tracking agents i and j whose sensing squares overlap, ``S_a(s_{k-1}^i) cap
S_a(s_{k-1}^j) != empty`` (:func:`squares_overlap`), exchange their predicted estimate sets
and score how alike they are with the OSPA distance of order 2 (eq. 19,
:func:`overlap_increment`). The cumulative score over a window of steps ``[kappa : K]``,

    ``Q = sum_{k = kappa..K} I(S_a(s_{k-1}^i), S_a(s_{k-1}^j)) * DeltaL_k``,

with ``I = 1`` if the squares overlapped at step k and ``inf`` otherwise, is low when the two
agents track the same targets; once ``Q <= Q_th`` one of them, picked at random
(:func:`pick_switcher`), switches to searching. :class:`OverlapWindow` keeps the window of
one pair of agents (Sec. VI-A: window 3, Q_th = 0.9 m).

Units: DeltaL is an OSPA distance between position sets [m], in [0, c]; Q, a sum of
``window`` of them, is in metres too, and ``Q_th = 0.9 m`` over 3 steps is a mean OSPA of
0.3 m per step.

Two readings of the threshold (:data:`THRESHOLD_FORMS`): ``sum``, the printed ``Q <= Q_th``
(the default), and ``mean``, ``Q / window <= Q_th``, Q_th read as a bound on the per-step
DeltaL. Two agents' estimates of one target differ by about the range sd (1 m), so the
smallest one-step DeltaL seen is ~0.36 m and three of them never sum to 0.9 m; the mean
reading is the one under which the test can fire with the paper's sensor
(docs/decisions.md).

The cut-off c of eq. 19 is not given in the paper; it is a parameter, 10 m by default (the
side of the sensing square and the cut-off the repository's OSPA uses elsewhere). The
choice does not change any decision once ``c > Q_th sqrt(n)`` (n the larger set): then
``Q <= Q_th`` forces equal cardinalities at every step (a missing target alone costs
``c / sqrt(n) > Q_th``) and matched distances below c, where the cut-off does not act; so
every such c gives the same score whenever it is at most Q_th. With c = 10 m and
Q_th = 0.9 m that holds up to n = 123 targets.

Readings of the paper:

- The estimates compared are the targets' positions [m] (Q_th is in metres); eq. 19 writes
  ``||x - y||`` of the states, which for the 4-D ``[x, xdot, y, ydot]`` would add m and m/s.
- Eq. 19 needs both sets non-empty (n, m != 0); with an empty set the increment is taken as
  ``inf``: no evidence of an overlap, and the window cannot fire through that step.
- The window is of consecutive steps. A step whose squares do not overlap enters as
  ``inf``, so Q stays ``inf`` until that step has left the window; a gap in the step
  numbers (no push at all) restarts the window, to the same effect.

Reference: S. Papaioannou et al., "A cooperative multi-agent probabilistic framework for
search and track missions", IEEE Trans. Control of Network Systems, 2021, Sec. V-C b,
eq. 19; the OSPA metric of Schuhmacher, Vo & Vo (2008), :mod:`.ospa`.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ...geometry.points import as_points
from ...ospa import ospa

__all__ = ["THRESHOLD_FORMS", "OverlapWindow", "overlap_increment", "pick_switcher",
           "squares_overlap"]

#: Sec. VI-A: the tracking-overlap threshold Q_th [m] and the window length [steps].
Q_THRESHOLD = 0.9
WINDOW = 3
#: What Q_th bounds: the window's sum of DeltaL (as printed) or their mean (per step).
THRESHOLD_FORMS = ("sum", "mean")
#: Default OSPA cut-off c of eq. 19 [m] (not given in the paper; see the module notes).
CUTOFF = 10.0


def _point(name: str, p: object) -> np.ndarray:
    a = np.asarray(p, dtype=float)
    if a.shape != (2,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be a finite position of shape (2,) [m], got "
                         f"{np.asarray(p).tolist()!r}")
    return a


def _positive(name: str, v: object) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {v!r}") from None
    if not (np.isfinite(x) and x > 0.0):
        raise ValueError(f"{name} must be finite and > 0, got {v!r}")
    return x


def _count(name: str, v: object, minimum: int = 0) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {v!r}")
    return int(v)


def squares_overlap(s_i: np.ndarray, s_j: np.ndarray, side: float) -> bool:
    """Whether the closed sensing squares S_a(s_i) and S_a(s_j) intersect.

    Two axis-aligned closed squares of side a meet iff their centres are at most a apart
    along both x and y (touching edges or corners count).

    Parameters
    ----------
    s_i, s_j : np.ndarray, shape (2,)
        Agent positions (square centres) [m].
    side : float
        Side a [m], > 0.
    """
    a = _positive("side", side)
    d = np.abs(_point("s_i", s_i) - _point("s_j", s_j))
    return bool(d[0] <= a and d[1] <= a)


def overlap_increment(x_i: np.ndarray, x_j: np.ndarray, cutoff: float = CUTOFF) -> float:
    """Incremental tracking overlap score DeltaL_k^c of eq. 19 [m].

    With ``m = |X_i| <= n = |X_j|`` (swapped otherwise: the score is symmetric)::

        DeltaL = [ (1/n) ( min_pi sum_{l=1..m} d_c(x_l^i, x_pi(l)^j)^2 + (n - m) c^2 ) ]^(1/2)

    ``d_c(x, y) = min(c, ||x - y||)``, the minimum over injections pi of {1..m} into {1..n}:
    the OSPA distance of order 2 with cut-off c (:func:`.ospa.ospa`).

    Parameters
    ----------
    x_i, x_j : np.ndarray, shape (m, 2) and (n, 2)
        Predicted target positions of agents i and j [m].
    cutoff : float
        c [m], > 0.

    Returns
    -------
    float
        DeltaL in [0, c] [m]; ``inf`` if either set is empty (eq. 19 requires n, m != 0:
        an empty set is no evidence of tracking the same targets).
    """
    c = _positive("cutoff", cutoff)
    a = as_points(x_i, "x_i (estimates of agent i)")
    b = as_points(x_j, "x_j (estimates of agent j)")
    if a.shape[0] == 0 or b.shape[0] == 0:
        return float("inf")
    return ospa(a, b, c=c, p=2.0)


class OverlapWindow:
    """Cumulative tracking overlap score Q of one pair of agents over the last steps.

    Keeps the terms ``I * DeltaL`` of the last ``window`` consecutive steps; Q is their sum
    once the window is full. A step whose number does not follow the previous one restarts
    the window. The caller resets it (:meth:`reset`) once the overlap has been resolved.

    Parameters
    ----------
    window : int
        Number of consecutive steps summed, >= 1 (3, Sec. VI-A).
    cutoff : float
        OSPA cut-off c of eq. 19 [m], > 0.
    """

    def __init__(self, window: int = WINDOW, cutoff: float = CUTOFF) -> None:
        self.window = _count("window", window, minimum=1)
        self.cutoff = _positive("cutoff", cutoff)
        self._terms: deque[float] = deque(maxlen=self.window)
        self._last: int | None = None

    def reset(self) -> None:
        """Forget every step."""
        self._terms.clear()
        self._last = None

    @property
    def score(self) -> float | None:
        """Q [m] over the last ``window`` consecutive steps, or None before they are in."""
        if len(self._terms) < self.window:
            return None
        return float(sum(self._terms))

    def push(self, step: int, overlapping: bool, x_i: np.ndarray | None = None,
             x_j: np.ndarray | None = None) -> float | None:
        """Add step k's term and return Q, or None while the window is not full.

        Parameters
        ----------
        step : int
            Time step k, >= 0, larger than the previous one; a gap restarts the window.
        overlapping : bool
            Whether ``S_a(s_{k-1}^i) cap S_a(s_{k-1}^j) != empty`` (:func:`squares_overlap`).
        x_i, x_j : np.ndarray, shapes (m, 2), (n, 2), or None
            The two agents' predicted target positions [m]; needed only when overlapping
            (the agents exchange them only then).

        Returns
        -------
        float or None
            Q [m] (``inf`` if any step in the window did not overlap or had an empty set).
        """
        k = _count("step", step)
        if self._last is not None and k <= self._last:
            raise ValueError(f"step must increase: got {k} after {self._last}")
        if not isinstance(overlapping, (bool, np.bool_)):
            raise ValueError(f"overlapping must be a bool, got {overlapping!r}")
        if overlapping:
            if x_i is None or x_j is None:
                raise ValueError("x_i and x_j (the two estimate sets) are needed when the "
                                 "sensing squares overlap")
            term = overlap_increment(x_i, x_j, self.cutoff)
        else:
            # I = inf: inf * DeltaL, also when DeltaL = 0 (where IEEE gives NaN).
            term = float("inf")
        if self._last is not None and k != self._last + 1:
            self._terms.clear()
        self._terms.append(term)
        self._last = k
        return self.score

    def detected(self, threshold: float = Q_THRESHOLD, form: str = "sum") -> bool:
        """True when the window is full and Q is within the threshold.

        Parameters
        ----------
        threshold : float
            Q_th [m], >= 0 (0.9 in Sec. VI-A).
        form : {"sum", "mean"}
            ``sum``: ``Q <= Q_th`` (Sec. V-C b as printed); ``mean``: ``Q / window <= Q_th``,
            the mean DeltaL of the window's steps.
        """
        t = float(threshold)
        if not (np.isfinite(t) and t >= 0.0):
            raise ValueError(f"threshold (Q_th) must be finite and >= 0 [m], got {threshold!r}")
        if form not in THRESHOLD_FORMS:
            raise ValueError(f"form must be one of {THRESHOLD_FORMS}, got {form!r}")
        q = self.score
        if q is None:
            return False
        return (q if form == "sum" else q / self.window) <= t


def pick_switcher(seed: int, step: int, id_a: int, id_b: int) -> int:
    """The agent of the pair that switches to searching (Sec. V-C b: "picked at random").

    Both agents compute the same answer without another exchange: a fair bit from the hash of
    ``(seed, step, min id, max id)`` by :class:`numpy.random.SeedSequence` (its
    ``generate_state``, which numpy keeps stable across versions and which does not depend on
    a generator's sampling algorithm), so it is symmetric in the order of the two ids and
    reproducible from the run's seed.

    Parameters
    ----------
    seed : int
        The run's seed, >= 0.
    step : int
        Time step k of the decision, >= 0.
    id_a, id_b : int
        The two agents' ids, >= 0, distinct.

    Returns
    -------
    int
        ``id_a`` or ``id_b``.
    """
    seed = _count("seed", seed)
    step = _count("step", step)
    a, b = _count("id_a", id_a), _count("id_b", id_b)
    if a == b:
        raise ValueError(f"the two agents must differ, got id {a} twice")
    lo, hi = min(a, b), max(a, b)
    bit = int(np.random.SeedSequence([seed, step, lo, hi]).generate_state(1)[0]) & 1
    return hi if bit else lo
