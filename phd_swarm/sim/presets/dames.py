"""Dames (2020) Sec. IV: static targets (IV-A) and moving targets with births (IV-B).

Both on the 100 x 100 m map with a team of holonomic robots at 2 m/s and a sensor at 2 Hz.
"""

from __future__ import annotations

from phd_swarm.core import models as core_models
from phd_swarm.sim.presets.registry import preset
from phd_swarm.sim.scenario import BOTTOM_CENTRE_BOX, MAP_100, Scenario, TargetConfig

__all__ = ["dames_moving", "dames_static"]


@preset("Dames (2020) Sec. IV-A", base_of=("static",))
def dames_static(robots: int = 20, targets: int = 30, resolution: float = 1.0) -> Scenario:
    """Dames (2020) Sec. IV-A: static targets on a 100 x 100 m map, 250 s.

    ``targets`` are drawn uniformly from the 120 x 120 m square centred on the map and those
    outside E are discarded (so 30 give 20.8 on average). Robots: holonomic, 2 m/s, sensor
    at 2 Hz (dt = 0.5 s). The robots start "at randomized locations within the box at the
    bottom center of the environment shown in Fig. 3"; the paper does not give the box's
    size, so we use Chen et al.'s 20 x 10 m box at the bottom centre (x 40..60, y 0..10).
    """
    return Scenario(
        name="dames_static", env=MAP_100, resolution=resolution,
        models=core_models.dames_static(), dt=0.5, duration=250.0, robots=robots,
        robot_start_box=BOTTOM_CENTRE_BOX, robot_max_speed=2.0,
        targets=TargetConfig(kind="static", count=targets,
                             draw_box=(-10.0, -10.0, 110.0, 110.0)))


@preset("Dames (2020) Sec. IV-B", base_of=("dames_walk",))
def dames_moving(robots: int = 20, targets: int = 20, resolution: float = 1.0) -> Scenario:
    """Dames (2020) Sec. IV-B: moving targets with births on a 100 x 100 m map, 500 s.

    ``targets`` is the initial number, placed uniformly in E (the paper does not say how).
    Truth: 1 m/s, heading steps N(0, 0.1 rad) at 10 Hz, removal on leaving E, births from
    the filter's birth PHD (eq. 14, 0.1 per step within 5 m of the boundary). Robots and
    start box as in :func:`dames_static` (the box size is our choice there too).
    """
    return Scenario(
        name="dames_moving", env=MAP_100, resolution=resolution,
        models=core_models.dames_moving(), dt=0.5, duration=500.0, robots=robots,
        robot_start_box=BOTTOM_CENTRE_BOX, robot_max_speed=2.0,
        targets=TargetConfig(kind="dames_walk", count=targets, speed=1.0, heading_sd=0.1,
                             heading_rate=10.0, birth=True))
