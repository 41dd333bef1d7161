"""The range-bearing sensor's model: h(x, s), its range-dependent noise, the clutter.

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

Who uses it: the ``square_range_bearing`` sensor part (:mod:`.square_range_bearing`, which
simulates the scans), the particle PHD of ``papaioannou_sat`` (the likelihood over states,
:func:`range_bearing_log_likelihood`, and the inverse model of its births,
:meth:`RangeBearingSensor.to_positions`) and its control's Renyi reward
(:mod:`phd_swarm.core.controllers.sat_search_track.renyi`). The EKF and UKF Gaussian-mixture
update with this sensor (Vo & Ma 2006's extension of the GM-PHD filter to nonlinear models,
which Papaioannou Sec. VI-A mentions as the alternative to SMC) serves only the estimators
benchmark and lives with it (``bench/gm_phd_nonlinear.py``).

Reference: S. Papaioannou, P. Kolios, T. Theocharides, C. G. Panayiotou, M. M. Polycarpou,
"A cooperative multi-agent probabilistic framework for search and track missions", IEEE
Trans. Control of Network Systems, 2021, Sec. VI-A.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import check_measurements


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Angle(s) ``a`` [rad] mapped to (-pi, pi] (pi stays pi, -pi becomes pi)."""
    a = np.asarray(a, dtype=float)
    w = np.pi - np.mod(np.pi - a, 2.0 * np.pi)
    # np.mod can round up to exactly 2 pi for a tiny negative argument, giving -pi.
    return np.where(w <= -np.pi, w + 2.0 * np.pi, w)


def check_sensor_position(sensor: np.ndarray) -> np.ndarray:
    """``sensor`` as a float position (2,) [m], refused if malformed or not finite."""
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


def polar(delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Range [m] and bearing [rad] of offsets ``delta`` (..., 2) from the sensor.

    The bearing of a zero offset is 0 (``atan2(0, 0)``).
    """
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

    def noise_sd_at(self, r: np.ndarray) -> np.ndarray:
        """Noise sds (..., 2): (sigma_zeta [m], sigma_phi [rad]) at ranges ``r`` (...) [m]."""
        return np.stack([self.zeta0 + self.beta_zeta * r, self.phi0 + self.beta_phi * r],
                        axis=-1)

    def measure(self, positions: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """Noise-free measurements h(x, s) (N, 2): range [m], bearing [rad] in (-pi, pi]."""
        p, s = _check_positions(positions), check_sensor_position(sensor)
        r, phi = polar(p - s)
        return np.stack([r, phi], axis=-1)

    def noise_sd(self, positions: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """Noise sds (N, 2): (sigma_zeta [m], sigma_phi [rad]) at each target's range."""
        p, s = _check_positions(positions), check_sensor_position(sensor)
        return self.noise_sd_at(np.hypot(*(p - s).T))

    def simulate(self, rng: np.random.Generator, positions: np.ndarray,
                 sensor: np.ndarray) -> np.ndarray:
        """Noisy measurements (N, 2) of targets at ``positions``, noise drawn from ``rng``.

        Draws from the likelihood g: the range may come out negative near the sensor (see the
        module notes); the bearing is wrapped to (-pi, pi].
        """
        p, s = _check_positions(positions), check_sensor_position(sensor)
        r, phi = polar(p - s)
        noise = self.noise_sd_at(r) * rng.standard_normal((p.shape[0], 2))
        z = np.stack([r, phi], axis=-1) + noise
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
        p, s = _check_positions(positions), check_sensor_position(sensor)
        r, phi = polar(p - s)                                   # (N,)
        sd = self.noise_sd_at(r)                                # (N, 2)
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
        s = check_sensor_position(sensor)
        r = np.maximum(z[:, 0], 0.0)
        c, sn = np.cos(z[:, 1]), np.sin(z[:, 1])
        pos = s + r[:, None] * np.stack([c, sn], axis=-1)
        sd = self.noise_sd_at(r)
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
        (``states[:, position_index]``), in the form the particle PHD takes
        (:class:`~phd_swarm.core.estimators.smc_phd.estimator.SmcPhdEstimator`).
    """
    idx = np.asarray(position_index)

    def log_likelihood(z: np.ndarray, states: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        states = np.asarray(states, dtype=float)
        if states.ndim != 2:
            raise ValueError(f"states must have shape (N, d), got {states.shape}")
        check_position_index(position_index, states.shape[1])
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
    check_sensor_position(sensor)
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


def check_position_index(position_index: tuple[int, int], d: int) -> np.ndarray:
    """The state indices (2,) of the target's x and y in a state of dimension ``d``, checked."""
    idx = np.asarray(position_index)
    if (idx.shape != (2,) or not np.issubdtype(idx.dtype, np.integer)
            or idx[0] == idx[1] or np.any((idx < 0) | (idx >= d))):
        raise ValueError(f"position_index must be two distinct state indices in [0, {d}), "
                         f"got {position_index!r}")
    return idx
