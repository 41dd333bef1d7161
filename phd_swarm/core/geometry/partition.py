"""Voronoi and power-diagram partitions of the rectangular environment E.

Robot ``r`` with position q_r [m] and power weight rho_r [m] has the power distance

    d_r(x) = ||x - q_r||^2 - rho_r^2      [m^2]                     (Chen et al. eq. 12)

and its cell is W_r = {x in E : d_r(x) <= d_k(x) for all k} (Chen eq. 12-13). With every
rho_r = 0 this is the Voronoi partition V_r of Dames (2020) eq. 7 with f(x) = x^2, which
Lloyd's algorithm uses (Dames eq. 8, Chen eq. 2).

Two representations are kept, and they answer different questions:

- *bin ownership* (:mod:`.ownership`: :func:`~.ownership.assign_bins`,
  :func:`~.ownership.bin_owners`): each bin centre goes to the generator of smallest power
  distance, ties to the lowest index; the canonical rule that decides which robot stores a
  bin's PHD weight (Dames Sec. III, Alg. 1).
- *cell polygons* (this module, :func:`cells`, :func:`cell_of`, :func:`partition`): W_r as a
  convex polygon, for areas, neighbour sets (who must talk to whom, Dames Sec. II-D) and
  geometric centroids. Polygon primitives are in :mod:`.polygons`.

Generators are indexed by their row in ``positions``; callers order the rows by robot id,
so "lowest index" means "lowest robot id".
"""

from __future__ import annotations

import math
from bisect import bisect_left
from dataclasses import dataclass

import numpy as np

from .grid import Environment, Grid
from .ownership import bin_owners, check_generators
from .polygons import polygon_area

#: Vertices closer than this fraction of (width + height) are merged after a clip.
_MERGE_REL = 1e-12

#: Tolerance on power distances for "a vertex lies on a bisector", as a fraction of
#: (width + height)^2 (see :func:`neighbours`).
_TOUCH_REL = 1e-9


def _clip(poly: np.ndarray, f: np.ndarray, merge_tol: float) -> tuple[np.ndarray, float]:
    """Sutherland-Hodgman clip of a convex polygon (V, 2) to the half-plane f <= 0.

    ``f`` (V,) is the affine half-plane function at the vertices. Returns the clipped
    polygon with near-duplicate consecutive vertices merged, or (0, 2) if less than a
    triangle is left, and its reach: the largest vertex norm [m] (0 for an empty one).

    A cell has a handful of vertices, for which numpy's per-call cost is ~10x the work,
    so the vertices are walked as Python floats; every value is one IEEE expression per
    element, as in array form: the crossing point ``v_k + t (v_k+1 - v_k)`` with
    ``t = f_k / (f_k - f_k+1)``, the merge test ``max |v_i - v_i-1| > merge_tol`` (cyclic)
    and the reach ``sqrt(max(x^2 + y^2))``.
    """
    pts = poly.tolist()
    fs = f.tolist()
    n = len(pts)
    out = []
    # Per edge k, emit v_k if kept, then the crossing point if the edge crosses.
    for k in range(n):
        nxt = k + 1 if k + 1 < n else 0
        fk, fn = fs[k], fs[nxt]
        kept = fk <= 0.0
        if kept:
            out.append(pts[k])
        if kept != (fn <= 0.0):
            t = fk / (fk - fn)
            (x0, y0), (x1, y1) = pts[k], pts[nxt]
            out.append([x0 + t * (x1 - x0), y0 + t * (y1 - y0)])
    if len(out) < 3:
        return np.empty((0, 2)), 0.0
    distinct = []
    px, py = out[-1]
    for v in out:
        x, y = v
        if max(abs(x - px), abs(y - py)) > merge_tol:
            distinct.append(v)
        px, py = x, y
    if len(distinct) < 3:
        return np.empty((0, 2)), 0.0
    return np.array(distinct), math.sqrt(max(x * x + y * y for x, y in distinct))


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
      in :func:`~.ownership.assign_bins`.
    - A power cell may be empty, and need not contain its own generator.
    - Cells of less than a triangle after merging vertices closer than
      1e-12 (width + height) are returned empty.
    """
    q, rho2 = check_generators(positions, power_weights)
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
            near = order[b, :n_far[b]]
            result.append(_clip_cell(env.corners - q[r], e[b, near] / dist[b, near, None],
                                     h_sorted[b, :n_far[b]], merge_tol) + q[r])
    return result


def _clip_cell(poly: np.ndarray, u: np.ndarray, h: np.ndarray, merge_tol: float) -> np.ndarray:
    """Clip ``poly`` (relative to q_r) by the half-planes y . u_k <= h_k.

    ``u`` (K, 2) are the unit vectors e_k / dist_k and ``h`` (K,) the offsets, sorted by h
    and without the unusable ones (+inf, NaN). The scan stops at the first h_k >= the
    largest vertex norm, which no half-plane with a larger h can cut either. The products
    ``poly @ u.T`` are taken over the block of half-planes below that norm: BLAS may round
    a product differently with the block's shape, so the blocks are part of the rounding.
    """
    bounds = h.tolist()
    reach = math.sqrt(max(x * x + y * y for x, y in poly.tolist()))
    k = 0
    while k < len(bounds):
        stop = bisect_left(bounds, reach)
        if stop <= k:
            break
        f = poly @ u[k:stop].T - h[k:stop]
        cutting = np.logical_or.reduce(f > 0.0, axis=0)
        j = int(cutting.argmax())
        if not cutting[j]:
            break
        poly, reach = _clip(poly, f[:, j], merge_tol)
        if poly.shape[0] == 0:
            break
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
    q, rho2 = check_generators(positions, power_weights)
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
    near = order[:np.count_nonzero(h_sorted < np.inf)]
    poly = _clip_cell(env.corners - q[index], e[near] / dist[near, None], h_sorted[:near.size],
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

    Corner contacts count because the lowest-index rule of :func:`~.ownership.assign_bins` can
    give a bin centre exactly at a shared corner to either cell. W_r is E cut by the half-planes
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
    q, rho2 = check_generators(positions, power_weights)
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
        """:func:`~.ownership.bin_owners` of ``grid`` for these generators, shape (grid.size,)."""
        return bin_owners(grid, self.positions, self.power_weights)


def partition(env: Environment, positions: np.ndarray,
              power_weights: np.ndarray | None = None) -> Partition:
    """Cells, neighbour sets and areas of the power diagram (Chen eq. 12-13) of E.

    With ``power_weights=None`` this is the Voronoi partition of Dames (2020) eq. 7.
    Shapes and units are those of :class:`Partition`. Arrays in the result are read-only.
    """
    q, rho2 = check_generators(positions, power_weights)
    rho = np.zeros(q.shape[0]) if power_weights is None else np.asarray(power_weights, float)
    polys = _power_cells(env, q, rho2)
    nbrs = neighbours(env, q, rho, cells=polys)
    areas = np.array([polygon_area(p) for p in polys])
    return Partition(env=env, positions=_readonly(q), power_weights=_readonly(rho),
                     cells=tuple(_readonly(p) for p in polys),
                     neighbours=tuple(_readonly(n) for n in nbrs), areas=_readonly(areas))
