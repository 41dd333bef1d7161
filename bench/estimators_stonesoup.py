"""Stone Soup side of the estimators benchmark (``bench/estimators.py``).

Imported only when Stone Soup is installed: ``scripts/bench.sh estimators`` installs the
pinned stonesoup==1.9.1 into the benchmark-only environment .venv-bench
(``scripts/bench_stonesoup_setup.sh``); nothing of phd_swarm imports this module.

The pieces are those of Stone Soup's GM-PHD tutorial, with the benchmark's models:

- GM-PHD: ``KalmanPredictor`` / ``KalmanUpdater`` under a ``DistanceHypothesiser``
  (Mahalanobis gate ``gate``: 3 in Stone Soup's GM-PHD tutorial and by default here, which
  spares the PHD update of the far pairs; ``inf`` = no gating, every component meets every
  measurement as in our filter, several times slower), wrapped by ``GaussianMixtureHypothesiser``
  (``order_by_detection=True``, what ``PHDUpdater`` expects); ``PHDUpdater`` (p_D, p_S and
  the clutter density kappa); ``GaussianMixtureReducer`` (prune T, merge U, truncate at
  J_max). Births: ``TaggedWeightedGaussianState`` components tagged "birth", re-added at
  the current time every step. State order is Stone Soup's [x, vx, y, vy].
- Scenario A: the same with :class:`MeanGatedPHDUpdater`, a ``PHDUpdater`` whose p_D is
  evaluated per component at its (predicted) mean: p_inside within the FoV radius of the
  sensor, else 0. Stone Soup 1.9.1's ``PHDUpdater`` has one scalar ``prob_detection``.
- SMC-PHD: ``SMCPHDPredictor`` (expansion births from a ``ParticleSampler``) and
  ``SMCPHDUpdater`` with a ``SystematicResampler`` back to the particle budget, driven by a
  ``SimpleHypothesiser`` as in ``SMCPHDInitiator``.
- SMC-PHD on range-bearing B: the same, measured by :class:`RangeDependentBearingRange`, a
  ``CartesianToBearingRange`` whose likelihood uses the noise sds at each particle's range
  (Stone Soup 1.9.1's model has one fixed noise covariance), with the clutter intensity
  ``lambda r / A`` per detection (:class:`_PolarClutterSMCPHDUpdater`; its ``SMCPHDUpdater``
  takes one scalar).

Where Stone Soup 1.9.1 differs from Vo & Ma (and from ours), by design of its classes:
``PHDUpdater`` drops the missed-detection terms of birth components; the reducer caps a
merged component's weight at 1, merges pairwise against the running merged component, and
spreads the pruned and truncated weight over the remaining components.

Each ``run_*`` returns ``{"ms": [...], "sizes": [...], "estimates": [(N_k, 2) arrays]}``;
the timed part of a step is hypothesise (which predicts) + update + reduce (or resample)
+ extraction. Building the ``Detection`` objects from the shared measurement arrays is not
timed (our side's ``Scan`` construction is not either).
"""

from __future__ import annotations

import math
import time
from datetime import datetime, timedelta

import numpy as np
import stonesoup
from scipy.special import logsumexp
from scipy.stats import multivariate_normal
from stonesoup.base import Property
from stonesoup.hypothesiser.distance import DistanceHypothesiser
from stonesoup.hypothesiser.gaussianmixture import GaussianMixtureHypothesiser
from stonesoup.hypothesiser.simple import SimpleHypothesiser
from stonesoup.measures import Mahalanobis
from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer
from stonesoup.models.measurement.linear import LinearGaussian
from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
from stonesoup.models.transition.linear import (
    CombinedLinearGaussianTransitionModel,
    ConstantVelocity,
    RandomWalk,
)
from stonesoup.predictor.kalman import KalmanPredictor
from stonesoup.predictor.particle import SMCPHDPredictor
from stonesoup.resampler.particle import SystematicResampler
from stonesoup.sampler.particle import ParticleSampler
from stonesoup.types.angle import Bearing
from stonesoup.types.array import StateVector, StateVectors
from stonesoup.types.detection import Detection
from stonesoup.types.state import ParticleState, TaggedWeightedGaussianState
from stonesoup.types.update import GaussianMixtureUpdate
from stonesoup.updater.kalman import KalmanUpdater
from stonesoup.updater.particle import SMCPHDUpdater
from stonesoup.updater.pointprocess import PHDUpdater

T0 = datetime(2024, 1, 1)


def version() -> str:
    """The installed Stone Soup version."""
    return stonesoup.__version__


class MeanGatedPHDUpdater(PHDUpdater):
    """``PHDUpdater`` with p_D evaluated at each component's mean against a disk FoV.

    ``PointProcessUpdater.update`` of Stone Soup 1.9.1, with ``prob_detection`` replaced by
    p_D(component mean): ``p_inside`` if the mean's position (state indices ``position``)
    is within ``radius`` of ``sensor``, else 0. Set ``sensor`` before each update.
    """

    radius: float = Property(doc="FoV radius [m]")
    p_inside: float = Property(doc="p_D inside the FoV")
    position: tuple = Property(default=(0, 1), doc="state indices of x and y")
    sensor: np.ndarray = Property(default=None, doc="sensor position (2,) [m] of this scan")

    def _p_d(self, state) -> float:
        m = state.state_vector
        dx = float(m[self.position[0], 0]) - float(self.sensor[0])
        dy = float(m[self.position[1], 0]) - float(self.sensor[1])
        return self.p_inside if math.hypot(dx, dy) <= self.radius else 0.0

    def update(self, hypotheses):
        """The PHD update of ``hypotheses`` (ordered by detection, missed last)."""
        updated_components = []
        for multi_hypothesis in hypotheses[:-1]:
            updated_measurement_components = []
            weight_sum = 0
            for hypothesis in multi_hypothesis:
                measurement_prediction = self.updater.predict_measurement(
                    hypothesis.prediction, hypothesis.measurement.measurement_model)
                measurement = hypothesis.measurement
                prediction = hypothesis.prediction
                q = multivariate_normal.pdf(measurement.state_vector.flatten(),
                                            mean=measurement_prediction.mean.flatten(),
                                            cov=measurement_prediction.covar)
                new_weight = self._p_d(prediction) * prediction.weight * q
                if prediction.tag != "birth":
                    new_weight *= self.prob_survival
                weight_sum += new_weight
                temp = self.updater.update(hypothesis)
                updated_measurement_components.append(TaggedWeightedGaussianState(
                    tag=prediction.tag if prediction.tag != "birth" else None,
                    weight=new_weight, state_vector=temp.mean, covar=temp.covar,
                    timestamp=temp.timestamp))
            for component in updated_measurement_components:
                if self.normalisation:
                    component.weight /= (weight_sum + self.clutter_spatial_density)
                updated_components.append(component)
        for missed in hypotheses[-1]:
            prediction = missed.prediction
            if prediction.tag != "birth":
                updated_components.append(TaggedWeightedGaussianState(
                    tag=prediction.tag,
                    weight=prediction.weight * (1 - self._p_d(prediction)) * self.prob_survival,
                    state_vector=prediction.mean, covar=prediction.covar,
                    timestamp=prediction.timestamp))
        for component in updated_components:
            if component.weight == 0:
                component.weight = np.finfo(float).eps
        return GaussianMixtureUpdate(hypothesis=hypotheses, components=updated_components)


def _gm_components(weights, means, covs, tag: str | None, timestamp, order) -> list:
    """TaggedWeightedGaussianState components from our arrays, state reordered by ``order``."""
    out = []
    for w, m, p in zip(weights, means, covs, strict=True):
        kw = {} if tag is None else {"tag": tag}
        out.append(TaggedWeightedGaussianState(
            StateVector(m[order]), p[np.ix_(order, order)], weight=float(w),
            timestamp=timestamp, **kw))
    return out


def _extract(components, position) -> np.ndarray:
    """round(w) copies of the position of each component of weight > 0.5 (Vo & Ma Table III)."""
    est = []
    for c in components:
        w = float(c.weight)
        if w > 0.5:
            pos = [float(c.state_vector[position[0], 0]), float(c.state_vector[position[1], 0])]
            est += [pos] * int(math.floor(w + 0.5))
    return np.asarray(est, dtype=float).reshape(-1, 2)


def _run_gm(data, dt, transition, measurement_model, phd_updater, reducer, initial,
            births, order, position, gate, before_update=None) -> dict:
    hypothesiser = GaussianMixtureHypothesiser(
        DistanceHypothesiser(KalmanPredictor(transition), KalmanUpdater(measurement_model),
                             Mahalanobis(), missed_distance=float(gate)),
        order_by_detection=True)
    comps = _gm_components(*initial, tag=None, timestamp=T0 - timedelta(seconds=dt),
                           order=order)
    ms, sizes, estimates = [], [], []
    for k in range(data.steps):
        now = T0 + timedelta(seconds=k * dt)
        detections = {Detection(StateVector(z), timestamp=now,
                                measurement_model=measurement_model) for z in data.z[k]}
        if before_update is not None:
            before_update(k)
        t0 = time.perf_counter()
        current = comps + _gm_components(*births, tag="birth", timestamp=now, order=order)
        hypotheses = hypothesiser.hypothesise(current, detections, timestamp=now)
        updated = phd_updater.update(hypotheses)
        comps = list(reducer.reduce(list(updated.components)))
        x = _extract(comps, position)
        ms.append((time.perf_counter() - t0) * 1e3)
        sizes.append(len(comps))
        estimates.append(x)
    return {"ms": ms, "sizes": sizes, "estimates": estimates}


def run_gm_tracking(data, spec, initial, births, gate: float = 3.0) -> dict:
    """Stone Soup's GM-PHD on scenario B (``spec``: estimators.TrackingSpec).

    ``initial`` and ``births``: (weights, means, covs) in our state order [x, y, vx, vy];
    ``gate``: Mahalanobis gate of the hypothesiser (``inf``: none).
    """
    transition = CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(spec.q), ConstantVelocity(spec.q)])
    mm = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=spec.r_sd ** 2 * np.eye(2))
    updater = PHDUpdater(KalmanUpdater(mm), clutter_spatial_density=spec.clutter_intensity,
                         prob_detection=spec.p_d, prob_survival=spec.p_s)
    reducer = GaussianMixtureReducer(prune_threshold=spec.prune, merge_threshold=spec.merge,
                                     max_number_components=spec.j_max)
    order = np.array([0, 2, 1, 3])  # ours [x, y, vx, vy] -> Stone Soup [x, vx, y, vy]
    return _run_gm(data, spec.dt, transition, mm, updater, reducer, initial, births, order,
                   (0, 2), gate)


def run_gm_search(data, spec, prior, gate: float = 3.0) -> dict:
    """Stone Soup's GM-PHD on scenario A with p_D gated at the component mean.

    ``prior``: the initial intensity (weights, means, covs) over [x, y]; ``gate``: as
    :func:`run_gm_tracking`.
    """
    transition = CombinedLinearGaussianTransitionModel([RandomWalk(spec.q), RandomWalk(spec.q)])
    mm = LinearGaussian(ndim_state=2, mapping=(0, 1), noise_covar=spec.r_sd ** 2 * np.eye(2))
    updater = MeanGatedPHDUpdater(KalmanUpdater(mm),
                                  clutter_spatial_density=spec.clutter_intensity,
                                  prob_survival=1.0, radius=spec.radius, p_inside=spec.p_d)
    reducer = GaussianMixtureReducer(prune_threshold=spec.prune, merge_threshold=spec.merge,
                                     max_number_components=spec.j_max)

    def set_sensor(k: int) -> None:
        updater.sensor = data.sensor[k]

    empty = (np.empty(0), np.empty((0, 2)), np.empty((0, 2, 2)))
    return _run_gm(data, 1.0, transition, mm, updater, reducer, prior, empty,
                   np.array([0, 1]), (0, 1), gate, before_update=set_sensor)


class _SMCPHDUpdater(SMCPHDUpdater):
    """``SMCPHDUpdater`` keeping its per-hypothesis log weights for the extraction."""

    def get_log_weights_per_hypothesis(self, hypotheses):
        self.last_log_weights = super().get_log_weights_per_hypothesis(hypotheses)
        return self.last_log_weights


class _ExactSMCPHDUpdater(_SMCPHDUpdater):
    """``SMCPHDUpdater`` with the likelihood g(z | x) evaluated without noise.

    Stone Soup 1.9.1 evaluates ``measurement_model.logpdf(detection, prediction,
    noise=True)``, and ``noise=True`` makes the model's ``function`` add a fresh random
    measurement-noise draw to every particle's predicted measurement: g(z | x) becomes
    N(z; H x + v, R) with v ~ N(0, R), a randomly jittered and on average broadened
    likelihood, not the one of Vo et al. (2005). This subclass evaluates N(z; H x, R).
    """

    def _get_measurement_loglikelihoods(self, prediction, detections):
        g = np.zeros((prediction.state_vector.shape[1], len(detections)))
        for i, detection in enumerate(detections):
            model = self._check_measurement_model(detection.measurement_model)
            g[:, i] = model.logpdf(detection, prediction, noise=False)
        return g


def _run_smc(data, spec, particles: int, seed: int, measurement_model, updater,
             detection_vector, birth_fraction: float) -> dict:
    """Stone Soup's SMC-PHD over ``data`` with ``updater`` (an :class:`_SMCPHDUpdater`).

    Births, initial particles, CV transition and extraction of :func:`run_smc_tracking`;
    ``detection_vector(z)``: the Stone Soup measurement vector of our measurement row z.
    """
    rng = np.random.default_rng(seed + 7919)
    np.random.seed(seed)  # Stone Soup's transition noise and resampler draw from np.random

    def sample(num_samples: int) -> np.ndarray:
        n = int(num_samples)
        return np.vstack([rng.uniform(0.0, spec.side, n), rng.normal(0.0, spec.v_sd, n),
                          rng.uniform(0.0, spec.side, n), rng.normal(0.0, spec.v_sd, n)])

    transition = CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(spec.q), ConstantVelocity(spec.q)])
    predictor = SMCPHDPredictor(
        transition_model=transition, death_probability=-math.log(spec.p_s),
        birth_probability=birth_fraction, birth_rate=spec.birth_rate,
        birth_sampler=ParticleSampler(distribution_func=sample, params={"num_samples": 1},
                                      ndim_state=4),
        birth_scheme="expansion")
    hypothesiser = SimpleHypothesiser(predictor=predictor)
    state = ParticleState(StateVectors(sample(particles)),
                          log_weight=np.full(particles, math.log(spec.n_initial / particles)),
                          timestamp=T0 - timedelta(seconds=spec.dt))
    ms, sizes, estimates = [], [], []
    for k in range(data.steps):
        now = T0 + timedelta(seconds=k * spec.dt)
        detections = {Detection(detection_vector(z), timestamp=now,
                                measurement_model=measurement_model) for z in data.z[k]}
        t0 = time.perf_counter()
        hypotheses = hypothesiser.hypothesise(state, detections, timestamp=now)
        hypotheses.single_hypotheses.sort(key=bool)  # missed detection first
        state = updater.update(hypotheses)
        lw = updater.last_log_weights[:, 1:]          # (particles predicted, M)
        pos = np.asarray(hypotheses[0].prediction.state_vector, dtype=float)[[0, 2]]
        est = []
        if lw.shape[1]:
            total = logsumexp(lw, axis=0)
            for j in np.flatnonzero(np.exp(total) > 0.5):
                w = np.exp(lw[:, j] - total[j])
                est += [pos @ w] * int(math.floor(math.exp(total[j]) + 0.5))
        x = np.asarray(est, dtype=float).reshape(-1, 2)
        ms.append((time.perf_counter() - t0) * 1e3)
        sizes.append(len(state))
        estimates.append(x)
    return {"ms": ms, "sizes": sizes, "estimates": estimates}


def run_smc_tracking(data, spec, particles: int, seed: int,
                     birth_fraction: float = 0.1, exact_likelihood: bool = False) -> dict:
    """Stone Soup's SMC-PHD on scenario B with a budget of ``particles`` particles.

    ``exact_likelihood``: the updater evaluates g(z | x) without the random noise Stone
    Soup 1.9.1 adds to it (:class:`_ExactSMCPHDUpdater`).

    Expansion births: ``birth_fraction * particles`` uniform particles per step carrying
    ``spec.birth_rate`` in all; resampled back to ``particles`` after each update.
    Extraction: for each measurement, the weight it claims; above 0.5, the weighted mean
    position of the particles (round(weight) copies).
    """
    mm = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=spec.r_sd ** 2 * np.eye(2))
    updater_class = _ExactSMCPHDUpdater if exact_likelihood else _SMCPHDUpdater
    updater = updater_class(measurement_model=mm, prob_detect=spec.p_d,
                            clutter_intensity=spec.clutter_intensity, num_samples=particles,
                            resampler=SystematicResampler())
    return _run_smc(data, spec, particles, seed, mm, updater, StateVector, birth_fraction)


class RangeDependentBearingRange(CartesianToBearingRange):
    """``CartesianToBearingRange`` whose noise sds grow with each particle's range.

    Our scenario's sensor (Papaioannou Sec. VI-A, ``phd_swarm.core.sensors.range_bearing_model``)
    has g(z | x) = N(z; h(x), diag(sigma_phi(r)^2, sigma_r(r)^2)) with
    ``sigma_r = zeta0 + beta_zeta r``, ``sigma_phi = phi0 + beta_phi r`` at the target's
    range r = ||p - s||. Stone Soup 1.9.1's ``CartesianToBearingRange`` has a single noise
    covariance (``noise_covar``; ``covar()`` takes no state), so it cannot express that. This
    subclass keeps its measurement function h (Stone Soup's order: bearing, range; bearing
    of the target from ``translation_offset``) and replaces the noise:

    - ``logpdf(detection, state)``: per particle, the diagonal Gaussian with the sds at that
      particle's noise-free range, of (z - h(x)) with the bearing difference wrapped to
      [-pi, pi) (``Bearing.mod_angle``, as the parent does);
    - ``function(state, noise=True)`` (used by ``logpdf(..., noise=True)``, which is what
      Stone Soup's ``SMCPHDUpdater`` calls): adds a noise draw per particle with the sds at
      that particle's range (from ``np.random``, as the parent's ``rvs``).

    ``noise_covar`` (what ``covar()`` and ``rvs()`` still return / draw from) is the
    covariance at zero range; the particle filter does not use it.
    """

    zeta0: float = Property(default=1.0, doc="range sd at zero range [m]")
    beta_zeta: float = Property(default=5e-5, doc="growth of the range sd [m/m]")
    phi0: float = Property(default=math.pi / 180.0, doc="bearing sd at zero range [rad]")
    beta_phi: float = Property(default=1e-5, doc="growth of the bearing sd [rad/m]")

    def _sd(self, rho) -> np.ndarray:
        """Noise sds (2, N): bearing, range, at the ranges ``rho`` (N,)."""
        rho = np.asarray(rho, dtype=float)
        return np.vstack([self.phi0 + self.beta_phi * rho, self.zeta0 + self.beta_zeta * rho])

    def _function(self, state, noise=False, **kwargs):
        clean = super()._function(state, noise=False, **kwargs)       # (2, N) [phi; rho]
        if noise is True:
            noise = self._sd(clean[1]) * np.random.standard_normal(clean.shape)
        elif noise is False or noise is None:
            return clean
        return clean + noise

    def logpdf(self, state1, state2, noise=False, **kwargs):
        """Log-likelihood of ``state1`` given each particle of ``state2`` (sds at its range)."""
        clean = super()._function(state2, noise=False, **kwargs)
        sd = self._sd(clean[1])
        pred = clean if noise is False or noise is None else (
            clean + (sd * np.random.standard_normal(clean.shape) if noise is True else noise))
        v = np.asarray(state1.state_vector.astype(np.float64)) - np.asarray(pred, dtype=float)
        v[0] = Bearing.mod_angle(v[0])
        likelihood = np.atleast_1d(-0.5 * np.sum((v / sd) ** 2, axis=0)
                                   - np.log(2.0 * np.pi * sd[0] * sd[1]))
        return likelihood[0] if len(likelihood) == 1 else likelihood


class _PolarClutterSMCPHDUpdater(_SMCPHDUpdater):
    """``SMCPHDUpdater`` with the clutter intensity evaluated at each detection.

    Clutter uniform over the square of side ``side`` centred on the sensor, measured
    without noise in (bearing, range): intensity ``clutter_rate * r / side^2`` inside the
    square (r >= 0), else 0 [1/(m rad)]. Stone Soup 1.9.1's updater takes one scalar
    ``clutter_intensity``; its update uses ``log(clutter_intensity)`` broadcast against the
    per-detection sums, so this sets it to the (M,) array of the detections, in the order
    the update takes them, before each update.
    """

    clutter_rate: float = Property(default=10.0, doc="expected clutter points per scan")
    side: float = Property(default=200.0, doc="side of the clutter square [m]")

    def get_log_weights_per_hypothesis(self, hypotheses):
        z = np.array([np.asarray(h.measurement.state_vector, dtype=float).ravel()
                      for h in hypotheses if h]).reshape(-1, 2)   # (M, 2): bearing, range
        phi, r = z[:, 0], z[:, 1]
        half = 0.5 * self.side
        inside = ((r >= 0.0) & (np.abs(r * np.cos(phi)) <= half)
                  & (np.abs(r * np.sin(phi)) <= half))
        self.clutter_intensity = np.where(inside, self.clutter_rate * r / self.side ** 2, 0.0)
        with np.errstate(divide="ignore"):   # log(0) = -inf outside the square: no clutter
            return super().get_log_weights_per_hypothesis(hypotheses)


class _ExactPolarClutterSMCPHDUpdater(_PolarClutterSMCPHDUpdater, _ExactSMCPHDUpdater):
    """The polar-clutter updater with the exact likelihood of :class:`_ExactSMCPHDUpdater`."""


def run_smc_range_bearing(data, spec, particles: int, seed: int, noise_sd: tuple,
                          birth_fraction: float = 0.1, exact_likelihood: bool = False) -> dict:
    """Stone Soup's SMC-PHD on range-bearing B (``data``: estimators.make_range_bearing).

    As :func:`run_smc_tracking` (budget, births, initial particles, CV model, p_S, p_D,
    extraction), with :class:`RangeDependentBearingRange` (``noise_sd``: zeta0, beta_zeta,
    phi0, beta_phi) from the sensor position (fixed; the square's centre) and the clutter
    intensity ``lambda r / A`` of :class:`_PolarClutterSMCPHDUpdater`. Our measurement rows
    (range, bearing) become Stone Soup's (bearing, range) vectors, the bearing a
    ``Bearing`` (wrapped to [-pi, pi)). ``exact_likelihood``: as in
    :func:`run_smc_tracking`.
    """
    sensor = np.asarray(data.sensor[0], dtype=float)
    if not np.allclose(data.sensor, sensor):
        raise ValueError("run_smc_range_bearing needs a fixed sensor")
    zeta0, beta_zeta, phi0, beta_phi = (float(v) for v in noise_sd)
    mm = RangeDependentBearingRange(
        ndim_state=4, mapping=(0, 2), noise_covar=np.diag([phi0 ** 2, zeta0 ** 2]),
        translation_offset=StateVector(sensor), zeta0=zeta0, beta_zeta=beta_zeta, phi0=phi0,
        beta_phi=beta_phi)
    updater_class = (_ExactPolarClutterSMCPHDUpdater if exact_likelihood
                     else _PolarClutterSMCPHDUpdater)
    updater = updater_class(measurement_model=mm, prob_detect=spec.p_d,
                            clutter_intensity=spec.clutter_intensity, num_samples=particles,
                            resampler=SystematicResampler(), clutter_rate=spec.clutter_rate,
                            side=spec.side)

    def detection_vector(z) -> StateVector:
        return StateVector([Bearing(float(z[1])), float(z[0])])

    return _run_smc(data, spec, particles, seed, mm, updater, detection_vector, birth_fraction)
