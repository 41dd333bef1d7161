"""Shirsat & Berman (2021) Sec. VI: robots on a random walk over a grid, static targets."""

from __future__ import annotations

from phd_swarm.core import models as core_models
from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.presets.registry import preset
from phd_swarm.sim.scenario import Scenario, TargetConfig

__all__ = ["SHIRSAT_DT", "SHIRSAT_LAYOUT_SEED", "SHIRSAT_SPACING", "SHIRSAT_SYSTEM",
           "shirsat_berman"]

#: Shirsat & Berman's system: disk sensor with Poisson clutter, a GM-PHD per robot with a
#: reward set, meet-and-merge on the same node, the DTDS random walk.
SHIRSAT_SYSTEM = {"sensor": "disk", "estimator": "shirsat_gmphd", "exchange": "meet_merge",
                  "controller": "dtds_walk"}

#: Grid spacing [m] and seconds per step of Shirsat & Berman's walk (not in the paper; the
#: exact renewal analysis puts 0.5 m and 1 s nearest the paper's 68 s, docs/decisions.md).
SHIRSAT_SPACING = 0.5
SHIRSAT_DT = 1.0

#: Seed of Shirsat & Berman's target layouts: the same targets in every run (Sec. VI).
SHIRSAT_LAYOUT_SEED = 2021


@preset("Shirsat & Berman (2021) Sec. VI")
def shirsat_berman(side: float = 5.0, robots: int = 3, targets: int = 3,
                   duration: float = 300.0) -> Scenario:
    """Shirsat & Berman (2021) Sec. VI: robots on a random walk over a grid, static targets.

    The small scenario (Figs. 4-8): a 5 x 5 m square, 3 robots, 3 targets, 300 s; Table 1
    has 20 robots on 15 / 20 / 30 m squares with 10 / 15 / 20 targets for 1000 / 2000 /
    3000 s (``side``, ``robots``, ``targets``, ``duration``). Robots start on random nodes
    of the 0.5 m grid and move one node per 1 s step (speed 0.5 m/s; the spacing and step
    are not given, docs/decisions.md); 4-neighbour moves with a self-loop (eq. 4). Targets
    are drawn uniformly over the square from :data:`SHIRSAT_LAYOUT_SEED`, the same in every
    run. OSPA (which the paper does not use) with c = 1.5 m, p = 2: c is the reward sets'
    duplicate distance, past which an estimate is not the target's.
    """
    env = Environment(0.0, 0.0, float(side), float(side))
    return Scenario(
        name="shirsat_berman", env=env, resolution=0.1, models=core_models.shirsat_berman(),
        dt=SHIRSAT_DT, duration=float(duration), robots=robots,
        robot_start_box=(0.0, 0.0, float(side), float(side)),
        robot_max_speed=SHIRSAT_SPACING / SHIRSAT_DT, robot_start_grid=SHIRSAT_SPACING,
        targets=TargetConfig(kind="static", count=targets,
                             draw_box=(0.0, 0.0, float(side), float(side)),
                             layout_seed=SHIRSAT_LAYOUT_SEED),
        ospa_c=1.5, ospa_p=2.0,
        system=SystemConfig(**SHIRSAT_SYSTEM,
                            options=(("grid_spacing", SHIRSAT_SPACING),)))
