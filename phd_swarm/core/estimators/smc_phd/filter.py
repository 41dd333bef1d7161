"""Sequential Monte Carlo (particle) PHD filter (Vo, Singh & Doucet 2005), vectorised.

The intensity (PHD) of the targets is carried by weighted particles,
``v(x) ~ sum_i w_i delta(x - x_i)``; the total weight is the expected number of targets.
The particle PHD filter of Vo, Singh & Doucet (2005; its steps 1-3: prediction, update,
resampling) with the proposal equal to the motion model, and two improvements from the
same group:

- newborn particles (those of the measurement-driven birth) get no missed-detection term
  and the update reports, per measurement, how much of it the persistent particles took,
  U(z), which drives the next births (Ristic, Clark, Vo & Vo 2012);
- the measurement-based state extraction, one estimate per measurement that the particles
  took with weight W(z) > 0.5, the weighted mean of their shares (Ristic, Clark & Vo 2010),
  next to the usual clustering into round(mass) clusters.

This module holds:

- :class:`ParticleSet`: the intensity as plain arrays, with ``to_arrays``/``from_arrays``
  for exchange between robots;
- :func:`predict`, :func:`update`, :func:`resample`: the three steps of the filter;
- :func:`extract` (k-means, :func:`scipy.cluster.vq.kmeans2` with k-means++ seeding) and
  :func:`extract_by_measurement`.

The models and the birth samplers (fixed, and the measurement-driven birth of Ristic et al.
2012) are in :mod:`.smc_phd.models`; the estimator role over these functions is
:class:`.smc_phd.estimator.SmcPhdEstimator`.

No loop runs over particles or measurements: the update is one (M, N) array of
log-likelihoods. All randomness comes from a :class:`numpy.random.Generator` passed in, so
a run is reproducible bit for bit from its seed.

The update, for predicted particles (w_i, x_i), persistent or newborn, measurements Z:

    C(z)   = sum_j p_D(x_j) g(z | x_j) w_j
    s_i(z) = p_D(x_i) g(z | x_i) w_i / (kappa(z) + C(z))        (share of particle i in z)
    w_i'   = (1 - p_D(x_i)) w_i [i persistent] + sum_z s_i(z)

(Vo et al. 2005 step 2 for persistent particles; Ristic et al. 2012 for the split
between persistent and newborn). It is computed in log space: with kappa = 0 a measurement
far from every particle is explained by the nearest ones instead of giving 0/0.

References
----------
B.-N. Vo, S. Singh and A. Doucet, "Sequential Monte Carlo methods for multi-target
filtering with random finite sets", IEEE Trans. Aerospace and Electronic Systems 41(4),
2005.
B. Ristic, D. Clark and B.-N. Vo, "Improved SMC implementation of the PHD filter", Proc.
13th Int. Conf. on Information Fusion, 2010.
B. Ristic, D. Clark, B.-N. Vo and B.-T. Vo, "Adaptive target birth intensity for PHD and
CPHD filters", IEEE Trans. Aerospace and Electronic Systems 48(2), 2012.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.cluster.vq import kmeans2, vq

from ...checks import (
    check_finite,
    check_generator,
    check_measurements,
    check_positive_int,
    check_probability,
)

#: Motion model sampler: (rng, states (N, d)) -> states one step later (N, d).
Transition = Callable[[np.random.Generator, np.ndarray], np.ndarray]
#: Log-likelihood: (z (M, m), states (N, d)) -> log g(z | x) (M, N).
LogLikelihood = Callable[[np.ndarray, np.ndarray], np.ndarray]
#: Birth sampler: rng -> the birth particles of one step.
BirthSampler = Callable[[np.random.Generator], "ParticleSet"]
#: Birth state sampler: (rng, z (M, m), n per measurement) -> states (M * n, d), the n
#: states of the first measurement first.
StateSampler = Callable[[np.random.Generator, np.ndarray, int], np.ndarray]

_TOL = 1e-9
#: Log of a term's ratio to the largest of its row below which the update drops it.
_LOG_NEGLIGIBLE = -700.0


def _round_half_up(x: float) -> int:
    """``floor(x + 1/2)``, the rounding of the GM-PHD's Table III."""
    return int(np.floor(x + 0.5))


def _check_states(name: str, states: np.ndarray, n: int, d: int) -> np.ndarray:
    states = np.asarray(states, dtype=float)
    if states.shape != (n, d):
        raise ValueError(f"{name} must have shape ({n}, {d}), got {states.shape}")
    check_finite(name, states)
    return states


# ---------------------------------------------------------------- the particle set


@dataclass(frozen=True, eq=False)
class ParticleSet:
    """A particle intensity ``sum_i w_i delta(x - x_i)``.

    The arrays are copied on construction and read-only.

    Attributes
    ----------
    weights : np.ndarray, shape (N,)
        Particle weights [expected number of targets each carries], finite, >= 0; their
        sum is the expected number of targets.
    states : np.ndarray, shape (N, d)
        Particle states, in the units of the state (the first two coordinates are the
        position [m] for :class:`.smc_phd.estimator.SmcPhdEstimator`).
    newborn : np.ndarray of bool, shape (N,)
        Particles of the measurement-driven birth, not yet updated (Ristic et al. 2012):
        they get no missed-detection term. Prediction turns every surviving particle
        persistent (False).
    """

    weights: np.ndarray
    states: np.ndarray
    newborn: np.ndarray

    def __post_init__(self) -> None:
        w = np.array(self.weights, dtype=float).reshape(-1)
        x = np.array(self.states, dtype=float)
        b = np.asarray(self.newborn)
        n = w.shape[0]
        if x.ndim != 2 or x.shape[0] != n:
            raise ValueError(f"states must have shape ({n}, d) to match the {n} weights, "
                             f"got {x.shape}")
        if b.shape != (n,):
            raise ValueError(f"newborn must have shape ({n},), got {b.shape}")
        if b.dtype != bool:
            if b.dtype.kind not in "iu" or np.any((b != 0) & (b != 1)):
                raise ValueError(f"newborn must be boolean, got dtype {b.dtype}")
        b = np.array(b, dtype=bool)
        check_finite("weights", w)
        if np.any(w < 0.0):
            i = int(np.flatnonzero(w < 0.0)[0])
            raise ValueError(f"weights must be >= 0: weight {i} is {w[i]!r}")
        check_finite("states", x)
        for name, a in (("weights", w), ("states", x), ("newborn", b)):
            a.flags.writeable = False
            object.__setattr__(self, name, a)

    @classmethod
    def empty(cls, dim: int) -> ParticleSet:
        """The zero intensity over a ``dim``-dimensional state."""
        return cls(np.empty(0), np.empty((0, dim)), np.empty(0, dtype=bool))

    @classmethod
    def concatenate(cls, sets: list[ParticleSet]) -> ParticleSet:
        """The sum of intensities: the particles of ``sets`` one after the other."""
        if not sets:
            raise ValueError("concatenate needs at least one particle set")
        dims = {s.dim for s in sets}
        if len(dims) != 1:
            raise ValueError(f"particle sets of different state dimensions {sorted(dims)}")
        return cls(np.concatenate([s.weights for s in sets]),
                   np.concatenate([s.states for s in sets]),
                   np.concatenate([s.newborn for s in sets]))

    def __len__(self) -> int:
        return self.weights.shape[0]

    @property
    def dim(self) -> int:
        """State dimension d."""
        return self.states.shape[1]

    @property
    def mass(self) -> float:
        """Total weight, the expected number of targets."""
        return float(self.weights.sum())

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Plain arrays for exchange, writable copies.

        Returns
        -------
        dict
            ``weights`` (N,) float64, ``states`` (N, d) float64, ``newborn`` (N,) bool.
        """
        return {"weights": self.weights.copy(), "states": self.states.copy(),
                "newborn": self.newborn.copy()}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray], dim: int | None = None
                    ) -> ParticleSet:
        """The particle set of :meth:`to_arrays`' output, validated.

        Parameters
        ----------
        arrays : mapping
            ``weights`` (N,), ``states`` (N, d), ``newborn`` (N,); real numbers, finite,
            weights >= 0, newborn boolean.
        dim : int, optional
            Expected state dimension d; checked if given.

        Raises
        ------
        ValueError
            Naming the missing key, the array of wrong type or shape, the non-finite or
            negative value.
        """
        missing = [k for k in ("weights", "states", "newborn") if k not in arrays]
        if missing:
            raise ValueError(f"particle arrays lack {missing}")
        for k in ("weights", "states"):
            kind = np.asarray(arrays[k]).dtype.kind
            if kind not in "fiu":
                raise ValueError(f"{k} must be real numbers, got dtype "
                                 f"{np.asarray(arrays[k]).dtype}")
        out = cls(arrays["weights"], arrays["states"], arrays["newborn"])
        if dim is not None and out.dim != dim:
            raise ValueError(f"particle states have dimension {out.dim}, expected {dim}")
        return out


# ---------------------------------------------------------------- prediction


def predict(particles: ParticleSet, transition: Transition,
            p_s: float | Callable[[np.ndarray], np.ndarray],
            birth: BirthSampler | ParticleSet | None, rng: np.random.Generator
            ) -> ParticleSet:
    """Predicted intensity v_{k|k-1}: survivors moved by the motion model, then births.

    Survivor i: ``x_i <- transition(rng, x_i)`` (a draw from f(. | x_i), the proposal of
    Vo et al. 2005 step 1 being the motion model), ``w_i <- p_S(x_i) w_i`` with p_S
    evaluated at the state before the move; every survivor is persistent afterwards. The
    births are appended unchanged (not moved: they are drawn at time k), with their own
    flags. Spawning is not modelled.

    Parameters
    ----------
    particles : ParticleSet
        Posterior intensity v_{k-1}, N particles of dimension d.
    transition : callable
        ``transition(rng, states (N, d)) -> (N, d)``, e.g.
        :func:`linear_gaussian_transition`.
    p_s : float or callable
        Survival probability over one step [-], in [0, 1], or ``p_s(states (N, d)) ->
        (N,)``.
    birth : callable, ParticleSet or None
        ``birth(rng) -> ParticleSet`` (a fixed birth intensity,
        :func:`.smc_phd.models.gaussian_birth`), particles already drawn (those of
        :func:`.smc_phd.models.measurement_birth` from the previous scan), or None for no births.
    rng : np.random.Generator
        Source of all randomness (the transition's, then the birth sampler's).

    Returns
    -------
    ParticleSet
        N survivors, then the births.
    """
    rng = check_generator(rng)
    n, d = len(particles), particles.dim
    if callable(p_s):
        ps = np.asarray(p_s(particles.states), dtype=float)
        if ps.shape != (n,):
            raise ValueError(f"p_s(states) must have shape ({n},), got {ps.shape}")
    else:
        ps = np.asarray(p_s, dtype=float)
        if ps.ndim:
            raise ValueError(f"p_s must be a number or a callable, got shape {ps.shape}")
    check_probability("p_s", ps)
    moved = _check_states("transition(rng, states)",
                          transition(rng, particles.states) if n else particles.states, n, d)
    survivors = ParticleSet(ps * particles.weights, moved, np.zeros(n, dtype=bool))
    if birth is None:
        return survivors
    born = birth if isinstance(birth, ParticleSet) else birth(rng)
    if not isinstance(born, ParticleSet):
        raise ValueError(f"birth(rng) must return a ParticleSet, got {type(born).__name__}")
    if len(born) == 0:
        return survivors
    if born.dim != d:
        raise ValueError(f"birth particles have dimension {born.dim}, the particles {d}")
    return ParticleSet.concatenate([survivors, born])


# ---------------------------------------------------------------- update


@dataclass(frozen=True, eq=False)
class SmcUpdateResult:
    """The posterior particles and, per measurement, how the particles shared it.

    Attributes
    ----------
    particles : ParticleSet
        Posterior intensity v_k: the predicted particles, reweighted; all keep their flags.
    persistent_mass : np.ndarray, shape (M,)
        U(z) = sum of s_i(z) over the persistent particles [-], in [0, 1]; ``1 - U(z)`` is
        how unassociated z is (Ristic et al. 2012), the input of
        :func:`.smc_phd.models.measurement_birth`.
    detection_mass : np.ndarray, shape (M,)
        W(z) = sum of s_i(z) over all particles [-], in [0, 1]; the rest, 1 - W(z), is the
        clutter's share kappa(z) / (kappa(z) + C(z)).
    detection_means : np.ndarray, shape (M, d)
        ``sum_i s_i(z) x_i / W(z)``, the state estimate of z for the measurement-based
        extraction (Ristic et al. 2010); zeros where W(z) = 0.
    """

    particles: ParticleSet
    persistent_mass: np.ndarray
    detection_mass: np.ndarray
    detection_means: np.ndarray


def update(particles: ParticleSet, z: np.ndarray, log_likelihood: LogLikelihood,
           p_d: float | np.ndarray, clutter: float | np.ndarray) -> SmcUpdateResult:
    """Posterior intensity v_k given the measurement set Z_k (Vo et al. 2005 step 2).

    ``w_i <- [(1 - p_D(x_i)) [i persistent] + sum_z s_i(z)] w_i`` with the share
    ``s_i(z) = p_D(x_i) g(z | x_i) w_i / (kappa(z) + C(z))``,
    ``C(z) = sum_j p_D(x_j) g(z | x_j) w_j`` over all particles, persistent and newborn;
    newborn particles get no missed-detection term (Ristic et al. 2012). Computed in log
    space with one (M, N) array: ``log C(z)`` by a log-sum-exp, so a measurement far from
    every particle gives shares of the nearest particles (kappa = 0) or zero shares
    (kappa > 0), never 0/0; a measurement no particle can explain (all p_D w g = 0) with
    kappa = 0 gives zero shares.

    Parameters
    ----------
    particles : ParticleSet
        Predicted intensity v_{k|k-1}, N particles of dimension d.
    z : np.ndarray, shape (M, m)
        Measurements, finite (M may be 0).
    log_likelihood : callable
        ``log_likelihood(z (M, m), states (N, d)) -> (M, N)``, log g(z | x) [log of
        1 / (measurement units)]; -inf for a zero likelihood, never NaN or +inf.
    p_d : float or np.ndarray, shape (N,)
        Detection probability of each particle [-], in [0, 1].
    clutter : float or np.ndarray, shape (M,)
        kappa(z), the clutter intensity at each measurement [1 / (measurement units), 1/m^2
        for 2-D positions], finite, >= 0.

    Returns
    -------
    SmcUpdateResult
        The posterior particles; U(z), W(z) and the share-weighted mean state of each
        measurement.
    """
    z = check_measurements(z)
    n, d, n_meas = len(particles), particles.dim, z.shape[0]
    p_d = np.broadcast_to(np.asarray(p_d, dtype=float), (n,)) if np.ndim(p_d) == 0 \
        else np.asarray(p_d, dtype=float)
    if p_d.shape != (n,):
        raise ValueError(f"p_d must have shape ({n},), got {p_d.shape}")
    check_probability("p_d", p_d)
    kappa = np.asarray(clutter, dtype=float)
    if kappa.ndim and kappa.shape != (n_meas,):
        raise ValueError(f"clutter must be a number or have shape ({n_meas},), got "
                         f"{kappa.shape}")
    check_finite("clutter", kappa)
    if np.any(kappa < 0.0):
        raise ValueError("clutter must be >= 0")
    w = particles.weights
    w_missed = np.where(particles.newborn, 0.0, (1.0 - p_d) * w)
    if n == 0 or n_meas == 0:
        return SmcUpdateResult(
            ParticleSet(w_missed, particles.states, particles.newborn),
            np.zeros(n_meas), np.zeros(n_meas), np.zeros((n_meas, d)))

    log_g = np.asarray(log_likelihood(z, particles.states), dtype=float)
    if log_g.shape != (n_meas, n):
        raise ValueError(f"log_likelihood must return shape ({n_meas}, {n}), got "
                         f"{log_g.shape}")
    with np.errstate(divide="ignore"):
        log_num = log_g + np.log(p_d * w)[None, :]               # (M, N), a new array
        log_kappa = np.broadcast_to(np.log(kappa), (n_meas,))
    top = log_num.max(axis=1)                                    # (M,)
    if np.any(np.isnan(top) | (top == np.inf)):    # any NaN or +inf of log_g shows here
        raise ValueError("log_likelihood must not return NaN or +inf")
    explained = top > -np.inf
    top[~explained] = 0.0
    log_num -= top[:, None]
    # exp underflows below about -708, and is several times slower there (subnormal
    # results); terms below e^-700 of the row's largest are raised to e^-700 instead
    # (1e-304 of the largest: no sum or mean moves by a representable amount, and one pass
    # over the array is saved against zeroing them).
    np.maximum(log_num, _LOG_NEGLIGIBLE, out=log_num)
    raw = np.exp(log_num, out=log_num)             # p_D g w / e^top, (M, N), max 1 a row
    # One pass over the (M, N) array gives, per measurement, C(z) e^-top, the persistent
    # part and the state sums; the shares s_i(z) = raw * factor(z) are never formed.
    columns = np.empty((n, d + 2))
    columns[:, :d] = particles.states
    columns[:, d] = ~particles.newborn
    columns[:, d + 1] = 1.0
    row = raw @ columns                                          # (M, d + 2)
    with np.errstate(divide="ignore"):
        log_c = np.log(row[:, d + 1]) + top                      # log C(z)
    log_den = np.logaddexp(log_kappa, log_c)                     # log (kappa + C(z))
    # s_i(z) = (p_D g w / e^top) e^(top - log_den): the factor is <= 1 where some particle
    # explains z; rows nothing explains are zero (not 0 * inf when kappa = 0).
    with np.errstate(over="ignore", invalid="ignore"):
        factor = np.where(explained, np.exp(top - log_den), 0.0)
    w_post = w_missed + factor @ raw
    row *= factor[:, None]
    det_mass, persistent_mass, sums = row[:, d + 1], row[:, d], row[:, :d]
    means = np.divide(sums, det_mass[:, None], out=np.zeros_like(sums),
                      where=det_mass[:, None] > 0.0)
    return SmcUpdateResult(ParticleSet(w_post, particles.states, particles.newborn),
                           np.clip(persistent_mass, 0.0, 1.0),
                           np.clip(det_mass, 0.0, 1.0), means)


# ---------------------------------------------------------------- resampling


def particle_count(mass: float, n: int | None = None, per_target: int | None = None,
                   min_particles: int | None = None, max_particles: int | None = None
                   ) -> int:
    """Number of particles after resampling.

    ``n`` if given; otherwise ``per_target * round(mass)`` (Vo et al. 2005: a fixed number
    of particles per expected target, round half up), at least ``min_particles``
    (``per_target`` by default, so a mass below 1/2 keeps one target's worth) and at most
    ``max_particles`` (no cap by default). Without either, see :func:`resample`.
    """
    if n is not None and per_target is not None:
        raise ValueError("give either n or per_target, not both")
    if n is not None:
        return check_positive_int("n", n)
    per = check_positive_int("per_target", per_target)
    floor = per if min_particles is None else check_positive_int("min_particles", min_particles)
    count = max(floor, per * _round_half_up(mass))
    if max_particles is not None:
        count = min(count, check_positive_int("max_particles", max_particles))
    return count


def resample(particles: ParticleSet, rng: np.random.Generator, n: int | None = None,
             per_target: int | None = None, min_particles: int | None = None,
             max_particles: int | None = None) -> ParticleSet:
    """Systematic resampling that keeps the total mass (Vo et al. 2005 step 3).

    With ``mass = sum_i w_i``, ``L`` particles are chosen by systematic resampling from the
    normalised weights (one uniform draw u ~ U[0, 1/L), positions ``u + l / L``), each of
    weight ``mass / L``; the chosen particles keep their states and newborn flags.
    Particles of zero weight are never chosen. An empty or massless set gives an empty set.

    Parameters
    ----------
    particles : ParticleSet
        N particles.
    rng : np.random.Generator
        Source of the one uniform draw.
    n : int, optional
        Fixed number of particles L.
    per_target, min_particles, max_particles : int, optional
        ``L = clip(per_target * round(mass), min_particles, max_particles)``
        (:func:`particle_count`).

    With neither ``n`` nor ``per_target``, L = N.

    Returns
    -------
    ParticleSet
        L particles of equal weight, in the order of the originals.
    """
    rng = check_generator(rng)
    mass = particles.mass
    if n is None and per_target is None:
        n = max(len(particles), 1)
    count = particle_count(mass, n, per_target, min_particles, max_particles)
    if len(particles) == 0 or not mass > 0.0:
        return ParticleSet.empty(particles.dim)
    cdf = np.cumsum(particles.weights)
    cdf /= cdf[-1]
    cdf[-1] = 1.0
    positions = (rng.random() + np.arange(count)) / count
    idx = np.minimum(np.searchsorted(cdf, positions, side="right"), len(particles) - 1)
    return ParticleSet(np.full(count, mass / count), particles.states[idx],
                       particles.newborn[idx])


# ---------------------------------------------------------------- extraction


def _kmeans2(data: np.ndarray, k: int, rng: np.random.Generator, iterations: int):
    """:func:`scipy.cluster.vq.kmeans2` with k-means++ seeding from ``rng``.

    SciPy >= 1.15 takes ``rng``; older versions (the distribution's python3-scipy) take
    the same Generator as ``seed``. An empty cluster keeps its previous centroid (SciPy's
    'warn' behaviour, without the warning).
    """
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="One of the clusters is empty")
        try:
            return kmeans2(data, int(k), iter=iterations, minit="++", rng=rng)
        except TypeError:                                   # SciPy < 1.15
            return kmeans2(data, int(k), iter=iterations, minit="++", seed=rng)


def extract(particles: ParticleSet, rng: np.random.Generator, position_dims: int = 2,
            iterations: int = 10, max_points: int = 2000) -> np.ndarray:
    """round(mass) state estimates by k-means clustering of the particle positions.

    The number of targets is ``K = round(mass)`` (half up). The particles are reduced to an
    equally weighted sample (themselves if their weights are equal and they are at most
    ``max_points``, otherwise ``max_points`` drawn by systematic resampling), clustered into
    K clusters on their first ``position_dims`` coordinates by
    :func:`scipy.cluster.vq.kmeans2` (k-means++ seeding from ``rng``); then every particle
    joins its nearest centroid and each cluster's estimate is the weighted mean of its
    members' full states. A cluster that ends with no weight is dropped (fewer than K
    estimates); with fewer distinct positions than K, K is that number.

    Parameters
    ----------
    particles : ParticleSet
        N particles of dimension d >= position_dims.
    rng : np.random.Generator
        Source of the resampling and the k-means++ seeding.
    position_dims : int
        Leading state coordinates clustered on [m].
    iterations : int
        k-means iterations.
    max_points : int
        Largest sample given to k-means.

    Returns
    -------
    np.ndarray, shape (K, d)
        Estimated states, heaviest cluster first.
    """
    rng = check_generator(rng)
    d = particles.dim
    pd_ = check_positive_int("position_dims", position_dims)
    if pd_ > d:
        raise ValueError(f"position_dims {pd_} exceeds the state dimension {d}")
    iterations = check_positive_int("iterations", iterations)
    max_points = check_positive_int("max_points", max_points)
    k = _round_half_up(particles.mass)
    if k == 0 or len(particles) == 0:
        return np.empty((0, d))
    w = particles.weights
    if len(particles) <= max_points and np.all(w == w[0]):
        sample = particles.states
    else:
        sample = resample(particles, rng, n=max_points).states
    pos = np.ascontiguousarray(sample[:, :pd_])
    k = min(k, len(np.unique(pos, axis=0)))
    centroids, _ = _kmeans2(pos, k, rng, iterations)
    labels, _ = vq(np.ascontiguousarray(particles.states[:, :pd_]), centroids)
    mass = np.bincount(labels, weights=w, minlength=k)
    sums = np.stack([np.bincount(labels, weights=w * particles.states[:, c], minlength=k)
                     for c in range(d)], axis=1)
    keep = np.flatnonzero(mass > 0.0)
    keep = keep[np.argsort(-mass[keep], kind="stable")]
    return sums[keep] / mass[keep, None]


def extract_by_measurement(result: SmcUpdateResult, threshold: float = 0.5) -> np.ndarray:
    """Measurement-based state extraction (Ristic, Clark & Vo 2010).

    Each measurement z whose particles took weight W(z) > ``threshold`` (0.5 in the paper)
    gives one estimate, the weighted mean of the particle states by their shares s_i(z)
    (``result.detection_means``). No clustering; missed targets give no estimate.

    Parameters
    ----------
    result : SmcUpdateResult
        The update that produced the posterior.
    threshold : float
        Least W(z) for an estimate [-], in [0, 1).

    Returns
    -------
    np.ndarray, shape (K, d)
        Estimated states, in measurement order.
    """
    t = float(threshold)
    if not 0.0 <= t < 1.0:
        raise ValueError(f"threshold must lie in [0, 1), got {threshold!r}")
    return result.detection_means[result.detection_mass > t].copy()
