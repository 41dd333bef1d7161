"""Models and birth samplers of the particle PHD filter (:mod:`.smc_phd.filter`).

- the target motion as a sampler: :func:`linear_gaussian_transition` (x' = F x + w,
  w ~ N(0, Q));
- the measurement likelihood: :func:`linear_gaussian_log_likelihood` (z = H x + v,
  v ~ N(0, R)); the range-bearing sensor's is
  :func:`.range_bearing_model.range_bearing_log_likelihood`;
- the detection probability: :func:`constant_p_d`; the field-of-view models of
  :mod:`.fov_detection` give ``at_points``, a sensor part's instance
  ``detection_probability`` (:class:`~phd_swarm.core.sensors.base.Sensor`);
- fixed birth intensities as samplers: :func:`gaussian_birth`, :func:`uniform_birth`;
- the measurement-driven birth of Ristic, Clark, Vo & Vo (2012):
  :func:`measurement_birth`, with :func:`gaussian_measurement_sampler` to draw a newborn's
  state around a measurement.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ...checks import (
    check_finite,
    check_generator,
    check_measurements,
    check_positive_int,
    check_probability,
)
from .filter import _TOL, BirthSampler, ParticleSet, StateSampler, Transition


def _psd_factor(name: str, a: np.ndarray) -> np.ndarray:
    """A factor L with L L^T = a, for a symmetric positive semi-definite ``a``."""
    check_finite(name, a)
    if not np.allclose(a, a.T, rtol=1e-9, atol=1e-12):
        raise ValueError(f"{name} must be symmetric")
    lam, vec = np.linalg.eigh(0.5 * (a + a.T))
    if lam.size and lam.min() < -1e-10 * max(1.0, float(np.abs(lam).max())):
        raise ValueError(f"{name} must be positive semi-definite, has eigenvalue "
                         f"{lam.min():.3g}")
    return vec * np.sqrt(np.clip(lam, 0.0, None))


def linear_gaussian_transition(F: np.ndarray, Q: np.ndarray) -> Transition:
    """Sampler of the motion model ``x' = F x + w``, ``w ~ N(0, Q)``.

    Parameters
    ----------
    F : np.ndarray, shape (d, d)
        State transition matrix.
    Q : np.ndarray, shape (d, d)
        Process noise covariance, symmetric positive semi-definite (a constant-velocity
        model's ``sigma_a^2 G G^T`` of rank 2 is accepted).

    Returns
    -------
    callable
        ``transition(rng, states (N, d)) -> (N, d)``: one draw of d standard normals per
        particle.
    """
    f = np.array(F, dtype=float)
    q = np.array(Q, dtype=float)
    if f.ndim != 2 or f.shape[0] != f.shape[1]:
        raise ValueError(f"F must be square (d, d), got {f.shape}")
    d = f.shape[0]
    if q.shape != (d, d):
        raise ValueError(f"Q must have shape ({d}, {d}), got {q.shape}")
    check_finite("F", f)
    factor = _psd_factor("Q", q)

    def transition(rng: np.random.Generator, states: np.ndarray) -> np.ndarray:
        return states @ f.T + rng.standard_normal(states.shape) @ factor.T

    return transition


def linear_gaussian_log_likelihood(H: np.ndarray, R: np.ndarray):
    """Log-likelihood of ``z = H x + v``, ``v ~ N(0, R)``: ``log N(z; H x, R)``.

    Parameters
    ----------
    H : np.ndarray, shape (m, d)
        Observation matrix.
    R : np.ndarray, shape (m, m)
        Measurement noise covariance [m^2 for position measurements], symmetric positive
        definite.

    Returns
    -------
    callable
        ``log_likelihood(z (M, m), states (N, d), sensor=None) -> (M, N)`` [log of
        1 / (measurement units)]; the sensor position is accepted and ignored, so the same
        function serves :func:`update` and :class:`SmcPhdEstimator`.
    """
    h = np.array(H, dtype=float)
    r = np.array(R, dtype=float)
    if h.ndim != 2:
        raise ValueError(f"H must have shape (m, d), got {h.shape}")
    m, d = h.shape
    if r.shape != (m, m):
        raise ValueError(f"R must have shape ({m}, {m}), got {r.shape}")
    check_finite("H", h)
    check_finite("R", r)
    if not np.allclose(r, r.T, rtol=1e-9, atol=1e-12):
        raise ValueError("R must be symmetric")
    try:
        chol = np.linalg.cholesky(r)
    except np.linalg.LinAlgError:
        raise ValueError("R must be positive definite") from None
    whiten = np.linalg.inv(chol).T                         # y = nu @ whiten: L^-1 nu
    log_norm = -0.5 * m * np.log(2.0 * np.pi) - np.log(np.diagonal(chol)).sum()

    def log_likelihood(z: np.ndarray, states: np.ndarray,
                       sensor: np.ndarray | None = None) -> np.ndarray:
        z = check_measurements(z)
        if z.shape[0] and z.shape[1] != m:
            raise ValueError(f"measurements z must have shape (M, {m}), got {z.shape}")
        states = np.asarray(states, dtype=float)
        if states.ndim != 2 or states.shape[1] != d:
            raise ValueError(f"states must have shape (N, {d}), got {states.shape}")
        zw = z.reshape(-1, m) @ whiten                      # (M, m)
        ew = states @ (h.T @ whiten)                        # (N, m)
        # |zw - ew|^2 = |zw|^2 + |ew|^2 - 2 zw.ew: one matrix product and two broadcast
        # sums over the (M, N) array. Centred first, so that the cancellation costs
        # about 1e-16 of (extent / sd)^2, 1e-11 for a 200 m field and 1 m noise.
        centre = zw.mean(axis=0) if zw.shape[0] else np.zeros(m)
        zw = zw - centre
        ew = ew - centre
        out = zw @ ew.T                                     # (M, N)
        out += (log_norm - 0.5 * np.einsum("ij,ij->i", zw, zw))[:, None]
        out -= 0.5 * np.einsum("ij,ij->i", ew, ew)[None, :]
        return out

    return log_likelihood


def constant_p_d(p: float) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """A detection probability ``p`` for every particle: ``p_d(states, sensor) -> (N,)``."""
    check_probability("p_d", np.asarray(p, dtype=float))
    p = float(p)

    def p_d(states: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        return np.full(np.shape(states)[0], p)

    return p_d


def gaussian_measurement_sampler(R: np.ndarray, velocity_cov: np.ndarray,
                                 velocity_mean: np.ndarray | None = None) -> StateSampler:
    """Birth density b(x | z) of a position measurement: position ~ N(z, R), velocity prior.

    The inverse of ``z = [I 0] x + v``, ``v ~ N(0, R)``: the position is z plus measurement
    noise, the velocity (the other coordinates) is drawn from ``N(velocity_mean,
    velocity_cov)`` independently.

    Parameters
    ----------
    R : np.ndarray, shape (m, m)
        Measurement noise covariance [m^2], symmetric positive semi-definite.
    velocity_cov : np.ndarray, shape (d - m, d - m)
        Covariance of the remaining coordinates [m^2/s^2 for velocities].
    velocity_mean : np.ndarray, shape (d - m,), optional
        Their mean; zero by default.

    Returns
    -------
    callable
        ``sample_state(rng, z (M, m), n) -> (M * n, d)``, the n states of ``z[0]`` first.
    """
    r = np.array(R, dtype=float)
    vc = np.array(velocity_cov, dtype=float)
    if r.ndim != 2 or r.shape[0] != r.shape[1]:
        raise ValueError(f"R must be square (m, m), got {r.shape}")
    if vc.ndim != 2 or vc.shape[0] != vc.shape[1]:
        raise ValueError(f"velocity_cov must be square, got {vc.shape}")
    m, dv = r.shape[0], vc.shape[0]
    vm = np.zeros(dv) if velocity_mean is None else np.array(velocity_mean, dtype=float)
    if vm.shape != (dv,):
        raise ValueError(f"velocity_mean must have shape ({dv},), got {vm.shape}")
    check_finite("velocity_mean", vm)
    fr, fv = _psd_factor("R", r), _psd_factor("velocity_cov", vc)

    def sample_state(rng: np.random.Generator, z: np.ndarray, n: int) -> np.ndarray:
        z = np.asarray(z, dtype=float).reshape(-1, m)
        pos = np.repeat(z, n, axis=0) + rng.standard_normal((z.shape[0] * n, m)) @ fr.T
        vel = vm + rng.standard_normal((z.shape[0] * n, dv)) @ fv.T
        return np.hstack([pos, vel])

    return sample_state


def gaussian_birth(weights: np.ndarray, means: np.ndarray, covs: np.ndarray,
                   n_per_component: int, newborn: bool = False) -> BirthSampler:
    """A fixed birth intensity ``sum_b w_b N(x; m_b, P_b)`` as a particle sampler.

    Each call draws ``n_per_component`` particles from each component, of weight
    ``w_b / n_per_component`` each (Vo et al. 2005 step 1, proposal = the birth
    intensity).

    Parameters
    ----------
    weights : np.ndarray, shape (B,)
        Expected births per step of each component, >= 0.
    means : np.ndarray, shape (B, d)
        Component means.
    covs : np.ndarray, shape (B, d, d)
        Component covariances, symmetric positive semi-definite.
    n_per_component : int
        Particles drawn per component and step, >= 1.
    newborn : bool
        Flag of the drawn particles. False by default: births of an a-priori intensity
        are updated like any predicted target, with a missed-detection term, as in the
        standard PHD filter (and the GM-PHD of :mod:`.gm_phd.filter`). True treats them as the
        newborns of Ristic et al. 2012 (a target is born when first detected), which only
        makes sense for a birth intensity built from measurements.

    Returns
    -------
    callable
        ``birth(rng) -> ParticleSet`` of B * n_per_component particles.
    """
    w = np.array(weights, dtype=float).reshape(-1)
    mu = np.array(means, dtype=float)
    p = np.array(covs, dtype=float)
    b = w.shape[0]
    if mu.ndim != 2 or mu.shape[0] != b:
        raise ValueError(f"means must have shape ({b}, d), got {mu.shape}")
    d = mu.shape[1]
    if p.shape != (b, d, d):
        raise ValueError(f"covs must have shape ({b}, {d}, {d}), got {p.shape}")
    check_finite("weights", w)
    if np.any(w < 0.0):
        raise ValueError("birth weights must be >= 0")
    check_finite("means", mu)
    n = check_positive_int("n_per_component", n_per_component)
    factors = np.stack([_psd_factor(f"covs[{i}]", p[i]) for i in range(b)]) if b else p
    flag = bool(newborn)

    def birth(rng: np.random.Generator) -> ParticleSet:
        e = rng.standard_normal((b, n, d))
        states = mu[:, None, :] + np.einsum("bij,bnj->bni", factors, e)
        return ParticleSet(np.repeat(w / n, n), states.reshape(-1, d),
                           np.full(b * n, flag))

    return birth


def uniform_birth(low: np.ndarray, high: np.ndarray, mass: float, n: int,
                  newborn: bool = False) -> BirthSampler:
    """A birth intensity of total ``mass`` spread uniformly over the box [low, high).

    Parameters
    ----------
    low, high : np.ndarray, shape (d,)
        Corners of the box, in the units of the state; ``high >= low``.
    mass : float
        Expected births per step [-], >= 0.
    n : int
        Particles drawn per step, each of weight ``mass / n``, >= 1.
    newborn : bool
        Flag of the drawn particles (see :func:`gaussian_birth`).

    Returns
    -------
    callable
        ``birth(rng) -> ParticleSet`` of n particles (also usable for an initial intensity).
    """
    lo = np.array(low, dtype=float).reshape(-1)
    hi = np.array(high, dtype=float).reshape(-1)
    if hi.shape != lo.shape:
        raise ValueError(f"low and high must have the same shape, got {lo.shape} and "
                         f"{hi.shape}")
    check_finite("low", lo)
    check_finite("high", hi)
    if np.any(hi < lo):
        raise ValueError("high must be >= low in every coordinate")
    m = float(mass)
    if not np.isfinite(m) or m < 0.0:
        raise ValueError(f"mass must be finite and >= 0, got {mass!r}")
    count = check_positive_int("n", n)
    flag = bool(newborn)

    def birth(rng: np.random.Generator) -> ParticleSet:
        return ParticleSet(np.full(count, m / count), rng.uniform(lo, hi, (count, lo.size)),
                           np.full(count, flag))

    return birth


# ---------------------------------------------------------------- measurement-driven birth


def measurement_birth(z: np.ndarray, unassociated: np.ndarray, expected_births: float,
                      sample_state: StateSampler, n_per_measurement: int,
                      rng: np.random.Generator) -> ParticleSet:
    """Births at k+1 driven by the measurements of step k (Ristic, Clark, Vo & Vo 2012).

    Measurement z gets birth mass ``nu_B (1 - U(z)) / sum_z' (1 - U(z'))``, carried by
    ``n_per_measurement`` particles drawn from b(x | z) by ``sample_state``, each of weight
    ``mass(z) / n``, all newborn. A measurement the persistent particles fully explained
    (U(z) = 1) gets no births; if every measurement is explained (or Z is empty) there are
    no births at all (an empty set).

    Parameters
    ----------
    z : np.ndarray, shape (M, m)
        Measurements of step k.
    unassociated : np.ndarray, shape (M,)
        ``1 - U(z)`` from :func:`update` (``1 - result.persistent_mass``) [-], in [0, 1]
        (rounding excess of 1e-9 clipped).
    expected_births : float
        nu_B, expected number of births per step [-], finite, >= 0.
    sample_state : callable
        ``sample_state(rng, z (M, m), n) -> (M * n, d)``, the n states of ``z[0]`` first
        (e.g. :func:`gaussian_measurement_sampler`).
    n_per_measurement : int
        Particles per measurement, >= 1.
    rng : np.random.Generator
        Source of the states.

    Returns
    -------
    ParticleSet
        M * n newborn particles (the births of step k+1), or an empty set of dimension 0
        when Z is empty, or of the sampler's dimension when every z is explained.
    """
    rng = check_generator(rng)
    z = check_measurements(z)
    n_meas = z.shape[0]
    u = np.asarray(unassociated, dtype=float)
    if u.shape != (n_meas,):
        raise ValueError(f"unassociated must have shape ({n_meas},), got {u.shape}")
    check_finite("unassociated", u)
    if np.any((u < -_TOL) | (u > 1.0 + _TOL)):
        raise ValueError("unassociated (1 - U(z)) must lie in [0, 1]")
    u = np.clip(u, 0.0, 1.0)
    nu = float(expected_births)
    if not np.isfinite(nu) or nu < 0.0:
        raise ValueError(f"expected_births must be finite and >= 0, got {expected_births!r}")
    n = check_positive_int("n_per_measurement", n_per_measurement)
    if n_meas == 0:
        return ParticleSet.empty(0)
    states = np.asarray(sample_state(rng, z, n), dtype=float)
    if states.ndim != 2 or states.shape[0] != n_meas * n:
        raise ValueError(f"sample_state must return shape ({n_meas * n}, d), got "
                         f"{states.shape}")
    check_finite("sample_state(rng, z, n)", states)
    total = u.sum()
    if not total > 0.0:
        return ParticleSet.empty(states.shape[1])
    mass = nu * u / total
    return ParticleSet(np.repeat(mass / n, n), states, np.ones(n_meas * n, dtype=bool))
