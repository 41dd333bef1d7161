"""Range-bearing sensor with range-dependent noise, and its EKF / UKF Gaussian-mixture update.

The sensor of Papaioannou et al. (Sec. VI-A): a sensor at ``s`` (2,) [m] measuring a target at
position ``p = H x`` [m] returns

    ``h(x, s) = [ ||p - s||, atan2(p_y - s_y, p_x - s_x) ]``   ([m], [rad] in (-pi, pi])

with likelihood ``g(z | x, s) = N(z; h(x, s), diag(sigma_zeta^2, sigma_phi^2))`` and
standard deviations that grow with the range r = ||p - s||:
``sigma_zeta = zeta0 + beta_zeta r``, ``sigma_phi = phi0 + beta_phi r``
(zeta0 = 1 m, beta_zeta = 5e-5, phi0 = pi/180 rad, beta_phi = 1e-5 rad/m).

Conventions and decisions (see also docs/decisions.md):

- **Bearing.** The paper prints ``arctan((s_y - y) / (s_x - x))``. A one-argument arctan
  only returns (-pi/2, pi/2) and gives the same value for a target and for its mirror image
  through the sensor, so with the range it would not identify the position (the likelihood
  would have two modes, at p and at 2s - p); and the printed differences (s - p) are the
  direction of the sensor seen from the target. We use the usual bearing of the target from
  the sensor, ``atan2(p_y - s_y, p_x - s_x)`` in (-pi, pi], counter-clockwise from the world
  x axis, for which ``p = s + r (cos phi, sin phi)`` inverts the noise-free measurement.
- **Units of beta_zeta.** Printed as 5e-5 m^-1, but sigma_zeta = zeta0 + beta_zeta r is in
  metres, so beta_zeta is dimensionless (metres of sd per metre of range); the value is used
  as printed.
- **Angles.** Every bearing difference (innovation, likelihood, sigma-point spread) is
  wrapped to (-pi, pi] (:func:`wrap_angle`). The likelihood is the Gaussian of the wrapped
  difference, not the wrapped-normal sum over 2 pi k: with sigma_phi <= a few degrees the
  terms left out are below exp(-(pi / sigma_phi)^2 / 2), about 1e-7000 at 1 degree.
- **Measurement space and clutter.** Measurements live in (r, phi) and the clutter intensity
  kappa(z) is per m per rad. Clutter "uniform over the sensing area" is uniform in the plane,
  which in (r, phi) has intensity ``lambda r / A`` (the Jacobian of the polar map), not
  constant: :func:`clutter_density_square`.
- **Negative ranges.** The Gaussian likelihood gives mass to r < 0 (a few percent near the
  sensor, where sigma_zeta = 1 m); :meth:`RangeBearingSensor.simulate` draws from that same
  Gaussian, so that the simulated data and the filter agree. Clutter has no mass there.

EKF and UKF (:func:`ekf_terms`, :func:`ukf_terms`) produce the per-component
:class:`.gm_phd.filter.KalmanTerms` that :func:`.gm_phd.filter.update_with_terms` turns into the
PHD update (Vo & Ma 2006, the extension of the GM-PHD filter to nonlinear Gaussian models by
EKF / UKF linearisation, which Papaioannou Sec. VI-A mentions as the alternative to SMC); both are
vectorised over components and measurements. :class:`RangeBearingMeasurement` bundles the
sensor, the linearisation and the clutter as the measurement model of
:class:`.gm_phd.estimator.GmPhdEstimator`.

References: S. Papaioannou, P. Kolios, T. Theocharides, C. G. Panayiotou, M. M. Polycarpou,
"A cooperative multi-agent probabilistic framework for search and track missions", IEEE
Trans. Control of Network Systems, 2021, Sec. VI-A. E. A. Wan, R. van der Merwe, "The
unscented Kalman filter for nonlinear estimation", 2000 (scaled sigma points).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .gm_phd.filter import (
    GaussianMixture,
    KalmanTerms,
    UpdateResult,
    check_measurements,
    check_p_d,
    update_with_terms,
)


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Angle(s) ``a`` [rad] mapped to (-pi, pi] (pi stays pi, -pi becomes pi)."""
    a = np.asarray(a, dtype=float)
    w = np.pi - np.mod(np.pi - a, 2.0 * np.pi)
    # np.mod can round up to exactly 2 pi for a tiny negative argument, giving -pi.
    return np.where(w <= -np.pi, w + 2.0 * np.pi, w)


def _check_sensor(sensor: np.ndarray) -> np.ndarray:
    s = np.asarray(sensor, dtype=float)
    if s.shape != (2,):
        raise ValueError(f"sensor position must have shape (2,), got {s.shape}")
    if not np.all(np.isfinite(s)):
        raise ValueError(f"sensor position must be finite, got {s.tolist()}")
    return s


def _check_positions(positions: np.ndarray, name: str = "positions") -> np.ndarray:
    p = np.asarray(positions, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return p


def _polar(delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Range and bearing of offsets ``delta`` (..., 2) from the sensor (atan2(0, 0) = 0)."""
    return np.hypot(delta[..., 0], delta[..., 1]), np.arctan2(delta[..., 1], delta[..., 0])


@dataclass(frozen=True)
class RangeBearingSensor:
    """Range-bearing sensor with range-dependent Gaussian noise (Papaioannou Sec. VI-A).

    Attributes
    ----------
    zeta0 : float
        Range noise sd at zero range [m], > 0.
    beta_zeta : float
        Growth of the range sd with the range [m/m], >= 0 (printed "m^-1" in the paper).
    phi0 : float
        Bearing noise sd at zero range [rad], > 0.
    beta_phi : float
        Growth of the bearing sd with the range [rad/m], >= 0.
    """

    zeta0: float = 1.0
    beta_zeta: float = 5e-5
    phi0: float = np.pi / 180.0
    beta_phi: float = 1e-5

    def __post_init__(self) -> None:
        for name in ("zeta0", "beta_zeta", "phi0", "beta_phi"):
            v = float(getattr(self, name))
            if not np.isfinite(v):
                raise ValueError(f"{name} must be finite, got {v}")
            if name in ("zeta0", "phi0") and v <= 0.0:
                raise ValueError(f"{name} must be > 0 (the noise covariance must be "
                                 f"positive definite at every range), got {v}")
            if v < 0.0:
                raise ValueError(f"{name} must be >= 0, got {v}")
            object.__setattr__(self, name, v)

    def _sd(self, r: np.ndarray) -> np.ndarray:
        return np.stack([self.zeta0 + self.beta_zeta * r, self.phi0 + self.beta_phi * r],
                        axis=-1)

    def measure(self, positions: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """Noise-free measurements h(x, s) (N, 2): range [m], bearing [rad] in (-pi, pi]."""
        p, s = _check_positions(positions), _check_sensor(sensor)
        r, phi = _polar(p - s)
        return np.stack([r, phi], axis=-1)

    def noise_sd(self, positions: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """Noise sds (N, 2): (sigma_zeta [m], sigma_phi [rad]) at each target's range."""
        p, s = _check_positions(positions), _check_sensor(sensor)
        return self._sd(np.hypot(*(p - s).T))

    def simulate(self, rng: np.random.Generator, positions: np.ndarray,
                 sensor: np.ndarray) -> np.ndarray:
        """Noisy measurements (N, 2) of targets at ``positions``, noise drawn from ``rng``.

        Draws from the likelihood g: the range may come out negative near the sensor (see the
        module notes); the bearing is wrapped to (-pi, pi].
        """
        p, s = _check_positions(positions), _check_sensor(sensor)
        r, phi = _polar(p - s)
        z = np.stack([r, phi], axis=-1) + self._sd(r) * rng.standard_normal((p.shape[0], 2))
        z[:, 1] = wrap_angle(z[:, 1])
        return z

    def log_likelihood(self, z: np.ndarray, positions: np.ndarray,
                       sensor: np.ndarray) -> np.ndarray:
        """Log-likelihood log g(z_m | p_n, s) (M, N), the bearing difference wrapped.

        Parameters
        ----------
        z : np.ndarray, shape (M, 2)
            Measurements: range [m], bearing [rad] (any finite angle; it is wrapped).
        positions : np.ndarray, shape (N, 2)
            Target positions [m] (particles, say).
        sensor : np.ndarray, shape (2,)
            Sensor position [m].
        """
        z = check_measurements(z, 2)
        p, s = _check_positions(positions), _check_sensor(sensor)
        r, phi = _polar(p - s)                                  # (N,)
        sd = self._sd(r)                                        # (N, 2)
        dr = (z[:, 0, None] - r[None, :]) / sd[None, :, 0]
        dphi = wrap_angle(z[:, 1, None] - phi[None, :]) / sd[None, :, 1]
        return (-0.5 * (dr**2 + dphi**2)
                - np.log(2.0 * np.pi * sd[:, 0] * sd[:, 1])[None, :])

    def to_positions(self, z: np.ndarray, sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (M, 2) [m] the measurements imply, and their covariances (M, 2, 2) [m^2].

        ``p = s + r (cos phi, sin phi)``, covariance ``J diag(sigma^2) J^T`` with J the Jacobian
        of that map and sigma at the measured range (the first-order inverse of the model),
        for the measurement-driven births. A negative measured range is taken as 0 in the
        position (clutter and real targets alike are at r >= 0); a range of 0 still gets a
        positive-definite covariance (the bearing sd times a range floor of zeta0).
        """
        z = check_measurements(z, 2)
        s = _check_sensor(sensor)
        r = np.maximum(z[:, 0], 0.0)
        c, sn = np.cos(z[:, 1]), np.sin(z[:, 1])
        pos = s + r[:, None] * np.stack([c, sn], axis=-1)
        sd = self._sd(r)
        rj = np.maximum(r, self.zeta0)          # keep the cross-range variance positive at r=0
        jac = np.stack([np.stack([c, -rj * sn], axis=-1),
                        np.stack([sn, rj * c], axis=-1)], axis=-2)        # (M, 2, 2)
        cov = (jac * sd[:, None, :] ** 2) @ np.swapaxes(jac, -1, -2)
        return pos, 0.5 * (cov + np.swapaxes(cov, -1, -2))


def range_bearing_log_likelihood(sensor_model: RangeBearingSensor,
                                 position_index: tuple[int, int] = (0, 1)):
    """The sensor's log-likelihood over whole states, for the particle (SMC) PHD filter.

    Returns
    -------
    callable
        ``log_likelihood(z (M, 2), states (N, d), sensor (2,)) -> (M, N)`` [log of
        1/(m rad)]: :meth:`RangeBearingSensor.log_likelihood` at the states' positions
        (``states[:, position_index]``), in the form :class:`.smc_phd.filter.SmcPhdEstimator`
        takes.
    """
    idx = np.asarray(position_index)

    def log_likelihood(z: np.ndarray, states: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        states = np.asarray(states, dtype=float)
        if states.ndim != 2:
            raise ValueError(f"states must have shape (N, d), got {states.shape}")
        _check_position_index(position_index, states.shape[1])
        return sensor_model.log_likelihood(z, states[:, idx], sensor)

    return log_likelihood


def clutter_density_square(z: np.ndarray, sensor: np.ndarray, side: float,
                           rate: float) -> np.ndarray:
    """Clutter intensity kappa(z) (M,) [1/(m rad)] in range-bearing space.

    Clutter: a Poisson number (mean ``rate``) of points uniform over the axis-aligned square of
    side ``side`` [m] centred on the sensor (the sensing area S of Papaioannou, A = side^2),
    each measured without noise as (r, phi). Uniform in the plane means intensity rate / A per
    m^2; in polar coordinates dx dy = r dr dphi, so the intensity in (r, phi) is

        ``kappa(r, phi) = rate * r / A`` if ``s + r (cos phi, sin phi)`` is in the square and
        r >= 0, else 0.

    It is zero at the sensor and largest towards the corners; it integrates to ``rate`` over
    r >= 0, phi in (-pi, pi]. A constant kappa "uniform over the measurement space" would
    instead put as much clutter within 1 m of the sensor as between 4 and 5 m.

    Parameters
    ----------
    z : np.ndarray, shape (M, 2)
        Measurements: range [m], bearing [rad].
    sensor : np.ndarray, shape (2,)
        Sensor position [m] (only its presence matters: the square is centred on it).
    side : float
        Side of the square [m], > 0.
    rate : float
        Expected number of clutter points per scan, >= 0.
    """
    z = check_measurements(z, 2)
    _check_sensor(sensor)
    side, rate = float(side), float(rate)
    if not np.isfinite(side) or side <= 0.0:
        raise ValueError(f"side must be finite and > 0, got {side}")
    if not np.isfinite(rate) or rate < 0.0:
        raise ValueError(f"rate must be finite and >= 0, got {rate}")
    r, phi = z[:, 0], z[:, 1]
    half = 0.5 * side
    inside = ((r >= 0.0) & (np.abs(r * np.cos(phi)) <= half)
              & (np.abs(r * np.sin(phi)) <= half))
    return np.where(inside, rate * r / side**2, 0.0)


def _innovation(z: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Innovations z - eta (M, J, 2), the bearing difference wrapped to (-pi, pi]."""
    nu = z[:, None, :] - eta[None, :, :]
    nu[..., 1] = wrap_angle(nu[..., 1])
    return nu


def _check_position_index(position_index: tuple[int, int], d: int) -> np.ndarray:
    idx = np.asarray(position_index)
    if (idx.shape != (2,) or not np.issubdtype(idx.dtype, np.integer)
            or idx[0] == idx[1] or np.any((idx < 0) | (idx >= d))):
        raise ValueError(f"position_index must be two distinct state indices in [0, {d}), "
                         f"got {position_index!r}")
    return idx


def _check_mixture(mix: GaussianMixture) -> None:
    if not (np.all(np.isfinite(mix.weights)) and np.all(np.isfinite(mix.means))
            and np.all(np.isfinite(mix.covs))):
        raise ValueError("mixture weights, means and covariances must be finite")


def _r_matrix(sensor_model: RangeBearingSensor, r: np.ndarray) -> np.ndarray:
    """diag(sigma_zeta^2, sigma_phi^2) (J, 2, 2) at ranges r (J,)."""
    sd = sensor_model._sd(r)
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
    (:meth:`RangeBearingSensor.log_likelihood`) is exact.

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
    s = _check_sensor(sensor)
    idx = _check_position_index(position_index, mix.dim)
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
    r, phi = _polar(delta)
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
    s = _check_sensor(sensor)
    idx = _check_position_index(position_index, mix.dim)
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

    r_sig, phi_sig = _polar(m_p[:, None, :] + dx - s)        # (J, 2n+1) each
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
        Components that keep a missed-detection term (:func:`.gm_phd.filter.update_with_terms`).
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
    s = _check_sensor(sensor)
    z = check_measurements(z, 2)
    p_d = check_p_d(p_d, len(mix))
    clutter = _check_clutter(clutter, z.shape[0])
    if mix.dim < 2:
        raise ValueError(f"the state needs at least the 2-D position, got d={mix.dim}")
    _check_position_index(position_index, mix.dim)
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

    Fits the ``MeasurementModel`` protocol of :mod:`.gm_phd.estimator`.

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
