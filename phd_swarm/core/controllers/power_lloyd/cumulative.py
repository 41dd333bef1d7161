"""Cumulative target density (Gamma-Poisson) and power weights of Chen, Dames & Park (2021).

Sec. 3.2: each bin x keeps a Gamma posterior over "the expected number of targets found at
x", with shape alpha(x) (the total reward) and beta(x), "the inverse of the number of
historical observations". Initially alpha = 0 and beta = inf (Alg. 1 line 3). A robot that
receives a scan Z_i updates every bin x of its field of view F_i (eq. 9-10)::

    alpha(x) <- alpha(x) + rw,   beta(x) <- (beta(x)^-1 + 1)^-1,   rw = 1 if |Z_i| > 0 else 0,

so beta = 1/n after n observations. We store the observation count ``n`` (an integer,
0 initially) instead of beta: it is exact, and it avoids carrying inf.

The cumulative weight wc is the mode of the Gamma distribution (eq. 11), written in the
paper as ``(alpha - 1) / beta`` for alpha >= 1, else 0. With beta = 1/n that is
``(alpha - 1) * n``, which grows without bound with the number of observations (a bin
watched 1000 times with 500 rewards scores about 5e5), and ranks a bin watched often with
few rewards above one watched rarely with many. The paper's eq. 8 treats beta as a *rate*
while eq. 9 makes it a *scale*; the conjugate Gamma-Poisson posterior of a Poisson rate
(prior shape 0, rate 0, then one count rw per observation) has shape alpha and rate n, and
its mode is ``(alpha - 1) / n``: the long-run fraction of observations of x that found
something, in [0, 1). Two modes are provided:

- ``"rate"`` (default): ``(alpha - 1) / n`` for alpha >= 1 and n > 0, else 0;
- ``"literal"``: ``(alpha - 1) * n`` for alpha >= 1, else 0 (eq. 11 as printed);
- ``"laplace"``: ``(alpha + 1) / (n + 2)``, Laplace's rule of succession: the posterior
  mean of the probability that an observation of x finds something, under a uniform prior.
  An unobserved bin weighs 1/2 instead of 0, so an idle robot (Alg. 1 line 13) is drawn to
  unexplored space as well as to clusters, and away from space that was searched and found
  empty. Not in the paper; see docs/decisions.md for why it exists.

Power weights (Sec. 3.4, eq. 12-14): robot i's power cell uses ``||x - q_i||^2 - rho_i^2``
with ``rho_i = (mass_i)^(-1/2)``, where mass_i is the sum of wc over its cell (eq. 13,
Chen's "O" method) or of the PHD over its cell (eq. 14, the "P" method). The paper puts no
bound on rho; an unbounded rho empties its neighbours' cells. Two bounds are provided:
a fixed cap (:func:`power_weight`'s ``rho_max``) and the paper's uncapped weight guarded
at the partition by the distance to the nearest other robot (:func:`nearest_robot_cap`),
which keeps every robot in its own cell.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ...geometry.grid import Grid

MODES = ("rate", "literal", "laplace")


def _check_state(alpha: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(alpha, dtype=float)
    cnt = np.asarray(n)
    if a.ndim != 1:
        raise ValueError(f"alpha must have shape (K,), got {a.shape}")
    if cnt.shape != a.shape:
        raise ValueError(f"n must have the shape of alpha {a.shape}, got {cnt.shape}")
    if not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError("alpha must contain finite values >= 0")
    if cnt.dtype == bool or not np.issubdtype(cnt.dtype, np.number):
        raise ValueError(f"n must be numeric observation counts, got dtype {cnt.dtype}")
    cnt_f = cnt.astype(float)
    if not np.all(np.isfinite(cnt_f)) or np.any(cnt_f < 0) or np.any(cnt_f != np.round(cnt_f)):
        raise ValueError("n must contain whole numbers >= 0 (observation counts)")
    return a, cnt.astype(np.int64)


def cumulative_update_counts(alpha: np.ndarray, n: np.ndarray, observations: np.ndarray,
                             rewards: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Several scans' updates of the cumulative state at once (Chen eq. 9-10); pure.

    ``alpha += rewards`` and ``n += observations``, where ``observations`` counts the scans
    whose field of view held each bin and ``rewards`` those of them with a measurement.
    Chen applies eq. 9 to x in F_i, while Alg. 1 line 9 writes x in W_i (the robot's cell):
    the caller counts the bins it stores. Several scans covering a bin in one step are
    several observations. alpha, n and the rewards are whole numbers (exact in float64
    below 2**53), so adding them in one sum or one scan at a time gives the same floats.

    Parameters
    ----------
    alpha : np.ndarray, shape (K,)
        Total reward per bin (>= 0).
    n : np.ndarray, shape (K,)
        Number of observations per bin (whole numbers >= 0).
    observations, rewards : np.ndarray of int, shape (K,)
        Scans that observed each bin, and those of them that held a measurement
        (0 <= rewards <= observations).

    Returns
    -------
    alpha : np.ndarray, shape (K,), float
        New total rewards.
    n : np.ndarray, shape (K,), int64
        New observation counts.
    """
    a, cnt = _check_state(alpha, n)
    obs = np.asarray(observations)
    rew = np.asarray(rewards)
    if obs.shape != a.shape or rew.shape != a.shape:
        raise ValueError(f"observations and rewards must have the shape of alpha {a.shape}, "
                         f"got {obs.shape} and {rew.shape}")
    if not (np.issubdtype(obs.dtype, np.integer) and np.issubdtype(rew.dtype, np.integer)):
        raise ValueError("observations and rewards must be integer counts")
    if np.any(rew < 0) or np.any(rew > obs):
        raise ValueError("rewards must lie in [0, observations]")
    return a + rew, cnt + obs


def observe_scans(grid: Grid, radius: float, alpha: np.ndarray, n: np.ndarray,
                  scans: Iterable[tuple[np.ndarray, np.ndarray]]) -> None:
    """Chen eq. 9-10 over the whole map, in place.

    One observation per scan of each bin in its field of view, and one reward there if the
    scan holds a measurement.

    Parameters
    ----------
    grid : Grid
        The bin grid.
    radius : float
        Sensing radius [m] (the field of view is :meth:`Grid.disk_bins`).
    alpha : np.ndarray, shape (size,)
        Rewards per bin (float), updated in place.
    n : np.ndarray of int, shape (size,)
        Observations per bin, updated in place.
    scans : iterable of (sensor (2,), z (M, 2))
        The scans of one or more steps; the counts are integers, so their order does not
        matter.
    """
    for sensor, z in scans:
        fov = grid.disk_bins(sensor, radius)
        n[fov] += 1
        if len(z):
            alpha[fov] += 1.0


def cumulative_weight(alpha: np.ndarray, n: np.ndarray, mode: str = "rate") -> np.ndarray:
    """Cumulative weight wc per bin, the mode of the Gamma posterior (Chen eq. 11).

    Parameters
    ----------
    alpha : np.ndarray, shape (K,)
        Total reward per bin.
    n : np.ndarray, shape (K,)
        Number of observations per bin (beta = 1/n).
    mode : str
        ``"rate"``: ``(alpha - 1) / n`` if alpha >= 1 and n > 0, else 0; in [0, 1) when
        alpha <= n, which eq. 9-10 guarantee (one reward at most per observation).
        ``"literal"``: ``(alpha - 1) * n`` if alpha >= 1, else 0 (eq. 11 with beta = 1/n;
        unbounded in n). ``"laplace"``: ``(alpha + 1) / (n + 2)`` (not eq. 11: the rule of
        succession, 1/2 for an unobserved bin). See the module docstring.

    Returns
    -------
    np.ndarray, shape (K,)
        wc per bin (dimensionless, >= 0).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    a, cnt = _check_state(alpha, n)
    excess = a - 1.0
    if mode == "literal":
        return np.where(a >= 1.0, excess * cnt, 0.0)
    if mode == "laplace":
        return (a + 1.0) / (cnt + 2.0)
    valid = (a >= 1.0) & (cnt > 0)
    # Dividing by max(n, 1) keeps the discarded branch of np.where free of 0-division.
    return np.where(valid, excess / np.maximum(cnt, 1), 0.0)


def power_weight(mass: float | np.ndarray, rho_max: float) -> float | np.ndarray:
    """Power weight rho = min(mass^(-1/2), rho_max) of a robot's cell (Chen eq. 13-14) [m].

    ``mass`` is the expected number of targets in the cell: the sum of wc over the cell
    for eq. 13 (Chen's "O" method) or the sum of the PHD over the cell for eq. 14 (the "P"
    method). The paper reads ``mass^(-1/2)`` directly as a length in the power distance
    ``||x - q||^2 - rho^2`` [m^2], i.e. one expected target corresponds to rho = 1 m.
    The PHD grid weights are already masses; wc is a per-bin value that Chen Sec. 3.3
    treats as a density, so the caller decides whether to scale its sum by the bin area.

    A cell with no expected targets (mass <= 0, or a mass so small that mass^(-1/2)
    exceeds ``rho_max``) gets ``rho_max`` rather than inf: a robot that expects no targets
    gets the largest cell it can have, which is the paper's intent ("robots in areas with
    lower expected target density are assigned larger areas to explore"), while the
    partition stays finite and well defined. The environment diagonal D is a natural cap
    for a centralised partition because it is E's own length scale: with
    rho_i = D, ``||x - q_i||^2 - rho_i^2 <= 0`` at every x in E, so robot i claims all of
    E against a neighbour with rho = 0 and most of it against neighbours expecting about
    one target (rho = 1 m); a larger cap only lets an empty-handed robot take even more.

    Parameters
    ----------
    mass : float or np.ndarray
        Expected number of targets per cell (any shape); +inf gives 0.
    rho_max : float
        Cap [m], finite and > 0.

    Returns
    -------
    float or np.ndarray
        rho [m] in [0, rho_max]; a float for a scalar ``mass``, else an array of its shape.

    Raises
    ------
    ValueError
        If ``mass`` contains NaN or ``rho_max`` is not finite and positive.
    """
    if not (np.isfinite(rho_max) and rho_max > 0):
        raise ValueError(f"rho_max must be a finite number > 0, got {rho_max!r}")
    m = np.asarray(mass, dtype=float)
    if np.any(np.isnan(m)):
        raise ValueError("mass must not contain NaN")
    positive = m > 0
    # mass^-0.5 on a placeholder of 1 where mass <= 0 avoids 0^-0.5 = inf warnings; for
    # tiny positive masses it stays finite (5e-324^-0.5 = 4.4e161) and the cap applies.
    rho = np.where(positive, np.minimum(np.where(positive, m, 1.0) ** -0.5, rho_max),
                   float(rho_max))
    return float(rho) if rho.ndim == 0 else rho


def nearest_robot_cap(positions: np.ndarray, rho: np.ndarray,
                      margin: float = 0.0) -> np.ndarray:
    """Bound each power weight by the distance to the robot's nearest other robot [m].

    The guard of the uncapped power weight rho = mass^(-1/2) (Chen eq. 13-14), applied
    where the partition is computed, at the positions it is computed for::

        rho'_k = min(rho_k, g(D_k)),   g(D) = sqrt(max(0, D^2 - 2 m D)),

    with D_k = min_{j != k} ||q_j - q_k|| and m = ``margin`` >= 0 (m = 0: rho'_k <= D_k).

    What it guarantees (power distance d_k(x) = ||x - q_k||^2 - rho'_k^2, Chen eq. 12;
    cell W_r = {x : d_r(x) <= d_k(x) for all k}):

    1. Every generator lies in its own cell, so no cell is empty. For r != k let
       D = ||q_r - q_k|| >= D_k. Then rho'_k <= g(D_k) <= D_k <= D, so
       d_k(q_r) = D^2 - rho'_k^2 >= 0 >= -rho'_r^2 = d_r(q_r): rho'_k^2 - rho'_r^2 <= D^2
       for every pair, and q_r is in W_r. With rho'_r > 0 the inequality is strict, and
       W_r holds a disk around q_r (intersected with E): its area is > 0.
    2. With m > 0, W_r holds every x of E with ||x - q_r|| < min(m, D_r / 2), and owns it
       outright (no tie). W_r is cut by the half-planes (x - q_r) . u_k <= h_k,
       u_k = (q_k - q_r) / D, h_k = (D^2 + rho'_r^2 - rho'_k^2) / (2 D)
       (:func:`phd_swarm.core.geometry.partition.cells`). g is non-decreasing, so
       rho'_k^2 <= g(D)^2. If D >= 2m, h_k >= (D^2 - (D^2 - 2 m D)) / (2 D) = m; if D < 2m,
       then D_k <= D < 2m, g(D_k) = 0, rho'_k = 0 and h_k >= D / 2 >= D_r / 2. So
       h_k >= min(m, D_r / 2) > (x - q_r) . u_k for every k. With m = the bin side, a
       robot whose nearest other robot is more than sqrt(2) bin sides away owns the bin
       it stands in (whose centre is within sqrt(2)/2 bin sides of it). Point 1 alone
       does not give a bin: a cell squeezed between two heavier neighbours can be a strip
       thinner than a bin.

    Coincident robots (D_k = 0) get rho' = 0, and the lower index takes the shared point
    (:func:`~phd_swarm.core.geometry.ownership.assign_bins`). A robot alone keeps its rho.

    Parameters
    ----------
    positions : np.ndarray, shape (R, 2)
        Generators q [m] at the partition.
    rho : np.ndarray, shape (R,)
        Power weights [m], >= 0 and finite.
    margin : float
        m [m], >= 0.

    Returns
    -------
    np.ndarray, shape (R,)
        rho' [m], a new array; rho' <= rho.
    """
    q = np.asarray(positions, dtype=float)
    w = np.asarray(rho, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or w.shape != (q.shape[0],):
        raise ValueError(f"positions must have shape (R, 2) and rho shape (R,), got "
                         f"{q.shape} and {w.shape}")
    if not (np.isfinite(margin) and margin >= 0):
        raise ValueError(f"margin must be a finite number >= 0, got {margin!r}")
    if q.shape[0] < 2:
        return w.copy()
    d2 = np.sum((q[:, None, :] - q[None, :, :]) ** 2, axis=-1)
    np.fill_diagonal(d2, np.inf)
    nearest = np.sqrt(d2.min(axis=1))
    bound = np.sqrt(np.maximum(0.0, nearest * nearest - 2.0 * margin * nearest))
    return np.minimum(w, bound)


def cell_mass(values: np.ndarray, bin_area: float, kind: str) -> float:
    """Expected number of targets in a cell, the argument of :func:`power_weight`.

    ``kind="cumulative"`` (Chen eq. 13, the "O" method): wc is a per-bin rate that Chen
    Sec. 3.3 treats as a density, so the cell mass is ``sum(wc) * bin_area``; with it rho
    does not depend on the grid resolution, and at 1 m bins it equals the paper's plain sum.
    ``kind="phd"`` (eq. 14, the "P" method): PHD weights are already masses, summed as is.

    Parameters
    ----------
    values : np.ndarray, shape (K,)
        wc or PHD weights of the bins the robot owns.
    bin_area : float
        Area of one bin [m^2].
    kind : {"cumulative", "phd"}
        Which weights ``values`` are.

    Returns
    -------
    float
        Cell mass (expected targets), >= 0 for valid inputs.
    """
    total = float(np.sum(np.asarray(values, dtype=float)))
    if kind == "cumulative":
        return total * bin_area
    if kind == "phd":
        return total
    raise ValueError(f"cell_mass: kind must be 'cumulative' or 'phd', got {kind!r}")


def chen_lloyd_weights(has_measurement: bool, phd_w: np.ndarray,
                       wc: np.ndarray) -> np.ndarray:
    """Choose the importance weights phi over a robot's cell (Chen Alg. 1 lines 12-15).

    An idle robot (empty scan, Z_i = {}) follows the cumulative weight wc to search where
    targets have been found before; a busy robot (non-empty scan) follows the PHD to track
    the targets it sees.

    Parameters
    ----------
    has_measurement : bool
        Whether the robot's latest scan is non-empty.
    phd_w : np.ndarray, shape (K,)
        PHD masses over the cell's bins (wi).
    wc : np.ndarray, shape (K,)
        Cumulative weights over the same bins.

    Returns
    -------
    np.ndarray, shape (K,)
        A new array: ``phd_w`` if ``has_measurement`` else ``wc``.
    """
    if not isinstance(has_measurement, (bool, np.bool_)):
        raise ValueError(f"has_measurement must be a bool, got {has_measurement!r}")
    phd = np.asarray(phd_w, dtype=float)
    cum = np.asarray(wc, dtype=float)
    if phd.shape != cum.shape:
        raise ValueError(f"phd_w {phd.shape} and wc {cum.shape} must have the same shape")
    return np.array(phd if has_measurement else cum, dtype=float, copy=True)
