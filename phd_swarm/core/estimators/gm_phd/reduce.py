"""Pruning, merging and capping of a Gaussian mixture (Vo & Ma 2006, Table II), on arrays.

:func:`reduce_components` is the reduction of :func:`.gm_phd.filter.prune_and_merge`, on the
mixture's plain arrays. Two merge tests are offered (``merge_metric``), the two readings of
"within U of the heaviest component j" found in Vo's own work:

- ``candidate``: ``(m_i - m_j)^T P_i^-1 (m_i - m_j) <= U``, each candidate i in its own
  metric, as Table II prints it;
- ``heaviest``: ``(m_i - m_j)^T P_j^-1 (m_i - m_j) <= U``, every candidate in the metric of
  the heaviest remaining component j, the test of Vo's published MATLAB ``gaus_merge.m``
  (``iPt = inv(P(:,:,j))``, one inverse per group). Only the test: the merged covariance
  is Table II's moment-matched one under both rules (``gaus_merge.m`` leaves out the
  spread of the means, ``(m - m_i)(m - m_i)^T``).

They differ when the covariances do: under ``candidate`` a wide component (a birth prior, a
long-unseen target) merges into a tight, heavy one far outside that one's spread, and the
merged covariance grows to the wide one's scale; under ``heaviest`` it stays apart unless it
lies within U of the heavy one in the heavy one's metric, and conversely a tight component
near a wide heavy one merges under ``heaviest`` and not under ``candidate``.
docs/estimators.md compares them with Stone Soup's rule; docs/decisions.md records which
reading each preset uses.

Reference: B.-N. Vo and W.-K. Ma, "The Gaussian mixture probability hypothesis density
filter", IEEE Trans. Signal Processing 54(11), 2006, Table II.
"""

from __future__ import annotations

import numpy as np

from ...params import ParamSpec

__all__ = ["MERGE_METRICS", "MERGE_METRIC_OPTION", "carry", "check_merge_metric",
           "reduce_components", "reduce_with_sources"]

#: The merge tests: the metric of the heaviest component j, or of each candidate i.
MERGE_METRICS = ("heaviest", "candidate")

#: The ``merge_metric`` option of the parts that reproduce a paper citing Vo & Ma for the
#: reduction without printing its merge test (``sung_gmphd``, ``shirsat_gmphd``). Their
#: default is ``heaviest``, the test of Vo's own published code (docs/decisions.md); one
#: declaration, so that the parts and docs/parameters.md agree.
MERGE_METRIC_OPTION = ParamSpec(
    "merge_metric", "heaviest", "sung_gmphd, shirsat_gmphd: whose covariance the merge "
    "test's squared Mahalanobis distance is measured in: the heaviest component's "
    "(heaviest, Vo's MATLAB gaus_merge.m; the papers print no rule) or each candidate's "
    "(candidate, Vo & Ma Table II as printed)", choices=MERGE_METRICS)

#: Up to this many components (after pruning) the merge distances of all pairs are
#: computed at once, (J, J) of them; above it, one column per group (memory ~ J d^2).
_PAIRWISE_MAX = 256


def check_merge_metric(value: str, name: str = "merge_metric") -> str:
    """``value`` if it is one of :data:`MERGE_METRICS`, else a ``ValueError`` naming ``name``."""
    if not isinstance(value, str) or value not in MERGE_METRICS:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, MERGE_METRICS))}, "
                         f"got {value!r}")
    return value


def reduce_components(weights: np.ndarray, means: np.ndarray, covs: np.ndarray,
                      prune: float, merge: float, cap: int,
                      metric: str = "candidate") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Prune, merge and cap a mixture's components (Vo & Ma Table II).

    Components with weight <= ``prune`` (T) are dropped; their mass is not redistributed,
    as in the paper. Then, repeatedly, the heaviest remaining component j (ties to the
    lowest index) and every remaining i within ``merge`` (U) of it, in the metric chosen by
    ``metric`` (module docstring), merge into one with the summed weight, the weighted mean
    and the moment-matched covariance ``sum_i w_i (P_i + (m - m_i)(m - m_i)^T) / w``. The
    ``cap`` (J_max) heaviest groups are kept, heaviest first.

    Parameters
    ----------
    weights : np.ndarray, shape (J,)
    means : np.ndarray, shape (J, d)
    covs : np.ndarray, shape (J, d, d)
        The components, covariances symmetric positive definite.
    prune : float
        T, the pruning weight threshold [-].
    merge : float
        U, the bound on the squared Mahalanobis distance [-].
    cap : int
        J_max, the most components kept.
    metric : {"candidate", "heaviest"}
        Whose covariance the merge test's distance is measured in.

    Returns
    -------
    weights (K,), means (K, d), covs (K, d, d)
        K <= J_max components, heaviest first (stable among equal weights).
    """
    w, m, p, _ = _reduce(weights, means, covs, prune, merge, cap, metric, False)
    return w, m, p


def reduce_with_sources(weights: np.ndarray, means: np.ndarray, covs: np.ndarray,
                        prune: float, merge: float, cap: int, metric: str = "candidate"
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`reduce_components`, and where each input component went.

    The same components, bit for bit, and ``source`` (J,) int: the row of the output that
    input component i was merged into, -1 if it was pruned (weight <= T) or its group was
    capped away (beyond J_max). What the inputs carry (:func:`carry`) follows them.
    """
    return _reduce(weights, means, covs, prune, merge, cap, metric, True)


def carry(source: np.ndarray, values: np.ndarray, rows: int) -> np.ndarray:
    """Sum ``values`` (J, ...) of the inputs of a reduction into its ``rows`` outputs.

    ``source`` (J,) is :func:`reduce_with_sources`'s; inputs with source -1 are dropped.
    The sums are taken in input order (``np.add.at``), so they are deterministic.

    Returns
    -------
    np.ndarray, shape (rows, ...)
    """
    values = np.asarray(values, dtype=float)
    out = np.zeros((rows, *values.shape[1:]))
    kept = source >= 0
    np.add.at(out, source[kept], values[kept])
    return out


def _reduce(weights: np.ndarray, means: np.ndarray, covs: np.ndarray, prune: float,
            merge: float, cap: int, metric: str, want_sources: bool
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """:func:`reduce_components`, with the inputs' output rows if ``want_sources``."""
    check_merge_metric(metric)
    keep = weights > prune
    w, m, p = weights[keep], means[keep], covs[keep]
    source = np.full(weights.shape[0], -1) if want_sources else None
    if w.size == 0:
        return w, m, p, source
    n = w.size
    labels = np.full(n, -1)
    taken = np.zeros(n, dtype=bool)
    n_groups = 0
    order = np.argsort(-w, kind="stable")
    close = p_inv = None
    if n <= _PAIRWISE_MAX:
        # All pairs at once, close[i, j] = (m_i - m_j)^T A (m_i - m_j) <= U with A = P_i^-1
        # (candidate) or P_j^-1 (heaviest, j the group's leader); when no two components
        # are close (most steps of a search, far from the sensor) every component is its
        # own group, in weight order, and the loop is skipped.
        p_inv = np.linalg.inv(p)
        diff = m[:, None, :] - m[None, :, :]
        spec = "ijd,ide,ije->ij" if metric == "candidate" else "ijd,jde,ije->ij"
        close = np.einsum(spec, diff, p_inv, diff) <= merge
        if np.count_nonzero(close) == n:
            if want_sources:
                # Every component its own group: output row r is input order[r].
                source[np.flatnonzero(keep)[order[:cap]]] = np.arange(min(cap, n))
            return (*_singletons(w, m, p, order[:cap]), source)
    elif metric == "candidate":
        p_inv = np.linalg.inv(p)
    # Greedy grouping: the heaviest component not yet taken (argmax: the lowest index among
    # equal weights) takes every remaining i within U of it. Only the group labels are
    # found in this loop, one cheap pass per group over all J; the moments of all groups
    # are then computed at once.
    for j in order:
        if taken[j]:
            continue
        if close is not None:
            group = close[:, j] & ~taken
        else:
            diff = m - m[j]
            if metric == "candidate":
                dist = np.einsum("ni,nik,nk->n", diff, p_inv, diff)
            else:
                dist = np.einsum("ni,ik,nk->n", diff, np.linalg.inv(p[j]), diff)
            group = (dist <= merge) & ~taken
        group[j] = True
        labels[group] = n_groups
        taken |= group
        n_groups += 1
    by_group = np.argsort(labels, kind="stable")
    starts = np.searchsorted(labels[by_group], np.arange(n_groups))
    wg, mg, pg = w[by_group], m[by_group], p[by_group]
    w_sum = np.add.reduceat(wg, starts)
    mean = np.add.reduceat(wg[:, None] * mg, starts) / w_sum[:, None]
    dm = mean[labels[by_group]] - mg
    spread = wg[:, None, None] * (pg + dm[:, :, None] * dm[:, None, :])
    cov = np.add.reduceat(spread, starts) / w_sum[:, None, None]
    cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))
    order = np.argsort(-w_sum, kind="stable")[:cap]
    if want_sources:
        row = np.full(n_groups, -1)
        row[order] = np.arange(order.size)
        source[np.flatnonzero(keep)] = row[labels]
    return w_sum[order], mean[order], cov[order], source


def _singletons(w: np.ndarray, m: np.ndarray, p: np.ndarray,
                order: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`reduce_components`'s result when every component is its own group.

    The same arithmetic as the general path on groups of one (``(w m) / w``, the
    moment-matched covariance, the symmetrisation), bit for bit, without the grouping:
    ``order`` is the components by decreasing weight (stable), capped at J_max.
    """
    wg, mg, pg = w[order], m[order], p[order]
    mean = (wg[:, None] * mg) / wg[:, None]
    dm = mean - mg
    cov = wg[:, None, None] * (pg + dm[:, :, None] * dm[:, None, :]) / wg[:, None, None]
    return wg, mean, 0.5 * (cov + np.swapaxes(cov, -1, -2))
