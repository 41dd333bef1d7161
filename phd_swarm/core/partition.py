"""Voronoi and power-diagram partitions of the rectangular environment E.

Robot ``r`` with position q_r [m] and power weight rho_r [m] has the power distance

    d_r(x) = ||x - q_r||^2 - rho_r^2      [m^2]                     (Chen et al. eq. 12)

and its cell is W_r = {x in E : d_r(x) <= d_k(x) for all k} (Chen eq. 12-13). With every
rho_r = 0 this is the Voronoi partition V_r of Dames (2020) eq. 7 with f(x) = x^2, which
Lloyd's algorithm uses (Dames eq. 8, Chen eq. 2).

Two representations are kept, and they answer different questions:

- *bin ownership* (:func:`assign_bins`, :func:`bin_owners`): each bin centre goes to the
  generator of smallest power distance, ties to the lowest index. This is the canonical rule
  that decides which robot stores a bin's PHD weight (Dames Sec. III, Alg. 1); it is
  evaluated with one fixed floating-point expression so that a robot that only knows its
  neighbours reproduces the global answer bit for bit (see :func:`assign_bins`).
- *cell polygons* (:func:`cells`): W_r as a convex polygon, for areas, neighbour sets
  (who must talk to whom, Dames Sec. II-D) and geometric centroids.

Generators are indexed by their row in ``positions``; callers order the rows by robot id,
so "lowest index" means "lowest robot id".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .grid import Environment, Grid

#: Float elements per (points x generators) block in :func:`assign_bins`: two 512 kB blocks
#: stay in cache, which measured faster than larger blocks.
_BLOCK_ELEMENTS = 1 << 16

#: :func:`assign_bins` prunes generators per block of at most this many points ...
_PRUNE_BLOCK = 4096
#: ... when there are more generators than this.
_PRUNE_MIN_GENERATORS = 8

#: (bin, generator) pairs up to which :func:`bins_owned_in_box` evaluates every pair.
_DIRECT_PAIRS = 1 << 14

#: Vertices closer than this fraction of (width + height) are merged after a clip.
_MERGE_REL = 1e-12

#: Tolerance on power distances for "a vertex lies on a bisector", as a fraction of
#: (width + height)^2 (see :func:`neighbours`).
_TOUCH_REL = 1e-9


def _check_generators(positions: np.ndarray,
                      power_weights: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Validate generators; return positions (R, 2) and rho^2 (R,) as float arrays."""
    q = np.asarray(positions, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or q.shape[0] < 1:
        raise ValueError(f"positions must have shape (R, 2) with R >= 1, got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ValueError("positions must be finite")
    if power_weights is None:
        rho = np.zeros(q.shape[0])
    else:
        rho = np.asarray(power_weights, dtype=float)
        if rho.shape != (q.shape[0],):
            raise ValueError(f"power_weights must have shape ({q.shape[0]},) to match "
                             f"positions, got {rho.shape}")
        if not np.all(np.isfinite(rho)) or np.any(rho < 0):
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
    generators, each block of points first drops the generators that cannot own any of
    its points, as :func:`bins_owned_in_box` does for its tiles: over the block's bounding
    box, generator k's power distance lies in [L_k, U_k], and one with L_k > min_j U_j +
    margin is beaten everywhere in the box. The remaining generators are compared in
    increasing index order with the same per-pair values, so the owners, ties included,
    are those of the full comparison; only the cost falls (with 40 generators around a
    field of view at 0.1 m, ~6x fewer pairs).
    """
    q, rho2 = _check_generators(positions, power_weights)
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if not np.all(np.isfinite(p)):
        raise ValueError("points must be finite")
    index = np.arange(q.shape[0])
    if candidates is not None:
        index = np.unique(np.asarray(candidates, dtype=np.int64))
        if index.size == 0 or index[0] < 0 or index[-1] >= q.shape[0]:
            raise ValueError(f"candidates must be a non-empty set of indices in "
                             f"[0, {q.shape[0]}), got {candidates!r}")
        q, rho2 = q[index], rho2[index]
    n_gen = q.shape[0]
    out = np.empty(p.shape[0], dtype=np.int64)
    q0, q1 = q[:, 0], q[:, 1]
    prune = n_gen > _PRUNE_MIN_GENERATORS and p.shape[0] > 1
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
    return index[out] if candidates is not None else out


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
    q, rho2 = _check_generators(positions, power_weights)
    iy0, iy1, ix0, ix1 = (int(v) for v in box)
    if iy1 < iy0 or ix1 < ix0:
        return np.empty(0, dtype=np.int64)
    xs, ys = grid.xs[ix0:ix1 + 1], grid.ys[iy0:iy1 + 1]
    if xs.size * ys.size * q.shape[0] <= _DIRECT_PAIRS:
        iy, ix = np.meshgrid(np.arange(iy0, iy1 + 1), np.arange(ix0, ix1 + 1), indexing="ij")
        flat = (iy * grid.nx + ix).ravel()
        return flat[assign_bins(grid.centres_of(flat), q, power_weights) == index]
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
        mine = assign_bins(grid.centres_of(flat), q, power_weights,
                           candidates=candidates) == index
        owned[rows[mine], cols[mine]] = True
    rows, cols = np.nonzero(owned)
    return ((iy0 + rows) * grid.nx + (ix0 + cols)).astype(np.int64)


def _axis_bounds(lo: np.ndarray, hi: np.ndarray,
                 q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest and farthest |x - q| over the intervals [lo, hi] (T,) for each q (R,): (T, R)."""
    below, above = lo[:, None] - q[None, :], q[None, :] - hi[:, None]
    near = np.maximum(np.maximum(below, above), 0.0)
    far = np.maximum(np.abs(below), np.abs(above))
    return near, far


def polygon_area(poly: np.ndarray) -> float:
    """Area of a simple polygon by the shoelace formula [m^2], >= 0; (V, 2) -> float.

    Polygons with fewer than 3 vertices have area 0.
    """
    p = np.asarray(poly, dtype=float).reshape(-1, 2)
    if p.shape[0] < 3:
        return 0.0
    # Relative to the first vertex, so that far-from-origin polygons keep their precision.
    p = p - p[0]
    x, y = p[:, 0], p[:, 1]
    return float(abs(0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))


def polygon_centroid(poly: np.ndarray) -> np.ndarray:
    """Centroid of a simple polygon's area [m], shape (2,); poly (V, 2).

    A polygon of zero area (fewer than 3 vertices, or collinear ones) has the mean of its
    vertices as centroid; an empty polygon (0 vertices) is an error.
    """
    p = np.asarray(poly, dtype=float).reshape(-1, 2)
    if p.shape[0] == 0:
        raise ValueError("an empty polygon has no centroid")
    origin = p[0]
    r = p - origin
    x, y = r[:, 0], r[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    a2 = np.sum(cross)
    scale = np.max(np.abs(r)) if r.size else 0.0
    if p.shape[0] < 3 or abs(a2) <= 1e-14 * scale * scale:
        return p.mean(axis=0)
    cx = np.sum((x + xn) * cross) / (3.0 * a2)
    cy = np.sum((y + yn) * cross) / (3.0 * a2)
    return origin + np.array([cx, cy])


def points_in_polygon(points: np.ndarray, poly: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """Whether each point lies in a convex counter-clockwise polygon grown by ``tol``.

    A point is inside when its signed distance to every edge line is at most ``tol`` [m]
    on the outer side: ``tol > 0`` also accepts points just outside (robust membership),
    ``tol < 0`` only accepts points inside by more than ``-tol`` (strict interior).

    Parameters
    ----------
    points : np.ndarray, shape (N, 2)
        Query points [m].
    poly : np.ndarray, shape (V, 2)
        Convex polygon, counter-clockwise; V = 0 (empty cell) contains nothing.
    tol : float
        Margin [m].

    Returns
    -------
    np.ndarray of bool, shape (N,)
    """
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    v = np.asarray(poly, dtype=float).reshape(-1, 2)
    if v.shape[0] < 3:
        return np.zeros(p.shape[0], dtype=bool)
    inside = np.ones(p.shape[0], dtype=bool)
    for k in range(v.shape[0]):
        a, b = v[k], v[(k + 1) % v.shape[0]]
        edge = b - a
        length = np.hypot(edge[0], edge[1])
        if length == 0.0:
            continue
        # Left of a CCW edge is inside: cross(edge, p - a) / |edge| is the inward distance.
        inward = (edge[0] * (p[:, 1] - a[1]) - edge[1] * (p[:, 0] - a[0])) / length
        inside &= inward >= -tol
    return inside


def points_in_polygons(points: np.ndarray, polys: list[np.ndarray],
                       tol: float = 0.0) -> np.ndarray:
    """:func:`points_in_polygon` of every point in every polygon, in one array operation.

    ``points_in_polygons(p, polys, tol)[:, i] == points_in_polygon(p, polys[i], tol)``
    exactly: the edges of all polygons are stacked and the same float expressions are
    evaluated for every (point, edge) pair, so the cost is O(N x total vertices).

    Parameters
    ----------
    points : np.ndarray, shape (N, 2)
        Query points [m].
    polys : list of np.ndarray, each shape (V_i, 2)
        Convex counter-clockwise polygons; those with fewer than 3 vertices contain nothing.
    tol : float
        Margin [m], as in :func:`points_in_polygon`.

    Returns
    -------
    np.ndarray of bool, shape (N, len(polys))
    """
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    polys = [np.asarray(v, dtype=float).reshape(-1, 2) for v in polys]
    inside = np.zeros((p.shape[0], len(polys)), dtype=bool)
    real = [i for i, v in enumerate(polys) if v.shape[0] >= 3]
    if real and p.shape[0]:
        a, starts, nxt = stack_polygons([polys[i] for i in real])
        edge = a[nxt] - a
        length = np.hypot(edge[:, 0], edge[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            inward = (edge[:, 0] * (p[:, 1:2] - a[:, 1]) - edge[:, 1] * (p[:, 0:1] - a[:, 0])) \
                / length
        # Zero-length edges are skipped, as in points_in_polygon.
        ok = (inward >= -tol) | (length == 0.0)
        inside[:, real] = np.logical_and.reduceat(ok, starts, axis=1)
    return inside


def points_in_any_polygon(points: np.ndarray, polys: list[np.ndarray],
                          tol: float = 0.0) -> np.ndarray:
    """Whether each point lies in at least one of ``polys`` (each grown by ``tol``).

    :func:`points_in_polygons` or-ed over the polygons, taken in groups of about 2**16
    (point, vertex) pairs; the points already inside a polygon are not tested against the
    later groups.

    Parameters
    ----------
    points : np.ndarray, shape (N, 2)
        Query points [m].
    polys : list of np.ndarray, each shape (V_i, 2)
        Convex counter-clockwise polygons; those with fewer than 3 vertices contain nothing.
    tol : float
        Margin [m], as in :func:`points_in_polygon`.

    Returns
    -------
    np.ndarray of bool, shape (N,)
    """
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    inside = np.zeros(p.shape[0], dtype=bool)
    polys = [np.asarray(v, dtype=float).reshape(-1, 2) for v in polys]
    first = 0
    while first < len(polys) and not inside.all():
        rest = np.flatnonzero(~inside)
        n_vertices, last = 0, first
        while last < len(polys) and (last == first or
                                     rest.size * (n_vertices + len(polys[last])) <= 1 << 16):
            n_vertices += len(polys[last])
            last += 1
        inside[rest] = points_in_polygons(p[rest], polys[first:last], tol).any(axis=1)
        first = last
    return inside


def stack_polygons(polys: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All vertices of several polygons in one array, for edge-wise array operations.

    Parameters
    ----------
    polys : list of np.ndarray, each shape (V_i, 2), V_i >= 1

    Returns
    -------
    vertices : np.ndarray, shape (V, 2)
        The polygons' vertices one after the other, V = sum V_i.
    starts : np.ndarray of int64, shape (len(polys),)
        Row of each polygon's first vertex (for ``ufunc.reduceat``).
    following : np.ndarray of int64, shape (V,)
        Row of the next vertex of the same polygon (its first after its last), so that
        ``vertices[following] - vertices`` are the edges, as ``np.roll(poly, -1, axis=0)
        - poly`` per polygon.
    """
    sizes = np.array([len(v) for v in polys], dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(sizes[:-1])]).astype(np.int64)
    vertices = np.concatenate(polys).reshape(-1, 2)
    following = np.arange(1, vertices.shape[0] + 1)
    following[starts + sizes - 1] = starts
    return vertices, starts, following


def _clip(poly: np.ndarray, f: np.ndarray, merge_tol: float) -> np.ndarray:
    """Sutherland-Hodgman clip of a convex polygon (V, 2) to the half-plane f <= 0.

    ``f`` (V,) is the affine half-plane function at the vertices. Returns the clipped
    polygon with near-duplicate consecutive vertices merged, or (0, 2) if less than a
    triangle is left.
    """
    n = poly.shape[0]
    # Slices of a closed copy instead of np.roll: this runs ~10^3 times per partition
    # and np.roll's overhead dominated the cost of a clip.
    closed = np.empty((n + 1, 2))
    closed[:n] = poly
    closed[n] = poly[0]
    f_closed = np.empty(n + 1)
    f_closed[:n] = f
    f_closed[n] = f[0]
    in_closed = f_closed <= 0.0
    inside = in_closed[:n]
    crosses = inside != in_closed[1:]
    fn = f_closed[1:]
    t = f / np.where(crosses, f - fn, 1.0)
    hits = poly + t[:, None] * (closed[1:] - poly)
    # Per edge k, emit v_k if kept, then the crossing point if the edge crosses.
    both = np.empty((2 * n, 2))
    both[0::2] = poly
    both[1::2] = hits
    keep = np.empty(2 * n, dtype=bool)
    keep[0::2] = inside
    keep[1::2] = crosses
    out = both[keep]
    m = out.shape[0]
    if m < 3:
        return np.empty((0, 2))
    step = np.empty(m)
    step[1:] = np.abs(out[1:] - out[:-1]).max(axis=1)
    step[0] = np.abs(out[0] - out[-1]).max()
    distinct = step > merge_tol
    if np.count_nonzero(distinct) < 3:
        return np.empty((0, 2))
    return out[distinct]


def cells(env: Environment, positions: np.ndarray,
          power_weights: np.ndarray | None = None) -> list[np.ndarray]:
    """Power cells W_r (Chen eq. 12-13), or Voronoi cells V_r (Dames eq. 7), clipped to E.

    W_r is the rectangle E intersected with the half-planes {x : d_r(x) <= d_k(x)}, which
    are linear in x: ``2 x . (q_k - q_r) <= |q_k|^2 - rho_k^2 - |q_r|^2 + rho_r^2``.
    In coordinates relative to q_r, with D = |q_k - q_r| and u = (q_k - q_r) / D, this is
    ``(x - q_r) . u <= h_k = (D^2 + rho_r^2 - rho_k^2) / (2 D)``.

    Parameters
    ----------
    env : Environment
        The rectangle E.
    positions : np.ndarray, shape (R, 2)
        Generators q [m], rows ordered by robot id. Points outside E are allowed.
    power_weights : np.ndarray, shape (R,), optional
        Power weights rho >= 0 [m]; None gives the Voronoi diagram.

    Returns
    -------
    list of np.ndarray
        R convex polygons, counter-clockwise, shape (V_r, 2) [m]; an empty cell is
        (0, 2). The non-empty cells tile E (areas sum to ``env.area``).

    Notes
    -----
    - The half-planes of robot r are applied in increasing h_k. A half-plane with
      h_k >= max |v - q_r| over the current vertices v cannot cut the polygon, and nor can
      any later one, so clipping stops there: the cost is O(R log R) for the sort plus
      O(number of cutting half-planes), not O(R) clips per robot.
    - Coincident generators (D = 0): the larger rho takes the whole shared region; with
      equal rho the lower index keeps its cell and the higher index gets an empty one, as
      in :func:`assign_bins`.
    - A power cell may be empty, and need not contain its own generator.
    - Cells of less than a triangle after merging vertices closer than
      1e-12 (width + height) are returned empty.
    """
    q, rho2 = _check_generators(positions, power_weights)
    return _power_cells(env, q, rho2)


def _power_cells(env: Environment, q: np.ndarray, rho2: np.ndarray) -> list[np.ndarray]:
    """:func:`cells` for validated generators q (R, 2) and squared weights rho2 (R,)."""
    n_gen = q.shape[0]
    merge_tol = _MERGE_REL * (env.width + env.height)
    index = np.arange(n_gen)
    result: list[np.ndarray] = []
    rows = max(1, (1 << 18) // n_gen)
    for first in range(0, n_gen, rows):
        block = index[first:first + rows]
        # e[b, k] = q_k - q_r for r = block[b]; O(rows * R) memory, not O(R^2).
        e = q[None, :, :] - q[block, None, :]
        dist2 = e[..., 0] ** 2 + e[..., 1] ** 2
        self_or_same = dist2 == 0.0
        rho2_r = rho2[block, None]
        beaten = self_or_same & ((rho2 > rho2_r) | ((rho2 == rho2_r) & (index < block[:, None])))
        dist = np.sqrt(dist2)
        with np.errstate(divide="ignore", invalid="ignore"):
            h = np.where(self_or_same, np.inf, (dist2 + rho2_r - rho2) / (2.0 * dist))
        order = np.argsort(h, axis=1, kind="stable")
        h_sorted = np.take_along_axis(h, order, axis=1)
        # -inf (a near-coincident, heavier generator that takes everything) sorts first and
        # must be kept; +inf (self, coincident) and NaN (overflow) sort last and are not.
        n_far = np.count_nonzero(h_sorted < np.inf, axis=1)
        for b, r in enumerate(block):
            if beaten[b].any():
                result.append(np.empty((0, 2)))
                continue
            result.append(_clip_cell(env.corners - q[r], e[b], dist[b], h_sorted[b],
                                     order[b], int(n_far[b]), merge_tol) + q[r])
    return result


def _clip_cell(poly: np.ndarray, e: np.ndarray, dist: np.ndarray, h: np.ndarray,
               order: np.ndarray, n_far: int, merge_tol: float) -> np.ndarray:
    """Clip ``poly`` (relative to q_r) by the half-planes y . e_k / dist_k <= h_k.

    ``h`` and ``order`` are sorted by h; only the first ``n_far`` entries are usable. The
    scan stops at the first h_k >= the largest vertex norm, which no half-plane with a
    larger h can cut either.
    """
    reach = np.sqrt((poly * poly).sum(axis=1).max())
    k = 0
    while k < n_far:
        stop = int(np.searchsorted(h[:n_far], reach, side="left"))
        if stop <= k:
            break
        idx = order[k:stop]
        f = poly @ (e[idx] / dist[idx, None]).T - h[k:stop]
        cutting = (f > 0.0).any(axis=0).nonzero()[0]
        if cutting.size == 0:
            break
        j = int(cutting[0])
        poly = _clip(poly, f[:, j], merge_tol)
        if poly.shape[0] == 0:
            break
        reach = np.sqrt((poly * poly).sum(axis=1).max())
        k += j + 1
    return poly


def cell_of(env: Environment, index: int, positions: np.ndarray,
            power_weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The cell of one generator and its neighbours, without computing the other cells.

    This is what a robot of the distributed filter computes from the states its contacts
    sent (Dames Alg. 1 line 2): its own cell among the given generators, and which of them
    touch it. It gives the same polygon as ``cells(...)[index]``; a generator j is a
    neighbour when a vertex v of this cell has |d_index(v) - d_j(v)| within the tolerance of
    :func:`neighbours` (a shared edge or corner is a vertex of both cells).

    Parameters
    ----------
    env : Environment
        The rectangle E.
    index : int
        Row of ``positions`` whose cell is wanted.
    positions : np.ndarray, shape (R, 2)
        Generators q [m] (the robot itself and its contacts, in robot-id order).
    power_weights : np.ndarray, shape (R,), optional
        rho [m]; None for Voronoi.

    Returns
    -------
    poly : np.ndarray, shape (V, 2)
        Counter-clockwise cell, (0, 2) if empty.
    neighbour_rows : np.ndarray of int64
        Sorted rows of ``positions`` whose cells touch this one (empty for an empty cell).
    """
    q, rho2 = _check_generators(positions, power_weights)
    n_gen = q.shape[0]
    if not 0 <= index < n_gen:
        raise ValueError(f"cell_of: index {index} out of range for {n_gen} generators")
    merge_tol = _MERGE_REL * (env.width + env.height)
    e = q - q[index]
    dist2 = e[:, 0] ** 2 + e[:, 1] ** 2
    same = dist2 == 0.0
    rows = np.arange(n_gen)
    beaten = same & ((rho2 > rho2[index]) | ((rho2 == rho2[index]) & (rows < index)))
    if beaten.any():
        return np.empty((0, 2)), np.empty(0, dtype=np.int64)
    dist = np.sqrt(dist2)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where(same, np.inf, (dist2 + rho2[index] - rho2) / (2.0 * dist))
    order = np.argsort(h, kind="stable")
    h_sorted = h[order]
    n_far = int(np.count_nonzero(h_sorted < np.inf))
    poly = _clip_cell(env.corners - q[index], e, dist, h_sorted, order, n_far,
                      merge_tol) + q[index]
    if poly.shape[0] == 0:
        return np.empty((0, 2)), np.empty(0, dtype=np.int64)
    tol = _TOUCH_REL * (env.width + env.height) ** 2
    d = (poly[:, 0:1] - q[:, 0]) ** 2 + (poly[:, 1:2] - q[:, 1]) ** 2 - rho2
    touch = np.any(np.abs(d - d[:, index:index + 1]) <= tol, axis=0)
    touch[index] = False
    return poly, np.flatnonzero(touch)


def neighbours(env: Environment, positions: np.ndarray,
               power_weights: np.ndarray | None = None,
               cells: list[np.ndarray] | None = None) -> list[np.ndarray]:
    """Neighbour sets N(r) of the power (or Voronoi) diagram: cells that touch W_r.

    j is a neighbour of r when the two non-empty cells share an edge or a single point;
    it is detected as a vertex v of either cell with |d_r(v) - d_j(v)| <= 1e-9 (width +
    height)^2 [m^2]. Since v is in W_r, d_r(v) is the smallest power distance at v, so
    d_j(v) = d_r(v) puts v in W_j too. These are the robots r must talk to (Dames Sec.
    II-D, Alg. 1).

    Corner contacts count because the lowest-index rule of :func:`assign_bins` can give a
    bin centre exactly at a shared corner to either cell. W_r is E cut by the half-planes
    of N(r) alone, so for a non-empty cell
    ``assign_bins(x, ..., candidates=[r, *N(r)]) == r`` exactly when the global call gives
    r. The one exception needs an exact tie: a generator whose power cell has zero area
    (a segment or a point, reported empty) still wins ties on that set if it has the
    lowest index, and it has no neighbours to tell.

    Parameters
    ----------
    env : Environment
        The rectangle E (sets the tolerance scale).
    positions : np.ndarray, shape (R, 2)
        Generators q [m].
    power_weights : np.ndarray, shape (R,), optional
        Power weights rho >= 0 [m]; None for Voronoi.
    cells : list of np.ndarray, optional
        Output of :func:`cells` for the same generators, to avoid recomputing it.

    Returns
    -------
    list of np.ndarray of int64
        R sorted index arrays; symmetric; an empty cell has no neighbours.
    """
    q, rho2 = _check_generators(positions, power_weights)
    n_gen = q.shape[0]
    polys = _power_cells(env, q, rho2) if cells is None else cells
    if len(polys) != n_gen:
        raise ValueError(f"got {len(polys)} cells for {n_gen} generators")
    tol = _TOUCH_REL * (env.width + env.height) ** 2
    nonempty = np.array([len(p) > 0 for p in polys], dtype=bool)
    touch = np.zeros((n_gen, n_gen), dtype=bool)
    for r in np.flatnonzero(nonempty):
        v = np.asarray(polys[r], dtype=float)
        d = (v[:, 0:1] - q[:, 0]) ** 2 + (v[:, 1:2] - q[:, 1]) ** 2 - rho2
        touch[r] = np.any(np.abs(d - d[:, r:r + 1]) <= tol, axis=0)
    # Either cell's vertex is evidence; the union keeps the relation symmetric under
    # rounding.
    touch |= touch.T
    touch &= nonempty[:, None] & nonempty[None, :]
    np.fill_diagonal(touch, False)
    return [np.flatnonzero(row) for row in touch]


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=a.dtype, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Partition:
    """A power (or Voronoi) partition of E by R generators; see :func:`partition`.

    Attributes
    ----------
    env : Environment
        The rectangle E.
    positions : np.ndarray, shape (R, 2)
        Generators q [m], rows ordered by robot id.
    power_weights : np.ndarray, shape (R,)
        rho [m] (zeros for Voronoi).
    cells : tuple of np.ndarray
        R counter-clockwise convex polygons (V_r, 2) [m]; (0, 2) for an empty cell.
    neighbours : tuple of np.ndarray of int64
        R sorted neighbour index arrays, symmetric.
    areas : np.ndarray, shape (R,)
        Cell areas [m^2]; they sum to ``env.area``.
    """

    env: Environment
    positions: np.ndarray
    power_weights: np.ndarray
    cells: tuple[np.ndarray, ...]
    neighbours: tuple[np.ndarray, ...]
    areas: np.ndarray

    def owners(self, grid: Grid) -> np.ndarray:
        """:func:`bin_owners` of ``grid`` for these generators, shape (grid.size,)."""
        return bin_owners(grid, self.positions, self.power_weights)


def partition(env: Environment, positions: np.ndarray,
              power_weights: np.ndarray | None = None) -> Partition:
    """Cells, neighbour sets and areas of the power diagram (Chen eq. 12-13) of E.

    With ``power_weights=None`` this is the Voronoi partition of Dames (2020) eq. 7.
    Shapes and units are those of :class:`Partition`. Arrays in the result are read-only.
    """
    q, rho2 = _check_generators(positions, power_weights)
    rho = np.zeros(q.shape[0]) if power_weights is None else np.asarray(power_weights, float)
    polys = _power_cells(env, q, rho2)
    nbrs = neighbours(env, q, rho, cells=polys)
    areas = np.array([polygon_area(p) for p in polys])
    return Partition(env=env, positions=_readonly(q), power_weights=_readonly(rho),
                     cells=tuple(_readonly(p) for p in polys),
                     neighbours=tuple(_readonly(n) for n in nbrs), areas=_readonly(areas))
