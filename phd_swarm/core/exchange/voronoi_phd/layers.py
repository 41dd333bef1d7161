"""Per-bin state that travels with the bins: none, or Chen's cumulative density.

A robot stores, for every bin it owns, the PHD mass and whatever its controller keeps per
bin. A :class:`BinLayer` is that extra per-bin state: the hand-over gives a layer's values
of the bins that leave with them (:meth:`BinLayer.parcel`) and rebuilds the layer over the
bins owned afterwards (:meth:`BinLayer.take_over`); the measurement update reports which
bins each scan saw (:meth:`BinLayer.observe`) and closes the step (:meth:`BinLayer.apply`).
The plain PHD filter (Dames 2020) carries nothing (:class:`BinLayer`); Chen's "O" method
carries alpha and n per bin (:class:`CumulativeLayer`). :func:`layer_for` picks the layer of
a :class:`~.context.FilterContext`.

The same layers over the whole map (:class:`MapLayer`, :class:`CumulativeMapLayer`) are what
the central engine keeps in place of the robots' own, and what a log's reader rebuilds from
the recorded scans for the figures: the part's ``map_layer`` hook (:func:`map_layer`).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from ...controllers.power_lloyd.cumulative import (
    cumulative_update_counts,
    cumulative_weight,
    observe_scans,
)
from ...geometry.grid import Grid
from .context import FilterContext

#: Values of a layer for some bins, as a transfer carries them: (alpha, count), or
#: (None, None) for a layer without per-bin values.
Parcel = tuple[np.ndarray | None, np.ndarray | None]


class BinLayer:
    """No per-bin state besides the PHD mass (Dames 2020): every verb does nothing.

    Attributes
    ----------
    alpha, count : None
        What :class:`CumulativeLayer` holds per bin.
    """

    alpha: np.ndarray | None = None
    count: np.ndarray | None = None

    def reset(self, size: int) -> None:
        """Start over with ``size`` bins that nobody has observed yet."""

    def parcel(self, sel: np.ndarray) -> Parcel:
        """The values of the own bins ``sel`` (indices or mask), for a transfer."""
        return None, None

    def take_over(self, size: int, placed: Iterable[tuple[np.ndarray, Parcel]]) -> None:
        """Rebuild over ``size`` bins from parcels, each with its positions among them.

        Positions that no parcel fills, the orphans, start unobserved.
        """

    def observe(self, pos: np.ndarray, detected: bool) -> None:
        """One scan saw the own bins at positions ``pos``; ``detected``: it measured something."""

    def apply(self) -> None:
        """Fold the scans of the step into the layer (at the end of the measurement update)."""


class CumulativeLayer(BinLayer):
    """Chen's cumulative state per own bin: total reward alpha and observations n.

    Chen eq. 9-10 with one observation per scan whose field of view holds the bin and one
    reward per such scan with a measurement. The scans of a step are counted and applied
    together at its end
    (:func:`~phd_swarm.core.controllers.power_lloyd.cumulative.cumulative_update_counts`,
    bit-identical to one update per scan since the counts are whole numbers).

    Attributes
    ----------
    alpha : np.ndarray, shape (K,), or None
        Total reward of each own bin (None before the first :meth:`reset`).
    count : np.ndarray, shape (K,), or None
        Observations n = 1/beta of each own bin; float after a hand-over, int64 after an
        update.
    """

    def __init__(self) -> None:
        self.alpha = None
        self.count = None
        #: Scans of this step that saw each own bin, and those that measured something.
        self._observed: np.ndarray | None = None
        self._rewarded: np.ndarray | None = None

    def reset(self, size: int) -> None:
        """Start over with ``size`` bins that nobody has observed yet (alpha = n = 0)."""
        self.alpha = np.zeros(size)
        self.count = np.zeros(size)
        self._observed = self._rewarded = None

    def parcel(self, sel: np.ndarray) -> Parcel:
        """The alpha and n of the own bins ``sel`` (indices or mask), for a transfer."""
        assert self.alpha is not None and self.count is not None
        return self.alpha[sel], self.count[sel]

    def take_over(self, size: int, placed: Iterable[tuple[np.ndarray, Parcel]]) -> None:
        """Rebuild over ``size`` bins; orphans and bins sent without a layer get 0 and 0."""
        alpha = np.zeros(size)
        count = np.zeros(size)
        for pos, (a, n) in placed:
            if a is not None and n is not None:
                alpha[pos] = a
                count[pos] = n
        self.alpha, self.count = alpha, count
        self._observed = self._rewarded = None

    def observe(self, pos: np.ndarray, detected: bool) -> None:
        """Count one scan over the own bins ``pos`` (Chen eq. 9-10, applied in :meth:`apply`)."""
        if self._observed is None:
            assert self.alpha is not None
            self._observed = np.zeros(self.alpha.size, dtype=np.int64)
            self._rewarded = np.zeros(self.alpha.size, dtype=np.int64)
        self._observed[pos] += 1
        if detected:
            self._rewarded[pos] += 1

    def apply(self) -> None:
        """Add this step's scans: alpha += rewards, n += observations (Chen eq. 9-10)."""
        if self._observed is None:
            return
        self.alpha, self.count = cumulative_update_counts(self.alpha, self.count,
                                                          self._observed, self._rewarded)
        self._observed = self._rewarded = None


def layer_for(ctx: FilterContext) -> BinLayer:
    """A new, empty layer of the kind the context asks for (``ctx.cumulative``)."""
    return CumulativeLayer() if ctx.cumulative else BinLayer()


__all__ = ["BinLayer", "CumulativeLayer", "Parcel", "layer_for"]


class MapLayer:
    """The per-bin layer kept over the whole map: none (Dames 2020), for the central engine.

    What :class:`BinLayer` is to one robot's own bins, this is to every bin of the map at
    once: the central engine (:mod:`phd_swarm.engines.central`) counts the scans into it
    and gives each robot the values of its bins; a log's reader rebuilds it from the
    recorded scans (:func:`map_layer`).
    """

    def observe(self, scans: Iterable[tuple[np.ndarray, np.ndarray]]) -> None:
        """Count the scans ``(sensor (2,), z (M, 2))`` of a step."""

    def of(self, bins: np.ndarray) -> dict[str, np.ndarray]:
        """The layer's values of ``bins``, as fields of a controller's ``CellDensity``."""
        return {}

    def image(self) -> np.ndarray | None:
        """The layer as an image (ny, nx) for the figures; None if it has none."""
        return None


class CumulativeMapLayer(MapLayer):
    """Chen's cumulative state over the whole map: alpha and n per bin (Chen eq. 9-10).

    The counts are whole numbers, so they are exactly those the robots' own
    :class:`CumulativeLayer` carry, whatever the order of the scans. :meth:`image` is the
    cumulative density wc of eq. 11 in the reading ``mode``
    (:func:`~phd_swarm.core.controllers.power_lloyd.cumulative.cumulative_weight`).
    """

    def __init__(self, grid: Grid, radius: float, mode: str) -> None:
        self.grid, self.radius, self.mode = grid, radius, mode
        self.alpha = np.zeros(grid.size)
        self.count = np.zeros(grid.size, dtype=np.int64)

    def observe(self, scans: Iterable[tuple[np.ndarray, np.ndarray]]) -> None:
        """Count one observation per scan of each bin in view, and a reward with a measurement."""
        observe_scans(self.grid, self.radius, self.alpha, self.count, scans)

    def of(self, bins: np.ndarray) -> dict[str, np.ndarray]:
        """The rewards (``alpha``) and observations (``count``) of ``bins``."""
        return {"alpha": self.alpha[bins], "count": self.count[bins]}

    def image(self) -> np.ndarray:
        """The cumulative density wc (eq. 11) as an image (ny, nx)."""
        return cumulative_weight(self.alpha, self.count, self.mode).reshape(self.grid.shape)


def map_layer(scenario: Any, requires: frozenset[str]) -> MapLayer:
    """The exchange's ``map_layer`` hook: the whole-map layer that ``requires`` asks for.

    ``requires`` is what the controller needs (the central engine) or everything the
    exchange can carry (a log's figures): Chen's cumulative state if it holds
    ``cumulative``, else none.
    """
    if "cumulative" not in requires:
        return MapLayer()
    mode = dict(scenario.system.options).get("cumulative_mode", "rate")
    return CumulativeMapLayer(scenario.grid, scenario.models.detection.radius, mode)
