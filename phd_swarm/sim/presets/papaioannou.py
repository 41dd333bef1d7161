"""Papaioannou et al. Sec. VI: agents searching for and tracking NCV targets."""

from __future__ import annotations

from phd_swarm.core import models as core_models
from phd_swarm.core.models import PhdModels
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.presets.registry import preset
from phd_swarm.sim.scenario import MAP_100, Scenario, TargetConfig

__all__ = ["PAPAIOANNOU_SYSTEM", "papaioannou"]

#: Papaioannou et al.'s system: square range-bearing sensor, the SAT density (particle PHD
#: and search map), the opportunistic exchange within C_R, search-and-track control.
PAPAIOANNOU_SYSTEM = {"sensor": "square_range_bearing", "estimator": "papaioannou_sat",
                      "exchange": "sat_share", "controller": "sat_search_track"}


@preset("Papaioannou et al. Sec. VI", base_of=("ncv",))
def papaioannou(agents: int = 4, targets: int = 10, spawn: str = "centre") -> Scenario:
    """Papaioannou et al. Sec. VI: agents searching and tracking NCV targets, 100 x 100 m.

    100 steps of 1 s (Sec. VI-B); agents start uniformly over the area and move by eq. 4
    (at most 2 x 2 m per step, so the speed limit is 4 m/s); 10 targets born at the centre
    with random headings and a mean lifetime of 60 s (Fig. 3; ``spawn: uniform`` for Fig. 4),
    process noise q = 0.01 m^2/s^3 (the printed q = 1 is ``targets.process_noise: 1``;
    docs/decisions.md).
    OSPA of order 2 with c = 50 m (Fig. 3). The disk detection model of ``models`` only
    sizes the world's field-of-view markers (radius 5 m, the square's half side); the
    sensor part has its own models.
    """
    return Scenario(
        name="papaioannou", env=MAP_100, resolution=1.0,
        models=PhdModels(detection=core_models.DiskDetection(p_d=0.99, radius=5.0)),
        dt=1.0, duration=100.0, robots=agents, robot_start_box=(0.0, 0.0, 100.0, 100.0),
        robot_max_speed=4.0,
        targets=TargetConfig(kind="ncv", count=targets, spawn=spawn, speed=1.0,
                             lifetime_mean=60.0, process_noise=0.01),
        ospa_c=50.0, ospa_p=2.0, system=SystemConfig(**PAPAIOANNOU_SYSTEM))
