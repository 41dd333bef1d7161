"""Many robots' 2-D Gaussian mixtures at once: prediction, pruning and merging, row by row.

Shirsat & Berman's robots each run a small GM-PHD filter (a handful of components), so a
robot's step is dominated by numpy's per-call cost, not by arithmetic. Here the R robots'
mixtures are held in one padded array (:class:`PaddedMixtures`, row r = robot r) and each
step of Vo & Ma's filter is done for all rows with one set of numpy calls.

**Row independence.** A robot alone (a ROS node, R = 1) and the same robot in a team
(the in-memory engine, R = 20) must compute the same bits. Every operation here is
therefore elementwise, or a per-row argmax/argsort, or an addition into a row's own
accumulators in a fixed order; nothing reduces along an axis whose length depends on the
batch (a numpy ``sum`` over a padded axis would group its terms by the padded length).
``test/core/estimators/gm_phd/test_team.py`` checks a batch against its rows one at a time,
bit for bit.

**Equal to :mod:`.gm_phd.filter`.** :func:`prune_and_merge_rows` is Vo & Ma's Table II exactly as
:func:`.gm_phd.filter.prune_and_merge` computes it, under either merge metric, bit for bit, with
one exception: the merge test's squared Mahalanobis distance is written out elementwise
(``dx A00 dx + dx A01 dy + dy A10 dx + dy A11 dy``, left to right, A = P_i^-1 or P_j^-1
from LAPACK),
where :func:`.gm_phd.filter.prune_and_merge` lets ``einsum`` choose an order that depends on the
number of components. The two distances differ at most in the last bit, so a merge
decision differs only for a distance within a rounding error of U. The group sums
reproduce ``np.add.reduceat`` (the group's first member plus numpy's pairwise sum of the
others: sequential below 8 terms, eight accumulators up to 128, halves above;
:func:`_reduceat_sums`), and :func:`predict_rows` is :func:`.gm_phd.filter.predict` for F = I
(Shirsat & Berman's static targets), written out for any F.

Reference: B.-N. Vo and W.-K. Ma, "The Gaussian mixture probability hypothesis density
filter", IEEE T-SP 54(11), 2006, Tables I-II.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .filter import GaussianMixture
from .reduce import check_merge_metric

__all__ = ["PaddedMixtures", "predict_rows", "prune_and_merge_rows"]

#: numpy's pairwise summation: a plain loop below this many terms (``PW_BLOCKSIZE`` 128
#: and 8 accumulators above it, numpy/_core/src/umath/loops_utils.h.src).
_PW_LOOP = 8
_PW_BLOCK = 128


@dataclass
class PaddedMixtures:
    """R mixtures of 2-D components in one array; row r holds ``count[r]`` components first.

    Attributes
    ----------
    weights : np.ndarray, shape (R, J)
    means : np.ndarray, shape (R, J, 2) [m]
    covs : np.ndarray, shape (R, J, 2, 2) [m^2]
    count : np.ndarray of int, shape (R,)
        Components of each row; slots from ``count[r]`` on are padding (weight 0, mean 0,
        covariance I, never read as components).
    """

    weights: np.ndarray
    means: np.ndarray
    covs: np.ndarray
    count: np.ndarray

    @classmethod
    def empty(cls, rows: int, width: int) -> PaddedMixtures:
        """``rows`` empty rows with room for ``width`` components each."""
        covs = np.zeros((rows, width, 2, 2))
        covs[..., 0, 0] = covs[..., 1, 1] = 1.0
        return cls(np.zeros((rows, width)), np.zeros((rows, width, 2)), covs,
                   np.zeros(rows, dtype=np.int64))

    @classmethod
    def from_mixtures(cls, mixtures: Sequence[GaussianMixture],
                      width: int | None = None) -> PaddedMixtures:
        """Rows from mixtures (copied), padded to ``width`` (default: the longest)."""
        counts = np.array([len(m) for m in mixtures], dtype=np.int64)
        width = int(counts.max(initial=0)) if width is None else int(width)
        out = cls.empty(len(mixtures), width)
        out.count[:] = counts
        for r, mix in enumerate(mixtures):
            n = counts[r]
            if n:
                out.weights[r, :n] = mix.weights
                out.means[r, :n] = mix.means
                out.covs[r, :n] = mix.covs
        return out

    @property
    def valid(self) -> np.ndarray:
        """Which slots hold components, shape (R, J) bool."""
        return np.arange(self.weights.shape[1]) < self.count[:, None]

    def row(self, r: int) -> GaussianMixture:
        """Row ``r`` as a mixture (copies)."""
        n = int(self.count[r])
        return GaussianMixture(self.weights[r, :n].copy(), self.means[r, :n].copy(),
                               self.covs[r, :n].copy())

    def set_row(self, r: int, mix: GaussianMixture) -> None:
        """Put ``mix`` in row ``r`` (it must fit)."""
        n = len(mix)
        self.count[r] = n
        self.weights[r, :n] = mix.weights
        self.means[r, :n] = mix.means
        self.covs[r, :n] = mix.covs
        self.weights[r, n:] = 0.0


def predict_rows(mixes: PaddedMixtures, f: np.ndarray, q: np.ndarray,
                 p_s: float) -> PaddedMixtures:
    """Survivors of every row: ``w p_S``, ``F m``, ``F P F^T + Q`` (Vo & Ma Table I step 2).

    Written out entry by entry for a 2 x 2 F, so that each row's numbers do not depend on
    the others; for F = I they equal :func:`.gm_phd.filter.predict`'s matrix products.
    """
    f = np.asarray(f, dtype=float)
    m0, m1 = mixes.means[..., 0], mixes.means[..., 1]
    means = np.stack([f[0, 0] * m0 + f[0, 1] * m1, f[1, 0] * m0 + f[1, 1] * m1], axis=-1)
    p = mixes.covs
    fp = np.empty_like(p)                                     # F P
    for i in range(2):
        for k in range(2):
            fp[..., i, k] = f[i, 0] * p[..., 0, k] + f[i, 1] * p[..., 1, k]
    covs = np.empty_like(p)                                   # F P F^T + Q
    for i in range(2):
        for j in range(2):
            covs[..., i, j] = (fp[..., i, 0] * f[j, 0] + fp[..., i, 1] * f[j, 1]) + q[i, j]
    return PaddedMixtures(p_s * mixes.weights, means, covs, mixes.count.copy())


def prune_and_merge_rows(mixes: PaddedMixtures, prune: float, merge: float,
                         cap: int, metric: str = "candidate", *, with_leads: bool = False
                         ) -> list[GaussianMixture] | tuple[list[GaussianMixture],
                                                            list[np.ndarray]]:
    """Vo & Ma Table II for every row: :func:`.filter.prune_and_merge` (see the module docstring).

    Components with weight <= ``prune`` are dropped; then, repeatedly, the heaviest
    remaining component j of a row (ties to the lowest index) and every remaining i of the
    row with ``(m_i - m_j)^T A (m_i - m_j) <= merge`` become one component with the
    summed weight, the weighted mean and the moment-matched covariance; the ``cap``
    heaviest groups are kept, heaviest first. A is P_i^-1 (``metric = candidate``, Table II
    as printed) or P_j^-1 (``heaviest``, Vo's ``gaus_merge.m``; :mod:`.gm_phd.reduce`).

    Returns
    -------
    list of GaussianMixture
        One per row.
    list of np.ndarray of int64, only with ``with_leads``
        Per row, the slot (index in the row of ``mixes``) of each output component's lead,
        the heaviest component of its group (what a label carried by the components
        follows: :mod:`.shirsat.labels`).
    """
    check_merge_metric(metric)
    rows, width = mixes.weights.shape
    keep = mixes.valid & (mixes.weights > prune)
    if not keep.any():
        empty = [GaussianMixture.empty(2) for _ in range(rows)]
        return (empty, [np.empty(0, dtype=np.int64)] * rows) if with_leads else empty
    w, m, p = mixes.weights, mixes.means, mixes.covs
    # Squared Mahalanobis distance of component i from component j in the metric of P_i
    # (candidate) or P_j (heaviest), close[r, i, j]; dropped and padding slots are never
    # close to anything.
    a = np.linalg.inv(np.where(keep[..., None, None], p, np.eye(2)))
    a = a[:, :, None] if metric == "candidate" else a[:, None, :]
    dx = m[:, :, None, 0] - m[:, None, :, 0]                  # (R, i, j)
    dy = m[:, :, None, 1] - m[:, None, :, 1]
    a00, a01 = a[..., 0, 0], a[..., 0, 1]
    a10, a11 = a[..., 1, 0], a[..., 1, 1]
    dist = dx * a00 * dx + dx * a01 * dy + dy * a10 * dx + dy * a11 * dy
    close = (dist <= merge) & keep[:, :, None] & keep[:, None, :]
    # Greedy grouping, every row at once: each round, the heaviest component not yet
    # taken in each row (argmax: the lowest index among equal weights) takes the row's
    # untaken components close to it.
    labels = np.full((rows, width), -1, dtype=np.int64)
    free = np.where(keep, w, -np.inf)
    everyone = np.arange(rows)
    n_groups = np.zeros(rows, dtype=np.int64)
    lead_slot = np.full((rows, width), -1, dtype=np.int64)
    while True:
        live = np.flatnonzero(free.max(axis=1) > -np.inf)
        if not live.size:
            break
        lead = free[live].argmax(axis=1)
        group = close[live, :, lead] & (labels[live] < 0)
        group[np.arange(live.size), lead] = True
        labels[live] = np.where(group, n_groups[live, None], labels[live])
        free[live] = np.where(group, -np.inf, free[live])
        lead_slot[live, n_groups[live]] = lead
        n_groups[live] += 1
    # Members in group order, the components of a group in index order (a stable sort of
    # the labels within each row, as gm_phd's argsort), rows one after another.
    flat = labels.reshape(-1)
    row_of = np.repeat(everyone, width)
    member = np.flatnonzero(flat >= 0)
    member = member[np.lexsort((member, flat[member], row_of[member]))]
    key = row_of[member] * (width + 1) + flat[member]
    first = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    sizes = np.diff(np.r_[first, member.size])
    wg = w.reshape(-1)[member]
    mg = m.reshape(-1, 2)[member]
    pg = p.reshape(-1, 2, 2)[member]
    w_sum = _reduceat_sums(wg, first, sizes)
    mean = _reduceat_sums(wg[:, None] * mg, first, sizes) / w_sum[:, None]
    dm = mean[np.repeat(np.arange(first.size), sizes)] - mg
    spread = wg[:, None, None] * (pg + dm[:, :, None] * dm[:, None, :])
    cov = _reduceat_sums(spread, first, sizes) / w_sum[:, None, None]
    cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))
    # Heaviest first within each row (stable), capped; groups are numbered per row.
    out, leads = [], []
    start = 0
    for r in range(rows):
        g = int(n_groups[r])
        ws = w_sum[start:start + g]
        order = np.argsort(-ws, kind="stable")[:cap] + start
        out.append(GaussianMixture(w_sum[order], mean[order], cov[order]))
        leads.append(lead_slot[r, order - start])
        start += g
    return (out, leads) if with_leads else out


def _reduceat_sums(x: np.ndarray, first: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """``np.add.reduceat(x, first)`` for segments of ``sizes`` (>= 1), bit for bit.

    numpy adds a segment's first element to the pairwise sum of the rest
    (:func:`_pairwise`); the rest is summed here for all short segments at once, one term
    per pass, and in a loop for the rare segments of more than eight.
    """
    out = x[first].copy()
    rest = sizes - 1
    short = rest < _PW_LOOP
    tail = np.zeros_like(out)
    for t in range(int(rest[short].max(initial=0))):
        sel = np.flatnonzero(short & (rest > t))
        tail[sel] = tail[sel] + x[first[sel] + 1 + t]
    for g in np.flatnonzero(~short):
        tail[g] = _pairwise(x[first[g] + 1:first[g] + sizes[g]])
    some = np.flatnonzero(rest > 0)
    out[some] = out[some] + tail[some]
    return out


def _pairwise(a: np.ndarray) -> np.ndarray:
    """The pairwise sum of numpy of ``a`` along axis 0 (``pairwise_sum`` in loops_utils.h.src)."""
    n = a.shape[0]
    if n < _PW_LOOP:
        res = np.zeros(a.shape[1:])
        for i in range(n):
            res = res + a[i]
        return res
    if n <= _PW_BLOCK:
        r = a[:8].copy()
        i = 8
        stop = n - n % 8
        while i < stop:
            r = r + a[i:i + 8]
            i += 8
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
        for j in range(i, n):
            res = res + a[j]
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return _pairwise(a[:n2]) + _pairwise(a[n2:])
