"""Geometry of cells in array form: radii, bounding boxes, polygon distances, bin-index sets.

The helpers the distributed filter (:mod:`phd_swarm.core.exchange.voronoi_phd`) needs beside the
partition itself (:mod:`.partition`): how far a cell reaches from its generator (the contact
rule, Dames 2020 Sec. III), which cells lie within the motion kernel's reach of each other
(phantom mass, Sec. III-B), and membership tests on the ascending flat bin indices a robot
owns. Every function that handles several polygons at once evaluates the same float
expressions per polygon as for one, so a result does not depend on how polygons are grouped.
"""

from __future__ import annotations

import numpy as np

from .partition import points_in_polygon, points_in_polygons, stack_polygons


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
