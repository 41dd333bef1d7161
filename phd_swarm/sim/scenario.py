"""Everything one simulated run needs, as frozen dataclasses.

A :class:`Scenario` fixes the map, the grid resolution, the filter's models, the time step,
the robot team, the true target population (:class:`TargetConfig`), the extraction
threshold, the OSPA parameters and the seed. The papers' settings are presets
(:mod:`phd_swarm.sim.presets`); :func:`phd_swarm.sim.scenario_dict.scenario_from_dict`
builds a scenario from a nested mapping (a YAML file) by overriding a preset.

The target config is one flat dataclass over every kind (``scenario.targets.<field>``);
each kind (:mod:`phd_swarm.sim.target_kinds`) reads its own fields and checks them against
the run when the scenario is built. This module imports the kinds (through
:mod:`phd_swarm.sim.targets`), never the world: the world and the presets import it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from functools import cached_property, partial
from typing import Any

import numpy as np

from phd_swarm.core.controllers.dtds_walk.grid_graph import lattice_count, lattice_range
from phd_swarm.core.extraction import ExtractionConfig
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.models import PhdModels
from phd_swarm.core.params import (
    expect_bool,
    expect_box,
    expect_int,
    expect_list,
    expect_number,
    expect_str,
)
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.dames_targets import BIRTH_HEADINGS
from phd_swarm.sim.ncv_paths import LIFETIME_MODELS
from phd_swarm.sim.ncv_targets import NOISE_FORMS, SPAWNS
from phd_swarm.sim.target_checks import check_inside
from phd_swarm.sim.target_kinds import lookup, names
from phd_swarm.sim.targets import TARGET_KINDS, make_targets

#: Side of the extraction window [m]: Dames' 3 x 3 bins of 1 m (Sec. IV).
EXTRACTION_WINDOW_M = 3.0

Box = tuple[float, float, float, float]

#: Order of the child streams the world spawns from the scenario's seed
#: (:class:`phd_swarm.sim.world.World`).
STREAMS = ("robot_starts", "targets", "sensor")

#: The Dames and Chen map: a 100 x 100 m open square.
MAP_100 = Environment(0.0, 0.0, 100.0, 100.0)

#: 20 x 10 m robot start box at the bottom centre of the 100 x 100 m map (Chen Sec. 4).
BOTTOM_CENTRE_BOX: Box = (40.0, 0.0, 60.0, 10.0)

#: A list of boxes (``targets.clusters``) and of counts (``targets.per_cluster``).
_boxes = partial(expect_list, item=expect_box)
_counts = partial(expect_list, item=partial(expect_int, low=0))


@dataclass(frozen=True)
class TargetConfig:
    """The true target population of a run (see :mod:`phd_swarm.sim.targets`).

    One flat set of fields over every kind: the config keys and ROS parameters
    (``scenario.targets.<field>``) and the stored results' hashes are spelled from it, and
    each kind reads its own fields (:attr:`~phd_swarm.sim.target_kinds.TargetKind.fields`).
    Each field is checked here on its own; the kind checks its fields together and against
    the run when the :class:`Scenario` is built.

    Attributes
    ----------
    kind : str
        A registered target kind (:data:`TARGET_KINDS`; :mod:`phd_swarm.sim.targets` lists
        the built-in ones with their papers).
    count : int
        Targets drawn (``static``: before those outside E are discarded), the initial number
        (``dames_walk``), or the total ``sum(per_cluster)`` (``clustered_walk``).
    draw_box : (xmin, ymin, xmax, ymax) or None
        ``static``: the square targets are drawn from [m] (Dames: 120 x 120 m centred on
        the map); ``turning_walk``: where they start (default: E).
    speed : float
        ``dames_walk`` and ``turning_walk``: forward speed [m/s] (Dames: 1; Sung: 0.05).
    heading_sd : float
        ``dames_walk``: s.d. of each heading change [rad] (Dames: 0.1).
    heading_rate : float
        ``dames_walk``: heading updates per second [Hz] (Dames: 10); ``dt * heading_rate``
        must be whole.
    birth : bool
        ``dames_walk``: draw births from the filter's birth PHD ``models.birth`` (Dames
        eq. 14, "the birth model matched the true statistics of the targets").
    birth_heading : {"inward", "uniform"}
        ``dames_walk``: a newborn's heading, uniform over the half-plane facing the centre
        of E (default: the paper's newborns "entered the environment and moved towards the
        center", Sec. IV-B) or uniform over all directions (then about half leave at once);
        docs/decisions.md.
    clusters : tuple of boxes
        ``clustered_walk``: the sub-regions [m] (Chen: 33 x 33 m at the lower-left and
        upper-right corners).
    per_cluster : tuple of int
        ``clustered_walk``: targets in each cluster (Chen: 30, 30).
    step_sd : float
        ``clustered_walk``: per-axis s.d. of the walk's velocity [m/s]; the step is
        ``N(0, (step_sd dt)^2 I)`` (default 1 = max_speed / 3, see
        :class:`~phd_swarm.sim.walkers.ClusteredWalkers`).
    max_speed : float
        ``clustered_walk``: speed cap [m/s] (Chen: 3).
    turn_every : float
        ``turning_walk``: seconds between two random headings [s] (Sung: 400 steps of 1 s).
    spawn : str
        ``ncv``: targets appear at the centre of E or uniformly in ``draw_box``
        (:data:`~phd_swarm.sim.ncv_targets.SPAWNS`; Papaioannou Fig. 3: centre).
    lifetime_mean : float
        ``ncv``: mean lifetime [s], geometric (Papaioannou Fig. 3-4: 60, Fig. 5: 30).
    birth_spread : float
        ``ncv``: birth times uniform over [0, birth_spread) [s]; 0: all present at the start.
    process_noise : float
        ``ncv``: q of the NCV model's Q [m^2/s^3] (Papaioannou Sec. VI-A: 1).
    noise_form : str
        ``ncv``: ``standard`` or ``printed`` Q (:func:`~phd_swarm.sim.ncv_targets.ncv_matrices`).
    lifetime_model : str
        ``ncv``: ``cut`` (a geometric lifetime cut by leaving E and by the run's end),
        ``contained`` or ``exit`` (whole lives inside E and the run; ``spawn: uniform``
        only; :mod:`~phd_swarm.sim.ncv_paths`).
    layout_seed : int or None
        ``static``: if set, the targets are drawn from a generator of this seed alone, so
        every run has the same targets whatever its own seed (Shirsat & Berman Sec. VI:
        "the positions of the targets were kept the same over all 100 runs"); None
        (default): from the world's target stream of the run's seed.
    """

    kind: str
    count: int = 0
    draw_box: Box | None = None
    speed: float = 1.0
    heading_sd: float = 0.1
    heading_rate: float = 10.0
    birth: bool = False
    birth_heading: str = "inward"
    clusters: tuple[Box, ...] = ()
    per_cluster: tuple[int, ...] = ()
    step_sd: float = 1.0
    max_speed: float = 3.0
    turn_every: float = 400.0
    layout_seed: int | None = None
    spawn: str = "uniform"
    lifetime_mean: float = 60.0
    birth_spread: float = 0.0
    process_noise: float = 1.0
    noise_form: str = "standard"
    lifetime_model: str = "cut"

    def __post_init__(self) -> None:
        expect_str(self.kind, "targets.kind", choices=names())
        if self.layout_seed is not None:
            expect_int(self.layout_seed, "targets.layout_seed", low=0)
        expect_int(self.count, "targets.count", low=0)
        if self.draw_box is not None:
            object.__setattr__(self, "draw_box", expect_box(self.draw_box, "targets.draw_box"))
        expect_number(self.speed, "targets.speed", low=0.0)
        expect_number(self.heading_sd, "targets.heading_sd", low=0.0)
        expect_number(self.heading_rate, "targets.heading_rate", low=0.0, strict=True)
        expect_bool(self.birth, "targets.birth")
        expect_str(self.birth_heading, "targets.birth_heading", choices=BIRTH_HEADINGS)
        expect_number(self.step_sd, "targets.step_sd", low=0.0)
        expect_number(self.max_speed, "targets.max_speed", low=0.0)
        expect_number(self.turn_every, "targets.turn_every", low=0.0, strict=True)
        expect_str(self.spawn, "targets.spawn", choices=SPAWNS)
        expect_number(self.lifetime_mean, "targets.lifetime_mean", low=0.0, strict=True)
        expect_number(self.birth_spread, "targets.birth_spread", low=0.0)
        expect_number(self.process_noise, "targets.process_noise", low=0.0)
        expect_str(self.noise_form, "targets.noise_form", choices=NOISE_FORMS)
        expect_str(self.lifetime_model, "targets.lifetime_model", choices=LIFETIME_MODELS)
        object.__setattr__(self, "clusters", _boxes(self.clusters, "targets.clusters"))
        object.__setattr__(self, "per_cluster", _counts(self.per_cluster, "targets.per_cluster"))


@dataclass(frozen=True)
class Scenario:
    """Everything one simulated run needs.

    Attributes
    ----------
    name : str
        Label of the run (the preset's name by default).
    env : Environment
        The map E [m].
    resolution : float
        Side of the filter's square bins [m] (Dames: 1; Chen: 0.1); must tile E.
    models : PhdModels
        The filter's target and sensor models; the simulated sensor (the ``disk`` sensor,
        :mod:`phd_swarm.core.sensors.disk`) draws from the same detection, measurement and
        clutter models.
    dt : float
        Time step [s]: one scan, one filter update and one move per step (Dames Sec. IV:
        the sensor runs at 2 Hz, so 0.5).
    duration : float
        Length of the run [s]; see :attr:`steps`.
    robots : int
        Team size R >= 1.
    robot_start_box : (xmin, ymin, xmax, ymax)
        Robots start uniformly in this box [m], which must lie inside E.
    robot_max_speed : float
        Holonomic robots' speed limit [m/s], > 0 (Dames: 2; Chen: 5).
    targets : TargetConfig
        The true target population.
    extraction_threshold : float
        Target-extraction threshold as a *density* [targets/m^2]: the per-bin mass threshold
        is ``extraction_threshold * resolution**2`` (see :attr:`extraction`), so 0.05
        reproduces Dames' 0.05 per 1 m bin and keeps its meaning at Chen's 0.1 m bins,
        where the literal per-bin 0.05 finds nothing (``docs/decisions.md``).
    ospa_c : float
        OSPA cut-off c [m] (both papers: 10).
    ospa_p : float
        OSPA order p >= 1, may be inf (both papers: 1).
    seed : int
        Seed of the world's random streams, >= 0 (:class:`phd_swarm.sim.world.World`), and
        of the robots' own (:func:`phd_swarm.core.agent.robot_generator`).
    system : SystemConfig
        The parts the robots run (sensor, estimator, exchange, controller) and their
        options (:mod:`phd_swarm.core.system`); default: Dames' PHD-weighted Lloyd.
    robot_start_grid : float or None
        If set, the spacing [m] of a square grid of nodes anchored at E's (xmin, ymin)
        corner (:class:`~phd_swarm.core.controllers.dtds_walk.grid_graph.GridGraph`), and each
        robot starts on a node drawn uniformly among those inside ``robot_start_box`` (two robots
        may share one): Shirsat & Berman's robots "start at random positions on the grid" (Sec.
        VI); set it to the ``dtds_walk`` controller's ``grid_spacing``. None (default): robots
        start uniformly in the box.
    """

    name: str
    env: Environment
    resolution: float
    models: PhdModels
    dt: float
    duration: float
    robots: int
    robot_start_box: Box
    robot_max_speed: float
    targets: TargetConfig
    extraction_threshold: float = 0.05
    ospa_c: float = 10.0
    ospa_p: float = 1.0
    seed: int = 0
    system: SystemConfig = field(default_factory=SystemConfig)
    robot_start_grid: float | None = None

    def __post_init__(self) -> None:
        expect_str(self.name, "name", nonempty=True)
        if not isinstance(self.env, Environment):
            raise ValueError(f"env must be an Environment, got {type(self.env).__name__}")
        expect_number(self.resolution, "resolution", low=0.0, strict=True)
        try:
            Grid(self.env, float(self.resolution))
        except ValueError as exc:
            raise ValueError(f"resolution: {exc}") from None
        if not isinstance(self.models, PhdModels):
            raise ValueError(f"models must be PhdModels, got {type(self.models).__name__}")
        expect_number(self.dt, "dt", low=0.0, strict=True)
        expect_number(self.duration, "duration", low=0.0, strict=True)
        if round(self.duration / self.dt) < 1:
            raise ValueError(f"duration ({self.duration} s) must hold at least one step of "
                             f"dt = {self.dt} s")
        expect_int(self.robots, "robots", low=1)
        box = expect_box(self.robot_start_box, "robot_start_box")
        check_inside("robot_start_box", box, self.env)
        object.__setattr__(self, "robot_start_box", box)
        expect_number(self.robot_max_speed, "robot_max_speed", low=0.0, strict=True)
        if not isinstance(self.targets, TargetConfig):
            raise ValueError(f"targets must be a TargetConfig, "
                             f"got {type(self.targets).__name__}")
        lookup(self.targets.kind).validate(self)
        expect_number(self.extraction_threshold, "extraction_threshold", low=0.0)
        expect_number(self.ospa_c, "ospa_c", low=0.0, strict=True)
        expect_number(self.ospa_p, "ospa_p", low=1.0, allow_inf=True)
        expect_int(self.seed, "seed", low=0)
        if not isinstance(self.system, SystemConfig):
            raise ValueError(f"system must be a SystemConfig, got {type(self.system).__name__}")
        try:
            self.extraction.footprint(self.grid)
        except ValueError as exc:
            raise ValueError(f"system.options.extraction_radius: {exc}") from None
        if self.robot_start_grid is not None:
            g = expect_number(self.robot_start_grid, "robot_start_grid", low=0.0, strict=True)
            object.__setattr__(self, "robot_start_grid", g)
            (x0, x1), (y0, y1) = self.start_grid_ranges()
            if x0 > x1 or y0 > y1:
                raise ValueError(
                    f"robot_start_grid: no node of the {g:g} m grid anchored at "
                    f"({self.env.xmin:g}, {self.env.ymin:g}) lies in robot_start_box {box}")

    def start_grid_ranges(self) -> tuple[tuple[int, int], tuple[int, int]]:
        """Node indices (first, last) along x and y of the start grid inside the start box.

        The nodes are ``(env.xmin + i g, env.ymin + j g)``, g = :attr:`robot_start_grid`,
        over E (those of :class:`~phd_swarm.core.controllers.dtds_walk.grid_graph.GridGraph` with
        that spacing); a range is empty (first > last) if no node lies in the box.

        Raises
        ------
        ValueError
            If :attr:`robot_start_grid` is None.
        """
        if self.robot_start_grid is None:
            raise ValueError("start_grid_ranges: robot_start_grid is not set")
        g, env, box = float(self.robot_start_grid), self.env, self.robot_start_box
        return (lattice_range(env.xmin, g, lattice_count(env.xmin, env.xmax, g), box[0],
                              box[2]),
                lattice_range(env.ymin, g, lattice_count(env.ymin, env.ymax, g), box[1],
                              box[3]))

    @property
    def steps(self) -> int:
        """Number of time steps of the run, ``round(duration / dt)``."""
        return int(round(self.duration / self.dt))

    @cached_property
    def grid(self) -> Grid:
        """The filter's bin grid on E at :attr:`resolution`."""
        return Grid(self.env, float(self.resolution))

    @property
    def extraction(self) -> ExtractionConfig:
        """Extraction settings: :attr:`extraction_threshold` per m^2 in a 3 m window.

        Dames' window of 3 bins of 1 m, kept in metres (:data:`EXTRACTION_WINDOW_M`) so that
        the estimator is the same at every grid resolution: at 0.1 m a 3-bin window finds
        several maxima on one target's peak (docs/decisions.md). Options of ``grid_phd``
        replace the window: ``extraction_window`` [m], ``extraction_radius`` (a disk, > 0).
        """
        opt = dict(self.system.options)
        return ExtractionConfig(threshold_per_m2=float(self.extraction_threshold),
                                neighbourhood_m=opt.get("extraction_window", EXTRACTION_WINDOW_M),
                                radius_m=opt.get("extraction_radius") or None)

    def initial_truth(self) -> tuple[np.ndarray, np.ndarray]:
        """The true targets at step 0 (ids (N,), positions (N, 2) [m]), as the world draws them.

        The same draw as :class:`phd_swarm.sim.world.World` built from this scenario (the
        targets' own stream, child 1 of the seed, :data:`STREAMS`). A system whose prior
        comes from an "external source" that knows roughly where the targets are (Sung &
        Tokekar Sec. V-A and VI-A) builds it from this, in its part's set-up.
        """
        child = np.random.SeedSequence(self.seed).spawn(len(STREAMS))[STREAMS.index("targets")]
        targets = make_targets(np.random.default_rng(child), self)
        return targets.ids.copy(), targets.positions.copy()

    def with_overrides(self, **changes: Any) -> Scenario:
        """A copy with some fields replaced (``dataclasses.replace``), validated again."""
        return dataclasses.replace(self, **changes)

    def with_system(self, **changes: Any) -> Scenario:
        """A copy with some parts, options or plugins of :attr:`system` replaced.

        See :meth:`SystemConfig.with_parts`; e.g. ``with_system(controller="uniform")``.
        """
        return self.with_overrides(system=self.system.with_parts(**changes))


__all__ = ["BOTTOM_CENTRE_BOX", "EXTRACTION_WINDOW_M", "MAP_100", "STREAMS", "TARGET_KINDS",
           "Scenario", "TargetConfig"]
