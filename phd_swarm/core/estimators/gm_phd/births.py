"""New GM-PHD components: two measurement-driven birth rules and one around the robot.

A fixed birth intensity (Vo & Ma A.3) must cover every place a target can appear; when
targets can appear anywhere that is wasteful and slow to confirm. The first two rules here
place the new components where the measurements are, the third where the sensor is. The
state's first two coordinates are the target position [m]; the others (a velocity, say)
start at ``other_mean`` with covariance ``other_cov``.

- :class:`AdaptiveBirth`, after Ristic, Clark, Vo & Vo (2012), "Adaptive target birth
  intensity for PHD and CPHD filters", IEEE Trans. AES 48(2). The targets are labelled
  persistent or newborn. Measurement z of step k proposes a newborn component for step k+1
  at z, with weight

  ``nu_B (1 - U_k(z)) / sum_{z' in Z_k} (1 - U_k(z'))``,

  where nu_B is the expected number of births per step and ``U_k(z)`` the share of z that
  the update gave the persistent components: ``sum_j w_j(z)`` over persistent j. A
  measurement the persistent targets explain proposes little. In the update of step k+1 a
  newborn component has no missed-detection term: a newborn target is one detected for the
  first time, so an undetected newborn is not a target (:func:`.gm_phd.filter.update_with_terms`,
  ``missed``). The estimator (:class:`.gm_phd.estimator.GmPhdEstimator`) flags the newborns and
  computes ``U_k``.
- :class:`PerMeasurementBirth`, Sung & Tokekar (Sec. V-D): after pruning and merging, one
  new component per measurement of the step, weight 1, mean the measured position,
  covariance the measurement noise R. It overestimates the number of targets (the paper
  says so, Sec. VI-A); it is there to reproduce that paper.
- :class:`RingBirth`, Shirsat & Berman (Sec. VI, eq. 39-40): the birth intensity of step k,
  gamma_k, is a few components on a ring of radius r_birth around the robot's position q_k
  at step k, whatever the measurements.

Where the measurement is not a position (range-bearing), the caller gives the position it
implies and that position's covariance (``positions``, ``position_covs``): the inverse of
the measurement model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...checks import check_nonnegative
from .filter import GaussianMixture


def _check_other(other_mean: np.ndarray | None, other_cov: np.ndarray | None,
                 dim: int) -> tuple[np.ndarray, np.ndarray]:
    n = dim - 2
    mean = np.zeros(n) if other_mean is None else np.asarray(other_mean, dtype=float)
    cov = np.eye(n) if other_cov is None else np.asarray(other_cov, dtype=float)
    if mean.shape != (n,):
        raise ValueError(f"other_mean must have shape ({n},) for a state of dimension {dim}, "
                         f"got {mean.shape}")
    if cov.shape != (n, n):
        raise ValueError(f"other_cov must have shape ({n}, {n}) for a state of dimension "
                         f"{dim}, got {cov.shape}")
    if n and (not np.all(np.isfinite(cov)) or not np.allclose(cov, cov.T)
              or np.any(np.linalg.eigvalsh(cov) <= 0.0)):
        raise ValueError("other_cov must be finite, symmetric and positive definite")
    return mean, cov


def place(positions: np.ndarray, position_covs: np.ndarray, weights: np.ndarray, dim: int,
          other_mean: np.ndarray | None = None,
          other_cov: np.ndarray | None = None) -> GaussianMixture:
    """Components at ``positions`` (M, 2) with position covariances (M, 2, 2).

    In a state of dimension ``dim``, the position block comes from the measurement, the
    rest from (``other_mean``, ``other_cov``), uncorrelated with the position.
    """
    mean_o, cov_o = _check_other(other_mean, other_cov, dim)
    n = positions.shape[0]
    means = np.empty((n, dim))
    means[:, :2] = positions
    means[:, 2:] = mean_o
    covs = np.zeros((n, dim, dim))
    covs[:, :2, :2] = position_covs
    covs[:, 2:, 2:] = cov_o
    return GaussianMixture(np.asarray(weights, dtype=float), means, covs)


@dataclass(frozen=True, eq=False)
class AdaptiveBirth:
    """Ristic et al. (2012) measurement-driven birth intensity (see the module docstring).

    Attributes
    ----------
    expected_births : float
        nu_B, the expected number of target births per step [-], >= 0.
    other_mean : np.ndarray, shape (d - 2,), optional
        Mean of the non-position coordinates of a newborn (zeros by default).
    other_cov : np.ndarray, shape (d - 2, d - 2), optional
        Their covariance (identity by default), SPD.
    """

    expected_births: float
    other_mean: np.ndarray | None = None
    other_cov: np.ndarray | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "expected_births",
                           check_nonnegative("expected_births", self.expected_births))

    def components(self, positions: np.ndarray, position_covs: np.ndarray,
                   associated: np.ndarray, dim: int) -> GaussianMixture:
        """Newborn components for the next step from this step's measurements.

        Parameters
        ----------
        positions : np.ndarray, shape (M, 2)
            Positions the measurements imply [m].
        position_covs : np.ndarray, shape (M, 2, 2)
            Their covariances [m^2].
        associated : np.ndarray, shape (M,)
            U_k(z), the share of each measurement given to persistent components [-], in
            [0, 1].
        dim : int
            State dimension d.
        """
        free = np.clip(1.0 - np.asarray(associated, dtype=float), 0.0, 1.0)
        total = free.sum()
        weights = (self.expected_births * free / total if total > 0.0
                   else np.zeros_like(free))
        return place(positions, position_covs, weights, dim, self.other_mean, self.other_cov)


@dataclass(frozen=True, eq=False)
class PerMeasurementBirth:
    """Sung & Tokekar (Sec. V-D): one component per measurement, weight 1, covariance R.

    Attributes
    ----------
    weight : float
        Weight of each new component [-] (1 in the paper), > 0.
    other_mean : np.ndarray, shape (d - 2,), optional
        Mean of the non-position coordinates (zeros by default).
    other_cov : np.ndarray, shape (d - 2, d - 2), optional
        Their covariance (identity by default), SPD.
    """

    weight: float = 1.0
    other_mean: np.ndarray | None = None
    other_cov: np.ndarray | None = None

    def __post_init__(self) -> None:
        w = float(self.weight)
        if not np.isfinite(w) or w <= 0.0:
            raise ValueError(f"weight must be finite and > 0, got {self.weight!r}")
        object.__setattr__(self, "weight", w)

    def components(self, positions: np.ndarray, position_covs: np.ndarray,
                   dim: int) -> GaussianMixture:
        """One component per measurement at its position with its covariance (R)."""
        return place(positions, position_covs, np.full(positions.shape[0], self.weight), dim,
                     self.other_mean, self.other_cov)


#: Shirsat & Berman's angles theta_l of the birth components (eq. 40) [rad].
RING_ANGLES = (0.25 * np.pi, 0.75 * np.pi, 1.25 * np.pi, 1.75 * np.pi)


@dataclass(frozen=True, eq=False)
class RingBirth:
    """Shirsat & Berman (Sec. VI, eq. 39-40): births on a ring around the robot.

    ``gamma_k(x) = sum_l w_gamma N(x; mu_l, P_gamma)`` with
    ``mu_l = q_k + r_birth (cos theta_l, sin theta_l)`` (eq. 40), q_k the robot's position
    at step k, and ``P_gamma = variance I`` on the position block; the paper has 4
    components, w_gamma = 0.1, P_gamma = 0.5 I, r_birth = 0.8 r_FoV and theta_l = pi/4,
    3 pi/4, 5 pi/4, 7 pi/4 ("so that the targets are birthed only near the boundary of the
    FoV").

    When the births enter: in Vo & Ma the birth intensity gamma_k is part of the predicted
    intensity of step k (Table I step 1, the paper's eq. 26), updated by the measurements of
    step k. Here gamma_k depends on q_k, which the filter learns only with the scan of step
    k (``Scan.sensor``), not at the prediction. The caller therefore adds
    :meth:`components` of the scan's sensor position to the predicted survivors at the
    start of the update of step k, before the detection probabilities and the Kalman terms
    are computed: the sum is exactly v_{k|k-1} of eq. 26 (no spawns), so the births of step
    k sit around the robot's position of step k and are updated by Z_k, as in Vo & Ma
    (:meth:`phd_swarm.core.estimators.shirsat.estimator.ShirsatEstimator.update` does this).
    A newborn has a missed-detection term like any component (the paper's filter is Vo &
    Ma's; no newborn label as in :class:`AdaptiveBirth`).

    Attributes
    ----------
    radius : float
        r_birth, the ring's radius [m], finite and >= 0.
    weight : float
        w_gamma, the weight of each component [expected births per step], finite, >= 0.
    variance : float
        The diagonal of the position covariance P_gamma [m^2], finite and > 0.
    angles : tuple of float
        theta_l [rad], one component each (the paper's four by default); at least one.
    other_mean : np.ndarray, shape (d - 2,), optional
        Mean of the non-position coordinates (zeros by default).
    other_cov : np.ndarray, shape (d - 2, d - 2), optional
        Their covariance (identity by default), SPD.
    """

    radius: float
    weight: float = 0.1
    variance: float = 0.5
    angles: tuple[float, ...] = RING_ANGLES
    other_mean: np.ndarray | None = None
    other_cov: np.ndarray | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", check_nonnegative("radius", self.radius))
        object.__setattr__(self, "weight", check_nonnegative("weight", self.weight))
        v = check_nonnegative("variance", self.variance)
        if v <= 0.0:
            raise ValueError(f"variance must be > 0, got {self.variance!r}")
        object.__setattr__(self, "variance", v)
        angles = np.asarray(self.angles, dtype=float).reshape(-1)
        if angles.size == 0 or not np.all(np.isfinite(angles)):
            raise ValueError(f"angles must be one or more finite numbers [rad], got "
                             f"{self.angles!r}")
        object.__setattr__(self, "angles", tuple(angles.tolist()))
        object.__setattr__(self, "_offsets", self.radius * np.stack(
            [np.cos(angles), np.sin(angles)], axis=1))
        object.__setattr__(self, "_position_covs", np.broadcast_to(
            self.variance * np.eye(2), (angles.size, 2, 2)).copy())

    def components(self, sensor: np.ndarray, dim: int) -> GaussianMixture:
        """gamma_k for a robot at ``sensor`` (eq. 39-40), one component per angle.

        Parameters
        ----------
        sensor : np.ndarray, shape (2,)
            q_k, the robot's position at step k [m].
        dim : int
            State dimension d.

        Returns
        -------
        GaussianMixture
            len(angles) components, in the order of ``angles``.
        """
        q = np.asarray(sensor, dtype=float).reshape(-1)
        if q.shape != (2,) or not np.isfinite(q).all():
            raise ValueError(f"sensor must be a finite position (2,) [m], got {sensor!r}")
        n = len(self.angles)
        if dim == 2 and self.other_mean is None and self.other_cov is None:
            # Positions only: place() would copy the same numbers in (a robot's every step).
            return GaussianMixture(np.full(n, self.weight), q + self._offsets,
                                   self._position_covs.copy())
        return place(q + self._offsets, self._position_covs, np.full(n, self.weight), dim,
                     self.other_mean, self.other_cov)

    def ring_rows(self, sensors: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """gamma_k of many robots at once, positions only: what :meth:`components` gives each.

        Parameters
        ----------
        sensors : np.ndarray, shape (R, 2)
            The robots' positions [m] (finite; not checked again).

        Returns
        -------
        weights : np.ndarray, shape (B,)
        means : np.ndarray, shape (R, B, 2) [m]
            Row r equals ``components(sensors[r], 2).means``, bit for bit.
        covs : np.ndarray, shape (B, 2, 2) [m^2]
        """
        sensors = np.asarray(sensors, dtype=float).reshape(-1, 2)
        return (np.full(len(self.angles), self.weight), sensors[:, None, :] + self._offsets,
                self._position_covs.copy())
