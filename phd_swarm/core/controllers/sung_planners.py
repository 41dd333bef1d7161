"""Sung & Tokekar's planners: ``lawnmower``, ``nearest_gaussian`` and ``largest_gaussian``.

- ``lawnmower`` (Sec. VI-A, Fig. 6): a boustrophedon over the whole map that returns to
  the robot's start in a straight line after each sweep. The lanes and their ends are
  inset by ``lawnmower_inset`` from the map's edges and spread evenly, at most
  ``lawnmower_spacing`` apart. The defaults, 12.5 m (half the FoV radius) and 7 lanes
  125 / 6 = 20.83 m apart, are derived from the paper's step count: from the map's corner
  a sweep is 1,212.13 m, 2,427 steps of 0.5 m, 7,281 for the three sweeps the caption
  puts at 7,278 (docs/decisions.md).
- ``nearest_gaussian`` (Sec. V-G, strategy i): head for the mean of the mixture component
  nearest the robot.
- ``largest_gaussian`` (Sec. V-G, strategy ii): head for the mean of the component with
  the largest covariance, a scalar given by ``size_measure``.

The two Gaussian planners read the robot's GM-PHD (``knowledge.estimator.mixture``, the
``gaussian_mixture`` capability); ``min_weight`` leaves out lighter components (0: every
component, as printed). With no component left they follow their own lawn-mower path, so a
robot that knows of nothing keeps searching.

The lawn-mower path starts at the pattern corner nearest the robot's first position and ends
at that position (the "original position" of Fig. 6), both taken lazily from the first
:meth:`~phd_swarm.core.controllers.base.Controller.decide`. The robot's goal is its current
waypoint; it moves on to the next once it stands on it (within :data:`REACHED`).

Each planner also tells what it will visit next, for display
(:meth:`~phd_swarm.core.controllers.base.Controller.planned_path`): the lawn mower the rest
of its sweep, the Gaussian planners the goal they chose last (or their lawn mower's rest).
Asking changes no decision.

Reference: Y. Sung and P. Tokekar, "GM-PHD filter for searching and tracking an unknown
number of targets with a mobile sensor with limited FOV", IEEE T-ASE, 2022, Sec. V-G and
VI-A.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import registry
from ..params import ParamSpec
from .base import Controller, Decision, Knowledge

#: A waypoint is reached when the robot is this close to it [m].
REACHED = 1e-9

#: Scalars for "the largest covariance" of a 2x2 covariance P.
SIZE_MEASURES = ("max_eigenvalue", "trace", "determinant")

LANE_SPACING = ParamSpec(
    "lawnmower_spacing", 20.84,
    "lawnmower, nearest_gaussian, largest_gaussian (fallback): largest lane spacing [m]; "
    "the lanes are spread evenly, as few as keep them this close. 20.84: 7 lanes 20.83 m "
    "apart on Sung & Tokekar's map, which fits their 7,278 steps (docs/decisions.md).",
    low=0.1, high=1e4)
LANE_INSET = ParamSpec(
    "lawnmower_inset", 12.5,
    "lawnmower (and fallback): distance of the outer lanes and of the lane ends from the "
    "map's edges [m]; 12.5 (half the FoV radius) fits the 7,278 steps.", low=0.0, high=1e4)
LANE_AXIS = ParamSpec(
    "lawnmower_axis", "y",
    "lawnmower (and fallback): the axis the lanes run along; y: lanes parallel to y, the "
    "robot advancing across x.", choices=("x", "y"))
SWEEPS = ParamSpec(
    "lawnmower_sweeps", 0,
    "lawnmower (and fallback): sweeps before the robot stays at its start; 0 repeats for "
    "ever (the run's duration ends the paper's three sweeps).", low=0, high=1_000_000)
MIN_WEIGHT = ParamSpec(
    "min_weight", 0.0,
    "nearest_gaussian, largest_gaussian: components lighter than this are not goals; 0 "
    "takes every component, as printed (docs/decisions.md).", low=0.0, high=1e6)
SIZE_MEASURE = ParamSpec(
    "size_measure", "max_eigenvalue",
    "largest_gaussian: the size of a covariance, its largest eigenvalue (the largest "
    "variance, Sung Fig. 10), trace or determinant.", choices=SIZE_MEASURES)

#: Options of the lawn-mower path, taken by all three planners (the fallback).
LAWNMOWER_OPTIONS = (LANE_SPACING, LANE_INSET, LANE_AXIS, SWEEPS)


@dataclass(frozen=True, eq=False)
class SungPlannerConfig:
    """Resolved options and the map's lanes, shared by a team's planners.

    Attributes
    ----------
    bounds : tuple of float
        The map (xmin, ymin, xmax, ymax) [m].
    lanes : np.ndarray, shape (2n, 2)
        Lane ends in visiting order from the (xmin, ymin) corner [m]
        (:func:`lawnmower_lanes`).
    sweeps : int
        Sweeps before the robot stays at its start; 0: for ever.
    min_weight : float
        Lightest component a Gaussian planner heads for.
    size_measure : str
        One of :data:`SIZE_MEASURES`.
    """

    bounds: tuple[float, float, float, float]
    lanes: np.ndarray
    sweeps: int = 0
    min_weight: float = 0.0
    size_measure: str = "max_eigenvalue"


def lawnmower_lanes(bounds: tuple[float, float, float, float], spacing: float,
                    inset: float = 0.0, axis: str = "y") -> np.ndarray:
    """Lane ends of a boustrophedon over a box, in visiting order from (xmin, ymin).

    The outer lanes and the lane ends lie ``inset`` inside the box; the n lanes are spread
    evenly between the outer two, n the fewest that keeps them at most ``spacing`` apart.
    A box narrower than twice the inset puts the lanes, or their ends, on its centre line.
    Every point of the box is within max(inset * sqrt(2), spacing / 2) of the lanes.

    Parameters
    ----------
    bounds : tuple of float
        (xmin, ymin, xmax, ymax) [m].
    spacing : float
        Largest lane spacing [m], > 0.
    inset : float
        Distance of the outer lanes and of the lane ends from the edges [m], >= 0.
    axis : str
        ``"y"``: lanes parallel to y, ``"x"``: parallel to x.

    Returns
    -------
    np.ndarray, shape (2n, 2)
        Lane i runs from row 2i to row 2i + 1 [m]; odd lanes run backwards.
    """
    xmin, ymin, xmax, ymax = (float(b) for b in bounds)
    if axis == "y":
        across, along = (xmin, xmax), (ymin, ymax)
    else:
        across, along = (ymin, ymax), (xmin, xmax)

    def inside(lo: float, hi: float) -> tuple[float, float]:
        if hi - lo <= 2 * inset:
            return (lo + hi) / 2, (lo + hi) / 2
        return lo + inset, hi - inset

    first, last = inside(*across)
    lo, hi = inside(*along)
    # The tolerance keeps a spacing given as width / m (in floating point) at m gaps.
    n = 1 + math.ceil((last - first) / spacing - 1e-9)
    u = np.linspace(first, last, n)
    v = np.where(np.arange(n)[:, None] % 2 == 0, [lo, hi], [hi, lo]).reshape(-1)
    uv = np.column_stack([np.repeat(u, 2), v])
    return uv if axis == "y" else uv[:, ::-1].copy()


def oriented_lanes(lanes: np.ndarray, bounds: tuple[float, float, float, float],
                   start: np.ndarray) -> np.ndarray:
    """``lanes`` mirrored so that the path begins at the pattern corner nearest ``start``.

    Parameters
    ----------
    lanes : np.ndarray, shape (2n, 2)
        From :func:`lawnmower_lanes` [m].
    bounds : tuple of float
        The box the lanes were laid in [m].
    start : np.ndarray, shape (2,)
        The robot's first position [m].

    Returns
    -------
    np.ndarray, shape (2n, 2)
        Of the four mirror images (none, in x, in y, in both; ties in that order) the one
        whose first point is nearest ``start``.
    """
    centre2 = np.array([bounds[0] + bounds[2], bounds[1] + bounds[3]], dtype=float)
    images = []
    for flip in ((False, False), (True, False), (False, True), (True, True)):
        img = lanes.copy()
        for k in (0, 1):
            if flip[k]:
                img[:, k] = centre2[k] - img[:, k]
        images.append(img)
    firsts = np.array([img[0] for img in images])
    return images[int(np.argmin(np.sum((firsts - start) ** 2, axis=1)))]


def covariance_size(covs: np.ndarray, measure: str) -> np.ndarray:
    """One scalar per covariance: largest eigenvalue, trace or determinant.

    Parameters
    ----------
    covs : np.ndarray, shape (J, 2, 2)
        Symmetric covariances [m^2].
    measure : str
        One of :data:`SIZE_MEASURES`.

    Returns
    -------
    np.ndarray, shape (J,)
        [m^2] for the eigenvalue and the trace, [m^4] for the determinant.
    """
    covs = np.asarray(covs, dtype=float)
    if measure == "max_eigenvalue":
        if covs.shape[0] == 0:
            return np.empty(0)
        return np.linalg.eigvalsh(covs)[:, -1]
    if measure == "trace":
        return np.trace(covs, axis1=1, axis2=2)
    if measure == "determinant":
        return np.linalg.det(covs) if covs.shape[0] else np.empty(0)
    raise ValueError(f"size_measure: expected one of {list(SIZE_MEASURES)}, got {measure!r}")


def _option(spec: ParamSpec, options: dict[str, Any]) -> Any:
    return spec.check(options.get(spec.name, spec.default), "system.options")


def setup(scenario: Any, system: Any, **runtime: Any) -> SungPlannerConfig:
    """Resolve the options (missing ones take their defaults) and lay the map's lanes.

    Raises
    ------
    ValueError
        For an option out of its range, the message naming it
        (``system.options: min_weight: ...``).
    """
    options = dict(getattr(system, "options", ()) or ())
    env = scenario.env
    bounds = (float(env.xmin), float(env.ymin), float(env.xmax), float(env.ymax))
    lanes = lawnmower_lanes(bounds, _option(LANE_SPACING, options),
                            _option(LANE_INSET, options), _option(LANE_AXIS, options))
    return SungPlannerConfig(bounds, lanes, _option(SWEEPS, options),
                             _option(MIN_WEIGHT, options), _option(SIZE_MEASURE, options))


class LawnMower(Controller):
    """The lawn-mower path of Sung & Tokekar (Fig. 6): sweep the map, return to the start.

    One sweep visits the lanes (:func:`oriented_lanes`) and comes back in a straight line
    to the robot's first position; sweeps repeat (for ever, or ``config.sweeps`` times,
    after which the robot stays at its start).

    Parameters
    ----------
    config : SungPlannerConfig
        From :func:`setup`.
    """

    def __init__(self, config: SungPlannerConfig) -> None:
        self.config = config
        self.home: np.ndarray | None = None
        self.path: np.ndarray | None = None
        self.index = 0
        self.sweeps_done = 0

    @property
    def finished(self) -> bool:
        """Whether the robot has made all its sweeps (never with ``sweeps`` = 0)."""
        return 0 < self.config.sweeps <= self.sweeps_done

    def begin(self, position: np.ndarray) -> None:
        """Take ``position`` [m] as the start and lay the path from it (once; later no-op)."""
        if self.path is not None:
            return
        self.home = np.array(position, dtype=float).reshape(2)
        lanes = oriented_lanes(self.config.lanes, self.config.bounds, self.home)
        self.path = np.vstack([lanes, self.home])

    def goal(self, position: np.ndarray) -> np.ndarray:
        """The current waypoint [m], shape (2,), after moving past those ``position`` is on."""
        self.begin(position)
        assert self.path is not None and self.home is not None
        q = np.asarray(position, dtype=float)
        # Bounded: a path whose waypoints all coincide with q moves on at most once round.
        for _ in range(len(self.path)):
            if self.finished or np.hypot(*(self.path[self.index] - q)) > REACHED:
                break
            self.index += 1
            if self.index == len(self.path):
                self.index = 0
                self.sweeps_done += 1
        return self.home.copy() if self.finished else self.path[self.index].copy()

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """Goal: the current waypoint of the lawn-mower path; power weight 0."""
        return Decision(goal=self.goal(knowledge.position), power_weight=0.0)

    def planned_path(self) -> np.ndarray:
        """The rest of the current sweep (Fig. 6), from the current waypoint on [m].

        Returns
        -------
        np.ndarray, shape (P, 2)
            The waypoints as of the last :meth:`goal`: the current one first, the robot's
            start last (a repeating path then begins its next sweep, not shown); only the
            start once the sweeps are done; none before the first :meth:`begin`.
        """
        if self.path is None or self.home is None:
            return np.empty((0, 2))
        if self.finished:
            return self.home.reshape(1, 2).copy()
        return self.path[self.index:].copy()


def mixture_arrays(knowledge: Knowledge, who: str) -> tuple[np.ndarray, ...]:
    """Weights (J,), position means (J, 2) [m] and covariances (J, 2, 2) of the robot's GM.

    The position part is the first two state coordinates.

    Raises
    ------
    ValueError
        If the estimator has no ``mixture`` (it does not provide ``gaussian_mixture``).
    """
    mixture = getattr(knowledge.estimator, "mixture", None)
    if mixture is None:
        raise ValueError(f"controller {who} needs the estimator's Gaussian mixture "
                         f"(knowledge.estimator.mixture, capability gaussian_mixture)")
    w = np.asarray(mixture.weights, dtype=float).reshape(-1)
    if w.size == 0:
        return w, np.empty((0, 2)), np.empty((0, 2, 2))
    means = np.asarray(mixture.means, dtype=float).reshape(w.size, -1)
    d = means.shape[1]
    covs = np.asarray(mixture.covs, dtype=float).reshape(w.size, d, d)
    return w, means[:, :2], covs[:, :2, :2]


class NearestGaussian(Controller):
    """Sung & Tokekar's nearest-Gaussian (Sec. V-G, i): go to the nearest component mean.

    Candidates are the components of weight >= ``config.min_weight``; ties go to the lower
    index. With none, the robot follows its lawn-mower path (:class:`LawnMower`), which
    resumes where it was left.

    Parameters
    ----------
    config : SungPlannerConfig
        From :func:`setup`.
    """

    name = "nearest_gaussian"

    def __init__(self, config: SungPlannerConfig) -> None:
        self.config = config
        self.fallback = LawnMower(config)
        #: The component mean chosen at the last decision [m]; None when it fell back.
        self.chosen: np.ndarray | None = None

    def choose(self, position: np.ndarray, weights: np.ndarray, means: np.ndarray,
               covs: np.ndarray) -> int | None:
        """Index of the nearest candidate component, or None if there is none."""
        keep = np.flatnonzero(weights >= self.config.min_weight)
        if keep.size == 0:
            return None
        d2 = np.sum((means[keep] - position) ** 2, axis=1)
        return int(keep[np.argmin(d2)])

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """Goal: the chosen component's mean, or the lawn-mower waypoint; power weight 0."""
        q = np.asarray(knowledge.position, dtype=float)
        self.fallback.begin(q)
        w, means, covs = mixture_arrays(knowledge, self.name)
        j = self.choose(q, w, means, covs)
        goal = self.fallback.goal(q) if j is None else means[j].copy()
        self.chosen = None if j is None else goal.copy()
        return Decision(goal=goal, power_weight=0.0)

    def planned_path(self) -> np.ndarray:
        """The goal of the last decision (Sec. V-G), or the fallback's path [m].

        Returns
        -------
        np.ndarray, shape (P, 2)
            The chosen component's mean as one waypoint, or, when the last decision fell
            back to the lawn mower, its remaining waypoints
            (:meth:`LawnMower.planned_path`); none before the first decision.
        """
        if self.chosen is not None:
            return self.chosen.reshape(1, 2).copy()
        return self.fallback.planned_path()


class LargestGaussian(NearestGaussian):
    """Sung & Tokekar's largest-Gaussian (Sec. V-G, ii): go to the widest component's mean.

    The width of a covariance is ``config.size_measure`` (:func:`covariance_size`); among
    the components of weight >= ``config.min_weight`` the widest wins, ties to the lower
    index. With none, the lawn-mower path.

    Parameters
    ----------
    config : SungPlannerConfig
        From :func:`setup`.
    """

    name = "largest_gaussian"

    def choose(self, position: np.ndarray, weights: np.ndarray, means: np.ndarray,
               covs: np.ndarray) -> int | None:
        """Index of the candidate with the largest covariance, or None if there is none."""
        keep = np.flatnonzero(weights >= self.config.min_weight)
        if keep.size == 0:
            return None
        return int(keep[np.argmax(covariance_size(covs[keep], self.config.size_measure))])


registry.register(
    "controller", "lawnmower", lambda config, rid: LawnMower(config), setup=setup,
    description="Boustrophedon over the map returning to the start each sweep "
                "(Sung & Tokekar 2022, Fig. 6).",
    options=LAWNMOWER_OPTIONS)
registry.register(
    "controller", "nearest_gaussian", lambda config, rid: NearestGaussian(config),
    setup=setup,
    description="Head for the nearest Gaussian mean of the GM-PHD; lawn mower when it is "
                "empty (Sung & Tokekar 2022, Sec. V-G).",
    options=(*LAWNMOWER_OPTIONS, MIN_WEIGHT), requires=("gaussian_mixture",))
registry.register(
    "controller", "largest_gaussian", lambda config, rid: LargestGaussian(config),
    setup=setup,
    description="Head for the mean of the GM-PHD component with the largest covariance; "
                "lawn mower when it is empty (Sung & Tokekar 2022, Sec. V-G).",
    options=(*LAWNMOWER_OPTIONS, MIN_WEIGHT, SIZE_MEASURE), requires=("gaussian_mixture",))
