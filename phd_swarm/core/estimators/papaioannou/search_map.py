"""The search map of Papaioannou et al.: the search density on virtual targets (eq. 7, 9, 10).

The surveillance region A is tiled by square regions r_v of side ``node_size``; the centre
of each is a *virtual target* x in X^0, a node v of the search map G (Sec. V-A). A node's
*search value* is eq. 10 with the search density constant over r_v,

    p^search(r_v) = int_{r_v} D(x in X^0) dx / (|r_v| / |A|) = |A| D(x_v in X^0),

in [0, 1]: 0 for a region never searched, 1 for a region just searched (Sec. V-B(a)).
This module stores p_v, one float per node, and runs the recursion on it:

- prediction, eq. 7: nodes outside the sensing area S_a(s_{k-1}) decay by J_k (a constant,
  0.999 in Sec. VI-A); nodes inside it keep their value;
- update, eq. 9: nodes inside S_a(s_k) get the density 1 / |A|, i.e. p_v = 1; the others
  keep the predicted value;
- cooperation, Sec. V-B(c): two maps merge by the elementwise max.

S_a(s) is the closed axis-aligned square of side ``side`` centred on s (eq. 5 prints its
boundary, max(|x - s_x|, |y - s_y|) = a / 2; the region is the set where the max is
<= a / 2). A virtual target is inside S_a(s) when its node centre is (IV-C's indicator on
the virtual target), so a region counts as searched only through its centre.

Index conventions are those of :class:`phd_swarm.core.geometry.grid.Grid`: node ``(iy, ix)`` has
flat index ``iy * nx + ix`` (x fastest) and centre ``(xmin + (ix + 0.5) node_size,
ymin + (iy + 0.5) node_size)`` [m].

Reference: S. Papaioannou et al., "A cooperative multi-agent probabilistic framework for
search and track missions", IEEE T-CNS, Sec. IV-C, V-A, V-B.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ...geometry.grid import Environment, Grid

__all__ = ["EDGE_TOLERANCE", "DEFAULT_DECAY", "SearchGrid", "initial_values", "predict",
           "update", "check_values", "max_merge", "unvisited", "searched_fraction"]

#: Slack [m] on the sensing square's half side: a node on the closed square's edge in exact
#: arithmetic stays inside when the agent's position carries rounding (e.g. 0.1 + 0.2).
EDGE_TOLERANCE = 1e-9

#: J_k(x), the decay of eq. 7 per step outside the sensing area (Sec. VI-A: 0.999).
DEFAULT_DECAY = 0.999


@dataclass(frozen=True)
class SearchGrid:
    """The nodes of the search map and the agent's square sensing area.

    Parameters
    ----------
    xmin, ymin, xmax, ymax : float
        The surveillance region A [m]; its width and height must be whole multiples of
        ``node_size`` (to 1e-9 relative) so the regions r_v tile A with equal areas.
    node_size : float
        Side of a region r_v [m], > 0. The paper does not give it.
    side : float
        Side a of the sensing square S_a [m], > 0 (Sec. VI-A: 10 m).

    Attributes
    ----------
    nx, ny, size : int
        Nodes along x, along y, and S = nx * ny.
    positions : np.ndarray, shape (S, 2)
        The virtual targets (node centres) [m], flat-index order, read-only.

    Raises
    ------
    ValueError
        For bounds that are not finite or not increasing, a node size or side that is not
        a finite number > 0, or a region that is not a whole number of nodes.
    """

    xmin: float
    ymin: float
    xmax: float
    ymax: float
    node_size: float
    side: float

    def __post_init__(self) -> None:
        bounds = (self.xmin, self.ymin, self.xmax, self.ymax)
        if not all(math.isfinite(float(v)) for v in bounds) or not (
                self.xmax > self.xmin and self.ymax > self.ymin):
            raise ValueError(f"search grid: expected finite bounds with xmax > xmin and "
                             f"ymax > ymin, got {bounds}")
        for name in ("node_size", "side"):
            v = getattr(self, name)
            if not (math.isfinite(float(v)) and v > 0):
                raise ValueError(f"search grid: {name} must be a finite number > 0 [m], "
                                 f"got {v!r}")
        for name, extent in (("width", self.xmax - self.xmin),
                             ("height", self.ymax - self.ymin)):
            n = extent / self.node_size
            if abs(n - round(n)) > 1e-9 * max(1.0, n) or round(n) < 1:
                raise ValueError(f"search grid: region {name} {extent} m is not a whole "
                                 f"number of {self.node_size} m nodes")

    @cached_property
    def grid(self) -> Grid:
        """The same nodes as a :class:`~phd_swarm.core.geometry.grid.Grid` of bins."""
        return Grid(Environment(self.xmin, self.ymin, self.xmax, self.ymax), self.node_size)

    @property
    def nx(self) -> int:
        """Nodes along x."""
        return self.grid.nx

    @property
    def ny(self) -> int:
        """Nodes along y."""
        return self.grid.ny

    @property
    def size(self) -> int:
        """S, the number of nodes (virtual targets)."""
        return self.grid.size

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """The region (xmin, ymin, xmax, ymax) [m]."""
        return (self.xmin, self.ymin, self.xmax, self.ymax)

    @property
    def area(self) -> float:
        """|A| [m^2]."""
        return (self.xmax - self.xmin) * (self.ymax - self.ymin)

    @property
    def node_area(self) -> float:
        """|r_v| [m^2], the same for every node."""
        return self.node_size * self.node_size

    @property
    def positions(self) -> np.ndarray:
        """Node centres, shape (S, 2) [m], read-only."""
        return self.grid.centres

    def flat_index(self, iy: np.ndarray, ix: np.ndarray) -> np.ndarray:
        """Flat index ``iy * nx + ix`` of nodes ``(iy, ix)``."""
        return self.grid.flat_index(iy, ix)

    def unravel(self, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(iy, ix)`` of flat indices; the inverse of :meth:`flat_index`."""
        return self.grid.unravel(flat)

    def node_of(self, points: np.ndarray) -> np.ndarray:
        """Flat index of the region r_v containing each point, -1 outside A.

        Parameters
        ----------
        points : array_like, shape (N, 2) or (2,)
            Positions [m].

        Returns
        -------
        np.ndarray of int, shape (N,)
            Points on the upper edges belong to the last row/column of regions.
        """
        return self.grid.bin_of(points)

    def inside(self, positions: np.ndarray, side: float | None = None) -> np.ndarray:
        """Which virtual targets lie in the closed sensing square S_a(s) (eq. 5, IV-C).

        A node x is inside when ``max(|x_x - s_x|, |x_y - s_y|) <= side / 2`` (with
        :data:`EDGE_TOLERANCE` slack). The test is separable, so it runs on the nx column
        and ny row coordinates and one outer product.

        Parameters
        ----------
        positions : array_like, shape (..., 2)
            Centres s of the squares (agent positions) [m].
        side : float, optional
            Side of the square [m]; :attr:`side` by default.

        Returns
        -------
        np.ndarray of bool, shape (..., S)
            The indicator 1_{S_a}(x_v, s) for every node v.
        """
        s = np.asarray(positions, dtype=float)
        if s.shape[-1:] != (2,):
            raise ValueError(f"inside: expected positions of shape (..., 2), got {s.shape}")
        if not np.isfinite(s).all():
            raise ValueError("inside: positions must be finite")
        side = self.side if side is None else float(side)
        if not (math.isfinite(side) and side > 0):
            raise ValueError(f"inside: side must be a finite number > 0 [m], got {side!r}")
        half = 0.5 * side + EDGE_TOLERANCE
        in_x = np.abs(self.grid.xs - s[..., 0, None]) <= half          # (..., nx)
        in_y = np.abs(self.grid.ys - s[..., 1, None]) <= half          # (..., ny)
        return (in_y[..., :, None] & in_x[..., None, :]).reshape(s.shape[:-1] + (self.size,))


def initial_values(grid: SearchGrid) -> np.ndarray:
    """The search values before anything is searched: 0 everywhere, shape (S,)."""
    return np.zeros(grid.size)


def check_values(values: np.ndarray, size: int | None = None,
                 what: str = "values") -> np.ndarray:
    """``values`` as a float array of shape (size,) (any length if None) in [0, 1].

    Raises a ValueError naming ``what`` for another shape, NaN or a value outside [0, 1].
    """
    v = np.asarray(values, dtype=float)
    if v.ndim != 1 or (size is not None and v.shape[0] != size):
        want = "(S,)" if size is None else f"({size},)"
        raise ValueError(f"search map: expected {what} of shape {want}, got {v.shape}")
    if v.size and not (v.min() >= 0.0 and v.max() <= 1.0):
        raise ValueError(f"search map: {what} must be search values in [0, 1] (no NaN), "
                         f"got range [{v.min()}, {v.max()}]")
    return v


def _check_position(position: np.ndarray) -> np.ndarray:
    s = np.asarray(position, dtype=float)
    if s.shape != (2,) or not np.isfinite(s).all():
        raise ValueError(f"search map: expected a finite position of shape (2,), "
                         f"got {s.tolist()}")
    return s


def predict(values: np.ndarray, grid: SearchGrid, previous_position: np.ndarray,
            decay: float = DEFAULT_DECAY) -> np.ndarray:
    """Prediction of the search density, eq. 7, on the search values.

    p_{k|k-1}(v) = p_{k-1}(v) [(1 - 1_{S_a}(x_v, s_{k-1})) J + 1_{S_a}(x_v, s_{k-1})]:
    nodes outside the sensing square at the previous position decay by J, nodes inside it
    keep their value.

    Parameters
    ----------
    values : np.ndarray, shape (S,)
        p_{k-1}, search values in [0, 1].
    grid : SearchGrid
    previous_position : array_like, shape (2,)
        s_{k-1} [m].
    decay : float
        J_k, constant over the map, in [0, 1].

    Returns
    -------
    np.ndarray, shape (S,)
        p_{k|k-1}, a new array.
    """
    v = check_values(values, grid.size)
    if not (math.isfinite(decay) and 0.0 <= decay <= 1.0):
        raise ValueError(f"search map: decay J must be in [0, 1], got {decay!r}")
    return np.where(grid.inside(_check_position(previous_position)), v, v * decay)


def update(values: np.ndarray, grid: SearchGrid, position: np.ndarray) -> np.ndarray:
    """Update of the search density, eq. 9, on the search values.

    D_k = 1_{S_a}(x, s_k) / |A| + (1 - 1_{S_a}(x, s_k)) D_{k|k-1}; through eq. 10,
    p_k(v) = 1 inside the sensing square at the new position, p_{k|k-1}(v) elsewhere.

    Parameters
    ----------
    values : np.ndarray, shape (S,)
        p_{k|k-1}, search values in [0, 1].
    grid : SearchGrid
    position : array_like, shape (2,)
        s_k [m].

    Returns
    -------
    np.ndarray, shape (S,)
        p_k, a new array.
    """
    v = check_values(values, grid.size)
    return np.where(grid.inside(_check_position(position)), 1.0, v)


def max_merge(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Fuse two agents' search maps by the elementwise max (Sec. V-B(c)).

    Parameters
    ----------
    a, b : np.ndarray, shape (S,)
        Search values in [0, 1] on the same grid.

    Returns
    -------
    np.ndarray, shape (S,)
    """
    a = check_values(a, None, "first map")
    b = check_values(b, a.shape[0], "second map")
    return np.maximum(a, b)


def unvisited(values: np.ndarray, beta: float) -> np.ndarray:
    """The unvisited nodes V-bar = {v : p_v <= beta} (Sec. V-B(a)), ascending.

    Parameters
    ----------
    values : np.ndarray, shape (S,)
        Search values in [0, 1].
    beta : float
        The threshold, in [0, 1]; inclusive.

    Returns
    -------
    np.ndarray of int, shape (K,)
    """
    v = check_values(values, None)
    if not (math.isfinite(beta) and 0.0 <= beta <= 1.0):
        raise ValueError(f"search map: threshold beta must be in [0, 1], got {beta!r}")
    return np.flatnonzero(v <= beta)


def searched_fraction(values: np.ndarray) -> float:
    """int_A D(x in X^0) dx: the searched share of A (Fig. 1, 2, 4 plot it in percent).

    With the density constant over equal-area regions, the integral is
    sum_v D_v |r_v| = sum_v p_v |r_v| / |A| = mean(p_v). Decayed values count by their
    value, so it stays below 1 under any decay J < 1, as the paper notes (Sec. VI-B).

    Parameters
    ----------
    values : np.ndarray, shape (S,)
        Search values in [0, 1], S >= 1.

    Returns
    -------
    float, in [0, 1]
    """
    v = check_values(values, None)
    if v.size == 0:
        raise ValueError("search map: searched_fraction of an empty map")
    return float(v.mean())
