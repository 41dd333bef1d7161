"""Papaioannou et al.'s SAT density: a particle PHD of the true targets and a search map.

Registered as the ``papaioannou_sat`` estimator (:mod:`phd_swarm.core.registry`). Each agent
propagates the searching-and-tracking (SAT) density of Sec. V-A, which has two parts:

- the target density on true targets, eq. 6 and 8: the particle (SMC) PHD filter of Vo,
  Singh & Doucet (2005), an :class:`~.smc_phd.estimator.SmcPhdEstimator` this estimator holds
  (:attr:`PapaioannouEstimator.filter`), with the state ``[x, y, vx, vy]`` (positions first,
  the repository's convention; the paper orders it ``[x, vx, y, vy]``), the NCV motion of
  Sec. VI-A (F, Q with T = dt), survival p_S = 0.99, and the ``square_range_bearing``
  sensor's models: the range-bearing likelihood with range-dependent noise, p_D = p_D^max
  inside the agent's square and 0 outside (eq. 5), its clutter; births "distributed
  inside the agent sensing area with average rate of 3 births per time-step": each update
  first adds the birth intensity ``birth_mass`` spread uniformly over the square S_a(s_k)
  of the step's position, velocities uniform in ``[-birth_speed, birth_speed]^2``
  (``birth_newborn``: they take no missed-detection term, Ristic et al. 2012, so births
  nobody measured vanish at once; the filter's :class:`~.smc_phd.estimator.ScanBirth`). Its
  particles are drawn where the step's measurements are and weighted by importance
  (``births: measurement``, :meth:`PapaioannouEstimator._births_near`): the bearing is
  measured to 1 degree, 7 cm across at 4 m, so births drawn uniformly over 100 m^2
  (``births: uniform``) put almost none in the likelihood's peak; then the update, the
  estimates and the resampling. The estimates are this estimator's own, read off each
  update between the filter's weighing and its resampling: by measurement (Ristic, Clark & Vo
  2010: a measurement whose particles took weight > 0.5 gives the weighted mean of their
  states; ``estimates_from: persistent`` counts only the particles that existed before the
  scan), held out of view (``hold_gate``), or the k-means of the square's mass;
- the search density on virtual targets, eq. 7, 9, 10
  (:mod:`phd_swarm.core.estimators.papaioannou.search_map`): one search value per node of the
  search map, decayed by J outside the previous square and set to 1 inside the current one; the
  exchange max-merges the values of the agents met (:meth:`PapaioannouEstimator.merge_search`).

The controller reads the particles, the search values and two one-step predictions: the
predicted multi-target state X^_{k+1|k} (:meth:`PapaioannouEstimator.predicted_states`, the
estimates only), which the agents exchange and compare by eq. 19, and the states it tracks
(:meth:`PapaioannouEstimator.track_states`: those and, with ``look_tentative``, the first
detections it looks at again).

Reference: S. Papaioannou et al., "A cooperative multi-agent probabilistic framework for
search and track missions", IEEE T-CNS, Sec. V-A, VI-A.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.distance import cdist

from ... import registry
from ...outputs import Output
from ...params import ParamSpec
from ...scan import Scan
from ...sensors.range_bearing_model import RangeBearingSensor, range_bearing_log_likelihood
from ..base import Estimator
from ..smc_phd.estimator import Resampling, ScanBirth, SmcPhdEstimator
from ..smc_phd.filter import ParticleSet, extract, extract_by_measurement
from ..smc_phd.models import linear_gaussian_transition
from . import search_map as sm
from .figures import step_figures

#: Results revision of the parts this module registers (:func:`phd_swarm.config.sweep_hash.
#: results_revisions`). 2: ``predicted_states`` no longer holds the tentative detections, so
#: the exchanged sets that eq. 19 compares are the estimates only (issue 33).
RESULTS_REVISION = 2

#: Stream of the estimators' own generators (particles), apart from the robots' and the
#: world's (``SeedSequence(seed, spawn_key=(ESTIMATOR_STREAM, robot_id))``).
ESTIMATOR_STREAM = 20

OPTIONS = (
    ParamSpec("survival_probability", 0.99, "papaioannou_sat: p_S per step (Sec. VI-A: 0.99)",
              low=0.0, high=1.0),
    ParamSpec("process_noise", 0.01, "papaioannou_sat: q of the NCV model's Q [m^2/s^3] "
              "(Sec. VI-A prints Q for q = 1, which cannot keep the stated 1 m/s per axis; "
              "docs/decisions.md)", low=0.0),
    ParamSpec("birth_mass", 3.0, "papaioannou_sat: expected births per step, uniform over the "
              "agent's sensing square (Sec. VI-A: 3)", low=0.0),
    ParamSpec("birth_speed", 2.0, "papaioannou_sat: births' velocities uniform in [-v, v]^2 "
              "[m/s] (not stated; the targets move at 1 m/s per axis)", low=0.0),
    ParamSpec("births", "measurement", "papaioannou_sat: the uniform birth intensity's "
              "particles drawn near the step's measurements, importance-weighted "
              "(measurement), or uniformly over the sensing square (uniform)",
              choices=("measurement", "uniform")),
    ParamSpec("birth_newborn", True, "papaioannou_sat: births take no missed-detection term "
              "(Ristic et al. 2012); false: the plain PHD update of eq. 8"),
    ParamSpec("particles_per_target", 300, "papaioannou_sat: particles per expected target "
              "after resampling (and per unit of birth mass)", low=1),
    ParamSpec("max_particles", 6000, "papaioannou_sat: most particles after resampling",
              low=1),
    ParamSpec("estimates_from", "persistent", "papaioannou_sat: a measurement gives an "
              "estimate when the particles that existed before the scan took weight > 0.5 "
              "(persistent: a new target is reported from its second detection), or when all "
              "did, births included (all: Ristic, Clark & Vo 2010, a clutter point in view is "
              "an estimate at once); square: round(mass in the sensing square) estimates by "
              "k-means there (Sec. V-A)",
              choices=("all", "persistent", "square")),
    ParamSpec("look_tentative", True, "papaioannou_sat: the look rule: a measurement whose "
              "particles, births included, took weight > 0.5 but that is not an estimate yet "
              "is handed to the controller with the predicted estimates, so the agent tracks "
              "it and looks again (false: no looks, the controller sees the estimates only)"),
    ParamSpec("hold_gate", 5.0, "papaioannou_sat: an estimate no measurement renews is "
              "kept, moved to the particles within this distance [m] of its prediction, while "
              "their weight exceeds 0.5 (0: estimates only from this step's measurements)",
              low=0.0),
    ParamSpec("roughening", 0.0, "papaioannou_sat: sd of the jitter added to every "
              "resampled particle's position [m] and velocity [m/s] (regularisation; 0: none)",
              low=0.0),
    ParamSpec("node_size", 5.0, "papaioannou_sat: side of a search-map region r_v [m] (not "
              "stated; half the sensing square)", low=0.0),
    ParamSpec("search_decay", 0.999, "papaioannou_sat: J, the search values' decay per step "
              "outside the sensing square (eq. 7; Sec. VI-A: 0.999)", low=0.0, high=1.0),
)


@dataclass(frozen=True, eq=False)
class PapaioannouSetup:
    """What every agent's estimator shares (see the module docstring).

    Attributes
    ----------
    dt : float
        Step T [s].
    f, q : np.ndarray, shape (4, 4)
        NCV transition and process noise in the order ``[x, y, vx, vy]``.
    p_s : float
    sensor : Any
        The ``square_range_bearing`` sensor's models (side, p_D, clutter, RangeBearingSensor).
    grid : phd_swarm.core.estimators.papaioannou.search_map.SearchGrid
    decay : float
    birth_mass, birth_speed : float
    birth_newborn : bool
    per_target, max_particles : int
    seed : int
        The run's seed, for the estimators' own generators.
    """

    dt: float
    f: np.ndarray
    q: np.ndarray
    p_s: float
    sensor: Any
    grid: sm.SearchGrid
    decay: float
    birth_mass: float
    birth_speed: float
    birth_newborn: bool
    per_target: int
    max_particles: int
    seed: int = 0
    roughening: float = 0.0
    confirmed_only: bool = False
    extraction: str = "persistent"
    measurement_births: bool = True
    hold_gate: float = 0.0
    look_tentative: bool = False


def ncv_model(dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """F and Q of the NCV model (Sec. VI-A) for the state ``[x, y, vx, vy]``."""
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    qq = np.zeros((4, 4))
    qq[:2, :2] = q * dt ** 3 / 3.0 * np.eye(2)
    qq[:2, 2:] = qq[2:, :2] = q * dt ** 2 / 2.0 * np.eye(2)
    qq[2:, 2:] = q * dt * np.eye(2)
    return f, qq


class PapaioannouEstimator(Estimator):
    """One agent's SAT density (see the module docstring).

    Parameters
    ----------
    setup : PapaioannouSetup
    robot_id : int
    rng : np.random.Generator
        Source of the particles' randomness (motion, births, resampling), shared with the
        particle filter.

    Attributes
    ----------
    filter : SmcPhdEstimator
        The particle PHD of the true targets (eq. 6, 8), with the paper's models and births.
    search : np.ndarray, shape (V,)
        Search values p_v of the map's nodes (eq. 10), 0 = never searched.
    """

    def __init__(self, setup: PapaioannouSetup, robot_id: int,
                 rng: np.random.Generator) -> None:
        self.setup = setup
        self.robot_id = int(robot_id)
        self.rng = rng
        sensor = setup.sensor
        self._sensor: RangeBearingSensor = sensor.model
        self.filter = SmcPhdEstimator(
            dim=4, transition=linear_gaussian_transition(setup.f, setup.q), p_s=setup.p_s,
            log_likelihood=range_bearing_log_likelihood(sensor.model),
            p_d=lambda states, pose: sensor.detection_probability(states[:, :2], pose),
            clutter=sensor.clutter_intensity,
            birth=ScanBirth(self._births_near if setup.measurement_births else self._births),
            rng=rng, resampling=Resampling(per_target=setup.per_target,
                                           min_particles=setup.per_target,
                                           max_particles=setup.max_particles,
                                           roughening=setup.roughening),
            extraction="measurement_only")
        #: Search values p_v of the map's nodes (eq. 10), 0 = never searched.
        self.search = sm.initial_values(setup.grid)
        self._position: np.ndarray | None = None
        self._states = np.empty((0, 4))
        #: Detections the births made likely (weight > 0.5) that are not estimates yet.
        self._tentative = np.empty((0, 4))
        self.step = -1

    @property
    def particles(self) -> ParticleSet:
        """The particle PHD of the true targets (the filter's particles)."""
        return self.filter.particles

    # ------------------------------------------------------------------ filter
    def predict(self) -> None:
        """Eq. 6 for the survivors (NCV motion, p_S); births come with the scan (eq. 6's b_k)."""
        self.filter.predict()

    def update(self, scan: Scan) -> None:
        """Births in S_a(s_k), eq. 8, estimates, resampling; eq. 7 and 9 on the search map."""
        s = self.setup
        sensor = scan.sensor
        last_states = self._states
        result = self.filter.update_weights(scan)
        # Measurements the particles, births included, took with weight > 0.5.
        seen = extract_by_measurement(result) if s.extraction != "square" else None
        if s.extraction == "square":
            # Sec. V-A: n^ = round(mass inside the sensing square), the n^ highest peaks of
            # the PHD there (k-means of the particles in the square, Vo et al. 2005).
            post = result.particles
            inside = s.sensor.inside(post.states[:, :2], sensor)
            here = ParticleSet(post.weights[inside], post.states[inside],
                               post.newborn[inside])
            self._states = extract(here, np.random.default_rng(self.rng.integers(2**63)))
        elif s.confirmed_only:
            # Ristic, Clark & Vo (2010): a measurement explained by particles that existed
            # before this scan (U(z) > 0.5) gives an estimate; births report a step later.
            self._states = result.detection_means[result.persistent_mass > 0.5].copy()
        else:
            self._states = seen.copy()
        if s.hold_gate > 0.0 and s.extraction != "square":
            self._states = np.concatenate([self._states,
                                           self._held(last_states, result.particles,
                                                      self._states)])
        self._tentative = np.empty((0, 4))
        if s.look_tentative and seen is not None:
            if len(seen) and len(self._states):
                gate = max(s.hold_gate, 1e-9)
                seen = seen[~(cdist(seen[:, :2], self._states[:, :2]) <= gate).any(axis=1)]
            self._tentative = seen
        # Resampling, and with ``roughening`` the jitter of Musso, Oudjane & Le Gland (2001):
        # resampled copies of one particle are moved apart, so a cloud the 1-degree bearing
        # squeezed to a sliver keeps particles where the next viewpoint's bearing line may
        # cross it.
        self.filter.resample()
        previous = sensor if self._position is None else self._position
        self.search = sm.update(sm.predict(self.search, s.grid, previous, s.decay), s.grid,
                                sensor)
        self._position = np.array(sensor, dtype=float)
        self.step = int(scan.step)

    def _held(self, previous: np.ndarray, post: ParticleSet,
              renewed: np.ndarray) -> np.ndarray:
        """The previous estimates no measurement renewed, moved to the posterior's mass.

        Each previous estimate x^_{k-1} is predicted to F x^_{k-1}; unless a renewed estimate
        lies within ``hold_gate`` of it, the posterior particles within ``hold_gate`` of the
        prediction (positions) give it again, at their weighted mean, if their weight is
        > 0.5. A target out of the square keeps its estimate while its mass lasts (p_D = 0
        there, so the PHD keeps it at p_S per step); one missed in view loses it
        (1 - p_D = 0.01 of its weight stays).
        """
        gate = self.setup.hold_gate
        previous = previous @ self.setup.f.T
        if len(previous) == 0 or len(post) == 0:
            return np.empty((0, 4))
        if len(renewed):
            near = (cdist(previous[:, :2], renewed[:, :2]) <= gate).any(axis=1)
            previous = previous[~near]
        w = (cdist(previous[:, :2], post.states[:, :2]) <= gate) * post.weights   # (K, N)
        mass = w.sum(axis=1)
        keep = mass > 0.5
        return (w[keep] @ post.states) / mass[keep, None]

    def _births_near(self, rng: np.random.Generator, z: np.ndarray,
                     sensor: np.ndarray) -> ParticleSet:
        """The uniform birth intensity of :meth:`_births`, sampled where the measurements are.

        Positions are drawn from the mixture q(x) = (1/M) sum_m N(x; p(z_m), C(z_m)) of the
        positions the M measurements imply (:meth:`~.range_bearing_model.RangeBearingSensor.
        to_positions`), velocities from the birth's own uniform law; each particle's weight
        is the importance ratio ``b(x) / (q(x) N)`` with b the uniform birth density over
        the square (``birth_mass / a^2`` per m^2), so the births' intensity is b in
        expectation, with particles only where a measurement can give them weight. With
        ``birth_newborn`` (no missed-detection term) the births nothing measured would
        vanish in the update anyway, so nothing is lost by not drawing them.
        """
        s = self.setup
        m = len(z)
        if m == 0 or s.birth_mass == 0.0:
            return ParticleSet.empty(4)
        n = s.per_target
        pos, cov = self._sensor.to_positions(z, sensor)
        chol = np.linalg.cholesky(cov)                                    # (M, 2, 2)
        e = rng.standard_normal((m, n, 2))
        x = (pos[:, None, :] + np.einsum("mij,mnj->mni", chol, e)).reshape(-1, 2)
        vel = (2.0 * rng.random((m * n, 2)) - 1.0) * s.birth_speed
        d = x[:, None, :] - pos[None, :, :]                               # (N, M, 2)
        inv = np.linalg.inv(cov)
        maha = np.einsum("nmi,mij,nmj->nm", d, inv, d)
        dens = np.exp(-0.5 * maha) / (2.0 * np.pi * np.sqrt(np.linalg.det(cov)))
        q = dens.mean(axis=1)                                             # (N,)
        inside = s.sensor.inside(x, sensor)
        b = s.birth_mass / s.sensor.side ** 2
        w = np.where(inside, b / (q * m * n), 0.0)
        return ParticleSet(w, np.concatenate([x, vel], axis=1),
                           np.full(m * n, bool(s.birth_newborn)))

    def _births(self, rng: np.random.Generator, z: np.ndarray,
                sensor: np.ndarray) -> ParticleSet:
        """``birth_mass`` over the sensing square S_a(sensor), particles drawn uniformly there.

        Velocities uniform in ``[-birth_speed, birth_speed]^2``; ``z`` is not used.
        """
        s = self.setup
        n = int(round(s.birth_mass * s.per_target))
        if n == 0 or s.birth_mass == 0.0:
            return ParticleSet.empty(4)
        u = rng.random((n, 4))
        half = 0.5 * s.sensor.side
        states = np.concatenate([sensor + (2.0 * u[:, :2] - 1.0) * half,
                                 (2.0 * u[:, 2:] - 1.0) * s.birth_speed], axis=1)
        return ParticleSet(np.full(n, s.birth_mass / n), states,
                           np.full(n, bool(s.birth_newborn)))

    # --------------------------------------------------------------- readings
    def estimate_states(self) -> np.ndarray:
        """X^_k, the extracted states ``[x, y, vx, vy]`` (K, 4)."""
        return self._states.copy()

    def estimates(self) -> np.ndarray:
        """X^_k positions (K, 2) [m]."""
        return self._states[:, :2].copy()

    def tentative_states(self) -> np.ndarray:
        """Detections not yet estimates whose particles took weight > 0.5 (T, 4)."""
        return self._tentative.copy()

    def predicted_states(self) -> np.ndarray:
        """X^_{k+1|k}, the predicted multi-target state (K, 4): the estimates moved by F.

        The mean prediction (no noise). This is the set the agents exchange and that eq. 19
        compares (Sec. V-C b: "the predicted multi-target states"); the tentative
        detections are not in it (:meth:`track_states`).
        """
        return self._states @ self.setup.f.T

    def track_states(self) -> np.ndarray:
        """What the controller tracks at k+1 (K + T, 4): X^_{k+1|k} and the predicted looks.

        The estimates and, with ``look_tentative``, the tentative detections, moved by F
        without noise; the agent is in tracking mode while this is not empty.
        """
        return np.concatenate([self._states, self._tentative]) @ self.setup.f.T

    @property
    def sensor_position(self) -> np.ndarray | None:
        """s_k, where the last scan was taken (2,) [m]; None before the first."""
        return None if self._position is None else self._position.copy()

    def expected_count(self) -> float:
        """The particles' total weight (the PHD's mass)."""
        return self.filter.expected_count()

    def merge_search(self, values: np.ndarray) -> None:
        """Max-merge another agent's search values into this one's (Sec. V-B c)."""
        self.search = sm.max_merge(self.search, sm.check_values(values, self.search.size,
                                                                "search values"))

    def export_state(self) -> dict[str, np.ndarray]:
        """The particles as arrays (:meth:`.smc_phd.filter.ParticleSet.to_arrays`)."""
        return self.filter.export_state()


def _setup(scenario: Any, system: Any, **runtime: Any) -> PapaioannouSetup:
    opt = {spec.name: system.option(spec.name) for spec in OPTIONS}
    sensor = system.parts()["sensor"].setup(scenario, system)
    env = scenario.env
    f, q = ncv_model(float(scenario.dt), float(opt["process_noise"]))
    grid = sm.SearchGrid(env.xmin, env.ymin, env.xmax, env.ymax, float(opt["node_size"]),
                         float(sensor.side))
    return PapaioannouSetup(float(scenario.dt), f, q, float(opt["survival_probability"]),
                            sensor, grid, float(opt["search_decay"]), float(opt["birth_mass"]),
                            float(opt["birth_speed"]), bool(opt["birth_newborn"]),
                            int(opt["particles_per_target"]), int(opt["max_particles"]),
                            int(scenario.seed), float(opt["roughening"]),
                            confirmed_only=opt["estimates_from"] == "persistent",
                            extraction=str(opt["estimates_from"]),
                            measurement_births=opt["births"] == "measurement",
                            hold_gate=float(opt["hold_gate"]),
                            look_tentative=bool(opt["look_tentative"]))


def _make(setup: PapaioannouSetup, robot_id: int) -> PapaioannouEstimator:
    rng = np.random.default_rng(np.random.SeedSequence(
        setup.seed, spawn_key=(ESTIMATOR_STREAM, int(robot_id))))
    return PapaioannouEstimator(setup, robot_id, rng)


#: The agent's search values of the step.
SEARCH_MAP = Output(
    "search_map", "phd_swarm_msgs/msg/DensityGrid",
    "phd_swarm.nodes.faces.search_and_track:SEARCH_MAP",
    "The agent's search values p_v, one per node of its search map (Papaioannou et al. "
    "eq. 10), 0 = never searched, 1 = searched now.")

registry.register(
    "estimator", "papaioannou_sat", _make, setup=_setup,
    description="SAT density: a particle PHD of the targets (NCV, range-bearing, births in "
                "the sensing square) and the search values of a search map (Papaioannou et "
                "al. Sec. V-A, eq. 6-10).",
    options=OPTIONS, provides=("particles", "search_map"),
    requires=("square_fov", "range_bearing_measurement"), outputs=(SEARCH_MAP,),
    figures=step_figures)
