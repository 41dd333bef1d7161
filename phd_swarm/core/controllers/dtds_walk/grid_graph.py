"""The spatial grid graph of Shirsat & Berman Sec. II-III and its random walk (eq. 4).

The environment is discretised into a square grid; the vertices of its cells are the
*nodes* (Sec. II), and a robot moves at each discrete time k from its node i to a node of
N(i) ∪ {i}, each with probability 1 / (d_i + 1) (eq. 4), d_i the number of neighbours of
i. The paper does not say whether the neighbours are the 4 nodes one spacing away along
the axes or also the 4 diagonal ones; :class:`GridGraph` offers both (``neighbours`` = 4
or 8). Every node has a self-loop (Fig. 2: "self-edges"), which is what makes the chain
aperiodic.

Reference: A. Shirsat and S. Berman, "Decentralized multi-target tracking with multiple
quadrotors using a PHD filter", AIAA SciTech 2021, Sec. II-III, eq. 1-4.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np
import scipy.sparse as sp

#: Relative tolerance with which a side that is a whole number of spacings (in floating
#: point, e.g. 5 / 0.1 = 49.999...) gets its last node.
SIDE_TOLERANCE = 1e-9

#: Node moves (dx, dy) in units of the spacing, by neighbourhood.
MOVES = {
    4: ((1, 0), (0, 1), (-1, 0), (0, -1)),
    8: ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)),
}


def lattice_count(lo: float, hi: float, spacing: float) -> int:
    """Number of nodes lo, lo + spacing, ... that are <= hi (at least 1).

    A side that is not a whole number of spacings ends at its last whole spacing; one that
    is, up to :data:`SIDE_TOLERANCE` relative, ends on ``hi``.
    """
    return int(math.floor((hi - lo) / spacing + SIDE_TOLERANCE)) + 1


def lattice_range(lo: float, spacing: float, count: int, box_lo: float,
                  box_hi: float) -> tuple[int, int]:
    """Indices ``(first, last)`` (inclusive) of the lattice nodes inside an interval.

    The nodes are ``lo + i spacing``, i < count; those in [box_lo, box_hi] (with
    :data:`SIDE_TOLERANCE` relative slack) are kept; ``first > last`` if there is none.
    """
    first = max(0, math.ceil((box_lo - lo) / spacing - SIDE_TOLERANCE))
    last = min(count - 1, math.floor((box_hi - lo) / spacing + SIDE_TOLERANCE))
    return first, last


class GridGraph:
    """Nodes of a square grid over a rectangle and the random walk of eq. 4.

    Nodes are at ``(xmin + i spacing, ymin + j spacing)`` for i = 0..nx-1, j = 0..ny-1,
    numbered ``j * nx + i`` (x fastest). The grid is anchored at (xmin, ymin) and includes
    the nodes on the rectangle's edges; a side that is not a whole number of spacings ends
    at its last whole spacing, so a strip narrower than one spacing along the far (max)
    edges has no nodes (:func:`lattice_count`). A node's neighbours N(i) are the nodes one
    spacing away along the axes (``neighbours=4``) or also along the diagonals
    (``neighbours=8``); its degree d_i = |N(i)| does not count its self-loop.

    Parameters
    ----------
    xmin, ymin, xmax, ymax : float
        The rectangle [m], xmax >= xmin, ymax >= ymin.
    spacing : float
        Cell side [m], > 0.
    neighbours : {4, 8}
        The moves: axis neighbours only, or with the diagonals.

    Attributes
    ----------
    nx, ny : int
        Nodes along x and y.
    positions : np.ndarray, shape (S, 2)
        Node positions [m].
    degrees : np.ndarray of int, shape (S,)
        d_i, neighbours of each node (self-loop not counted).
    table : np.ndarray of int, shape (S, 1 + K)
        Row i: i itself, then its d_i neighbours, then -1 padding (K = ``neighbours``);
        a uniform index in 0..d_i picks a move of eq. 4.

    Raises
    ------
    ValueError
        For bounds that are not finite or are reversed, a spacing that is not a finite
        number > 0, or ``neighbours`` other than 4 or 8.
    """

    def __init__(self, xmin: float, ymin: float, xmax: float, ymax: float, spacing: float,
                 neighbours: int = 4) -> None:
        bounds = [float(v) for v in (xmin, ymin, xmax, ymax)]
        if not all(math.isfinite(v) for v in bounds) or bounds[2] < bounds[0] \
                or bounds[3] < bounds[1]:
            raise ValueError(f"grid graph: expected finite bounds with xmax >= xmin and "
                             f"ymax >= ymin, got {tuple(bounds)}")
        spacing = float(spacing)
        if not (math.isfinite(spacing) and spacing > 0):
            raise ValueError(f"grid graph: spacing must be a finite number > 0 [m], "
                             f"got {spacing!r}")
        if isinstance(neighbours, bool) or neighbours not in MOVES:
            raise ValueError(f"grid graph: neighbours must be 4 or 8, got {neighbours!r}")
        self.xmin, self.ymin, self.xmax, self.ymax = bounds
        self.spacing = spacing
        self.neighbours = int(neighbours)
        self.nx = lattice_count(self.xmin, self.xmax, spacing)
        self.ny = lattice_count(self.ymin, self.ymax, spacing)
        ix = np.tile(np.arange(self.nx), self.ny)
        iy = np.repeat(np.arange(self.ny), self.nx)
        self.positions = np.column_stack([self.xmin + ix * spacing, self.ymin + iy * spacing])
        moves = np.array(MOVES[self.neighbours])
        jx = ix[:, None] + moves[:, 0]
        jy = iy[:, None] + moves[:, 1]
        valid = (jx >= 0) & (jx < self.nx) & (jy >= 0) & (jy < self.ny)
        target = np.where(valid, jy * self.nx + jx, -1)
        # Valid moves first, in MOVES order, then the padding.
        order = np.argsort(~valid, axis=1, kind="stable")
        self.degrees = valid.sum(axis=1)
        self.table = np.column_stack([np.arange(self.size),
                                      np.take_along_axis(target, order, axis=1)])

    @property
    def size(self) -> int:
        """S, the number of nodes."""
        return self.nx * self.ny

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """The rectangle (xmin, ymin, xmax, ymax) [m] the graph was built over."""
        return (self.xmin, self.ymin, self.xmax, self.ymax)

    @property
    def longest_move(self) -> float:
        """Length of the longest move [m]: the spacing, times sqrt(2) with diagonals."""
        return self.spacing * (math.sqrt(2.0) if self.neighbours == 8 else 1.0)

    def node_of(self, points: np.ndarray) -> np.ndarray:
        """Index of the node nearest each point (vectorised).

        The grid is a product of two 1-D lattices, so the nearest node rounds each
        coordinate to its nearest lattice value and clips it to the grid; points outside
        the rectangle get the nearest node on its border. A coordinate exactly half-way
        between two nodes goes to the upper one.

        Parameters
        ----------
        points : array_like, shape (..., 2)
            Positions [m].

        Returns
        -------
        np.ndarray of int, shape (...)
        """
        p = np.asarray(points, dtype=float)
        if p.shape[-1:] != (2,):
            raise ValueError(f"node_of: expected points of shape (..., 2), got {p.shape}")
        ix = np.clip(np.floor((p[..., 0] - self.xmin) / self.spacing + 0.5), 0, self.nx - 1)
        iy = np.clip(np.floor((p[..., 1] - self.ymin) / self.spacing + 0.5), 0, self.ny - 1)
        return (iy * self.nx + ix).astype(np.int64)

    def node_of_point(self, x: float, y: float) -> int:
        """:meth:`node_of` for one point (x, y) [m], in scalar arithmetic (a robot's step).

        The same operations on the same doubles as :meth:`node_of`, so the same node.
        """
        ix = min(max(math.floor((x - self.xmin) / self.spacing + 0.5), 0), self.nx - 1)
        iy = min(max(math.floor((y - self.ymin) / self.spacing + 0.5), 0), self.ny - 1)
        return iy * self.nx + ix

    def neighbours_of(self, node: int) -> np.ndarray:
        """N(i): the neighbours of node ``node`` (itself excluded), shape (d_i,)."""
        return self.table[node, 1:1 + self.degrees[node]].copy()

    @cached_property
    def edges(self) -> np.ndarray:
        """The edge set E_s as directed pairs (i, j), self-loops (i, i) first, shape (E, 2).

        Undirected: (i, j) is in it exactly when (j, i) is (Sec. II). E = S + sum d_i.
        """
        rows = np.repeat(np.arange(self.size), self.degrees + 1)
        cols = self.table[self.table >= 0]
        # table rows list i first, so its row-major valid entries are (i, i), (i, N(i)).
        out = np.column_stack([rows, cols])
        loops = out[:, 0] == out[:, 1]
        return np.vstack([out[loops], out[~loops]])

    @cached_property
    def transition_matrix(self) -> sp.csr_matrix:
        """P of eq. 4: p_ij = 1 / (d_i + 1) for j in N(i) ∪ {i}, else 0 (S x S, CSR).

        Row-stochastic: a robot's distribution evolves as the row vector pi_{k+1} = pi_k P
        (eq. 1, written there with P acting on a column).
        """
        rows = np.repeat(np.arange(self.size), self.degrees + 1)
        cols = self.table[self.table >= 0]
        vals = np.repeat(1.0 / (self.degrees + 1), self.degrees + 1)
        return sp.csr_matrix((vals, (rows, cols)), shape=(self.size, self.size))

    @cached_property
    def stationary(self) -> np.ndarray:
        """The stationary distribution pi_i = (d_i + 1) / sum_j (d_j + 1), shape (S,).

        Proof (detailed balance). For an edge (i, j) of E_s, self-loops included,
        pi_i p_ij = (d_i + 1) / Z * 1 / (d_i + 1) = 1 / Z with Z = sum_l (d_l + 1); since
        E_s is undirected, (j, i) is an edge too and pi_j p_ji = 1 / Z. For a pair that is
        not an edge both sides are 0. So pi_i p_ij = pi_j p_ji for all i, j: P is
        reversible with respect to pi, and summing over i gives (pi P)_j =
        sum_i pi_j p_ji = pi_j, so pi is stationary; it is the only one, the chain being
        irreducible on a connected grid (Sec. III).
        """
        w = (self.degrees + 1).astype(float)
        return w / w.sum()

    def step(self, rng: np.random.Generator, nodes: np.ndarray) -> np.ndarray:
        """One move of eq. 4 for many robots at once.

        Each robot at node i draws a uniform index in 0..d_i into row i of :attr:`table`
        (itself, then its neighbours): each of the d_i + 1 moves has probability
        1 / (d_i + 1).

        Parameters
        ----------
        rng : np.random.Generator
            The only source of randomness (one ``integers`` draw per robot).
        nodes : array_like of int, shape (...)
            Current nodes.

        Returns
        -------
        np.ndarray of int, shape (...)
            The next nodes.
        """
        nodes = np.asarray(nodes, dtype=np.int64)
        pick = rng.integers(0, self.degrees[nodes] + 1)
        return self.table[nodes, pick]

    def __repr__(self) -> str:
        return (f"GridGraph({self.xmin}, {self.ymin}, {self.xmax}, {self.ymax}, "
                f"spacing={self.spacing}, neighbours={self.neighbours}: "
                f"{self.nx} x {self.ny} nodes)")
