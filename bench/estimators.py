"""Estimators benchmark: our GM-PHD (and SMC-PHD) against Stone Soup 1.9.1's, same data.

Run with ``scripts/bench.sh estimators [--quick] [--no-stonesoup] [--only B|A|C|smc|rb]``. The
script installs Stone Soup (pinned, 1.9.1) into the benchmark-only environment .venv-bench
(``scripts/bench_stonesoup_setup.sh``); with ``--no-stonesoup`` our side runs alone from the
project's .venv and Stone Soup is never imported. Prints a table and writes the figures as
JSON to ``bench/results/estimators-<date>.json``.

Stone Soup's GM-PHD gates the component-measurement pairs at Mahalanobis distance 3 (the
``missed_distance`` of its GM-PHD tutorial; ``--ss-gate inf`` for none, as in ours, which
costs Stone Soup several times more): the default is the faster Stone Soup.

Each scenario's truth and measurement sets are generated once (seeded numpy Generator) and
fed identically to both implementations. Timed per step: predict + update + prune/merge +
extraction (for Stone Soup: hypothesise, which predicts, + PHD update + reduce +
extraction). Reported per implementation: median and p95 ms per step, mean number of
components (or particles), mean OSPA over the last half of the steps, and the speed ratio
(Stone Soup's median / ours).

Scenario B (tracking), 200 steps of T = 1 s (``--quick``: 20 steps, 10 initial targets):

- truth: 50 initial targets, positions uniform in the 200 x 200 m square, velocities
  N(0, 0.5^2) per axis; nearly-constant velocity with white-noise acceleration intensity
  q = 0.05 (F, Q of the CV model for T = 1); survival 0.99 per step; births Poisson(0.2)
  per step, uniform in the square, velocity N(0, 0.5^2); targets reflect off the walls;
- measurements: p_D = 0.95, position with sd 1 m; clutter Poisson(10) uniform in the square;
- both filters: the same CV model; p_S = 0.99, p_D = 0.95, kappa = 10 / 200^2;
  birth intensity: four Gaussians at the quadrant centres (50, 50), (150, 50), (50, 150),
  (150, 150) m, position sd 50 m, velocity 0 with sd 0.5 m/s, weight 0.05 each (0.2 in
  all); initial intensity: the same four Gaussians with total weight = the number of
  initial targets (50); reduction T = 1e-5, U = 4, J_max = 100; extraction: round(w)
  copies of each component of weight > 0.5. OSPA c = 10 m, p = 1.

Scenario A (search, limited field of view), 500 steps (``--quick``: 60):

- truth: 10 stationary targets uniform in the 150 x 150 m square;
- sensor: lawn-mower path, lanes along x from x = 0 to 150 m at y = 12.5, 37.5, ..., 137.5 m
  (25 m apart), joined at the ends; constant speed, so the whole path takes all the steps;
- measurements: disk FoV of radius 25 m, p_D = 0.9 inside, 0 outside; position sd 0.5 m;
  clutter Poisson(1) uniform in the FoV disk;
- both filters: state (x, y), F = I, Q = 1e-4 I m^2 (a random walk, "small Q"); p_S = 1;
  no births (every target is there from the start); initial intensity for the search: a
  6 x 6 grid of Gaussians at 25 m spacing (centres 12.5 ... 137.5 m), sd 10 m, weight
  10/36 each (10 expected targets; neighbours are 6.25 apart in squared Mahalanobis
  distance, above U, so the prior does not collapse in the merge); kappa = 1 / (pi 25^2);
  reduction T = 1e-5, U = 4, J_max = 100;
- p_D of a component: at its mean (0.9 if the mean is inside the disk, else 0) for Stone
  Soup (a custom updater) and for our "mean" row; our "integrated" row uses
  ``phd_swarm.core.sensors.fov_detection.DiskFov(25, 0.9, integrate=True)``
  (:func:`our_a_pd`). OSPA c = 100 m, p = 2, and the oracle OSPA: the estimate is
  every target that has been inside the FoV at some step so far, exactly.

Scenario C (revisits of moving targets, small field of view; ours only, issue 33), 600
steps (``--quick``: 120). Chosen for where the integrated p_D should matter on principle:
components whose spread is comparable to the FoV when the sensor looks at them, because the
targets move while unseen and the prior is wide against a small disk. Fixed before any run:

- truth: 8 targets uniform in the 100 x 100 m square, each a random walk with variance
  q = 0.25 m^2 per step (sd 0.5 m a step, ~7 m over a sweep), reflected at the walls;
- sensor: the lawn-mower of A on this square (lanes along x at y = 12.5 ... 87.5 m, 25 m
  apart), run 3 times, forward, backward, forward, at constant speed over all the steps,
  so that each target is looked at again about every 200 steps;
- measurements: disk FoV of radius 12.5 m (half the lane spacing: one sweep covers the
  square once), p_D = 0.9 inside, position sd 0.5 m, clutter Poisson(1) uniform in the disk;
- filter: state (x, y), F = I, Q = q I (the truth's model), p_S = 1, no births; initial
  intensity a 4 x 4 grid of Gaussians at 25 m spacing, sd 10 m, weight 8/16 each;
  kappa = 1 / (pi 12.5^2); reduction T = 1e-5, U = 4, J_max = 100;
- rows: p_D at the mean and integrated (``DiskFov(12.5, 0.9)``), each under both merge
  rules (``GmPhdModel.merge_metric`` "candidate" and "heaviest"); OSPA c = 50 m (half the
  side), p = 2, and the oracle of A (the targets seen so far, at their true positions).

SMC-PHD on B (``--only smc`` or the default run): Stone Soup's SMCPHDPredictor/Updater with
a budget of N particles after resampling (``--particles``, 20000; quick: 2000) plus
0.1 N birth particles per step (expansion scheme, birth rate 0.2, uniform positions,
N(0, 0.5^2) velocities); initial particles: N uniform in the square with total weight = the
number of initial targets. Extraction: for each measurement, the particle weight it
claims; above 0.5, the weighted mean position (round(weight) copies). Stone Soup 1.9.1's
updater evaluates the likelihood with ``noise=True``, which adds a random measurement-noise
draw to each particle's predicted measurement (a jittered, on average broadened
likelihood); a second Stone Soup row runs it with the exact likelihood
(``estimators_stonesoup._ExactSMCPHDUpdater``), the filter ours implements. Ours
(:func:`run_ours_smc`) has the same budget, births, models and extraction.

Range-bearing on B (``--only rb`` or the default run): the truth of B measured by
Papaioannou's range-bearing sensor (Sec. VI-A noise: sd 1 m + 5e-5 r in range, 1 degree +
1e-5 r rad in bearing) from the centre of the square, p_D 0.95, clutter Poisson(10) uniform
over the square, measured without noise in (r, phi) (its intensity there is
``lambda r / A``, :func:`.range_bearing_model.clutter_density_square`). Ours: the GM-PHD with
the EKF and the UKF update (:mod:`gm_phd_nonlinear`), and the SMC-PHD with the
range-bearing likelihood; models, births and reduction as on B. Stone Soup's counterpart of
the SMC-PHD (two rows, its updater's noisy likelihood and the exact one, as on "smc"; same
budget, births and extraction): ``CartesianToBearingRange`` (bearing, range order; our rows
are converted, the bearing difference wrapped) cannot take a range-dependent noise, so
``estimators_stonesoup.RangeDependentBearingRange`` evaluates the likelihood with the sds
at each particle's range, and ``_PolarClutterSMCPHDUpdater`` gives each detection its
clutter intensity ``lambda r / A`` (Stone Soup's updater takes one scalar). The GM-PHD
rows have no Stone Soup counterpart here (their speed-up is left blank).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from results_io import machine_meta, write_results

from phd_swarm.core.estimators.gm_phd.filter import GaussianMixture, GmPhdModel, constant_p_d
from phd_swarm.core.ospa import ospa
from phd_swarm.core.scan import Scan

try:  # the estimator class is moving to its own module
    from phd_swarm.core.estimators.gm_phd.estimator import GmPhdEstimator
except ImportError:  # pragma: no cover - older layout
    from phd_swarm.core.estimators.gm_phd.filter import GmPhdEstimator

OURS = "phd_swarm"
STONESOUP = "stonesoup 1.9.1"


# ---------------------------------------------------------------------------- scenarios


@dataclass(frozen=True)
class TrackingSpec:
    """Scenario B: tracking in a square, everything detectable."""

    steps: int = 200
    dt: float = 1.0
    n_initial: int = 50
    q: float = 0.05                 # white-noise acceleration intensity [m^2/s^3]
    side: float = 200.0             # [m]
    v_sd: float = 0.5               # initial and birth velocity sd per axis [m/s]
    birth_rate: float = 0.2         # expected births per step
    p_s: float = 0.99
    p_d: float = 0.95
    r_sd: float = 1.0               # position measurement sd [m]
    clutter_rate: float = 10.0      # expected clutter measurements per step
    birth_pos_sd: float = 50.0      # sd of each of the four birth Gaussians [m]
    prune: float = 1e-5
    merge: float = 4.0
    j_max: int = 100
    ospa_c: float = 10.0
    ospa_p: float = 1.0

    @property
    def clutter_intensity(self) -> float:
        """Clutter intensity kappa [1/m^2]: the clutter rate over the square."""
        return self.clutter_rate / self.side ** 2


@dataclass(frozen=True)
class SearchSpec:
    """Scenario A: search for stationary targets with a disk field of view."""

    steps: int = 500
    n_targets: int = 10
    side: float = 150.0
    lane_spacing: float = 25.0
    first_lane: float = 12.5
    radius: float = 25.0
    p_d: float = 0.9
    r_sd: float = 0.5
    clutter_rate: float = 1.0
    q: float = 1e-4                 # random-walk variance per step [m^2]
    prior_spacing: float = 25.0     # grid of the initial intensity [m]
    prior_sd: float = 10.0
    prune: float = 1e-5
    merge: float = 4.0
    j_max: int = 100
    ospa_c: float = 100.0
    ospa_p: float = 2.0

    @property
    def clutter_intensity(self) -> float:
        """Clutter intensity kappa [1/m^2]: the clutter rate over the FoV disk."""
        return self.clutter_rate / (math.pi * self.radius ** 2)


@dataclass(frozen=True)
class RevisitSpec(SearchSpec):
    """Scenario C: repeated lawn-mower sweeps over random-walking targets, small disk FoV.

    A's fields with C's values, and the number of sweeps.
    """

    steps: int = 600
    n_targets: int = 8
    side: float = 100.0
    radius: float = 12.5
    q: float = 0.25                 # random-walk variance per step, truth and model [m^2]
    ospa_c: float = 50.0
    sweeps: int = 3


@dataclass(frozen=True, eq=False)
class ScenarioData:
    """Truth and measurements of one run, generated once, shared by both implementations."""

    truth: list[np.ndarray]           # per step: (N_k, 2) true positions [m]
    z: list[np.ndarray]               # per step: (M_k, 2) measurements [m]
    sensor: np.ndarray                # (steps, 2) sensor position [m]
    oracle: list[np.ndarray] | None = None   # per step: the targets seen so far (A)

    @property
    def steps(self) -> int:
        """Number of steps."""
        return len(self.z)


def cv_matrices(dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """F, Q of the nearly-constant-velocity model, state [x, y, vx, vy]."""
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    q1 = q * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    qm = np.zeros((4, 4))
    qm[np.ix_([0, 2], [0, 2])] = q1
    qm[np.ix_([1, 3], [1, 3])] = q1
    return f, qm


def make_tracking(spec: TrackingSpec, rng: np.random.Generator) -> ScenarioData:
    """Truth and measurement sets of scenario B."""
    f, qm = cv_matrices(spec.dt, spec.q)
    chol = np.linalg.cholesky(qm)

    def newborn(n: int) -> np.ndarray:
        return np.hstack([rng.uniform(0.0, spec.side, (n, 2)),
                          rng.normal(0.0, spec.v_sd, (n, 2))])

    x = newborn(spec.n_initial)
    truth, zs = [], []
    for k in range(spec.steps):
        if k > 0:
            x = x[rng.random(len(x)) < spec.p_s]
            x = x @ f.T + rng.standard_normal((len(x), 4)) @ chol.T
            for axis in (0, 1):  # reflect off the walls
                low, high = x[:, axis] < 0.0, x[:, axis] > spec.side
                x[low, axis] = -x[low, axis]
                x[high, axis] = 2.0 * spec.side - x[high, axis]
                x[low | high, axis + 2] *= -1.0
            x = np.vstack([x, newborn(rng.poisson(spec.birth_rate))])
        truth.append(x[:, :2].copy())
        det = x[rng.random(len(x)) < spec.p_d, :2]
        z = np.vstack([det + rng.normal(0.0, spec.r_sd, det.shape),
                       rng.uniform(0.0, spec.side, (rng.poisson(spec.clutter_rate), 2))])
        zs.append(z[rng.permutation(len(z))])
    return ScenarioData(truth, zs, np.full((spec.steps, 2), spec.side / 2))


def lawnmower(spec: SearchSpec) -> np.ndarray:
    """Sensor positions (steps, 2): lanes along x, constant speed over the whole path."""
    return _along(_lane_corners(spec.first_lane, spec.side, spec.lane_spacing), spec.steps)


def _lane_corners(first_lane: float, side: float, spacing: float) -> np.ndarray:
    """Corners (2L, 2) of a lawn-mower over [0, side]^2: lanes along x, every ``spacing``."""
    pts = []
    for i, y in enumerate(np.arange(first_lane, side, spacing)):
        xs = (0.0, side) if i % 2 == 0 else (side, 0.0)
        pts += [(xs[0], y), (xs[1], y)]
    return np.asarray(pts)


def _along(pts: np.ndarray, steps: int) -> np.ndarray:
    """``steps`` positions (steps, 2) along the polyline ``pts`` at constant speed."""
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s_pts = np.concatenate([[0.0], np.cumsum(seg)])
    s = np.linspace(0.0, s_pts[-1], steps)
    return np.column_stack([np.interp(s, s_pts, pts[:, 0]), np.interp(s, s_pts, pts[:, 1])])


def make_search(spec: SearchSpec, rng: np.random.Generator) -> ScenarioData:
    """Truth, measurement sets and oracle estimates of scenario A."""
    targets = rng.uniform(0.0, spec.side, (spec.n_targets, 2))
    sensor = lawnmower(spec)
    seen = np.zeros(spec.n_targets, dtype=bool)
    truth, zs, oracle = [], [], []
    for q in sensor:
        inside = np.linalg.norm(targets - q, axis=1) <= spec.radius
        seen |= inside
        truth.append(targets.copy())
        zs.append(_disk_scan(rng, spec, q, targets, inside))
        oracle.append(targets[seen].copy())
    return ScenarioData(truth, zs, sensor, oracle)


def _disk_scan(rng: np.random.Generator, spec: SearchSpec, q: np.ndarray,
               x: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """One scan of A or C at ``q``, shuffled: detections and Poisson clutter in the disk.

    The targets ``inside`` the disk are detected with p_D and measured with noise.
    """
    det = x[inside & (rng.random(len(x)) < spec.p_d)]
    n_c = rng.poisson(spec.clutter_rate)
    rad = spec.radius * np.sqrt(rng.random(n_c))
    ang = rng.uniform(0.0, 2.0 * np.pi, n_c)
    clutter = q + np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
    z = np.vstack([det + rng.normal(0.0, spec.r_sd, det.shape), clutter])
    return z[rng.permutation(len(z))]


def revisit_path(spec: RevisitSpec) -> np.ndarray:
    """Sensor positions (steps, 2): the lawn-mower swept ``sweeps`` times, alternating."""
    sweep = _lane_corners(spec.first_lane, spec.side, spec.lane_spacing)
    pts = [sweep]
    for i in range(1, spec.sweeps):
        pts.append((sweep[::-1] if i % 2 else sweep)[1:])
    return _along(np.vstack(pts), spec.steps)


def make_revisit(spec: RevisitSpec, rng: np.random.Generator) -> ScenarioData:
    """Truth, measurement sets and oracle estimates of scenario C."""
    x = rng.uniform(0.0, spec.side, (spec.n_targets, 2))
    sensor = revisit_path(spec)
    seen = np.zeros(spec.n_targets, dtype=bool)
    truth, zs, oracle = [], [], []
    for k, q in enumerate(sensor):
        if k > 0:
            x = x + rng.normal(0.0, math.sqrt(spec.q), x.shape)
            x = np.abs(x)                                   # reflect at 0 and at the side
            x = spec.side - np.abs(spec.side - x)
        inside = np.linalg.norm(x - q, axis=1) <= spec.radius
        seen |= inside
        truth.append(x.copy())
        zs.append(_disk_scan(rng, spec, q, x, inside))
        oracle.append(x[seen].copy())
    return ScenarioData(truth, zs, sensor, oracle)


# ------------------------------------------------------------------ shared model choices


def tracking_birth(spec: TrackingSpec, total: float) -> tuple[np.ndarray, ...]:
    """Four Gaussians at the quadrant centres, weight ``total`` in all; state [x, y, vx, vy]."""
    c = (0.25 * spec.side, 0.75 * spec.side)
    means = np.array([[x, y, 0.0, 0.0] for y in c for x in c])
    cov = np.diag([spec.birth_pos_sd ** 2] * 2 + [spec.v_sd ** 2] * 2)
    return np.full(4, total / 4), means, np.repeat(cov[None], 4, axis=0)


def search_prior(spec: SearchSpec) -> tuple[np.ndarray, ...]:
    """Initial intensity of the search: a grid of Gaussians, weight = expected targets."""
    g = np.arange(spec.prior_spacing / 2, spec.side, spec.prior_spacing)
    means = np.array([[x, y] for y in g for x in g])
    n = len(means)
    covs = np.repeat((spec.prior_sd ** 2 * np.eye(2))[None], n, axis=0)
    return np.full(n, spec.n_targets / n), means, covs


# ---------------------------------------------------------------------------- our side

DetectionProbability = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def our_a_pd(kind: str, spec: SearchSpec | None = None) -> DetectionProbability:
    """The detection model of our GM-PHD on scenario A.

    ``kind`` "mean": p_D at the component mean (what Stone Soup does). ``kind``
    "integrated": ``DiskFov(radius, p_inside, integrate=True)`` of
    :mod:`phd_swarm.core.sensors.fov_detection`, p_inside times the component's mass in the
    FoV (Sung & Tokekar eq. 9-10).
    """
    from phd_swarm.core.sensors.fov_detection import DiskFov

    spec = spec or SearchSpec()
    if kind not in ("mean", "integrated"):
        raise ValueError(f"unknown p_D kind {kind!r}")
    return DiskFov(spec.radius, spec.p_d, integrate=kind == "integrated")


@dataclass
class Run:
    """Per-step figures of one implementation on one scenario."""

    ms: list[float]
    sizes: list[int]
    estimates: list[np.ndarray]


def run_ours_gm(data: ScenarioData, model: GmPhdModel, prior: GaussianMixture,
                p_d: DetectionProbability) -> Run:
    """Our GM-PHD over the scenario: predict + update (+ prune/merge) + extract, timed."""
    est = GmPhdEstimator(model, mixture=prior, p_d=p_d)
    return run_estimator(est, data, lambda: len(est.mixture))


def run_estimator(est, data: ScenarioData, size: Callable[[], int]) -> Run:
    """Step ``est`` through the scenario's scans, timing predict + update + estimates."""
    ms, sizes, estimates = [], [], []
    scans = [Scan(robot_id=0, step=k, sensor=data.sensor[k], z=data.z[k])
             for k in range(data.steps)]
    for scan in scans:
        t0 = time.perf_counter()
        est.predict()
        est.update(scan)
        x = est.estimates()
        ms.append((time.perf_counter() - t0) * 1e3)
        sizes.append(size())
        estimates.append(x)
    return Run(ms, sizes, estimates)


def tracking_model(spec: TrackingSpec, merge_metric: str | None = None
                   ) -> tuple[GmPhdModel, GaussianMixture]:
    """Our GM-PHD model of scenario B and its initial intensity."""
    f, qm = cv_matrices(spec.dt, spec.q)
    h = np.zeros((2, 4))
    h[0, 0] = h[1, 1] = 1.0
    bw, bm, bc = tracking_birth(spec, spec.birth_rate)
    model = GmPhdModel(F=f, Q=qm, H=h, R=spec.r_sd ** 2 * np.eye(2), p_s=spec.p_s,
                       birth_weights=bw, birth_means=bm, birth_covs=bc,
                       clutter_intensity=spec.clutter_intensity, prune_threshold=spec.prune,
                       merge_threshold=spec.merge, max_components=spec.j_max,
                       **_rule(merge_metric))
    return model, GaussianMixture(*tracking_birth(spec, float(spec.n_initial)))


def search_model(spec: SearchSpec, merge_metric: str | None = None
                 ) -> tuple[GmPhdModel, GaussianMixture]:
    """Our GM-PHD model of scenario A and its initial intensity (the search prior)."""
    model = GmPhdModel(F=np.eye(2), Q=spec.q * np.eye(2), H=np.eye(2),
                       R=spec.r_sd ** 2 * np.eye(2), p_s=1.0, birth_weights=np.empty(0),
                       birth_means=np.empty((0, 2)), birth_covs=np.empty((0, 2, 2)),
                       clutter_intensity=spec.clutter_intensity, prune_threshold=spec.prune,
                       merge_threshold=spec.merge, max_components=spec.j_max,
                       **_rule(merge_metric))
    return model, GaussianMixture(*search_prior(spec))


def _rule(merge_metric: str | None) -> dict[str, str]:
    """``merge_metric`` as a GmPhdModel keyword, or none for the model's default."""
    return {} if merge_metric is None else {"merge_metric": merge_metric}


#: The merge rules of the GM-PHD model (issue 33).
MERGE_METRICS = ("candidate", "heaviest")


def revisit_model(spec: RevisitSpec, merge_metric: str | None = None
                  ) -> tuple[GmPhdModel, GaussianMixture]:
    """Our GM-PHD model of scenario C (random walk, no births) and its initial intensity.

    The model is A's (:func:`search_model`) with C's values; the prior is a uniform grid.
    """
    model, _ = search_model(spec, merge_metric)
    g = np.arange(spec.prior_spacing / 2, spec.side, spec.prior_spacing)
    means = np.array([[x, y] for y in g for x in g])
    covs = np.repeat((spec.prior_sd ** 2 * np.eye(2))[None], len(means), axis=0)
    return model, GaussianMixture(np.full(len(means), spec.n_targets / len(means)), means,
                                  covs)


def run_revisit(data: ScenarioData, spec: RevisitSpec) -> list[tuple[str, Run]]:
    """Scenario C's rows: p_D at the mean and integrated, under each merge rule."""
    from phd_swarm.core.sensors.fov_detection import DiskFov

    runs = []
    for rule in MERGE_METRICS:
        model, prior = revisit_model(spec, rule)
        for integrate, kind in ((False, "p_D at mean"), (True, "integrated")):
            label = f"GM-PHD {kind}" + ("" if rule is None else f", {rule}")
            runs.append((label, run_ours_gm(data, model, prior,
                                            DiskFov(spec.radius, spec.p_d, integrate=integrate))))
    return runs


def _smc_estimator(spec: TrackingSpec, particles: int, seed: int, log_likelihood,
                   clutter, birth_fraction: float = 0.1):
    """Our SMC-PHD set up as Stone Soup's on B (see :func:`run_ours_smc`)."""
    from phd_swarm.core.estimators.smc_phd.estimator import Resampling, SmcPhdEstimator
    from phd_swarm.core.estimators.smc_phd.filter import ParticleSet
    from phd_swarm.core.estimators.smc_phd.models import constant_p_d as particle_p_d
    from phd_swarm.core.estimators.smc_phd.models import linear_gaussian_transition

    f, qm = cv_matrices(spec.dt, spec.q)
    n_birth = max(1, int(birth_fraction * particles))

    def draw(rng: np.random.Generator, n: int, mass: float) -> ParticleSet:
        states = np.hstack([rng.uniform(0.0, spec.side, (n, 2)),
                            rng.normal(0.0, spec.v_sd, (n, 2))])
        return ParticleSet(np.full(n, mass / n), states, np.zeros(n, dtype=bool))

    rng = np.random.default_rng(seed + 7919)
    return SmcPhdEstimator(
        dim=4, transition=linear_gaussian_transition(f, qm), p_s=spec.p_s,
        log_likelihood=log_likelihood, p_d=particle_p_d(spec.p_d), clutter=clutter,
        birth=lambda g: draw(g, n_birth, spec.birth_rate), rng=rng,
        resampling=Resampling(n=particles), extraction="measurement",
        particles=draw(rng, particles, float(spec.n_initial)))


def run_ours_smc(data: ScenarioData, spec: TrackingSpec, particles: int,
                 seed: int, birth_fraction: float = 0.1) -> Run:
    """Our SMC-PHD on scenario B with the budget and births of the Stone Soup run.

    ``particles`` after each resampling; ``birth_fraction * particles`` birth particles per
    step, positions uniform in the square, velocities N(0, v_sd^2), carrying
    ``spec.birth_rate`` in all; initial: ``particles`` such particles carrying
    ``n_initial``; p_S, p_D, kappa and the CV model of scenario B; extraction per
    measurement (weight above 0.5: the weighted mean position), as on Stone Soup's side.
    Timed: predict + update + resample + extract.
    """
    from phd_swarm.core.estimators.smc_phd.models import linear_gaussian_log_likelihood

    h = np.hstack([np.eye(2), np.zeros((2, 2))])
    ll = linear_gaussian_log_likelihood(h, spec.r_sd ** 2 * np.eye(2))
    est = _smc_estimator(spec, particles, seed, ll, spec.clutter_intensity)
    return run_estimator(est, data, lambda: len(est.particles))


def make_range_bearing(data: ScenarioData, spec: TrackingSpec,
                       rng: np.random.Generator) -> ScenarioData:
    """B's truth measured in range and bearing from the square's centre (see the docstring)."""
    from phd_swarm.core.sensors.range_bearing_model import RangeBearingSensor

    sensor_model = RangeBearingSensor()
    centre = np.full(2, spec.side / 2)
    zs = []
    for truth in data.truth:
        det = truth[rng.random(len(truth)) < spec.p_d]
        clutter = rng.uniform(0.0, spec.side, (rng.poisson(spec.clutter_rate), 2)) - centre
        z = np.vstack([sensor_model.simulate(rng, det, centre),
                       np.column_stack([np.hypot(clutter[:, 0], clutter[:, 1]),
                                        np.arctan2(clutter[:, 1], clutter[:, 0])])])
        zs.append(z[rng.permutation(len(z))])
    return ScenarioData(data.truth, zs, np.tile(centre, (len(zs), 1)))


def run_ours_range_bearing(data: ScenarioData, spec: TrackingSpec, method: str,
                           particles: int, seed: int) -> Run:
    """Our GM-PHD (``method`` "ekf" or "ukf") or SMC-PHD ("smc") on range-bearing B."""
    from gm_phd_nonlinear import RangeBearingMeasurement

    from phd_swarm.core.sensors.range_bearing_model import (
        RangeBearingSensor,
        clutter_density_square,
        range_bearing_log_likelihood,
    )

    sensor_model = RangeBearingSensor()
    if method in ("ekf", "ukf"):
        model, prior = tracking_model(spec)
        measurement = RangeBearingMeasurement(sensor_model, method=method,
                                              clutter_rate=spec.clutter_rate,
                                              clutter_side=spec.side)
        est = GmPhdEstimator(model, mixture=prior, p_d=constant_p_d(spec.p_d),
                             measurement=measurement)
        return run_estimator(est, data, lambda: len(est.mixture))
    est = _smc_estimator(spec, particles, seed, range_bearing_log_likelihood(sensor_model),
                         lambda z, s: clutter_density_square(z, s, spec.side,
                                                             spec.clutter_rate))
    return run_estimator(est, data, lambda: len(est.particles))


# ----------------------------------------------------------------------------- summary


def summarise(scenario: str, impl: str, kind: str, run: Run, data: ScenarioData,
              c: float, p: float, size_kind: str) -> dict[str, object]:
    """One table row: timing percentiles, mean size, OSPA per step and over the last half."""
    d = [ospa(t, e, c=c, p=p) for t, e in zip(data.truth, run.estimates, strict=True)]
    half = len(d) // 2
    ms = np.asarray(run.ms)
    row: dict[str, object] = {
        "scenario": scenario, "implementation": impl, "variant": kind,
        "steps": data.steps, "median_ms": float(np.median(ms)),
        "p95_ms": float(np.percentile(ms, 95)), "size_kind": size_kind,
        "mean_size": float(np.mean(run.sizes)), "ospa_c": c, "ospa_p": p,
        "ospa_last_half": float(np.mean(d[half:])), "ospa_mean": float(np.mean(d)),
        "mean_estimates": float(np.mean([len(e) for e in run.estimates])),
        "mean_targets": float(np.mean([len(t) for t in data.truth])),
        "ms_per_step": [round(v, 4) for v in run.ms], "ospa_per_step": [round(v, 4) for v in d],
    }
    if data.oracle is not None:
        o = [ospa(t, e, c=c, p=p) for t, e in zip(data.truth, data.oracle, strict=True)]
        row["oracle_ospa_last_half"] = float(np.mean(o[half:]))
        row["ospa_above_oracle"] = row["ospa_last_half"] - row["oracle_ospa_last_half"]
    return row


#: The issue's targets: (scenario, our variant) -> (min speed-up, check of the OSPA).
TARGETS = {
    ("B", "GM-PHD"): (20.0, "OSPA <= Stone Soup's"),
    ("A", "GM-PHD integrated p_D"): (10.0, "OSPA within 0.5 m of the oracle"),
    ("smc", "SMC-PHD"): (10.0, "OSPA <= Stone Soup's"),
}


def compare(rows: list[dict[str, object]]) -> None:
    """Add the speed ratio (Stone Soup median / ours) and the target check to our rows.

    The reference of a row is the first Stone Soup row of the same scenario and filter
    family (GM-PHD or SMC-PHD; the first word of the variant).
    """
    for row in rows:
        if row["implementation"] != OURS:
            continue
        family = str(row["variant"]).split()[0]    # GM-PHD or SMC-PHD
        ref = next((r for r in rows if r["scenario"] == row["scenario"]
                    and r["implementation"] != OURS
                    and str(r["variant"]).split()[0] == family), None)
        row["speedup_vs_stonesoup"] = (None if ref is None
                                       else ref["median_ms"] / row["median_ms"])
        target = TARGETS.get((row["scenario"], row["variant"]))
        if target is None:
            continue
        need, how = target
        row["target"] = f">= {need:g}x faster, {how}"
        if row["scenario"] == "A":
            ospa_ok = row["ospa_above_oracle"] <= 0.5
        else:
            ospa_ok = None if ref is None else row["ospa_last_half"] <= ref["ospa_last_half"]
        speed_ok = None if ref is None else row["speedup_vs_stonesoup"] >= need
        row["target_met"] = None if speed_ok is None or ospa_ok is None else speed_ok and ospa_ok


def print_table(rows: list[dict[str, object]]) -> None:
    """The table of the rows, then whether each of the issue's targets is met."""
    head = (f"{'scenario':<8} {'implementation':<16} {'variant':<30} {'median ms':>10} "
            f"{'p95 ms':>9} {'comp/part':>10} {'OSPA 2nd half':>13} {'oracle':>7} "
            f"{'speed-up':>9}")
    print(head)
    print("-" * len(head))
    for r in rows:
        oracle = r.get("oracle_ospa_last_half")
        speed = r.get("speedup_vs_stonesoup")
        print(f"{r['scenario']:<8} {r['implementation']:<16} {r['variant']:<30} "
              f"{r['median_ms']:>10.2f} {r['p95_ms']:>9.2f} {r['mean_size']:>10.1f} "
              f"{r['ospa_last_half']:>13.3f} "
              f"{'' if oracle is None else f'{oracle:.3f}':>7} "
              f"{'' if speed is None else f'{speed:.1f}x':>9}")
    for r in rows:
        if "target" in r:
            met = {True: "met", False: "NOT met", None: "n/a (no Stone Soup run)"}
            print(f"target {r['scenario']} {r['variant']}: {r['target']}: "
                  f"{met[r['target_met']]}")


# -------------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark, print the table and write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: B 20 steps with 10 targets, A 60 steps, C 120 steps, "
                             "2000 particles")
    parser.add_argument("--steps", type=int, help="steps of every scenario (overrides)")
    parser.add_argument("--seed", type=int, default=1, help="scenario seed (default 1)")
    parser.add_argument("--particles", type=int,
                        help="SMC-PHD particle budget (default 20000; quick 2000)")
    parser.add_argument("--only", choices=("B", "A", "C", "smc", "rb"),
                        help="run one scenario only")
    parser.add_argument("--no-stonesoup", action="store_true",
                        help="our side only; Stone Soup is not imported")
    parser.add_argument("--ss-gate", type=float, default=3.0,
                        help="Mahalanobis gate of Stone Soup's GM-PHD hypothesiser "
                             "(default 3, its tutorial's; inf: no gating)")
    parser.add_argument("--merge-metric", choices=("candidate", "heaviest"),
                        help="merge rule of our GM-PHD in A and B (default: GmPhdModel's; "
                             "C runs both)")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args(argv)

    ss = None
    if not args.no_stonesoup:
        try:
            import estimators_stonesoup as ss
        except ImportError as exc:
            print(f"Stone Soup is not importable ({exc}): run `scripts/bench.sh estimators` "
                  "(it installs stonesoup==1.9.1 into .venv-bench) or pass --no-stonesoup",
                  file=sys.stderr)
            return 1

    b_spec = TrackingSpec(steps=20, n_initial=10) if args.quick else TrackingSpec()
    a_spec = SearchSpec(steps=60) if args.quick else SearchSpec()
    c_spec = RevisitSpec(steps=120) if args.quick else RevisitSpec()
    if args.steps is not None:
        b_spec, a_spec = replace(b_spec, steps=args.steps), replace(a_spec, steps=args.steps)
        c_spec = replace(c_spec, steps=args.steps)
    particles = args.particles or (2000 if args.quick else 20000)
    wanted = ("B", "A", "C", "smc", "rb") if args.only is None else (args.only,)
    rows: list[dict[str, object]] = []

    if "B" in wanted or "smc" in wanted or "rb" in wanted:
        b_data = make_tracking(b_spec, np.random.default_rng(args.seed))
        c, p = b_spec.ospa_c, b_spec.ospa_p
    if "B" in wanted:
        model, prior = tracking_model(b_spec, args.merge_metric)
        run = run_ours_gm(b_data, model, prior, constant_p_d(b_spec.p_d))
        rows.append(summarise("B", OURS, "GM-PHD", run, b_data, c, p, "components"))
        if ss is not None:
            rows.append(summarise("B", STONESOUP, f"GM-PHD gate {args.ss_gate:g}",
                                  Run(**ss.run_gm_tracking(
                                      b_data, b_spec, tracking_birth(b_spec, b_spec.n_initial),
                                      tracking_birth(b_spec, b_spec.birth_rate),
                                      gate=args.ss_gate)),
                                  b_data, c, p,
                                  "components"))
    if "A" in wanted:
        a_data = make_search(a_spec, np.random.default_rng(args.seed))
        c, p = a_spec.ospa_c, a_spec.ospa_p
        model, prior = search_model(a_spec, args.merge_metric)
        for kind, label in (("mean", "GM-PHD p_D at mean"),
                            ("integrated", "GM-PHD integrated p_D")):
            rows.append(summarise("A", OURS, label,
                                  run_ours_gm(a_data, model, prior, our_a_pd(kind, a_spec)),
                                  a_data, c, p, "components"))
        if ss is not None:
            rows.append(summarise("A", STONESOUP, f"GM-PHD p_D at mean gate {args.ss_gate:g}",
                                  Run(**ss.run_gm_search(a_data, a_spec, search_prior(a_spec),
                                                         gate=args.ss_gate)),
                                  a_data, c, p,
                                  "components"))
    if "C" in wanted:
        c_data = make_revisit(c_spec, np.random.default_rng(args.seed))
        for label, run in run_revisit(c_data, c_spec):
            rows.append(summarise("C", OURS, label, run, c_data, c_spec.ospa_c, c_spec.ospa_p,
                                  "components"))
    if "smc" in wanted:
        rows.append(summarise("smc", OURS, "SMC-PHD",
                              run_ours_smc(b_data, b_spec, particles, args.seed), b_data,
                              b_spec.ospa_c, b_spec.ospa_p, "particles"))
        if ss is not None:
            for exact, label in ((False, "SMC-PHD"), (True, "SMC-PHD exact likelihood")):
                rows.append(summarise("smc", STONESOUP, label,
                                      Run(**ss.run_smc_tracking(b_data, b_spec, particles,
                                                                args.seed,
                                                                exact_likelihood=exact)),
                                      b_data, b_spec.ospa_c, b_spec.ospa_p, "particles"))
    if "rb" in wanted:
        rb_data = make_range_bearing(b_data, b_spec, np.random.default_rng(args.seed + 1))
        for method, label, size_kind in (("ekf", "GM-PHD EKF", "components"),
                                         ("ukf", "GM-PHD UKF", "components"),
                                         ("smc", "SMC-PHD", "particles")):
            rows.append(summarise("B-rb", OURS, label,
                                  run_ours_range_bearing(rb_data, b_spec, method, particles,
                                                         args.seed),
                                  rb_data, b_spec.ospa_c, b_spec.ospa_p, size_kind))
        if ss is not None:
            from phd_swarm.core.sensors.range_bearing_model import RangeBearingSensor

            sensor_model = RangeBearingSensor()
            noise_sd = (sensor_model.zeta0, sensor_model.beta_zeta, sensor_model.phi0,
                        sensor_model.beta_phi)
            for exact, label in ((False, "SMC-PHD"), (True, "SMC-PHD exact likelihood")):
                rows.append(summarise("B-rb", STONESOUP, label,
                                      Run(**ss.run_smc_range_bearing(
                                          rb_data, b_spec, particles, args.seed, noise_sd,
                                          exact_likelihood=exact)),
                                      rb_data, b_spec.ospa_c, b_spec.ospa_p, "particles"))

    compare(rows)
    extra: dict[str, object] = {"seed": args.seed, "quick": args.quick,
                                "merge_metric": args.merge_metric or "model default",
                                "stonesoup_gate": args.ss_gate,
                                "particles": particles, "tracking_spec": asdict(b_spec),
                                "search_spec": asdict(a_spec),
                                "revisit_spec": asdict(c_spec)}
    if ss is not None:
        extra["stonesoup"] = ss.version()
    meta = machine_meta(**extra)
    print(f"estimators benchmark {meta['date']} ({meta['cpus']} cpus, {meta['machine']}, "
          f"seed {args.seed}{', quick' if args.quick else ''})")
    print_table(rows)
    write_results(args.out, "estimators", meta, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
