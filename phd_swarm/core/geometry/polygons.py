"""Polygon geometry: areas, centroids, point-in-polygon tests, and cells in array form.

The primitives of the cell polygons (:mod:`.partition`): area and centroid, point-in-polygon
tests for one or many polygons at once, and polygons stacked into one vertex array.

The helpers the distributed filter (:mod:`phd_swarm.core.exchange.voronoi_phd`) needs beside the
partition itself (:mod:`.partition`): how far a cell reaches from its generator (the contact
rule, Dames 2020 Sec. III), which cells lie within the motion kernel's reach of each other
(phantom mass, Sec. III-B), and membership tests on the ascending flat bin indices a robot
owns. Every function that handles several polygons at once evaluates the same float
expressions per polygon as for one, so a result does not depend on how polygons are grouped.
"""

from __future__ import annotations

import numpy as np


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
    edge = np.concatenate((v[1:], v[:1])) - v
    length = np.hypot(edge[:, 0], edge[:, 1])
    # Zero-length edges are skipped; dividing them by 1 instead keeps the values finite.
    skip = length == 0.0
    length[skip] = 1.0
    inside = np.empty(p.shape[0], dtype=bool)
    # All edges at once, in blocks of about 2**16 (point, edge) pairs.
    block = max(1, (1 << 16) // v.shape[0])
    for start in range(0, p.shape[0], block):
        x, y = p[start:start + block, 0:1], p[start:start + block, 1:2]
        # Left of a CCW edge is inside: cross(edge, p - a) / |edge| is the inward distance.
        inward = (edge[:, 0] * (y - v[:, 1]) - edge[:, 1] * (x - v[:, 0])) / length
        inside[start:start + block] = ((inward >= -tol) | skip).all(axis=1)
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


def cell_radius(q: np.ndarray, cell: np.ndarray) -> float:
    """Largest distance from the generator ``q`` (2,) to a vertex of ``cell`` (V, 2) [m].

    0 for an empty cell (V = 0).
    """
    if len(cell) == 0:
        return 0.0
    return float(np.sqrt(((np.asarray(cell) - np.asarray(q)[None, :2]) ** 2).sum(axis=1).max()))


def cell_radii(generators: list[np.ndarray], cells: list[np.ndarray]) -> np.ndarray:
    """:func:`cell_radius` of each (generator, cell) pair in one array operation [m], (N,).

    Parameters
    ----------
    generators : list of np.ndarray, each shape (2,)
        Generators q_i [m].
    cells : list of np.ndarray, each shape (V_i, 2)
        Their cells; an empty one (V_i = 0) has radius 0.

    Returns
    -------
    np.ndarray, shape (N,)
    """
    out = np.zeros(len(cells))
    sizes = np.array([len(c) for c in cells], dtype=np.int64)
    full = np.flatnonzero(sizes)
    if full.size == 0:
        return out
    vertices = np.concatenate([cells[i] for i in full]).reshape(-1, 2)
    q = np.repeat(np.array([generators[i][:2] for i in full], dtype=float).reshape(-1, 2),
                  sizes[full], axis=0)
    d2 = ((vertices - q) ** 2).sum(axis=1)
    starts = np.concatenate([[0], np.cumsum(sizes[full][:-1])])
    out[full] = np.sqrt(np.maximum.reduceat(d2, starts))
    return out


def bounding_boxes(polys: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners of the axis-aligned boxes of non-empty polygons [m].

    Parameters
    ----------
    polys : list of np.ndarray, each shape (V_i, 2), V_i >= 1

    Returns
    -------
    lo, hi : np.ndarray, shape (len(polys), 2)
    """
    if not polys:
        return np.empty((0, 2)), np.empty((0, 2))
    starts = np.cumsum([0] + [len(p) for p in polys[:-1]])
    vertices = np.concatenate(polys)
    return np.minimum.reduceat(vertices, starts, axis=0), np.maximum.reduceat(vertices, starts,
                                                                             axis=0)


def polygon_distances(a: np.ndarray, polys: list[np.ndarray]) -> np.ndarray:
    """Distance between the convex polygon ``a`` and each of ``polys`` [m], shape (P,).

    0 where they touch or overlap (a vertex of one within 1e-9 m of the other), else the
    smallest vertex-to-edge distance either way. All polygons are handled in one array
    operation per term, with the same float expressions per (vertex, edge) pair as for a
    single pair, so the result does not depend on which polygons are grouped together.

    Parameters
    ----------
    a : np.ndarray, shape (V, 2)
        Convex counter-clockwise polygon [m].
    polys : list of np.ndarray, each shape (V_i, 2), V_i >= 1
        Convex counter-clockwise polygons [m].

    Returns
    -------
    np.ndarray, shape (len(polys),)
    """
    b, starts, following = stack_polygons(polys)
    a_in_b = points_in_polygons(a, polys, tol=1e-9).any(axis=0)
    b_in_a = np.logical_or.reduceat(points_in_polygon(b, a, tol=1e-9), starts)
    # Vertices of a to the edges of every b, and vertices of every b to the edges of a.
    a_to_b = np.minimum.reduceat(points_to_edges2(a, b, b[following]).min(axis=0), starts)
    b_to_a = np.minimum.reduceat(
        points_to_edges2(b, a, np.roll(a, -1, axis=0)).min(axis=1), starts)
    dist = np.minimum(np.sqrt(a_to_b), np.sqrt(b_to_a))
    return np.where(a_in_b | b_in_a, 0.0, dist)


def points_to_edges2(points: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """Squared distance from each point to each segment p0 -> p1 [m^2].

    Parameters
    ----------
    points : np.ndarray, shape (P, 2)
    p0, p1 : np.ndarray, shape (E, 2)
        Segment ends; a zero-length segment is its point.

    Returns
    -------
    np.ndarray, shape (P, E)
    """
    d = p1 - p0
    # A floor instead of a branch: a zero-length segment gives t = 0, its first end.
    len2 = np.maximum((d * d).sum(axis=1), 1e-300)
    rel = points[:, None, :] - p0[None, :, :]
    t = np.clip((rel * d[None]).sum(axis=2) / len2, 0.0, 1.0)
    closest = p0[None] + t[..., None] * d[None]
    return ((points[:, None, :] - closest) ** 2).sum(axis=2)


def positions_in_sorted(sorted_set: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Positions in the ascending ``sorted_set`` of those ``values`` it holds, int64 (K,).

    The order of ``values`` is kept; values not in the set are left out.
    """
    if sorted_set.size == 0 or values.size == 0:
        return np.empty(0, dtype=np.int64)
    pos = np.minimum(np.searchsorted(sorted_set, values), sorted_set.size - 1)
    return pos[sorted_set[pos] == values]


def isin_sorted(values: np.ndarray, sorted_set: np.ndarray) -> np.ndarray:
    """``np.isin(values, sorted_set)`` for an ascending ``sorted_set``, by binary search."""
    if sorted_set.size == 0:
        return np.zeros(values.shape, dtype=bool)
    pos = np.minimum(np.searchsorted(sorted_set, values), sorted_set.size - 1)
    return sorted_set[pos] == values


__all__ = ["bounding_boxes", "cell_radii", "cell_radius", "isin_sorted", "points_to_edges2",
           "polygon_distances", "positions_in_sorted"]
