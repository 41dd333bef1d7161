"""Sung & Tokekar (2022) Sec. VI-A: one robot with a limited field of view, a lawn-mower."""

from __future__ import annotations

from phd_swarm.core import models as core_models
from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.presets.registry import preset
from phd_swarm.sim.scenario import Scenario, TargetConfig

__all__ = ["MAP_150", "SUNG_SYSTEM", "sung_tokekar"]

#: Sung & Tokekar's map: a 150 x 150 m open square (Fig. 6).
MAP_150 = Environment(0.0, 0.0, 150.0, 150.0)

#: Sung & Tokekar's system: disk FoV with one false positive per step at most, GM-PHD with
#: the limited-FoV rule and a track layer, no exchange (one robot), the lawn-mower.
SUNG_SYSTEM = {"sensor": "disk_false_positive", "estimator": "sung_gmphd",
               "exchange": "none", "controller": "lawnmower"}


@preset("Sung & Tokekar (2022) Sec. VI-A", base_of=("turning_walk",))
def sung_tokekar(targets: int = 10) -> Scenario:
    """Sung & Tokekar (2022) Sec. VI-A: one robot, 10 stationary targets, 7,278 s.

    150 x 150 m map, robot at 0.5 m/s with a disk FoV of radius 25 m (Fig. 6 caption);
    one step per second (the caption's 7,278 time steps for three lawn-mower sweeps at
    0.5 m/s fit dt = 1 s, docs/decisions.md). The robot starts at the lawn-mower's start,
    the lower-left corner. Targets uniform over the map (their positions are not given).
    OSPA with p = 2 and c = 100 m (Sec. VI-A.3). The system's parts and their options
    (false-positive probability, initial belief, thresholds) are in ``system``. The moving
    targets of Sec. VI-A.4 are ``targets.kind: turning_walk`` with the speed and turn period
    set here.
    """
    return Scenario(
        name="sung_tokekar", env=MAP_150, resolution=1.0,
        models=core_models.sung_tokekar(), dt=1.0, duration=7278.0, robots=1,
        robot_start_box=(0.0, 0.0, 1e-6, 1e-6), robot_max_speed=0.5,
        targets=TargetConfig(kind="static", count=targets, draw_box=(0.0, 0.0, 150.0, 150.0),
                             speed=0.05, turn_every=400.0),
        ospa_c=100.0, ospa_p=2.0, system=SystemConfig(**SUNG_SYSTEM))
