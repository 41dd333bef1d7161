"""Centralised grid PHD filter: one filter holding every bin of the map.

This is the reference that the distributed filter (Dames 2020, Sec. III, Alg. 1-2) must
reproduce: the same prediction (eq. 3) over the whole grid and the same sequence of
single-sensor updates (eq. 4-6), applied in increasing robot id (Alg. 2 line 10).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from ...extraction import ExtractionConfig, extract_targets
from ...geometry.grid import Grid
from ...models import PhdModels
from ...scan import Scan
from ..base import Estimator
from . import filter as phd_grid


class CentralPhdFilter(Estimator):
    """Grid PHD filter over the whole environment (Dames 2020 eq. 3-6).

    The state is one mass per bin (expected number of targets in the bin), held as an image
    of shape ``(ny, nx)`` (see :mod:`phd_swarm.core.geometry.grid` for the index
    convention), starting at ``models.initial_density * bin_area`` everywhere.

    Survival and birth images and the motion kernel are computed once. An update only
    touches the bins of the sensor's field-of-view disk, so its cost does not grow with the
    map.

    Parameters
    ----------
    grid : Grid
        Bins of the environment.
    models : PhdModels
        Target and sensor models.
    extraction : ExtractionConfig, optional
        Threshold and window of :meth:`estimates` (default: Dames' values).
    """

    def __init__(self, grid: Grid, models: PhdModels,
                 extraction: ExtractionConfig | None = None) -> None:
        self.grid = grid
        self.models = models
        self.extraction = extraction
        self.kernel = models.motion.kernel(grid.resolution)
        self.ps_img = models.survival.probability(grid).reshape(grid.shape)
        self.birth_img = models.birth.mass(grid).reshape(grid.shape)
        for arr in (self.kernel, self.ps_img, self.birth_img):
            arr.setflags(write=False)
        self._w = np.full(grid.shape, models.initial_density * grid.bin_area)

    @property
    def weights(self) -> np.ndarray:
        """Masses per bin, shape (ny, nx), read-only.

        Every predict/update builds a new image instead of writing into the old one, so an
        array obtained here is a snapshot that never changes afterwards.
        """
        view = self._w.view()
        view.setflags(write=False)
        return view

    @weights.setter
    def weights(self, value: np.ndarray) -> None:
        value = np.array(value, dtype=float, copy=True)
        if value.shape != self.grid.shape:
            raise ValueError(f"weights must have shape {self.grid.shape}, got {value.shape}")
        if not np.all(np.isfinite(value)) or np.any(value < 0):
            raise ValueError("weights must be finite and non-negative")
        self._w = value

    @property
    def total_mass(self) -> float:
        """Expected number of targets in E, the sum of all bin masses."""
        return float(self._w.sum())

    def predict(self) -> None:
        """Prediction step (eq. 3): survival, motion (mass leaving E is lost), birth."""
        self._w = phd_grid.predict_image(self._w, self.kernel, self.ps_img, self.birth_img)

    def predict_cells(self, cells: Sequence[np.ndarray]) -> None:
        """Eq. 3 as the robots compute it, when the motion is convolved by FFT.

        ``cells`` are the flat bins of each robot's cell (a partition of the map). With a
        kernel that :func:`~.filter.convolve_mass` applies by FFT (more than
        :data:`~.filter.DIRECT_MAX_TAPS` taps, Chen's at 0.1 m), the round-off is ~1e-16 of
        the largest mass in the convolved box. In a searched-out cell every mass can lie
        below the round-off of a whole-map FFT, and the centroid of that cell would follow
        it; the robots convolve their own bins only (:func:`~.filter.spread`), so their
        round-off is that of their own masses. Spreading each cell's bins the same way keeps
        the central engine's robots with the distributed ones
        (test/engines/test_central.py); sums are the same up to the order of the additions.
        With a direct kernel this is :meth:`predict`.
        """
        if self.kernel.size <= phd_grid.DIRECT_MAX_TAPS:
            self.predict()
            return
        grid = self.grid
        w = self._w.reshape(-1)
        survival = self.ps_img.reshape(-1)
        out = np.zeros(grid.size)
        for bins in cells:
            if bins.size:
                flat, moved = phd_grid.spread(grid, bins, survival[bins] * w[bins],
                                              self.kernel)
                out[flat] += moved
        self._w = (out + self.birth_img.reshape(-1)).reshape(grid.shape)

    def update(self, scan: Scan) -> None:
        """Update with one measurement set (eq. 4-6)."""
        self.update_all([scan])

    def update_all(self, scans: Iterable[Scan]) -> None:
        """Update with several measurement sets, one after the other (Dames Sec. III).

        The sets are applied in increasing ``robot_id`` (Alg. 2 line 10); the sort is stable,
        so sets with equal ids keep their given order. The result depends on the order only
        where fields of view overlap.
        """
        ordered = sorted(scans, key=lambda s: s.robot_id)
        if not ordered:
            return
        # One copy per call, then in-place per scan: keeps snapshots from `weights` intact
        # at the cost of one map copy, not one per scan.
        w = self._w.copy()
        flat_w = w.reshape(-1)
        radius = self.models.detection.radius
        for scan in ordered:
            bins = self.grid.disk_bins(scan.sensor, radius)
            if bins.size:
                flat_w[bins] = phd_grid.update_bins(self.grid, self.models, bins,
                                                    flat_w[bins], scan)
        self._w = w

    def estimates(self) -> np.ndarray:
        """Target positions (N, 2) [m]: the peaks of the PHD image (Dames Sec. IV)."""
        return extract_targets(self.grid, self._w, self.extraction)

    def expected_count(self) -> float:
        """Expected number of targets in E (:attr:`total_mass`)."""
        return self.total_mass

    def step(self, scans: Iterable[Scan]) -> None:
        """One filter step: :meth:`predict`, then :meth:`update_all` with ``scans``."""
        self.predict()
        self.update_all(scans)
