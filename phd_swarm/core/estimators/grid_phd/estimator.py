"""The grid ("bin") PHD estimator of Dames (2020) as a registered part: ``grid_phd``.

The filter's equations live in :mod:`phd_swarm.core.estimators.grid_phd.filter` (prediction eq. 3,
update eq. 4-6) and :class:`phd_swarm.core.estimators.grid_phd.central.CentralPhdFilter` (the whole
map in one filter, the central engine's team filter). In the distributed system a robot's bins and
their masses move from robot to robot with its cell, so they are held and updated by the
``voronoi_phd`` exchange participant
(:mod:`phd_swarm.core.exchange.voronoi_phd.participant`); what a robot reads from its own
bins is :class:`GridPhdEstimator`: the estimates (extraction over the window around the
cell, Dames Sec. IV) and the expected number of targets.

Options: the extraction's window, ``extraction_window`` (the side of the square, in metres,
Dames' 3 bins of 1 m) or ``extraction_radius`` (a disk instead, > 0), read by
:attr:`phd_swarm.sim.scenario.Scenario.extraction`, so that every reader of the team PHD
(the robots, the central filter, the sweeps, the monitor, ``evaluate``) extracts alike
(:mod:`phd_swarm.core.extraction`; docs/decisions.md, "The extraction floor").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import registry
from ...extraction import ExtractionConfig, expected_cardinality, extract_targets
from ...geometry.grid import Environment, Grid
from ...outputs import Observation, Output
from ...params import ParamSpec
from .central import CentralPhdFilter

#: The extraction's window (:class:`~phd_swarm.core.extraction.ExtractionConfig`); the
#: defaults are the scenarios' (``phd_swarm.sim.scenario.EXTRACTION_WINDOW_M``).
OPTIONS = (
    ParamSpec("extraction_window", 3.0, "grid_phd: side [m] of the square window in which "
              "an extracted peak is the largest bin (Dames Sec. IV: 3 bins of 1 m); at "
              "least 3 bins.", low=1e-3, high=1e3),
    ParamSpec("extraction_radius", 0.0, "grid_phd: 0 uses the square window; > 0, a peak "
              "is the largest bin within this radius [m] instead, so any two peaks farther "
              "apart are both extracted; at least the bin side (docs/decisions.md).",
              low=0.0, high=1e3),
)


@dataclass(frozen=True)
class GridPhdEstimator:
    """Estimates from the bins a robot owns (one per robot; holds no state).

    Attributes
    ----------
    grid : Grid
        The team's bin grid.
    extraction : ExtractionConfig
        Threshold and window of the peak extraction (:mod:`phd_swarm.core.extraction`).
    """

    grid: Grid
    extraction: ExtractionConfig

    def estimates(self, bins: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Target positions (N, 2) [m] extracted from the own bins.

        The extraction runs on the bounding window of the bins (zeros elsewhere), so its
        cost grows with the cell, not with the map.
        """
        if bins.size == 0:
            return np.empty((0, 2))
        nx = self.grid.shape[1]
        rows, cols = np.divmod(bins, nx)
        r0, c0 = int(rows.min()), int(cols.min())
        h, w = int(rows.max()) - r0 + 1, int(cols.max()) - c0 + 1
        res = self.grid.resolution
        env = self.grid.env
        sub = Grid(Environment(env.xmin + c0 * res, env.ymin + r0 * res,
                               env.xmin + (c0 + w) * res, env.ymin + (r0 + h) * res), res)
        image = np.zeros((h, w))
        image[rows - r0, cols - c0] = weights
        return extract_targets(sub, image, self.extraction)

    @staticmethod
    def expected_count(weights: np.ndarray) -> float:
        """Expected number of targets in the own bins, the sum of their masses."""
        return expected_cardinality(weights)


def _setup(scenario: Any, system: Any, **runtime: Any) -> GridPhdEstimator:
    return GridPhdEstimator(scenario.grid, scenario.extraction)


def central_filter(scenario: Any) -> CentralPhdFilter:
    """The team's filter over the whole map (the central engine's estimator)."""
    return CentralPhdFilter(scenario.grid, scenario.models, scenario.extraction)


#: The robot's PHD window of the step (Dames eq. 2), which the monitor sums to the team's.
DENSITY = Output(
    "density", "phd_swarm_msgs/msg/DensityGrid", "phd_swarm.nodes.faces.grid_phd:DENSITY",
    "The robot's PHD over a window of the grid, its owned bins (parameter "
    "`publish_density`); the monitor assembles the team PHD from them.", observed=True)

#: The same window for RViz2 / Foxglove (observation traffic, not a step topic).
DENSITY_GRID = Output(
    "density_grid", "nav_msgs/msg/OccupancyGrid",
    "phd_swarm.nodes.faces.grid_phd:DENSITY_GRID",
    "The robot's density window as an occupancy grid for RViz2 / Foxglove: 0..100, 100 = a "
    "PHD of 1 target per m^2 or more (docs/ros.md); with `density` (parameter "
    "`publish_density`).", qos="LATCHED")

registry.register(
    "estimator", "grid_phd", lambda estimator, rid: estimator, setup=_setup,
    description="Grid PHD filter (Dames 2020 eq. 3-6), distributed over the robots' cells.",
    options=OPTIONS, provides=("grid_density",),
    requires=("disk_fov", "position_measurement"),
    outputs=(DENSITY, DENSITY_GRID),
    observation=Observation(inputs=("density",), image="density"),
    central=central_filter, runs_in_exchange=True)
