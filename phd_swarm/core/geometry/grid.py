"""Rectangular environment and the uniform grid of bins that carries the PHD.

Dames (2020), Sec. III: "we divide the environment into a collection of equally-sized,
square bins and represent each bin with a single, stationary particle at its centroid".
The PHD is then one weight per bin: the expected number of targets in that bin (a *mass*,
dimensionless), never a density.

Index conventions (used everywhere in the stack):

- an image of the grid has shape ``(ny, nx)``; row ``iy`` is the y index, column ``ix`` the
  x index, row 0 at ``ymin`` (y grows with the row);
- a *flat* index is ``iy * nx + ix`` (C order of the image), so
  ``image.ravel()[flat] == image[iy, ix]``;
- bin ``(iy, ix)`` covers ``[xmin + ix*res, xmin + (ix+1)*res) x [ymin + iy*res, ...)``
  and its centre is ``(xmin + (ix+0.5)*res, ymin + (iy+0.5)*res)`` [m].
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class Environment:
    """Convex rectangular environment E = [xmin, xmax] x [ymin, ymax] [m]."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float

    def __post_init__(self) -> None:
        vals = (self.xmin, self.ymin, self.xmax, self.ymax)
        if not all(np.isfinite(v) for v in vals):
            raise ValueError(f"environment bounds must be finite, got {vals}")
        if not (self.xmax > self.xmin and self.ymax > self.ymin):
            raise ValueError(
                f"environment must have xmax > xmin and ymax > ymin, got {vals}")

    @property
    def width(self) -> float:
        """Extent along x [m]."""
        return self.xmax - self.xmin

    @property
    def height(self) -> float:
        """Extent along y [m]."""
        return self.ymax - self.ymin

    @property
    def area(self) -> float:
        """Area of E [m^2]."""
        return self.width * self.height

    @property
    def corners(self) -> np.ndarray:
        """Counter-clockwise corners, shape (4, 2) [m]."""
        return np.array([[self.xmin, self.ymin], [self.xmax, self.ymin],
                         [self.xmax, self.ymax], [self.xmin, self.ymax]])

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether each point lies in the closed rectangle; points (..., 2) -> bool (...)."""
        p = np.asarray(points, dtype=float)
        return ((p[..., 0] >= self.xmin) & (p[..., 0] <= self.xmax)
                & (p[..., 1] >= self.ymin) & (p[..., 1] <= self.ymax))

    def distance_to_boundary(self, points: np.ndarray) -> np.ndarray:
        """Distance ||x - dE|| from points inside E to the boundary [m]; (..., 2) -> (...)."""
        p = np.asarray(points, dtype=float)
        return np.minimum.reduce([p[..., 0] - self.xmin, self.xmax - p[..., 0],
                                  p[..., 1] - self.ymin, self.ymax - p[..., 1]])


@dataclass(frozen=True)
class Grid:
    """Uniform square bins of side ``resolution`` [m] covering an :class:`Environment`.

    The environment's width and height must be whole multiples of the resolution (to 1e-9
    relative), so that the bins tile E exactly and bin areas sum to the area of E.
    """

    env: Environment
    resolution: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.resolution) and self.resolution > 0):
            raise ValueError(f"grid resolution must be a positive number, got {self.resolution}")
        for name, extent in (("width", self.env.width), ("height", self.env.height)):
            n = extent / self.resolution
            if abs(n - round(n)) > 1e-9 * max(1.0, n) or round(n) < 1:
                raise ValueError(
                    f"environment {name} {extent} m is not a whole number of "
                    f"{self.resolution} m bins")

    @property
    def nx(self) -> int:
        """Number of bins along x."""
        return int(round(self.env.width / self.resolution))

    @property
    def ny(self) -> int:
        """Number of bins along y."""
        return int(round(self.env.height / self.resolution))

    @property
    def shape(self) -> tuple[int, int]:
        """Image shape ``(ny, nx)``."""
        return (self.ny, self.nx)

    @property
    def size(self) -> int:
        """Number of bins."""
        return self.nx * self.ny

    @property
    def bin_area(self) -> float:
        """Area of one bin [m^2]."""
        return self.resolution * self.resolution

    @cached_property
    def xs(self) -> np.ndarray:
        """Bin-centre x coordinates, shape (nx,) [m]."""
        return self.env.xmin + (np.arange(self.nx) + 0.5) * self.resolution

    @cached_property
    def ys(self) -> np.ndarray:
        """Bin-centre y coordinates, shape (ny,) [m]."""
        return self.env.ymin + (np.arange(self.ny) + 0.5) * self.resolution

    @cached_property
    def centres(self) -> np.ndarray:
        """Bin centres in flat-index order, shape (size, 2) [m]. Read-only."""
        xx, yy = np.meshgrid(self.xs, self.ys)
        c = np.stack([xx.ravel(), yy.ravel()], axis=1)
        c.setflags(write=False)
        return c

    @cached_property
    def _origin(self) -> np.ndarray:
        """``(xmin, ymin)`` [m], shape (2,)."""
        return np.array([self.env.xmin, self.env.ymin])

    def flat_index(self, iy: np.ndarray, ix: np.ndarray) -> np.ndarray:
        """Flat index of bins ``(iy, ix)``."""
        return np.asarray(iy) * self.nx + np.asarray(ix)

    def unravel(self, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of :meth:`flat_index`: ``(iy, ix)``."""
        return np.divmod(np.asarray(flat), self.nx)

    def centres_of(self, flat: np.ndarray) -> np.ndarray:
        """Centres of the given bins, shape (len(flat), 2) [m]."""
        iy, ix = self.unravel(flat)
        out = np.empty((ix.size, 2))
        out[:, 0] = self.xs[ix]
        out[:, 1] = self.ys[iy]
        return out

    def bin_of(self, points: np.ndarray) -> np.ndarray:
        """Flat index of the bin containing each point; points outside E give -1.

        Points on the upper edges ``x == xmax`` or ``y == ymax`` belong to the last bin.
        """
        p = np.atleast_2d(np.asarray(points, dtype=float))
        inside = self.env.contains(p)
        # Outside points (NaN included) are moved to xmin, ymin so the int cast is defined.
        q = np.where(inside[:, None], p, [self.env.xmin, self.env.ymin])
        ix = np.floor((q[:, 0] - self.env.xmin) / self.resolution).astype(np.int64)
        iy = np.floor((q[:, 1] - self.env.ymin) / self.resolution).astype(np.int64)
        # Clipping puts the upper edges in the last bin, and also points just below an upper
        # edge whose quotient rounds up to nx (e.g. the float below 1.5 with xmin -1.5, res 0.3).
        ix = np.clip(ix, 0, self.nx - 1)
        iy = np.clip(iy, 0, self.ny - 1)
        return np.where(inside, iy * self.nx + ix, -1)

    def disk_bins(self, centre: np.ndarray, radius: float) -> np.ndarray:
        """Flat indices (ascending) of the bins whose centres lie within ``radius`` of ``centre``.

        Only the bounding box of the disk is scanned, so the cost is O(radius^2 / res^2),
        independent of the map size.
        """
        cx, cy = float(centre[0]), float(centre[1])
        res = self.resolution
        ix0 = max(int(np.floor((cx - radius - self.env.xmin) / res - 0.5)), 0)
        ix1 = min(int(np.ceil((cx + radius - self.env.xmin) / res - 0.5)), self.nx - 1)
        iy0 = max(int(np.floor((cy - radius - self.env.ymin) / res - 0.5)), 0)
        iy1 = min(int(np.ceil((cy + radius - self.env.ymin) / res - 0.5)), self.ny - 1)
        if ix1 < ix0 or iy1 < iy0:
            return np.empty(0, dtype=np.int64)
        ix = np.arange(ix0, ix1 + 1)
        iy = np.arange(iy0, iy1 + 1)
        dx2 = (self.xs[ix] - cx) ** 2
        dy2 = (self.ys[iy] - cy) ** 2
        inside = dy2[:, None] + dx2[None, :] <= radius * radius
        iyy, ixx = np.nonzero(inside)
        return (iy[iyy] * self.nx + ix[ixx]).astype(np.int64)

    def disks_meet(self, flat: np.ndarray, centres: np.ndarray, radius: float) -> np.ndarray:
        """Whether each disk's :meth:`disk_bins` shares a bin with ``flat``, without listing it.

        ``disks_meet(flat, c, r)[i] == np.isin(disk_bins(c[i], r), flat).any()`` exactly:
        the disk's bounding box and the distance test are the same float expressions as in
        :meth:`disk_bins`, evaluated for every (bin, disk) pair of ``flat`` and the disks
        whose boxes meet the box of ``flat``. The cost is O(K x C) for K bins and C such
        disks, in blocks of about 2**16 pairs.

        Parameters
        ----------
        flat : np.ndarray of int, shape (K,)
            Flat indices of the bins (any order).
        centres : np.ndarray, shape (C, 2)
            Disk centres [m].
        radius : float
            Disk radius [m].

        Returns
        -------
        np.ndarray of bool, shape (C,)
        """
        flat = np.asarray(flat, dtype=np.int64).reshape(-1)
        c = np.asarray(centres, dtype=float).reshape(-1, 2)
        meet = np.zeros(c.shape[0], dtype=bool)
        if flat.size == 0 or c.shape[0] == 0:
            return meet
        res = self.resolution
        cx, cy = c[:, 0], c[:, 1]
        # Each disk's box of bin columns (x) and rows (y), both axes at once.
        lo = np.maximum(np.floor((c - radius - self._origin) / res - 0.5), 0)
        hi = np.minimum(np.ceil((c + radius - self._origin) / res - 0.5), (self.nx - 1,
                                                                           self.ny - 1))
        ix0, iy0, ix1, iy1 = lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1]
        iy, ix = self.unravel(flat)
        x_lo, x_hi, y_lo, y_hi = int(ix.min()), int(ix.max()), int(iy.min()), int(iy.max())
        cand = np.flatnonzero(np.logical_and.reduce(
            (lo <= (x_hi, y_hi)) & (hi >= (x_lo, y_lo)) & (lo <= hi), axis=1))
        # The squared distances along x of every column of the bins' box to every disk
        # centre, +inf outside the disk's box (likewise along y): a pair's sum is then the
        # distance test's value inside both boxes and +inf elsewhere.
        cols = np.arange(x_lo, x_hi + 1)[:, None]
        rows = np.arange(y_lo, y_hi + 1)[:, None]
        ix -= x_lo
        iy -= y_lo
        r2 = radius * radius
        block = max(1, (1 << 16) // flat.size)
        for start in range(0, cand.size, block):
            k = cand[start:start + block]
            dx2 = (self.xs[x_lo:x_hi + 1, None] - cx[k]) ** 2
            dx2[(cols < ix0[k]) | (cols > ix1[k])] = np.inf
            dy2 = (self.ys[y_lo:y_hi + 1, None] - cy[k]) ** 2
            dy2[(rows < iy0[k]) | (rows > iy1[k])] = np.inf
            meet[k] = (dy2[iy] + dx2[ix] <= r2).any(axis=0)
        return meet

    def image(self, flat: np.ndarray, values: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """Scatter per-bin ``values`` at ``flat`` indices into a full ``(ny, nx)`` image."""
        img = np.full(self.size, fill, dtype=float)
        img[np.asarray(flat, dtype=np.int64)] = values
        return img.reshape(self.shape)
