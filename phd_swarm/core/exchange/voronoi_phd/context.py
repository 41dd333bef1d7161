"""What every robot of a team shares: the grid, the models, derived per-bin arrays.

:class:`FilterContext` holds the numbers that all robots compute identically (the motion
kernel, p_s and birth mass per bin, the reach of phantom mass) and the contact rule that both
robots of a pair evaluate on the same numbers (Dames 2020 Sec. III: who must exchange
messages with whom).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ...geometry.grid import Grid
from ...models import PhdModels
from ..base import ENGINE_TIMEOUT_TICKS

#: Rounds without progress before an awaited silent peer is declared dead (the in-memory
#: engines' rounds; the ROS robot counts wall-clock tick periods, its ``timeout_ticks``
#: parameter, docs/parameters.md).
TIMEOUT_TICKS = ENGINE_TIMEOUT_TICKS

#: Field-of-view disks kept by :meth:`FilterContext.fov_bins`: one per robot of a step,
#: with room for the largest teams (at 0.1 m bins a disk of 5 m is ~60 kB).
_FOV_CACHE_SIZE = 256


@dataclass(frozen=True, eq=False)
class FilterContext:
    """What every robot of a team shares: the grid, the models and derived per-bin arrays.

    Robots in one process (the in-memory engine) may share one context, and then also its
    cache of field-of-view disks (:meth:`fov_bins`); a robot with a context of its own
    computes the same values.

    Attributes
    ----------
    grid : Grid
        The shared grid of bins.
    models : PhdModels
        The filter's models.
    cumulative : bool
        Carry Chen's cumulative state (alpha, n) with the bins.
    timeout_ticks : int
        Rounds without progress before a silent robot is declared dead.
    max_step : float
        Largest distance a robot moves in one step [m] (max speed x dt); sets the margin
        of the contact set.
    """

    grid: Grid
    models: PhdModels
    cumulative: bool = False
    timeout_ticks: int = TIMEOUT_TICKS
    max_step: float = 0.0

    @cached_property
    def kernel(self) -> np.ndarray:
        """Motion kernel on the grid."""
        return self.models.motion.kernel(self.grid.resolution)

    @cached_property
    def survival(self) -> np.ndarray:
        """p_s per bin, shape (size,)."""
        return self.models.survival.probability(self.grid)

    @cached_property
    def birth(self) -> np.ndarray:
        """Birth mass per bin, shape (size,)."""
        return self.models.birth.mass(self.grid)

    @property
    def prior_mass(self) -> float:
        """Initial mass of one bin."""
        return self.models.initial_density * self.grid.bin_area

    @cached_property
    def reach(self) -> float:
        """How far phantom mass can land from the bins it left [m]."""
        half = (self.kernel.shape[0] // 2) * self.grid.resolution
        return half * np.sqrt(2.0) + self.grid.resolution

    @property
    def contact_margin(self) -> float:
        """Slack for one step of motion of both robots and their cells [m]."""
        return 2.0 * self.max_step + self.grid.resolution * np.sqrt(2.0)

    def are_contacts(self, q_a: np.ndarray, rho_a: float, radius_a: float,
                     q_b: np.ndarray, rho_b: float, radius_b: float) -> bool:
        """Whether robots a and b must exchange messages next step (symmetric in a and b).

        Evaluated by both robots on the same numbers (positions, power weights and cell
        radii: the larger of the previous step's, sent in the states, and this step's, from
        the cells and relayed by the ownership transfers, see
        :func:`.membership.recent_radii`), so both agree. With
        R_a, R_b the cell radii (largest generator-to-vertex distances), the pair is kept
        when ``|q_a - q_b| <= 2 max(R_a, R_b) + rho_a + rho_b + max(fov, reach) + margin``:
        this covers power/Voronoi neighbours (a neighbour of a lies within 2 R_a + rho of
        q_a), a field of view meeting the other's cell (within R + fov) and phantom mass or
        bin hand-overs between cells within the kernel's reach, with the margin for the
        next move of both robots and the change of the cell radii.
        """
        q_b = np.asarray(q_b, dtype=float).reshape(1, 2)
        return bool(self.contact_mask(q_a, rho_a, radius_a, q_b, np.array([rho_b], float),
                                      np.array([radius_b], float))[0])

    def contact_mask(self, q_a: np.ndarray, rho_a: float, radius_a: float,
                     q_b: np.ndarray, rho_b: np.ndarray, radius_b: np.ndarray) -> np.ndarray:
        """:meth:`are_contacts` of robot a with each of N robots b at once.

        The same float expression as the pairwise rule, element by element (hypot, then
        the bound summed left to right), so both sides of a pair still agree bit for bit.

        Parameters
        ----------
        q_a : np.ndarray, shape (2,)
            Position of robot a [m].
        rho_a, radius_a : float
            Its power weight and cell radius [m].
        q_b : np.ndarray, shape (N, 2)
            Positions of the robots b [m].
        rho_b, radius_b : np.ndarray, shape (N,)
            Their power weights and cell radii [m].

        Returns
        -------
        np.ndarray of bool, shape (N,)
        """
        q_a = np.asarray(q_a, dtype=float)
        q_b = np.asarray(q_b, dtype=float).reshape(-1, 2)
        d = np.hypot(q_a[0] - q_b[:, 0], q_a[1] - q_b[:, 1])
        bound = (2.0 * np.maximum(radius_a, np.asarray(radius_b, dtype=float)) + rho_a
                 + np.asarray(rho_b, dtype=float)
                 + max(self.models.detection.radius, self.reach) + 2.0 * self.contact_margin)
        return d <= bound

    def fov_bins(self, sensor: np.ndarray) -> np.ndarray:
        """``grid.disk_bins(sensor, detection radius)``, cached by the exact position.

        In one step every robot whose bins meet a field of view needs that disk; robots
        sharing this context (one process) compute each disk once. The key is the position's
        bytes, so a hit returns exactly what :meth:`Grid.disk_bins` would; the arrays are
        read-only. The cache keeps the :data:`_FOV_CACHE_SIZE` most recent disks.
        """
        sensor = np.asarray(sensor, dtype=float).reshape(2)
        key = sensor.tobytes()
        cache = self._fov_cache
        disk = cache.get(key)
        if disk is None:
            disk = self.grid.disk_bins(sensor, self.models.detection.radius)
            disk.setflags(write=False)
            if len(cache) >= _FOV_CACHE_SIZE:
                cache.pop(next(iter(cache), None), None)
            cache[key] = disk
        return disk

    @cached_property
    def _fov_cache(self) -> dict[bytes, np.ndarray]:
        return {}


__all__ = ["FilterContext"]
