"""The GM-PHD filter as an estimator (:class:`.base.Estimator`): one robot's mixture.

Each step: :meth:`GmPhdEstimator.predict` (Vo & Ma Table I steps 1-2, plus the newborn
components proposed by the last scan under :class:`.gm_phd.births.AdaptiveBirth`), then
:meth:`GmPhdEstimator.update` with a scan (Table I steps 3-4 through a measurement model,
then Table II, then :class:`.gm_phd.births.PerMeasurementBirth` if chosen). The equations are
in :mod:`.gm_phd.filter`; this module holds the state between steps and what depends on the
sensor pose: the detection probability, the measurement model and the clutter.

A measurement model gives the Kalman terms of every component for a scan taken at a sensor
position (:class:`.gm_phd.filter.KalmanTerms`), the clutter intensity at each measurement, and the
positions the measurements imply (for the birth rules). :class:`LinearMeasurement` is the
linear-Gaussian one of the model (z = H x + v); the range-bearing sensor's EKF and UKF forms
serve the estimators benchmark only and live with it (``bench/gm_phd_nonlinear.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ...scan import Scan
from ..base import Estimator
from .births import AdaptiveBirth, PerMeasurementBirth
from .filter import (
    DetectionProbability,
    GaussianMixture,
    GmPhdModel,
    KalmanTerms,
    check_measurements,
    check_p_d,
    constant_p_d,
    extract,
    linear_terms,
    predict,
    prune_and_merge,
    prune_and_merge_carrying,
    update_with_terms,
)


class MeasurementModel(Protocol):
    """What the GM-PHD update needs from a sensor's measurement model."""

    #: Dimension m of a measurement.
    dim: int

    def terms(self, mix: GaussianMixture, sensor: np.ndarray) -> KalmanTerms:
        """Kalman terms of every component for a scan taken at ``sensor`` (2,) [m]."""

    def clutter(self, z: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """kappa(z), the clutter intensity at each measurement (M,)."""

    def positions(self, z: np.ndarray, sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (M, 2) [m] the measurements imply and their covariances (M, 2, 2)."""


@dataclass(frozen=True, eq=False)
class LinearMeasurement:
    """z = H x + v, v ~ N(0, R), with clutter of constant intensity (Vo & Ma A.1).

    Attributes
    ----------
    H : np.ndarray, shape (m, d)
        Observation matrix.
    R : np.ndarray, shape (m, m)
        Measurement noise covariance, SPD.
    clutter_intensity : float
        kappa, constant over the measurement space [1 / measurement units], >= 0.
    """

    H: np.ndarray
    R: np.ndarray
    clutter_intensity: float

    @classmethod
    def of(cls, model: GmPhdModel) -> LinearMeasurement:
        """The measurement model held by a :class:`.gm_phd.filter.GmPhdModel`."""
        return cls(model.H, model.R, model.clutter_intensity)

    @property
    def dim(self) -> int:
        """Measurement dimension m."""
        return self.H.shape[0]

    def terms(self, mix: GaussianMixture, sensor: np.ndarray) -> KalmanTerms:
        """Linear Kalman terms (Table I step 3); the sensor pose does not enter."""
        return linear_terms(mix, self.H, self.R)

    def clutter(self, z: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """The constant kappa at every measurement."""
        return np.full(z.shape[0], self.clutter_intensity)

    def positions(self, z: np.ndarray, sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Z itself with covariance R, when z measures the position: H = [I_2 0]."""
        d = self.H.shape[1]
        position = np.zeros((2, d))
        position[:, :2] = np.eye(2)
        if self.H.shape != (2, d) or not np.array_equal(self.H, position):
            raise ValueError("measurement-driven births need position measurements, "
                             f"H = [I_2 0]; got H = {self.H.tolist()}")
        return z.copy(), np.broadcast_to(self.R, (z.shape[0], 2, 2)).copy()


BirthRule = AdaptiveBirth | PerMeasurementBirth | None


class GmPhdEstimator(Estimator):
    """GM-PHD filter as an estimator: predict, update with a scan, prune and merge.

    The state's first two coordinates are the target position [m] (world frame).

    Parameters
    ----------
    model : GmPhdModel
        Motion model, fixed birth and spawn intensities, reduction and extraction settings.
    mixture : GaussianMixture, optional
        Initial intensity; empty by default.
    p_d : callable, optional
        ``p_d(means (J, d), covs (J, d, d), sensor (2,) [m]) -> (J,)``, the detection
        probability of each component for a scan taken at ``sensor`` (the sensors'
        :mod:`.fov_detection` has the field-of-view models); 0.9 everywhere by default.
    measurement : MeasurementModel, optional
        The sensor's measurement model; the model's linear one (H, R, kappa) by default.
    birth : AdaptiveBirth or PerMeasurementBirth, optional
        A measurement-driven birth rule (:mod:`.gm_phd.births`), in addition to the model's
        fixed birth intensity; none by default.
    fov_push : tuple of float, optional
        (lower, upper): Sung & Tokekar's limited-FoV update rule (Alg. 1 lines 5-7,
        eq. 11), off by default. The missed-detection term of a component whose p_D lies in
        [lower, upper] (near the edge of the field of view) has its position pushed away
        from the sensor y: ``mu <- mu + p_D (mu - y)``. The paper uses (0.4, 0.6).
    fov_push_to : {"paper", "threshold"}
        How far eq. 11 pushes: as printed (``paper``: by p_D times the distance to the
        sensor, ~12 m at the edge of a 25 m disk), or radially just far enough that the
        component's p_D falls to ``lower`` (``threshold``: the rule's stated aim, "get
        pushed outside the FOV", with the smallest move; found by bisection on the
        distance, to 1e-6 of it).
    undetected_births : {"keep", "drop"}
        What the update does with the model's fixed birth intensity (Vo & Ma A.3) where no
        measurement detects it. ``keep`` (default): a birth component has a
        missed-detection term ``(1 - p_D) w`` like any other (Vo & Ma Table I), so an
        undetected newborn is carried on. ``drop``: it has none, as the newborns of
        :class:`.gm_phd.births.AdaptiveBirth` (Ristic et al. 2012) and Stone Soup's
        ``PHDUpdater``: a birth is a target seen for the first time, and one not seen is
        offered again by the next step's birth intensity rather than carried. The births
        then also count as newborn, not persistent, in AdaptiveBirth's ``U_k(z)``. With a
        wide birth prior re-issued at the sensor each step and p_S = 1, ``keep`` piles the
        undetected newborns up (about (1 - p_D) of each birth: 0.65 of it with the
        integrated p_D of a 25 m-sd birth in a 25 m disk), see docs/benchmarks.md.
    record_shares : bool
        Keep :attr:`shares` after each update (off by default: the filter is the same
        either way, bit for bit).

    Attributes
    ----------
    shares : np.ndarray, shape (J, M) or None
        With ``record_shares``, after an update with M measurements: how much of the weight
        of each of the J components of :attr:`mixture` came from each measurement. A
        detection term of component j by z brings its weight w_j(z) (Table I step 4) to the
        component it is merged into (Table II, :func:`.gm_phd.reduce.reduce_with_sources`); a
        newborn of :class:`.gm_phd.births.PerMeasurementBirth` brings its weight to its own
        row; missed-detection terms bring nothing. Row sums are at most the weights.
    """

    def __init__(self, model: GmPhdModel, mixture: GaussianMixture | None = None,
                 p_d: DetectionProbability | None = None,
                 measurement: MeasurementModel | None = None,
                 birth: BirthRule = None,
                 fov_push: tuple[float, float] | None = None,
                 fov_push_to: str = "paper",
                 undetected_births: str = "keep",
                 record_shares: bool = False) -> None:
        if model.dim < 2:
            raise ValueError(f"GmPhdEstimator needs a state whose first two coordinates are "
                             f"the position, got d={model.dim}")
        self.model = model
        self.measurement = LinearMeasurement.of(model) if measurement is None else measurement
        self.birth = birth
        if fov_push is not None:
            lower, upper = (float(v) for v in fov_push)
            if not 0.0 <= lower <= upper <= 1.0:
                raise ValueError(f"fov_push must be (lower, upper) with 0 <= lower <= upper "
                                 f"<= 1, got {fov_push!r}")
            fov_push = (lower, upper)
        self.fov_push = fov_push
        if fov_push_to not in ("paper", "threshold"):
            raise ValueError(f"fov_push_to must be 'paper' or 'threshold', got {fov_push_to!r}")
        self.fov_push_to = fov_push_to
        if undetected_births not in ("keep", "drop"):
            raise ValueError(f"undetected_births must be 'keep' or 'drop', got "
                             f"{undetected_births!r}")
        self.undetected_births = undetected_births
        self.mixture = GaussianMixture.empty(model.dim) if mixture is None else mixture
        if self.mixture.dim != model.dim:
            raise ValueError(f"initial mixture has dimension {self.mixture.dim}, the model "
                             f"{model.dim}")
        self._p_d = constant_p_d(0.9) if p_d is None else p_d
        self._newborn = np.zeros(len(self.mixture), dtype=bool)
        self._proposed = GaussianMixture.empty(model.dim)
        self.record_shares = bool(record_shares)
        self.shares: np.ndarray | None = None

    def predict(self) -> None:
        """Births, spawns and survivors (Table I steps 1-2), then last scan's newborns."""
        predicted = predict(self.mixture, self.model)
        self.mixture = GaussianMixture(
            np.concatenate([predicted.weights, self._proposed.weights]),
            np.concatenate([predicted.means, self._proposed.means]),
            np.concatenate([predicted.covs, self._proposed.covs]))
        flags = np.zeros(len(predicted), dtype=bool)
        if self.undetected_births == "drop":
            flags[:len(self.model.birth_weights)] = True   # predict() puts the births first
        self._newborn = np.concatenate([flags, np.ones(len(self._proposed), dtype=bool)])
        self._proposed = GaussianMixture.empty(self.model.dim)

    def update(self, scan: Scan) -> None:
        """Update with ``scan`` (Table I steps 3-4), prune and merge (Table II), births."""
        sensor = scan.sensor
        z = check_measurements(scan.z, self.measurement.dim)
        mix, newborn = self.mixture, self._newborn
        p_d = check_p_d(self._p_d(mix.means, mix.covs, sensor), len(mix))
        terms = (self.measurement.terms(mix, sensor) if len(mix) and len(z) else None)
        if terms is None:
            weights = np.where(newborn, 0.0, (1.0 - p_d) * mix.weights)
            posterior = GaussianMixture(weights, mix.means, mix.covs)
            shares = np.zeros((len(z), len(mix)))
        else:
            result = update_with_terms(mix, z, terms, p_d, self.measurement.clutter(z, sensor),
                                       missed=~newborn)
            posterior, shares = result.mixture, result.detection_weights
        if self.fov_push is not None:
            posterior = self._push_from_fov(posterior, p_d, sensor)
        if self.record_shares:
            # Posterior rows: the J missed terms, then J detection terms per measurement.
            n, m = len(mix), len(z)
            brought = np.zeros((n * (1 + m), m))
            brought[n + np.arange(n * m), np.repeat(np.arange(m), n)] = shares.reshape(-1)
            self.mixture, self.shares = prune_and_merge_carrying(posterior, self.model,
                                                                 brought)
        else:
            self.mixture = prune_and_merge(posterior, self.model)
        self._newborn = np.zeros(len(self.mixture), dtype=bool)
        if self.birth is None or len(z) == 0:
            return
        positions, covs = self.measurement.positions(z, sensor)
        if isinstance(self.birth, AdaptiveBirth):
            associated = shares[:, ~newborn].sum(axis=1)
            self._proposed = self.birth.components(positions, covs, associated, self.model.dim)
        else:
            new = self.birth.components(positions, covs, self.model.dim)
            self.mixture = GaussianMixture(
                np.concatenate([self.mixture.weights, new.weights]),
                np.concatenate([self.mixture.means, new.means]),
                np.concatenate([self.mixture.covs, new.covs]))
            self._newborn = np.zeros(len(self.mixture), dtype=bool)
            if self.record_shares:
                self.shares = np.concatenate([self.shares, np.diag(new.weights)])

    def _push_from_fov(self, posterior: GaussianMixture, p_d: np.ndarray,
                       sensor: np.ndarray) -> GaussianMixture:
        """Sung & Tokekar eq. 11 on the missed-detection terms (the first J components)."""
        lower, upper = self.fov_push
        edge = (p_d >= lower) & (p_d <= upper)
        if not edge.any():
            return posterior
        means = posterior.means.copy()
        missed = means[:len(p_d)]
        if self.fov_push_to == "paper":
            missed[edge, :2] += p_d[edge, None] * (missed[edge, :2] - sensor)
        else:
            missed[edge] = self._push_to_threshold(missed[edge], posterior.covs[:len(p_d)][edge],
                                                   sensor, lower)
        return GaussianMixture(posterior.weights, means, posterior.covs)

    def _push_to_threshold(self, means: np.ndarray, covs: np.ndarray, sensor: np.ndarray,
                           lower: float) -> np.ndarray:
        """Move each mean radially away from ``sensor`` until its p_D is ``lower``.

        p_D decreases along the ray outward from the sensor once the mean is near the
        edge; the distance t is bracketed by [0, hi] with hi doubled until p_D <= lower,
        then bisected (60 halvings: to 1e-6 of hi or better).
        """
        out = means.copy()
        ray = out[:, :2] - sensor
        length = np.hypot(ray[:, 0], ray[:, 1])
        unit = np.where(length[:, None] > 0, ray / np.maximum(length, 1e-300)[:, None],
                        np.array([1.0, 0.0]))

        def p_at(t: np.ndarray) -> np.ndarray:
            moved = out.copy()
            moved[:, :2] += t[:, None] * unit
            return self._p_d(moved, covs, sensor)

        lo = np.zeros(len(out))
        hi = np.ones(len(out))
        for _ in range(60):
            above = p_at(hi) > lower
            if not above.any():
                break
            lo = np.where(above, hi, lo)
            hi = np.where(above, 2.0 * hi, hi)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            above = p_at(mid) > lower
            lo = np.where(above, mid, lo)
            hi = np.where(above, hi, mid)
        out[:, :2] += hi[:, None] * unit
        return out

    def estimates(self) -> np.ndarray:
        """Estimated target positions (N, 2) [m]: the first two coordinates (Table III)."""
        return extract(self.mixture, self.model)[:, :2]

    def expected_count(self) -> float:
        """Expected number of targets, the sum of the weights."""
        return float(self.mixture.weights.sum())

    def export_state(self) -> dict[str, np.ndarray]:
        """The mixture as plain arrays (:meth:`.gm_phd.filter.GaussianMixture.to_arrays`)."""
        return self.mixture.to_arrays()

    def import_state(self, arrays: dict[str, np.ndarray], where: str = "mixture") -> None:
        """Replace the mixture with checked arrays (refused with ``where`` named if bad)."""
        mix = GaussianMixture.from_arrays(arrays, where)
        if mix.dim != self.model.dim:
            raise ValueError(f"{where}: state dimension {mix.dim}, the model's is "
                             f"{self.model.dim}")
        self.mixture = mix
        self._newborn = np.zeros(len(mix), dtype=bool)
        self.shares = None
