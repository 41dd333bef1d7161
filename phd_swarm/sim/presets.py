"""The papers' settings as scenario presets.

Dames (2020) Sec. IV (:func:`dames_static`, :func:`dames_moving`), Chen, Dames & Park (2021)
Sec. 4 (:func:`chen_clustered`), Sung & Tokekar (2022) Sec. VI (:func:`sung_tokekar`),
Shirsat & Berman (2021) Sec. V (:func:`shirsat_berman`) and Papaioannou et al. Sec. VI-A
(:func:`papaioannou`); :data:`PRESETS` names them for configs (``preset:``).
"""

from __future__ import annotations

from collections.abc import Callable

from phd_swarm.core import models as core_models
from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.models import PhdModels
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.scenario import BOTTOM_CENTRE_BOX, MAP_100, Scenario, TargetConfig


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


#: Sung & Tokekar's map: a 150 x 150 m open square (Fig. 6).
MAP_150 = Environment(0.0, 0.0, 150.0, 150.0)

#: Sung & Tokekar's system: disk FoV with one false positive per step at most, GM-PHD with
#: the limited-FoV rule and a track layer, no exchange (one robot), the lawn-mower.
SUNG_SYSTEM = {"sensor": "disk_false_positive", "estimator": "sung_gmphd",
               "exchange": "none", "controller": "lawnmower"}


def sung_tokekar(targets: int = 10) -> Scenario:
    """Sung & Tokekar (2022) Sec. VI-A: one robot, 10 stationary targets, 7,278 s.

    150 x 150 m map, robot at 0.5 m/s with a disk FoV of radius 25 m (Fig. 6 caption);
    one step per second (the caption's 7,278 time steps for three lawn-mower sweeps at
    0.5 m/s fit dt = 1 s, docs/decisions.md). The robot starts at the lawn-mower's start,
    the lower-left corner. Targets uniform over the map (their positions are not given).
    OSPA with p = 2 and c = 100 m (Sec. VI-A.3). The system's parts and their options
    (false-positive probability, initial belief, thresholds) are in ``system``.
    """
    return Scenario(
        name="sung_tokekar", env=MAP_150, resolution=1.0,
        models=core_models.sung_tokekar(), dt=1.0, duration=7278.0, robots=1,
        robot_start_box=(0.0, 0.0, 1e-6, 1e-6), robot_max_speed=0.5,
        targets=TargetConfig(kind="static", count=targets, draw_box=(0.0, 0.0, 150.0, 150.0),
                             speed=0.05, turn_every=400.0),
        ospa_c=100.0, ospa_p=2.0, system=SystemConfig(**SUNG_SYSTEM))


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


#: Papaioannou et al.'s system: square range-bearing sensor, the SAT density (particle PHD
#: and search map), the opportunistic exchange within C_R, search-and-track control.
PAPAIOANNOU_SYSTEM = {"sensor": "square_range_bearing", "estimator": "papaioannou_sat",
                      "exchange": "sat_share", "controller": "sat_search_track"}


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


PRESETS: dict[str, Callable[[], Scenario]] = {
    "dames_static": dames_static, "dames_moving": dames_moving,
    "chen_clustered": chen_clustered, "sung_tokekar": sung_tokekar,
    "shirsat_berman": shirsat_berman, "papaioannou": papaioannou}


__all__ = ["MAP_150", "PRESETS", "chen_clustered", "dames_moving", "dames_static", "papaioannou",
           "shirsat_berman", "sung_tokekar"]
