"""Chen, Dames & Park (2021) Sec. 4: two clusters of walking targets on a 0.1 m grid."""

from __future__ import annotations

from phd_swarm.core import models as core_models
from phd_swarm.sim.presets.registry import preset
from phd_swarm.sim.scenario import BOTTOM_CENTRE_BOX, MAP_100, Scenario, TargetConfig

__all__ = ["chen_clustered"]


@preset("Chen, Dames & Park (2021) Sec. 4", base_of=("clustered_walk",))
def chen_clustered(robots: int = 70, resolution: float = 0.1) -> Scenario:
    """Chen, Dames & Park (2021) Sec. 4: two clusters of 30 targets, 0.1 m grid, 1000 s.

    Targets: 30 in the 33 x 33 m square at the lower-left corner and 30 in the one at the
    upper-right corner, a Gaussian random walk inside the squares capped at 3 m/s. Robots:
    start in a 20 x 10 m box at the bottom centre, 5 m/s, 5 m sensing radius. The sensor
    rate is not given; we keep Dames' 2 Hz (dt = 0.5 s), as Chen uses Dames' sensor model.
    The extraction threshold is not given either; we use Dames' 0.05 per m^2.
    """
    return Scenario(
        name="chen_clustered", env=MAP_100, resolution=resolution,
        models=core_models.chen_clustered(), dt=0.5, duration=1000.0, robots=robots,
        robot_start_box=BOTTOM_CENTRE_BOX, robot_max_speed=5.0,
        targets=TargetConfig(kind="clustered_walk", count=60,
                             clusters=((0.0, 0.0, 33.0, 33.0), (67.0, 67.0, 100.0, 100.0)),
                             per_cluster=(30, 30), step_sd=1.0, max_speed=3.0))
