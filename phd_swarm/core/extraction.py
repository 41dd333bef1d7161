"""Target extraction from the grid PHD: local maxima of the bin-weight image.

Dames (2020), Sec. IV: "we converted the PHD to an image and used the LocalMaximaFinder
from the MATLAB Computer Vision toolbox with a neighborhood size of 3 and a threshold of
0.05. The resulting maxima were used as the best guess of the target set." The image is
the per-bin weight w_j, an expected number of targets per bin (a mass, dimensionless),
laid out as in :mod:`phd_swarm.core.geometry.grid` (shape ``(ny, nx)``, flat index ``iy*nx + ix``).

Differences from MATLAB's ``vision.LocalMaximaFinder``, which repeatedly takes the global
maximum that "matches or exceeds" the threshold and zeroes its neighbourhood, up to a
maximum count (default 2, not given in the paper):

- a bin is kept only if it is a true local maximum (no larger bin in its window), so the
  shoulder of a broad peak just outside the suppressed window is not reported;
- the threshold is strict (``w > threshold``), so an image at the threshold gives nothing;
- there is no cap on the number of maxima;
- plateaus of equal maximal bins give one estimate each (see :func:`extract_targets`).

The threshold is a per-bin *mass*, so it does not scale with the grid resolution: a unit
mass spread as a Gaussian of 0.5 m s.d. (the measurement noise of Dames eq. 10) puts 0.47
in its central 1 m bin but 0.0063 in its central 0.1 m bin (100x more bins share it), so
a fixed 0.05 finds nothing at Chen's 0.1 m resolution.
``ExtractionConfig.threshold_per_m2`` states the threshold as a density instead (the
effective per-bin threshold is ``threshold_per_m2 * bin_area``; 0.05 per m^2 reproduces
Dames at 1 m), and ``neighbourhood_m`` states the window in metres.

The square window merges close peaks: two maxima are both kept only if each lies outside
the other's window, i.e. more than half a window apart along an axis (a 3 m window merges
targets 1.5 m apart, and diagonal pairs up to 2.1 m apart). ``ExtractionConfig.radius_m``
replaces the square by a disk: a bin is a maximum when no bin whose centre lies within
``radius_m`` of its own is larger, so any two peaks more than ``radius_m`` apart, in any
direction, are both kept (docs/decisions.md, "The extraction floor").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .geometry.grid import Grid

_EIGHT_CONNECTED = np.ones((3, 3), dtype=bool)


@dataclass(frozen=True)
class ExtractionConfig:
    """Parameters of :func:`extract_targets` (Dames Sec. IV: neighbourhood 3, threshold 0.05).

    Attributes
    ----------
    threshold : float
        A bin must carry strictly more than this mass (expected targets per bin) to be an
        estimate. Ignored when ``threshold_per_m2`` is set.
    neighbourhood : int
        Side of the square window, in bins, in which a maximum must be the largest; odd,
        >= 3 (so that 8-adjacent maxima are equal and form a plateau). Ignored when
        ``neighbourhood_m`` is set.
    threshold_per_m2 : float or None
        Threshold as a density [targets/m^2]; the per-bin threshold is then
        ``threshold_per_m2 * grid.bin_area``, which keeps the same meaning at any resolution.
    neighbourhood_m : float or None
        Window side [m]; the window is the nearest odd number of bins to
        ``neighbourhood_m / resolution`` (halves round up), and at least 3.
    radius_m : float or None
        If set, the window is the disk of this radius [m] instead of a square: the bins
        whose centres lie within ``radius_m`` of the bin's centre (:meth:`footprint`). It
        must reach the four nearest bins (``radius_m >= resolution``), else every bin
        above the threshold would be a maximum.
    """

    threshold: float = 0.05
    neighbourhood: int = 3
    threshold_per_m2: float | None = None
    neighbourhood_m: float | None = None
    radius_m: float | None = None

    def __post_init__(self) -> None:
        if not (np.isfinite(self.threshold) and self.threshold >= 0):
            raise ValueError(f"extraction.threshold must be a finite number >= 0, "
                             f"got {self.threshold!r}")
        if (isinstance(self.neighbourhood, bool)
                or not isinstance(self.neighbourhood, (int, np.integer))
                or self.neighbourhood < 3 or self.neighbourhood % 2 == 0):
            raise ValueError(f"extraction.neighbourhood must be an odd integer >= 3, "
                             f"got {self.neighbourhood!r}")
        if self.threshold_per_m2 is not None and not (
                np.isfinite(self.threshold_per_m2) and self.threshold_per_m2 >= 0):
            raise ValueError(f"extraction.threshold_per_m2 must be a finite number >= 0 "
                             f"or None, got {self.threshold_per_m2!r}")
        if self.neighbourhood_m is not None and not (
                np.isfinite(self.neighbourhood_m) and self.neighbourhood_m > 0):
            raise ValueError(f"extraction.neighbourhood_m must be a finite number > 0 "
                             f"or None, got {self.neighbourhood_m!r}")
        if self.radius_m is not None and not (
                np.isfinite(self.radius_m) and self.radius_m > 0):
            raise ValueError(f"extraction.radius_m must be a finite number > 0 or None, "
                             f"got {self.radius_m!r}")

    def bin_threshold(self, grid: Grid) -> float:
        """Per-bin mass threshold on ``grid`` (expected targets per bin)."""
        if self.threshold_per_m2 is not None:
            return float(self.threshold_per_m2 * grid.bin_area)
        return float(self.threshold)

    def window_bins(self, grid: Grid) -> int:
        """Odd side of the maximum-filter window on ``grid``, in bins."""
        if self.neighbourhood_m is None:
            return int(self.neighbourhood)
        bins = self.neighbourhood_m / grid.resolution
        # 3.0 / 0.1 = 29.999999999999996 must count as 30 bins, not 29.
        if abs(bins - round(bins)) < 1e-9 * max(1.0, bins):
            bins = float(round(bins))
        half = int(np.floor((bins - 1.0) / 2.0 + 0.5))
        return max(3, 2 * half + 1)

    def footprint(self, grid: Grid) -> np.ndarray | None:
        """The disk window of :attr:`radius_m` on ``grid``, or None for a square window.

        Returns
        -------
        np.ndarray of bool, shape (2 h + 1, 2 h + 1), or None
            ``True`` at the offsets (dy, dx) [bins] with
            ``(dx^2 + dy^2) resolution^2 <= radius_m^2`` (up to 1e-9 relative, so that a
            radius of a whole number of bins reaches those bins), h = floor(radius_m /
            resolution).

        Raises
        ------
        ValueError
            If ``radius_m`` < ``grid.resolution`` (the disk would hold the bin alone).
        """
        if self.radius_m is None:
            return None
        reach = self.radius_m / grid.resolution
        if reach < 1.0 - 1e-9:
            raise ValueError(f"a radius of {self.radius_m:g} m is below the bin side "
                             f"({grid.resolution:g} m): every bin above the threshold would "
                             f"be a maximum")
        h = int(np.floor(reach + 1e-9))
        dy, dx = np.mgrid[-h:h + 1, -h:h + 1]
        return (dx * dx + dy * dy) <= reach * reach * (1.0 + 1e-9)


def expected_cardinality(weights: np.ndarray) -> float:
    """Return the expected number of targets, the total PHD mass sum_j w_j (Dames Sec. II).

    Parameters
    ----------
    weights : np.ndarray, any shape
        Per-bin masses (expected targets per bin), e.g. the ``(ny, nx)`` image.
    """
    return float(np.sum(weights))


def extract_targets(grid: Grid, weights_image: np.ndarray,
                    config: ExtractionConfig | None = None) -> np.ndarray:
    """Target estimates: bin centres of the local maxima of the PHD image (Dames Sec. IV).

    A bin is a candidate when its weight equals the maximum over the ``k x k`` window
    centred on it (``k = config.window_bins(grid)``), or over the disk of
    ``config.radius_m`` when that is set (:meth:`ExtractionConfig.footprint`), and is
    strictly above ``config.bin_threshold(grid)``. Bins outside the image count as -inf,
    so bins on the border and in the corners can be maxima.

    Plateaus: 8-connected candidates (4-connected for a disk that does not reach the
    diagonal bins) necessarily share one value and form a plateau; each
    plateau gives a single estimate, at its bin with the lowest flat index (a deterministic
    choice that stays on the grid; the plateau centroid could fall between bins or, for a
    non-convex plateau, off it). A plateau that continues into equal-valued bins that are
    not candidates (because a larger bin lies within their window) is not a maximum as a
    whole and gives no estimate.

    Parameters
    ----------
    grid : Grid
        Grid the image lives on.
    weights_image : np.ndarray, shape (ny, nx) or (ny * nx,)
        Per-bin PHD masses (expected targets per bin); a flat array is taken in flat-index
        order.
    config : ExtractionConfig, optional
        Threshold and window; defaults to Dames' values (0.05, 3 bins).

    Returns
    -------
    np.ndarray, shape (K, 2)
        Bin-centre positions [m] of the K estimates, in increasing flat index; ``(0, 2)``
        when there are none.

    Raises
    ------
    ValueError
        If the image does not match the grid or contains NaN or infinite values.
    """
    cfg = config if config is not None else ExtractionConfig()
    w = np.asarray(weights_image, dtype=float)
    if w.shape == (grid.size,):
        w = w.reshape(grid.shape)
    if w.shape != grid.shape:
        raise ValueError(f"weights_image must have shape {grid.shape} (ny, nx) or "
                         f"({grid.size},), got {w.shape}")
    if not np.all(np.isfinite(w)):
        raise ValueError("weights_image must contain only finite values")

    disk = cfg.footprint(grid)
    if disk is None:
        size = cfg.window_bins(grid)
        local_max = ndimage.maximum_filter(w, size=size, mode="constant", cval=-np.inf)
        adjacent = _EIGHT_CONNECTED
    else:
        local_max = ndimage.maximum_filter(w, footprint=disk, mode="constant", cval=-np.inf)
        # Neighbours in the window are equal if both are candidates: a plateau is
        # connected through the window's own 3 x 3 middle (4- or 8-connected).
        h = disk.shape[0] // 2
        adjacent = disk[h - 1:h + 2, h - 1:h + 2]
    candidate = (w == local_max) & (w > cfg.bin_threshold(grid))
    if not candidate.any():
        return np.empty((0, 2))

    labels, n_plateaus = ndimage.label(candidate, structure=adjacent)
    # Reject plateaus that touch an equal-valued non-candidate: that bin has a larger bin
    # in its window, so the plateau as a whole is not a maximum.
    leaks = _equal_non_candidate_neighbour(w, candidate, adjacent)
    rejected = np.zeros(n_plateaus + 1, dtype=bool)
    rejected[labels[leaks]] = True

    flat = np.flatnonzero(candidate)
    flat_labels = labels.ravel()[flat]
    # flat is ascending, so the first occurrence of a label is its lowest flat index.
    _, first = np.unique(flat_labels, return_index=True)
    keep = flat[first]
    keep = keep[~rejected[labels.ravel()[keep]]]
    return grid.centres_of(keep)


def _equal_non_candidate_neighbour(w: np.ndarray, candidate: np.ndarray,
                                   adjacent: np.ndarray = _EIGHT_CONNECTED) -> np.ndarray:
    """Candidates with a neighbour of the same weight that is not a candidate; (ny, nx).

    The neighbours are the offsets where ``adjacent`` (3, 3) is True, the centre aside.
    """
    ny, nx = w.shape
    # Padding with NaN (never equal to anything) keeps out-of-image neighbours out.
    wp = np.pad(w, 1, constant_values=np.nan)
    cp = np.pad(candidate, 1, constant_values=False)
    out = np.zeros_like(candidate)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if (dy == 0 and dx == 0) or not adjacent[1 + dy, 1 + dx]:
                continue
            nw = wp[1 + dy:1 + dy + ny, 1 + dx:1 + dx + nx]
            nc = cp[1 + dy:1 + dy + ny, 1 + dx:1 + dx + nx]
            out |= candidate & (nw == w) & ~nc
    return out
