"""Bin ownership in a Voronoi or power diagram: which robot stores each bin.

Each bin centre x goes to the generator of smallest power distance
``||x - q_r||^2 - rho_r^2`` (Chen et al. eq. 12; Voronoi, Dames 2020 eq. 7, when every rho is
0), ties to the lowest index. This is the canonical rule that decides which robot stores a
bin's PHD weight (Dames Sec. III, Alg. 1); it is evaluated with one fixed floating-point
expression so that a robot that only knows its neighbours reproduces the global answer bit
for bit (see :func:`assign_bins`). The cell polygons are in :mod:`.partition`.

Generators are indexed by their row in ``positions``; callers order the rows by robot id,
so "lowest index" means "lowest robot id".
"""

from __future__ import annotations

import numpy as np

from .grid import Grid

#: Float elements per (points x generators) block in :func:`assign_bins`: two 512 kB blocks
#: stay in cache, which measured faster than larger blocks.
_BLOCK_ELEMENTS = 1 << 16

#: :func:`assign_bins` prunes generators per block of at most this many points ...
_PRUNE_BLOCK = 4096
#: ... when there are more generators than this and more (point, generator) pairs than
#: :data:`_PRUNE_MIN_PAIRS`: below that the bounds cost more than the pairs they save.
_PRUNE_MIN_GENERATORS = 8
_PRUNE_MIN_PAIRS = 1 << 13

#: (bin, generator) pairs up to which :func:`bins_owned_in_box` evaluates every pair.
_DIRECT_PAIRS = 1 << 14

def check_generators(positions: np.ndarray,
                      power_weights: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Validate generators; return positions (R, 2) and rho^2 (R,) as float arrays."""
    q = np.asarray(positions, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or q.shape[0] < 1:
        raise ValueError(f"positions must have shape (R, 2) with R >= 1, got {q.shape}")
    if not np.isfinite(q).all():
        raise ValueError("positions must be finite")
    if power_weights is None:
        return q, np.zeros(q.shape[0])
    rho = np.asarray(power_weights, dtype=float)
    if rho.shape != (q.shape[0],):
        raise ValueError(f"power_weights must have shape ({q.shape[0]},) to match "
                         f"positions, got {rho.shape}")
    # One pass for both: NaN and +-inf fail one of the two comparisons.
    if not ((rho >= 0.0) & (rho < np.inf)).all():
        raise ValueError(f"power weights must be finite and >= 0, got {rho}")
    return q, rho ** 2


def assign_bins(points: np.ndarray, positions: np.ndarray,
                power_weights: np.ndarray | None = None,
                candidates: np.ndarray | None = None) -> np.ndarray:
    """Owner of each point: the generator of smallest power distance (Chen eq. 12).

    The power distance is evaluated as exactly ``(x0 - q0)**2 + (x1 - q1)**2 - rho**2`` in
    float64 and the smallest value wins, ties going to the lowest generator index. Because
    the value for a (point, generator) pair does not depend on which other generators are
    compared, a robot that evaluates only itself and its neighbours (``candidates``) gets
    the same owner as the global call wherever the global owner is among the candidates.
    Use this function for every ownership decision; do not re-derive it with another
    formula (KD-tree, lifted coordinates), which would round differently on ties.

    Parameters
    ----------
    points : np.ndarray, shape (N, 2)
        Query points [m], typically bin centres. N may be 0.
    positions : np.ndarray, shape (R, 2)
        Generators q [m], rows ordered by robot id.
    power_weights : np.ndarray, shape (R,), optional
        Power weights rho >= 0 [m]; None means 0 for all (Voronoi, Dames eq. 7).
    candidates : np.ndarray of int, optional
        Restrict the competition to these generator indices (any order; they are compared
        in increasing index order so that ties resolve as in the global call).

    Returns
    -------
    np.ndarray of int64, shape (N,)
        Index into ``positions`` of each point's owner.

    Notes
    -----
    Points are processed in blocks of about 2**16 / R, so memory stays near 1 MB for any
    N (10^6 points x 100 robots is fine). With more than :data:`_PRUNE_MIN_GENERATORS`
    generators and :data:`_PRUNE_MIN_PAIRS` (point, generator) pairs, each block of points
    first drops the generators that cannot own any of its points, as
    :func:`bins_owned_in_box` does for its tiles: over the block's bounding box, generator
    k's power distance lies in [L_k, U_k], and one with L_k > min_j U_j + margin is beaten
    everywhere in the box. The remaining generators are compared in increasing index order
    with the same per-pair values, so the owners, ties included, are those of the full
    comparison; only the cost falls (with 40 generators around a
    field of view at 0.1 m, ~6x fewer pairs).
    """
    q, rho2 = check_generators(positions, power_weights)
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if not np.all(np.isfinite(p)):
        raise ValueError("points must be finite")
    if candidates is None:
        return assign_checked(p, q, rho2)
    index = np.unique(np.asarray(candidates, dtype=np.int64))
    if index.size == 0 or index[0] < 0 or index[-1] >= q.shape[0]:
        raise ValueError(f"candidates must be a non-empty set of indices in "
                         f"[0, {q.shape[0]}), got {candidates!r}")
    return index[assign_checked(p, q[index], rho2[index])]


def assign_checked(p: np.ndarray, q: np.ndarray, rho2: np.ndarray) -> np.ndarray:
    """:func:`assign_bins` of finite points for generators that passed :func:`check_generators`.

    The same owners, ties included, without validating the arguments again: for callers
    that assign several point sets to one set of generators.

    Parameters
    ----------
    p : np.ndarray, shape (N, 2)
        Finite query points [m].
    q : np.ndarray, shape (R, 2)
        Generators [m], as :func:`check_generators` returns them.
    rho2 : np.ndarray, shape (R,)
        Squared power weights [m^2], as :func:`check_generators` returns them.

    Returns
    -------
    np.ndarray of int64, shape (N,)
        Row of ``q`` of each point's owner.
    """
    n_gen = q.shape[0]
    out = np.empty(p.shape[0], dtype=np.int64)
    q0, q1 = q[:, 0], q[:, 1]
    prune = (n_gen > _PRUNE_MIN_GENERATORS and p.shape[0] > 1
             and p.shape[0] * n_gen > _PRUNE_MIN_PAIRS)
    block = min(_PRUNE_BLOCK, max(64, 2 * _BLOCK_ELEMENTS // n_gen)) if prune \
        else max(1, _BLOCK_ELEMENTS // n_gen)
    for start in range(0, p.shape[0], block):
        x0 = p[start:start + block, 0:1]
        x1 = p[start:start + block, 1:2]
        g0, g1, g_rho2 = q0, q1, rho2
        if prune:
            keep = _contenders(x0, x1, q, rho2)
            g0, g1, g_rho2 = q0[keep], q1[keep], rho2[keep]
        # In-place ufuncs keep the memory at two blocks while computing the same rounded
        # values as the expression in the docstring, in the same order.
        d = np.subtract(x0, g0)
        np.square(d, out=d)
        t = np.subtract(x1, g1)
        np.square(t, out=t)
        d += t
        d -= g_rho2
        best = np.argmin(d, axis=1)
        out[start:start + block] = keep[best] if prune else best
    return out


def _contenders(x0: np.ndarray, x1: np.ndarray, q: np.ndarray,
                rho2: np.ndarray) -> np.ndarray:
    """Ascending indices of the generators that may own a point in the points' bounding box.

    The points' coordinates are x0, x1 (N, 1). Kept: the generators whose smallest power
    distance over the box is not above the smallest largest one, plus a margin (see
    :func:`bins_owned_in_box`).
    """
    near_x, far_x = _axis_bounds(x0.min(keepdims=True).reshape(1),
                                 x0.max(keepdims=True).reshape(1), q[:, 0])
    near_y, far_y = _axis_bounds(x1.min(keepdims=True).reshape(1),
                                 x1.max(keepdims=True).reshape(1), q[:, 1])
    lower = near_x[0] ** 2 + near_y[0] ** 2 - rho2
    far2 = far_x[0] ** 2 + far_y[0] ** 2
    upper = far2 - rho2
    margin = 1e-9 * (far2 + rho2).max()
    return np.flatnonzero(lower <= upper.min() + margin)


def bin_owners(grid: Grid, positions: np.ndarray,
               power_weights: np.ndarray | None = None) -> np.ndarray:
    """Owner of every bin of ``grid``: :func:`assign_bins` of the bin centres.

    Returns
    -------
    np.ndarray of int64, shape (grid.size,)
        Generator index per flat bin index (``iy * nx + ix``).
    """
    return assign_bins(grid.centres, positions, power_weights)


def bins_owned_in_box(grid: Grid, index: int, positions: np.ndarray,
                      power_weights: np.ndarray | None,
                      box: tuple[int, int, int, int]) -> np.ndarray:
    """Bins of a box of the grid that :func:`assign_bins` gives to generator ``index``.

    Equal to ``flat[assign_bins(grid.centres_of(flat), positions, power_weights) ==
    index]`` for the ascending flat indices ``flat`` of the box (which is how boxes of up
    to :data:`_DIRECT_PAIRS` (bin, generator) pairs are done), but without evaluating
    every pair. The box is cut into about 8 x 8 tiles; for each tile and generator k,
    bounds ``L_k <= d_k(x) <= U_k`` of the power distance over the tile's bin centres
    follow from their nearest and farthest coordinates. A generator with
    ``L_k > min_j U_j + margin`` is beaten at every bin of the tile, so the owners there
    are those of the remaining *contenders*: a tile where ``index`` is the only contender
    is all its own, one where it is none is none of its own, and only the bins of the
    other tiles are assigned, by :func:`assign_bins` with the contenders of those tiles as
    ``candidates`` (whose values per (point, generator) pair do not depend on the other
    generators). The margin, 1e-9 of the largest squared distance plus rho^2 in the tile,
    exceeds the rounding error of the power distances and of the bounds (a few 1e-16 of
    that) by about 10^5, so pruning never changes a winner, ties included.

    Parameters
    ----------
    grid : Grid
    index : int
        Row of ``positions`` whose bins are wanted.
    positions : np.ndarray, shape (R, 2)
        Generators q [m], rows ordered by robot id.
    power_weights : np.ndarray, shape (R,), optional
        rho [m]; None for Voronoi.
    box : tuple of int
        ``(iy0, iy1, ix0, ix1)``, inclusive bin-index ranges.

    Returns
    -------
    np.ndarray of int64
        Ascending flat indices of the bins of the box owned by ``index``.
    """
    q, rho2 = check_generators(positions, power_weights)
    iy0, iy1, ix0, ix1 = (int(v) for v in box)
    if iy1 < iy0 or ix1 < ix0:
        return np.empty(0, dtype=np.int64)
    xs, ys = grid.xs[ix0:ix1 + 1], grid.ys[iy0:iy1 + 1]
    if xs.size * ys.size * q.shape[0] <= _DIRECT_PAIRS:
        rows, cols = np.nonzero(_rectangle_owned(xs, ys, q, rho2, index))
        return ((iy0 + rows) * grid.nx + (ix0 + cols)).astype(np.int64)
    # About 8 x 8 tiles, of 4 to 32 bins a side.
    tile = int(np.clip(round(np.sqrt(xs.size * ys.size) / 8), 4, 32))
    col_tile = np.arange(xs.size) // tile
    row_tile = np.arange(ys.size) // tile
    first_x = np.arange(0, xs.size, tile)
    first_y = np.arange(0, ys.size, tile)
    near_x, far_x = _axis_bounds(xs[first_x], xs[np.minimum(first_x + tile, xs.size) - 1],
                                 q[:, 0])
    near_y, far_y = _axis_bounds(ys[first_y], ys[np.minimum(first_y + tile, ys.size) - 1],
                                 q[:, 1])
    # (tile rows, tile columns, generators)
    lower = near_y[:, None, :] ** 2 + near_x[None, :, :] ** 2 - rho2
    far2 = far_y[:, None, :] ** 2 + far_x[None, :, :] ** 2
    upper = far2 - rho2
    margin = 1e-9 * (far2 + rho2).max(axis=2, keepdims=True)
    contender = lower <= upper.min(axis=2, keepdims=True) + margin
    alone = contender[..., index] & (contender.sum(axis=2) == 1)
    shared = contender[..., index] & ~alone
    owned = alone[row_tile[:, None], col_tile[None, :]]
    if shared.any():
        rows, cols = np.nonzero(shared[row_tile[:, None], col_tile[None, :]])
        flat = (iy0 + rows) * grid.nx + (ix0 + cols)
        candidates = np.flatnonzero(contender[shared].any(axis=0))
        mine = candidates[assign_checked(grid.centres_of(flat), q[candidates],
                                         rho2[candidates])] == index
        owned[rows[mine], cols[mine]] = True
    rows, cols = np.nonzero(owned)
    return ((iy0 + rows) * grid.nx + (ix0 + cols)).astype(np.int64)


def _rectangle_owned(xs: np.ndarray, ys: np.ndarray, q: np.ndarray, rho2: np.ndarray,
                     index: int) -> np.ndarray:
    """Whether :func:`assign_checked` gives each bin centre (xs[i], ys[j]) to ``index``.

    Shape (len(ys), len(xs)). The per-pair values are those of :func:`assign_checked`,
    ``(x0 - q0)**2 + (x1 - q1)**2 - rho**2`` (the sum of the two squares is commutative,
    so it rounds alike), with each column's and row's squared difference computed once
    instead of once per bin. ``index`` is the argmin (the first of the smallest) exactly
    where its value is below those of the generators before it and not above those after
    it. Every generator is compared (at most :data:`_DIRECT_PAIRS` pairs): pruning them
    first cost more than it saved at that size.
    """
    dx2 = np.square(xs[None, :] - q[:, 0:1])
    dy2 = np.square(ys[None, :] - q[:, 1:2])
    # (generators, rows, columns): the minima over generators run over whole planes.
    d = dy2[:, :, None] + dx2[:, None, :]
    d -= rho2[:, None, None]
    mine = d[index]
    owned = np.minimum.reduce(d[index + 1:], axis=0) >= mine if index + 1 < len(d) else \
        np.ones(mine.shape, dtype=bool)
    if index > 0:
        owned &= np.minimum.reduce(d[:index], axis=0) > mine
    return owned


def _axis_bounds(lo: np.ndarray, hi: np.ndarray,
                 q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest and farthest |x - q| over the intervals [lo, hi] (T,) for each q (R,): (T, R)."""
    below, above = lo[:, None] - q[None, :], q[None, :] - hi[:, None]
    near = np.maximum(np.maximum(below, above), 0.0)
    far = np.maximum(np.abs(below), np.abs(above))
    return near, far
