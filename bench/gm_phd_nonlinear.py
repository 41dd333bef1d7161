"""The range-bearing sensor's EKF / UKF Gaussian-mixture PHD update, for the benchmark only.

The GM-PHD filter extended to a nonlinear Gaussian measurement model by linearisation
(Vo & Ma 2006, its EKF and UKF forms), with the range-bearing sensor of Papaioannou
et al. (Sec. VI-A, :mod:`phd_swarm.core.sensors.range_bearing_model`), which the paper
mentions as the alternative to its SMC filter. No system of the package uses it (Papaioannou
et al.'s ``papaioannou_sat`` is a particle PHD); ``scripts/bench.sh estimators`` runs it on
the range-bearing scenario ("rb", :mod:`estimators`) against the particle filters, so it
lives here, with the benchmark.

:func:`ekf_terms` and :func:`ukf_terms` produce the per-component
:class:`~phd_swarm.core.estimators.gm_phd.filter.KalmanTerms` that
:func:`~phd_swarm.core.estimators.gm_phd.filter.update_with_terms` turns into the PHD update
(Vo & Ma Table I steps 3-4); both are vectorised over components and measurements, and every
bearing difference is wrapped to (-pi, pi] (the conventions are the sensor model's).
:func:`update_range_bearing` is that update in one call; :class:`RangeBearingMeasurement`
bundles the sensor, the linearisation and the clutter as the measurement model of
:class:`~phd_swarm.core.estimators.gm_phd.estimator.GmPhdEstimator`.

Imported as a sibling module by :mod:`estimators` (``python bench/estimators.py``) and by
its tests (``test/bench/test_gm_phd_nonlinear.py``, by path).

References: B.-N. Vo and W.-K. Ma, "The Gaussian mixture probability hypothesis density
filter", IEEE Trans. Signal Processing 54(11), 2006. S. Papaioannou, P. Kolios,
T. Theocharides, C. G. Panayiotou, M. M. Polycarpou, "A cooperative multi-agent
probabilistic framework for search and track missions", IEEE Trans. Control of Network
Systems, 2021, Sec. VI-A. E. A. Wan, R. van der Merwe, "The unscented Kalman filter for
nonlinear estimation", 2000 (scaled sigma points).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from phd_swarm.core.checks import check_measurements
from phd_swarm.core.estimators.gm_phd.filter import (
    GaussianMixture,
    KalmanTerms,
    UpdateResult,
    check_p_d,
    update_with_terms,
)
from phd_swarm.core.sensors.range_bearing_model import (
    RangeBearingSensor,
    check_position_index,
    check_sensor_position,
    clutter_density_square,
    polar,
    wrap_angle,
)


def _innovation(z: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Innovations z - eta (M, J, 2), the bearing difference wrapped to (-pi, pi]."""
    nu = z[:, None, :] - eta[None, :, :]
    nu[..., 1] = wrap_angle(nu[..., 1])
    return nu


def _check_mixture(mix: GaussianMixture) -> None:
    if not (np.all(np.isfinite(mix.weights)) and np.all(np.isfinite(mix.means))
            and np.all(np.isfinite(mix.covs))):
        raise ValueError("mixture weights, means and covariances must be finite")


def _r_matrix(sensor_model: RangeBearingSensor, r: np.ndarray) -> np.ndarray:
    """diag(sigma_zeta^2, sigma_phi^2) (J, 2, 2) at ranges r (J,)."""
    sd = sensor_model.noise_sd_at(r)
    out = np.zeros(r.shape + (2, 2))
    out[..., 0, 0] = sd[..., 0] ** 2
    out[..., 1, 1] = sd[..., 1] ** 2
    return out


def ekf_terms(mix: GaussianMixture, sensor: np.ndarray, sensor_model: RangeBearingSensor,
              position_index: tuple[int, int] = (0, 1),
              min_range: float | None = None) -> KalmanTerms:
    """EKF Kalman terms of every component: h linearised at the component mean.

    ``eta_j = h(m_j)``, ``H_j = dh/dx (m_j)`` (J, 2, d), zero outside the position columns,
    ``R_j = R(r(m_j))`` (the range-dependent noise at the mean), ``S_j = H_j P_j H_j^T + R_j``,
    ``K_j = P_j H_j^T S_j^-1``, updated covariance in Joseph form; the innovation wraps the
    bearing.

    Guard at the sensor: the bearing row of H is ``(-sin phi, cos phi) / r``, unbounded as
    r -> 0, and the EKF is not valid once the mean is within about a position sd of the
    sensor (the bearing then varies by up to 2 pi over the component). Rule: H is evaluated
    at the range ``max(r, min_range)`` along the sensor-to-mean direction (the +x direction,
    bearing 0, if the mean is exactly on the sensor, as atan2(0, 0) = 0); eta and R stay
    those of the mean. By default ``min_range`` is one position sd of the component (the
    square root of the largest eigenvalue of its position covariance), the typical distance
    of the target from the sensor when the mean is on it. A fixed tiny floor (1 mm, say)
    would keep the numbers finite but not sane: a bearing row of 1000 rad/m shrinks the
    cross-range variance to (sigma_phi * 1 mm)^2 while the innovation barely moves the mean,
    an overconfident component in the wrong place. With one sd, the bearing innovation moves
    the mean across by about sd * (innovation in rad) and the cross-range variance becomes
    about (sigma_phi sd)^2, the bearing's resolution at that distance. This changes nothing
    for a mean more than one sd from the sensor. Within it the update is still only a rough
    one (a bearing innovation near pi moves the mean the wrong way); :func:`ukf_terms` is no
    better there (its sigma points straddle the sensor), and only a particle filter
    (:meth:`RangeBearingSensor.log_likelihood
    <phd_swarm.core.sensors.range_bearing_model.RangeBearingSensor.log_likelihood>`) is exact.

    Parameters
    ----------
    mix : GaussianMixture
        Predicted intensity, J components of dimension d >= 2.
    sensor : np.ndarray, shape (2,)
        Sensor position [m].
    sensor_model : RangeBearingSensor
        Noise model.
    position_index : tuple of int
        State indices of the target's x and y [m].
    min_range : float, optional
        The guard distance [m], > 0; one position sd of each component by default.
    """
    s = check_sensor_position(sensor)
    idx = check_position_index(position_index, mix.dim)
    delta = mix.means[:, idx] - s                            # (J, 2)
    if min_range is None:
        p_pp = mix.covs[:, idx[:, None], idx[None, :]]
        half_tr = 0.5 * (p_pp[:, 0, 0] + p_pp[:, 1, 1])
        lam_max = half_tr + np.hypot(0.5 * (p_pp[:, 0, 0] - p_pp[:, 1, 1]), p_pp[:, 0, 1])
        floor = np.sqrt(np.maximum(lam_max, 0.0))
    else:
        floor = float(min_range)
        if not np.isfinite(floor) or floor <= 0.0:
            raise ValueError(f"min_range must be finite and > 0, got {min_range}")
    r, phi = polar(delta)
    eta = np.stack([r, phi], axis=-1)
    c, sn = np.cos(phi), np.sin(phi)                         # direction sensor -> mean
    rc = np.maximum(r, floor)
    jac_pos = np.stack([np.stack([c, sn], axis=-1),
                        np.stack([-sn / rc, c / rc], axis=-1)], axis=-2)   # (J, 2, 2)
    h = np.zeros((len(mix), 2, mix.dim))
    h[:, :, idx] = jac_pos
    r_mat = _r_matrix(sensor_model, r)
    hp = h @ mix.covs                                        # (J, 2, d) = H P (= (P H^T)^T)
    s_mat = hp @ np.swapaxes(h, -1, -2) + r_mat
    s_mat = 0.5 * (s_mat + np.swapaxes(s_mat, -1, -2))
    gain = np.swapaxes(np.linalg.solve(s_mat, hp), -1, -2)  # P H^T S^-1 (S symmetric)
    # Joseph form (I - K H) P (I - K H)^T + K R K^T: a sum of positive semi-definite terms,
    # so it stays PSD under rounding whatever K is. The short form (I - K H) P loses symmetry
    # and can go indefinite when H P H^T dwarfs R, which happens here: the bearing row of H
    # grows as 1/r near the sensor (up to 1/min_range), and the range-dependent R is small
    # for a close target against a broad newborn component. One covariance per component
    # serves every measurement, so the extra products cost nothing per measurement.
    ikh = np.eye(mix.dim) - gain @ h
    covs = (ikh @ mix.covs @ np.swapaxes(ikh, -1, -2)
            + gain @ r_mat @ np.swapaxes(gain, -1, -2))
    return KalmanTerms(eta, s_mat, gain, 0.5 * (covs + np.swapaxes(covs, -1, -2)),
                       _innovation)


def ukf_terms(mix: GaussianMixture, sensor: np.ndarray, sensor_model: RangeBearingSensor,
              position_index: tuple[int, int] = (0, 1), alpha: float = 1.0,
              beta: float = 2.0, kappa: float = 1.0) -> KalmanTerms:
    """UKF Kalman terms of every component: scaled unscented transform of h, all at once.

    h depends on the position p only, so the unscented transform is taken over the position
    marginal N(m_p, P_pp) (n = 2) and lifted to the whole state exactly: for a Gaussian prior
    the rest of the state is linear-Gaussian given p, so ``Cov(x, z) = P_xp P_pp^-1 Cov(p, z)``.
    Sigma points ``X_0 = m_p``, ``X_{i, i+n} = m_p +- sqrt(n + lambda) L_i`` (L = chol(P_pp),
    batched over components, (J, 2n+1, 2)), ``lambda = alpha^2 (n + kappa) - n``; mean
    weights ``W_0 = lambda / (n + lambda)``, covariance weight ``W_0 + 1 - alpha^2 + beta``,
    the others ``1 / (2 (n + lambda))``. The predicted range is the weighted mean; the
    predicted bearing is the circular one: deviations from the central point's bearing are
    wrapped to (-pi, pi], averaged, and added back (so sigma points on both sides of the +-pi
    cut average to about pi, not 0). ``S = sum W_c dY dY^T + R(r(m_p))`` (the noise at the
    mean, as in the EKF), ``K = Cov(x, z) S^-1``, updated covariance ``P - K S K^T``
    symmetrised.

    Why the position marginal and not the 2d+1 points of the whole state: the points along
    the non-position axes all map to h(m_p) and only dilute the weights, and the spread of
    the points in position would grow with d (sqrt(d + lambda) sd); here it is the same for
    any state. Defaults alpha = 1, beta = 2, kappa = 1: n + kappa = 3, the choice that
    matches the fourth moments of a Gaussian (Julier and Uhlmann), points at +-sqrt(3) sd,
    and every weight > 0 (W_0 = 1/3, W_0c = 7/3, the others 1/6). A small alpha (1e-3) would
    give a covariance weight near -1e6 and can make S indefinite.

    With nonnegative weights, the sigma-point covariance of (p, h(p)) plus block-diag(0, R) is
    positive semi-definite, its p block is P_pp exactly, and
    ``P - K S K^T = P - C S^-1 C^T`` (C = Cov(x, z)) is the Schur complement of the
    corresponding joint covariance of (x, z), hence positive semi-definite (and definite, as
    R is); rounding disturbs it only at ~1e-16 ||P||, which matters only if the measurement
    shrank some variance by ~1e16 (a 1 m range sd against a 1e8 m prior sd), so the short
    form, symmetrised against the rounding asymmetry, is safe here. With weights of both
    signs (other alpha, kappa) none of this holds.

    Parameters
    ----------
    mix : GaussianMixture
        Predicted intensity, J components of dimension d >= 2; the position blocks of the
        covariances must be positive definite.
    sensor : np.ndarray, shape (2,)
        Sensor position [m].
    sensor_model : RangeBearingSensor
        Noise model.
    position_index : tuple of int
        State indices of the target's x and y [m].
    alpha, beta, kappa : float
        Scaled-UT parameters (alpha > 0, 2 + kappa > 0).
    """
    s = check_sensor_position(sensor)
    idx = check_position_index(position_index, mix.dim)
    n = 2
    alpha, beta, kappa = float(alpha), float(beta), float(kappa)
    if not (np.isfinite(alpha) and np.isfinite(beta) and np.isfinite(kappa)):
        raise ValueError("alpha, beta and kappa must be finite")
    if alpha <= 0.0 or n + kappa <= 0.0:
        raise ValueError(f"need alpha > 0 and 2 + kappa > 0, got alpha={alpha}, "
                         f"kappa={kappa}")
    lam = alpha**2 * (n + kappa) - n
    m_p = mix.means[:, idx]                                   # (J, 2)
    p_pp = mix.covs[:, idx[:, None], idx[None, :]]            # (J, 2, 2)
    p_xp = mix.covs[:, :, idx]                                # (J, d, 2)
    try:
        chol = np.linalg.cholesky(p_pp)
    except np.linalg.LinAlgError:
        raise ValueError("the position block of every component covariance must be "
                         "positive definite for the UKF") from None
    offsets = np.sqrt(n + lam) * np.swapaxes(chol, -1, -2)   # row i = column i of L
    dx = np.concatenate([np.zeros((len(mix), 1, n)), offsets, -offsets], axis=1)
    w_m = np.full(2 * n + 1, 0.5 / (n + lam))
    w_m[0] = lam / (n + lam)
    w_c = w_m.copy()
    w_c[0] += 1.0 - alpha**2 + beta

    r_sig, phi_sig = polar(m_p[:, None, :] + dx - s)        # (J, 2n+1) each
    r_hat = r_sig @ w_m
    phi_ref = phi_sig[:, 0]
    dev = wrap_angle(phi_sig - phi_ref[:, None])             # around the central point
    mean_dev = dev @ w_m
    eta = np.stack([r_hat, wrap_angle(phi_ref + mean_dev)], axis=-1)
    dy = np.stack([r_sig - r_hat[:, None], dev - mean_dev[:, None]], axis=-1)  # (J, 2n+1, 2)

    # R at the mean's range (the noise's sd changes by 5e-5 m per m of range: its spread over
    # the sigma points is negligible against the noise itself).
    r_mean = np.hypot(*(m_p - s).T)
    s_mat = np.einsum("n,jna,jnb->jab", w_c, dy, dy) + _r_matrix(sensor_model, r_mean)
    s_mat = 0.5 * (s_mat + np.swapaxes(s_mat, -1, -2))
    c_pz = np.einsum("n,jna,jnb->jab", w_c, dx, dy)          # Cov(p, z) (J, 2, 2)
    cross = p_xp @ np.linalg.solve(p_pp, c_pz)               # Cov(x, z) (J, d, 2)
    gain = np.swapaxes(np.linalg.solve(s_mat, np.swapaxes(cross, -1, -2)), -1, -2)
    covs = mix.covs - gain @ s_mat @ np.swapaxes(gain, -1, -2)
    return KalmanTerms(eta, s_mat, gain, 0.5 * (covs + np.swapaxes(covs, -1, -2)),
                       _innovation)


_METHODS = {"ekf": ekf_terms, "ukf": ukf_terms}


def _check_clutter(clutter: float | np.ndarray, n_meas: int) -> np.ndarray:
    c = np.asarray(clutter, dtype=float)
    if c.ndim > 1 or (c.ndim == 1 and c.shape != (n_meas,)):
        raise ValueError(f"clutter must be a scalar or have shape ({n_meas},), got {c.shape}")
    if not np.all(np.isfinite(c)) or np.any(c < 0.0):
        raise ValueError("clutter intensity must be finite and >= 0")
    return np.broadcast_to(c, (n_meas,))


def update_range_bearing(mix: GaussianMixture, z: np.ndarray, sensor: np.ndarray,
                         sensor_model: RangeBearingSensor, p_d: np.ndarray,
                         clutter: float | np.ndarray, method: str = "ekf",
                         missed: np.ndarray | None = None,
                         position_index: tuple[int, int] = (0, 1),
                         **options: float) -> UpdateResult:
    """GM-PHD update (Vo & Ma Table I steps 3-4) with range-bearing measurements.

    Parameters
    ----------
    mix : GaussianMixture
        Predicted intensity, J components of dimension d >= 2.
    z : np.ndarray, shape (M, 2)
        Measurements: range [m], bearing [rad] (any finite angle; innovations are wrapped).
    sensor : np.ndarray, shape (2,)
        Sensor position [m].
    sensor_model : RangeBearingSensor
        Noise model.
    p_d : np.ndarray, shape (J,)
        Detection probability of each component [-].
    clutter : float or np.ndarray, shape (M,)
        kappa(z), the clutter intensity at each measurement [1/(m rad)], >= 0
        (:func:`clutter_density_square` for clutter uniform over a square area).
    method : {"ekf", "ukf"}
        Linearisation (:func:`ekf_terms`, :func:`ukf_terms`).
    missed : np.ndarray of bool, shape (J,), optional
        Components that keep a missed-detection term
        (:func:`~phd_swarm.core.estimators.gm_phd.filter.update_with_terms`).
    position_index : tuple of int
        State indices of the target's x and y [m].
    **options
        Passed to the terms: ``min_range`` (EKF); ``alpha``, ``beta``, ``kappa`` (UKF).

    Returns
    -------
    UpdateResult
        The J (1 + M) posterior components and the detection weights (M, J).
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {sorted(_METHODS)}, got {method!r}")
    s = check_sensor_position(sensor)
    z = check_measurements(z, 2)
    p_d = check_p_d(p_d, len(mix))
    clutter = _check_clutter(clutter, z.shape[0])
    if mix.dim < 2:
        raise ValueError(f"the state needs at least the 2-D position, got d={mix.dim}")
    check_position_index(position_index, mix.dim)
    _check_mixture(mix)
    j, d = len(mix), mix.dim
    if j == 0 or z.shape[0] == 0:   # only the missed-detection terms: no linearisation
        terms = KalmanTerms(np.zeros((j, 2)), np.zeros((j, 2, 2)), np.zeros((j, d, 2)),
                            np.zeros((j, d, d)))
    else:
        terms = _METHODS[method](mix, s, sensor_model, position_index, **options)
    return update_with_terms(mix, z, terms, p_d, clutter, missed)


@dataclass(frozen=True)
class RangeBearingMeasurement:
    """The range-bearing sensor as a GM-PHD measurement model (``terms``, ``clutter``, ...).

    Fits the ``MeasurementModel`` protocol of :mod:`phd_swarm.core.estimators.gm_phd.estimator`.

    Attributes
    ----------
    sensor_model : RangeBearingSensor
        Noise model.
    method : str
        "ekf" or "ukf".
    clutter_rate : float
        Expected clutter points per scan (lambda_c; 10 in Papaioannou Sec. VI-A), >= 0.
    clutter_side : float
        Side [m] of the square around the sensor the clutter is uniform over (10 m there).
    position_index : tuple of int
        State indices of the target's x and y [m].
    """

    sensor_model: RangeBearingSensor = RangeBearingSensor()
    method: str = "ekf"
    clutter_rate: float = 10.0
    clutter_side: float = 10.0
    position_index: tuple[int, int] = (0, 1)

    def __post_init__(self) -> None:
        if self.method not in _METHODS:
            raise ValueError(f"method must be one of {sorted(_METHODS)}, got {self.method!r}")
        # validates side and rate
        clutter_density_square(np.empty((0, 2)), np.zeros(2), self.clutter_side,
                               self.clutter_rate)
        object.__setattr__(self, "position_index", tuple(int(i) for i in self.position_index))

    @property
    def dim(self) -> int:
        """Measurement dimension (range, bearing)."""
        return 2

    def terms(self, mix: GaussianMixture, sensor: np.ndarray) -> KalmanTerms:
        """EKF or UKF terms of every component for a scan taken at ``sensor`` (2,) [m]."""
        return _METHODS[self.method](mix, sensor, self.sensor_model, self.position_index)

    def clutter(self, z: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """kappa(z) (M,) [1/(m rad)] for clutter uniform over the square around the sensor."""
        return clutter_density_square(z, sensor, self.clutter_side, self.clutter_rate)

    def positions(self, z: np.ndarray, sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (M, 2) [m] the measurements imply and their covariances (M, 2, 2)."""
        return self.sensor_model.to_positions(z, sensor)
