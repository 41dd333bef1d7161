"""The particle PHD filter as an estimator (:class:`.base.Estimator`): one robot's particles.

Each step: :meth:`SmcPhdEstimator.predict` (motion, survival, the births: a fixed birth
sampler, or the newborns the last scan proposed under :class:`MeasurementBirth`), then
:meth:`SmcPhdEstimator.update` with a scan, in two stages an owner may also call apart:
:meth:`SmcPhdEstimator.update_weights` (the births the scan brings under :class:`ScanBirth`,
the update of :mod:`.smc_phd.filter`, the next births) and :meth:`SmcPhdEstimator.resample`
(resampling, and the roughening of :class:`Resampling`). The equations are in
:mod:`.smc_phd.filter`, the models in :mod:`.smc_phd.models`.

A system's estimator composes it: Papaioannou et al.'s ``papaioannou_sat``
(:mod:`phd_swarm.core.estimators.papaioannou.estimator`) holds one, gives it the paper's
models and births, and reads each update (:attr:`SmcPhdEstimator.last_update`) for its own
extraction between the two stages.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ...checks import (
    check_generator,
    check_nonnegative,
    check_positive_int,
    check_probability,
)
from ...scan import Scan
from ..base import Estimator
from .filter import (
    BirthSampler,
    ParticleSet,
    SmcUpdateResult,
    StateSampler,
    Transition,
    extract,
    extract_by_measurement,
    particle_count,
    predict,
    resample,
    update,
)
from .models import measurement_birth

#: Birth sampler of a scan: (rng, z (M, m), sensor (2,)) -> the births its update weighs.
ScanBirthSampler = Callable[[np.random.Generator, np.ndarray, np.ndarray], ParticleSet]


@dataclass(frozen=True)
class MeasurementBirth:
    """Settings of the measurement-driven birth (Ristic et al. 2012).

    Attributes
    ----------
    expected_births : float
        nu_B, expected number of births per step [-], >= 0.
    sample_state : callable
        b(x | z) sampler, ``sample_state(rng, z (M, 2), n) -> (M * n, d)``.
    n_per_measurement : int
        Particles per measurement, >= 1.
    """

    expected_births: float
    sample_state: StateSampler
    n_per_measurement: int = 500

    def __post_init__(self) -> None:
        object.__setattr__(self, "expected_births",
                           check_nonnegative("expected_births", self.expected_births))
        if not callable(self.sample_state):
            raise ValueError("sample_state must be callable")
        object.__setattr__(self, "n_per_measurement",
                           check_positive_int("n_per_measurement", self.n_per_measurement))


@dataclass(frozen=True)
class ScanBirth:
    """Births drawn with each scan and updated by it: the birth intensity b_k of step k.

    For a birth intensity that depends on where the sensor is or on what it measured: each
    update first draws the births, ``sample(rng, z, sensor)``, and appends them to the
    predicted particles, so the scan weighs them with the others (e.g. Papaioannou et al.
    Sec. VI-A: births inside the agent's sensing area, whose particles may be drawn near the
    measurements and importance-weighted). Nothing is born at the prediction.

    Attributes
    ----------
    sample : callable
        ``sample(rng, z (M, m), sensor (2,)) -> ParticleSet`` of the state's dimension, or
        an empty one.
    """

    sample: ScanBirthSampler

    def __post_init__(self) -> None:
        if not callable(self.sample):
            raise ValueError("sample must be callable")


@dataclass(frozen=True)
class Resampling:
    """Particle count after each update (:func:`particle_count`).

    Attributes
    ----------
    n : int or None
        Fixed number of particles.
    per_target : int or None
        Particles per expected target; 1000 when ``n`` is not given either.
    min_particles, max_particles : int or None
        Bounds on ``per_target * round(mass)``; ``per_target`` and no cap by default.
    roughening : float
        Sd of a Gaussian jitter added to every coordinate of every resampled particle
        [state units: m, m/s], >= 0; 0 (the default): none. Regularisation (Musso, Oudjane
        & Le Gland 2001): copies of one particle are moved apart, so that a cloud a precise
        measurement squeezed keeps particles where the next one may fall.
    """

    n: int | None = None
    per_target: int | None = None
    min_particles: int | None = None
    max_particles: int | None = None
    roughening: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "roughening", check_nonnegative("roughening",
                                                                 self.roughening))
        if self.n is not None and self.per_target is not None:
            raise ValueError("resampling needs exactly one of n and per_target")
        if self.n is None and self.per_target is None:
            object.__setattr__(self, "per_target", 1000)
        particle_count(1.0, self.n, self.per_target, self.min_particles, self.max_particles)


class SmcPhdEstimator(Estimator):
    """Particle PHD filter as an estimator: predict, update, resample after each update.

    The state's first two coordinates are the target position [m] (world frame) and the
    measurement space is 2-D (a scan's z).

    Randomness: every draw comes from ``rng``, in this order: the prediction's (motion,
    then a fixed sampler's births), then each update's (the births of a :class:`ScanBirth`,
    the next births of a :class:`MeasurementBirth`, resampling, roughening). Extraction
    draws too (resampling to ``max_points``, k-means++ seeding); so that calling
    :meth:`estimates` neither changes the filter's later draws nor gives different answers
    on repeated calls, each update ends by drawing one seed from ``rng`` for the extraction
    of its posterior (and the constructor one for the initial particles), except under
    ``extraction="measurement_only"``, which draws nothing.

    Parameters
    ----------
    dim : int
        State dimension d >= 2.
    transition : callable
        ``transition(rng, states (N, d)) -> (N, d)``, e.g. :func:`linear_gaussian_transition`.
    p_s : float or callable
        Survival probability [-] or ``p_s(states) -> (N,)``.
    log_likelihood : callable
        ``log_likelihood(z (M, 2), states (N, d), sensor (2,)) -> (M, N)``, e.g.
        :func:`linear_gaussian_log_likelihood`.
    p_d : callable
        ``p_d(states (N, d), sensor (2,)) -> (N,)`` for a scan taken at ``sensor``, e.g.
        :func:`constant_p_d`.
    clutter : float or callable
        kappa [1/m^2], or ``clutter(z (M, 2), sensor (2,)) -> (M,)``.
    birth : callable, MeasurementBirth or ScanBirth
        A fixed birth sampler ``birth(rng) -> ParticleSet`` (:func:`gaussian_birth`),
        entering at each prediction; the measurement-driven birth: births from the scan of
        step k enter at the prediction to k+1; or births drawn with each scan and weighed
        by it (:class:`ScanBirth`).
    rng : np.random.Generator
        Source of all randomness.
    resampling : Resampling
        Particle count after each update; 1000 per expected target by default.
    extraction : {"kmeans", "measurement", "measurement_only"}
        :func:`extract` on the posterior particles, or :func:`extract_by_measurement` on
        the last update (k-means if there was none, e.g. after :meth:`import_state`; with
        ``measurement_only`` none, and no draws for the extraction).
    particles : ParticleSet, optional
        Initial intensity; empty by default.
    """

    def __init__(self, *, dim: int, transition: Transition,
                 p_s: float | Callable[[np.ndarray], np.ndarray],
                 log_likelihood: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
                 p_d: Callable[[np.ndarray, np.ndarray], np.ndarray],
                 clutter: float | Callable[[np.ndarray, np.ndarray], np.ndarray],
                 birth: BirthSampler | MeasurementBirth | ScanBirth,
                 rng: np.random.Generator, resampling: Resampling | None = None,
                 extraction: Literal["kmeans", "measurement", "measurement_only"] = "kmeans",
                 particles: ParticleSet | None = None) -> None:
        self.dim = check_positive_int("dim", dim, minimum=2)
        self.rng = check_generator(rng)
        if not callable(p_s):
            check_probability("p_s", np.asarray(p_s, dtype=float))
        if not callable(clutter):
            c = float(clutter)
            if not np.isfinite(c) or c < 0.0:
                raise ValueError(f"clutter must be finite and >= 0, got {clutter!r}")
        if not (callable(birth) or isinstance(birth, (MeasurementBirth, ScanBirth))):
            raise ValueError("birth must be a sampler birth(rng) -> ParticleSet, a "
                             "MeasurementBirth or a ScanBirth")
        if extraction not in ("kmeans", "measurement", "measurement_only"):
            raise ValueError(f"extraction must be 'kmeans', 'measurement' or "
                             f"'measurement_only', got {extraction!r}")
        self.transition, self.p_s, self.log_likelihood = transition, p_s, log_likelihood
        self.p_d, self.clutter, self.birth = p_d, clutter, birth
        self.resampling = Resampling() if resampling is None else resampling
        self.extraction = extraction
        self.particles = ParticleSet.empty(self.dim) if particles is None else particles
        if self.particles.dim != self.dim:
            raise ValueError(f"particles have dimension {self.particles.dim}, expected "
                             f"{self.dim}")
        self._pending_births: ParticleSet | None = None
        self._last_update: SmcUpdateResult | None = None
        self._extraction_seed = self._draw_extraction_seed()

    def _draw_extraction_seed(self) -> int | None:
        return None if self.extraction == "measurement_only" else int(self.rng.integers(2**63))

    @property
    def last_update(self) -> SmcUpdateResult | None:
        """The result of the last update (U(z), W(z), the shares' means); None after predict."""
        return self._last_update

    def predict(self) -> None:
        """Survivors moved, then the births: the fixed sampler's, or those of the last scan."""
        if isinstance(self.birth, MeasurementBirth):
            birth, self._pending_births = self._pending_births, None
        elif isinstance(self.birth, ScanBirth):
            birth = None
        else:
            birth = self.birth
        self.particles = predict(self.particles, self.transition, self.p_s, birth, self.rng)
        self._last_update = None

    def update(self, scan: Scan) -> None:
        """Update with ``scan``: :meth:`update_weights`, then :meth:`resample`."""
        self.update_weights(scan)
        self.resample()

    def update_weights(self, scan: Scan) -> SmcUpdateResult:
        """Weigh the particles by ``scan`` (Vo et al. 2005 step 2), without resampling.

        First the births the scan brings (:class:`ScanBirth`); after the update, the births
        it proposes for the next step (:class:`MeasurementBirth`). Leaves the weighted
        posterior in :attr:`particles` and returns the update (also :attr:`last_update`).
        """
        sensor = scan.sensor
        particles = self.particles
        if isinstance(self.birth, ScanBirth):
            born = self.birth.sample(self.rng, scan.z, sensor)
            if len(born):
                particles = ParticleSet.concatenate([particles, born])
        p_d = np.asarray(self.p_d(particles.states, sensor), dtype=float)
        kappa = self.clutter(scan.z, sensor) if callable(self.clutter) else self.clutter
        result = update(particles, scan.z,
                        lambda z, x: self.log_likelihood(z, x, sensor), p_d, kappa)
        if isinstance(self.birth, MeasurementBirth):
            b = self.birth
            born = measurement_birth(scan.z, 1.0 - result.persistent_mass,
                                     b.expected_births, b.sample_state,
                                     b.n_per_measurement, self.rng)
            self._pending_births = born
        self.particles = result.particles
        self._last_update = result
        return result

    def resample(self) -> None:
        """Resample the weighted posterior (:func:`resample`), then roughen it if asked."""
        r = self.resampling
        self.particles = resample(self.particles, self.rng, r.n, r.per_target,
                                  r.min_particles, r.max_particles)
        if r.roughening > 0.0 and len(self.particles):
            p = self.particles
            jitter = self.rng.standard_normal(p.states.shape) * r.roughening
            self.particles = ParticleSet(p.weights, p.states + jitter, p.newborn)
        self._extraction_seed = self._draw_extraction_seed()

    def estimate_states(self) -> np.ndarray:
        """Estimated full states (K, d), by the extraction setting."""
        if self.extraction != "kmeans" and self._last_update is not None:
            return extract_by_measurement(self._last_update)
        if self.extraction == "measurement_only":
            return np.empty((0, self.dim))
        return extract(self.particles, np.random.default_rng(self._extraction_seed))

    def estimates(self) -> np.ndarray:
        """Estimated target positions (K, 2) [m]: the first two coordinates."""
        return self.estimate_states()[:, :2]

    def expected_count(self) -> float:
        """Expected number of targets, the sum of the weights."""
        return self.particles.mass

    def export_state(self) -> dict[str, np.ndarray]:
        """The particle arrays (:meth:`ParticleSet.to_arrays`), for another robot."""
        return self.particles.to_arrays()

    def import_state(self, arrays: Mapping[str, np.ndarray], where: str = "particles") -> None:
        """Replace the particles by validated arrays (:meth:`ParticleSet.from_arrays`).

        A malformed field is refused with a ``ValueError`` naming ``where``.
        """
        try:
            self.particles = ParticleSet.from_arrays(arrays, dim=self.dim)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
        self._last_update = None
