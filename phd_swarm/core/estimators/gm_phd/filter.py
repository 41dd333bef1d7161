"""Gaussian-mixture PHD filter (Vo & Ma 2006), linear-Gaussian models, vectorised.

The intensity (PHD) of the targets is a weighted sum of Gaussians
``v(x) = sum_j w_j N(x; m_j, P_j)``; under linear-Gaussian motion and measurement models
the PHD recursion keeps that form (Vo & Ma 2006, Propositions 1-2). This module holds:

- :class:`GmPhdModel`: the models and the reduction settings (frozen, validated);
- :class:`GaussianMixture`: the intensity as plain arrays;
- :func:`predict` (Table I steps 1-2), :func:`update` (Table I steps 3-4, with a detection
  probability per component), :func:`prune_and_merge` (Table II, its arithmetic in
  :mod:`.gm_phd.reduce`; :func:`prune_and_merge_carrying` also sums what the components
  carry), :func:`extract` (Table III);
- :func:`linear_terms` and :func:`update_with_terms`: the update split in two, so that a
  nonlinear measurement model (the benchmark's EKF / UKF forms of the range-bearing sensor,
  ``bench/gm_phd_nonlinear.py``) only supplies the Kalman terms.

The estimator role over these functions is :class:`.gm_phd.estimator.GmPhdEstimator`.

The detection probability is given per component (the caller evaluates it at the mean, or
integrates it over the component: :mod:`.fov_detection`), which is exact when p_D is constant
over each component's support and an approximation otherwise; the paper's
Gaussian-mixture p_D extension is not implemented. New components come from the birth
intensity (A.3), from spawning (A.3, Table I step 1) and, in the estimator, from
the measurement-driven birth rules of :mod:`.gm_phd.births`.

Reference: B.-N. Vo and W.-K. Ma, "The Gaussian mixture probability hypothesis density
filter", IEEE Trans. Signal Processing 54(11), 2006.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...checks import check_finite, check_measurements, check_probability, check_spd
from .reduce import carry, check_merge_metric, reduce_components, reduce_with_sources

#: p_D evaluator: (means (J, d), covs (J, d, d), sensor position (2,) [m]) -> p_D (J,).
DetectionProbability = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class GaussianMixture:
    """A Gaussian-mixture intensity ``sum_j w_j N(x; m_j, P_j)``.

    Attributes
    ----------
    weights : np.ndarray, shape (J,)
        Component weights (expected number of targets each carries) [-].
    means : np.ndarray, shape (J, d)
        Component means, in the units of the state.
    covs : np.ndarray, shape (J, d, d)
        Component covariances.
    """

    weights: np.ndarray
    means: np.ndarray
    covs: np.ndarray

    def __post_init__(self) -> None:
        w = np.asarray(self.weights, dtype=float).reshape(-1)
        m = np.asarray(self.means, dtype=float)
        p = np.asarray(self.covs, dtype=float)
        j = w.shape[0]
        if m.ndim != 2 or m.shape[0] != j:
            raise ValueError(f"means must have shape ({j}, d), got {m.shape}")
        d = m.shape[1]
        if p.shape != (j, d, d):
            raise ValueError(f"covs must have shape ({j}, {d}, {d}), got {p.shape}")
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "means", m)
        object.__setattr__(self, "covs", p)

    @classmethod
    def empty(cls, dim: int) -> GaussianMixture:
        """The zero intensity over a ``dim``-dimensional state."""
        return cls(np.empty(0), np.empty((0, dim)), np.empty((0, dim, dim)))

    def __len__(self) -> int:
        return self.weights.shape[0]

    @property
    def dim(self) -> int:
        """State dimension d."""
        return self.means.shape[1]

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The mixture as plain float64 arrays ``{"weights", "means", "covs"}`` (copies)."""
        return {"weights": self.weights.copy(), "means": self.means.copy(),
                "covs": self.covs.copy()}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], where: str = "mixture"
                    ) -> GaussianMixture:
        """A mixture from :meth:`to_arrays` output, checked.

        What came over a link is refused with a ``ValueError`` naming ``where`` and the
        field if it is malformed: a missing field, shapes, NaN or inf, a negative weight, a
        covariance that is not symmetric positive definite.
        """
        missing = [k for k in ("weights", "means", "covs") if k not in arrays]
        if missing:
            raise ValueError(f"{where}: missing {', '.join(missing)}")
        try:
            mix = cls(arrays["weights"], arrays["means"], arrays["covs"])
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{where}: {exc}") from None
        for name in ("weights", "means"):
            if not np.all(np.isfinite(getattr(mix, name))):
                raise ValueError(f"{where}: {name} must be finite (no NaN or inf)")
        if np.any(mix.weights < 0.0):
            raise ValueError(f"{where}: weights must be >= 0, got {mix.weights.min()}")
        if len(mix):
            try:
                check_spd("covs", mix.covs)
            except ValueError as exc:
                raise ValueError(f"{where}: {exc}") from None
        return mix


@dataclass(frozen=True, eq=False)
class GmPhdModel:
    """Linear-Gaussian model and reduction settings of the GM-PHD filter (Vo & Ma A.1-A.3).

    Attributes
    ----------
    F : np.ndarray, shape (d, d)
        State transition matrix (A.1).
    Q : np.ndarray, shape (d, d)
        Process noise covariance (A.1), symmetric positive definite.
    H : np.ndarray, shape (m, d)
        Observation matrix (A.1).
    R : np.ndarray, shape (m, m)
        Measurement noise covariance (A.1) [m^2 for position measurements], SPD.
    p_s : float
        Survival probability over one step (A.2) [-], in [0, 1].
    birth_weights : np.ndarray, shape (B,)
        Birth intensity weights (A.3) [expected births per step each], >= 0.
    birth_means : np.ndarray, shape (B, d)
        Birth intensity means.
    birth_covs : np.ndarray, shape (B, d, d)
        Birth intensity covariances, SPD.
    clutter_intensity : float
        kappa, the clutter intensity in measurement space [1/m^2 for 2-D positions],
        constant over the space, >= 0.
    prune_threshold : float
        T of Table II: components with weight <= T are dropped [-].
    merge_threshold : float
        U of Table II: Mahalanobis (squared) distance within which components merge [-].
    merge_metric : {"candidate", "heaviest"}
        Whose covariance U is measured in (:mod:`.gm_phd.reduce`): each candidate's, as Table II
        prints it, or the heaviest component's, as Vo's MATLAB ``gaus_merge.m``.
    max_components : int
        J_max of Table II.
    extraction_threshold : float
        Weight above which a component yields estimates (Table III) [-].
    spawn_weights : np.ndarray, shape (S,)
        Spawn intensity weights w_beta (A.3) [expected spawns per target per step]; none by
        default.
    spawn_F : np.ndarray, shape (S, d, d)
        Spawn transition matrices F_beta (A.3).
    spawn_offsets : np.ndarray, shape (S, d)
        Spawn offsets d_beta (A.3).
    spawn_Q : np.ndarray, shape (S, d, d)
        Spawn covariances Q_beta (A.3), SPD.
    """

    F: np.ndarray
    Q: np.ndarray
    H: np.ndarray
    R: np.ndarray
    p_s: float
    birth_weights: np.ndarray
    birth_means: np.ndarray
    birth_covs: np.ndarray
    clutter_intensity: float
    prune_threshold: float = 1e-5
    merge_threshold: float = 4.0
    # Table II as printed: on `scripts/bench.sh estimators` A and B (seeds 1-10) the two
    # rules differ by less than the seed-to-seed noise, on C "candidate" is better with the
    # integrated p_D (docs/decisions.md). The Sung & Tokekar and Shirsat & Berman parts
    # default to "heaviest", as Vo's code.
    merge_metric: str = "candidate"
    max_components: int = 100
    extraction_threshold: float = 0.5
    spawn_weights: np.ndarray | None = None
    spawn_F: np.ndarray | None = None
    spawn_offsets: np.ndarray | None = None
    spawn_Q: np.ndarray | None = None

    def __post_init__(self) -> None:
        d = np.shape(self.F)[0] if np.ndim(self.F) == 2 else 0
        defaults = {"spawn_weights": np.empty(0), "spawn_F": np.empty((0, d, d)),
                    "spawn_offsets": np.empty((0, d)), "spawn_Q": np.empty((0, d, d))}
        for name, empty in defaults.items():
            if getattr(self, name) is None:
                object.__setattr__(self, name, empty)
        arrays = {}
        for name in ("F", "Q", "H", "R", "birth_weights", "birth_means", "birth_covs",
                     *defaults):
            a = np.array(getattr(self, name), dtype=float)
            a.flags.writeable = False
            arrays[name] = a
            object.__setattr__(self, name, a)
        f, q, h, r = arrays["F"], arrays["Q"], arrays["H"], arrays["R"]
        if f.ndim != 2 or f.shape[0] != f.shape[1]:
            raise ValueError(f"F must be square (d, d), got {f.shape}")
        d = f.shape[0]
        if q.shape != (d, d):
            raise ValueError(f"Q must have shape ({d}, {d}), got {q.shape}")
        if h.ndim != 2 or h.shape[1] != d:
            raise ValueError(f"H must have shape (m, {d}), got {h.shape}")
        m = h.shape[0]
        if r.shape != (m, m):
            raise ValueError(f"R must have shape ({m}, {m}), got {r.shape}")
        bw, bm, bc = arrays["birth_weights"], arrays["birth_means"], arrays["birth_covs"]
        if bw.ndim != 1:
            raise ValueError(f"birth_weights must have shape (B,), got {bw.shape}")
        b = bw.shape[0]
        if bm.shape != (b, d):
            raise ValueError(f"birth_means must have shape ({b}, {d}), got {bm.shape}")
        if bc.shape != (b, d, d):
            raise ValueError(f"birth_covs must have shape ({b}, {d}, {d}), got {bc.shape}")
        check_finite("F", f)
        check_finite("H", h)
        check_spd("Q", q)
        check_spd("R", r)
        check_finite("birth_weights", bw)
        if np.any(bw < 0.0):
            raise ValueError("birth_weights must be >= 0")
        check_finite("birth_means", bm)
        check_spd("birth_covs", bc)
        sw, sf, so, sq = (arrays[k] for k in defaults)
        n_spawn = sw.shape[0] if sw.ndim == 1 else -1
        for name, a, shape in (("spawn_weights", sw, (n_spawn,)),
                               ("spawn_F", sf, (n_spawn, d, d)),
                               ("spawn_offsets", so, (n_spawn, d)),
                               ("spawn_Q", sq, (n_spawn, d, d))):
            if n_spawn < 0 or a.shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
            check_finite(name, a)
        if np.any(sw < 0.0):
            raise ValueError("spawn_weights must be >= 0")
        if n_spawn:
            check_spd("spawn_Q", sq)
        check_probability("p_s", np.asarray(self.p_s, dtype=float))
        for name in ("clutter_intensity", "prune_threshold", "merge_threshold",
                     "extraction_threshold"):
            v = float(getattr(self, name))
            if not np.isfinite(v) or v < 0.0:
                raise ValueError(f"{name} must be finite and >= 0, got {v}")
            object.__setattr__(self, name, v)
        object.__setattr__(self, "p_s", float(self.p_s))
        check_merge_metric(self.merge_metric)
        if int(self.max_components) != self.max_components or self.max_components < 1:
            raise ValueError(f"max_components must be an integer >= 1, got "
                             f"{self.max_components!r}")
        object.__setattr__(self, "max_components", int(self.max_components))

    @property
    def dim(self) -> int:
        """State dimension d."""
        return self.F.shape[0]

    @property
    def measurement_dim(self) -> int:
        """Measurement dimension m."""
        return self.H.shape[0]


def _check_mixture(mix: GaussianMixture, model: GmPhdModel) -> None:
    if mix.dim != model.dim:
        raise ValueError(f"mixture state dimension {mix.dim} != model dimension {model.dim}")


def predict(mix: GaussianMixture, model: GmPhdModel) -> GaussianMixture:
    """Predicted intensity v_{k|k-1}: births, spawns and survivors (Table I steps 1-2).

    Births are the birth intensity (A.3). Spawn beta of component j (Proposition 1):
    ``w = w_j w_beta``, ``m = F_beta m_j + d_beta``, ``P = Q_beta + F_beta P_j F_beta^T``.
    Surviving component j: ``w = p_S w_j``, ``m = F m_j``, ``P = Q + F P_j F^T``.

    Parameters
    ----------
    mix : GaussianMixture
        Posterior intensity v_{k-1}, J components of dimension d.
    model : GmPhdModel
        Motion model (F, Q, p_S), birth intensity (B components), spawn intensity (S terms).

    Returns
    -------
    GaussianMixture
        B + S J + J components: the births, the spawns (for each spawn term, one per
        component of ``mix``), then the survivors in the order of ``mix``.
    """
    _check_mixture(mix, model)
    f = model.F
    means = mix.means @ f.T
    covs = f @ mix.covs @ f.T + model.Q
    weights = [model.birth_weights]
    all_means = [model.birth_means]
    all_covs = [model.birth_covs]
    if model.spawn_weights.size and len(mix):
        fb = model.spawn_F[:, None]                                     # (S, 1, d, d)
        weights.append((model.spawn_weights[:, None] * mix.weights[None, :]).reshape(-1))
        all_means.append((np.einsum("sik,jk->sji", model.spawn_F, mix.means)
                          + model.spawn_offsets[:, None, :]).reshape(-1, model.dim))
        spawn_covs = fb @ mix.covs[None] @ np.swapaxes(fb, -1, -2) + model.spawn_Q[:, None]
        all_covs.append(spawn_covs.reshape(-1, model.dim, model.dim))
    return GaussianMixture(np.concatenate([*weights, model.p_s * mix.weights]),
                           np.concatenate([*all_means, means]),
                           np.concatenate([*all_covs, covs]))


def update(mix: GaussianMixture, z: np.ndarray, model: GmPhdModel,
           p_d: np.ndarray) -> GaussianMixture:
    """Posterior intensity v_k given the measurement set Z_k (Table I steps 3-4, Proposition 2).

    For component j (predicted weight w_j, mean m_j, covariance P_j) and measurement z:
    ``eta_j = H m_j``, ``S_j = R + H P_j H^T``, ``K_j = P_j H^T S_j^-1`` (step 3);
    missed detection ``(1 - p_D,j) w_j`` with (m_j, P_j) unchanged; detection by z
    ``w_j(z) = p_D,j w_j q_j(z) / (kappa + sum_l p_D,l w_l q_l(z))`` with
    ``q_j(z) = N(z; eta_j, S_j)``, mean ``m_j + K_j (z - eta_j)`` and the updated covariance
    (step 4). With an empty scan only the missed-detection terms remain.

    Parameters
    ----------
    mix : GaussianMixture
        Predicted intensity v_{k|k-1}, J components of dimension d.
    z : np.ndarray, shape (M, m)
        Measurements, in the units of the measurement space (M may be 0).
    model : GmPhdModel
        Measurement model (H, R) and clutter intensity kappa [1/m^2 for 2-D positions].
    p_d : np.ndarray, shape (J,)
        Detection probability of each component [-], in [0, 1].

    Returns
    -------
    GaussianMixture
        J (1 + M) components: the J missed-detection terms, then J per measurement, in
        measurement order.
    """
    _check_mixture(mix, model)
    z = check_measurements(z, model.measurement_dim)
    p_d = check_p_d(p_d, len(mix))
    if len(mix) == 0 or z.shape[0] == 0:
        return GaussianMixture((1.0 - p_d) * mix.weights, mix.means.copy(), mix.covs.copy())
    terms = linear_terms(mix, model.H, model.R)
    return update_with_terms(mix, z, terms, p_d, model.clutter_intensity).mixture


def check_p_d(p_d: np.ndarray, n: int) -> np.ndarray:
    """``p_d`` as a float array (n,) in [0, 1], refused with a clear error otherwise."""
    p_d = np.asarray(p_d, dtype=float)
    if p_d.shape != (n,):
        raise ValueError(f"p_d must have shape ({n},), got {p_d.shape}")
    check_probability("p_d", p_d)
    return p_d


@dataclass(frozen=True, eq=False)
class KalmanTerms:
    """What the update of each component needs, whatever linearised the measurement model.

    Attributes
    ----------
    eta : np.ndarray, shape (J, m)
        Predicted measurement of each component.
    s : np.ndarray, shape (J, m, m)
        Innovation covariance of each component, symmetric positive definite.
    gain : np.ndarray, shape (J, d, m)
        Kalman gain of each component (the cross-covariance times S^-1).
    covs : np.ndarray, shape (J, d, d)
        Updated covariance of each component (one for all measurements).
    innovation : callable, optional
        ``innovation(z (M, m), eta (J, m)) -> (M, J, m)``; plain ``z - eta`` by default, a
        wrapped difference for angles.
    """

    eta: np.ndarray
    s: np.ndarray
    gain: np.ndarray
    covs: np.ndarray
    innovation: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None


def linear_terms(mix: GaussianMixture, h: np.ndarray, r: np.ndarray) -> KalmanTerms:
    """Kalman terms of the linear-Gaussian measurement model z = H x + v, v ~ N(0, R) (step 3)."""
    eta = mix.means @ h.T                                   # (J, m)
    pht = mix.covs @ h.T                                    # (J, d, m)
    s = h @ pht + r                                         # (J, m, m)
    s = 0.5 * (s + np.swapaxes(s, -1, -2))
    gain = pht @ np.linalg.inv(s)                           # (J, d, m)
    # Joseph form (I - K H) P (I - K H)^T + K R K^T: it stays symmetric positive
    # semi-definite under rounding for any gain, where (I - K H) P loses symmetry and can
    # go indefinite when R is small against P. It is computed once per component (all
    # measurements share it), so its extra products cost nothing per measurement.
    # The sum is symmetrised too, so that the result is symmetric bit for bit.
    ikh = np.eye(mix.dim) - gain @ h                        # (J, d, d)
    covs = (ikh @ mix.covs @ np.swapaxes(ikh, -1, -2)
            + gain @ r @ np.swapaxes(gain, -1, -2))
    return KalmanTerms(eta, s, gain, 0.5 * (covs + np.swapaxes(covs, -1, -2)))


@dataclass(frozen=True, eq=False)
class UpdateResult:
    """The posterior mixture and, per measurement, how its mass was shared.

    Attributes
    ----------
    mixture : GaussianMixture
        J (1 + M) components: the J missed-detection terms, then J per measurement.
    detection_weights : np.ndarray, shape (M, J)
        w_j(z), the weight measurement z gave component j [-]; row sums are <= 1, the
        rest of each row being the clutter's share kappa(z) / L(z).
    """

    mixture: GaussianMixture
    detection_weights: np.ndarray


def update_with_terms(mix: GaussianMixture, z: np.ndarray, terms: KalmanTerms,
                      p_d: np.ndarray, clutter: float | np.ndarray,
                      missed: np.ndarray | None = None) -> UpdateResult:
    """Table I step 4 given the Kalman terms of every component, vectorised over J x M.

    ``w_j(z) = p_D,j w_j N(z; eta_j, S_j) / (kappa(z) + sum_l p_D,l w_l N(z; eta_l, S_l))``,
    mean ``m_j + K_j (z - eta_j)``, covariance ``terms.covs``; the missed-detection terms
    ``(1 - p_D,j) w_j`` come first.

    Parameters
    ----------
    mix : GaussianMixture
        Predicted intensity, J components.
    z : np.ndarray, shape (M, m)
        Checked measurements (:func:`check_measurements`).
    terms : KalmanTerms
        Per-component predicted measurement, innovation covariance, gain, updated covariance.
    p_d : np.ndarray, shape (J,)
        Checked detection probabilities (:func:`check_p_d`).
    clutter : float or np.ndarray, shape (M,)
        kappa(z), the clutter intensity at each measurement, in 1 / (measurement units).
    missed : np.ndarray of bool, shape (J,), optional
        Components that keep a missed-detection term; all by default. A component without
        one (a newborn of the measurement-driven birth) has weight 0 there.
    """
    n_comp, n_meas = len(mix), z.shape[0]
    nz = z.shape[1]
    w_missed = (1.0 - p_d) * mix.weights
    if missed is not None:
        w_missed = np.where(missed, w_missed, 0.0)
    if n_comp == 0 or n_meas == 0:
        return UpdateResult(GaussianMixture(w_missed, mix.means.copy(), mix.covs.copy()),
                            np.zeros((n_meas, n_comp)))
    chol = np.linalg.cholesky(terms.s)
    s_inv = np.linalg.inv(terms.s)
    if terms.innovation is None:
        nu = z[:, None, :] - terms.eta[None, :, :]          # (M, J, m)
    else:
        nu = terms.innovation(z, terms.eta)
    maha = np.einsum("mji,jik,mjk->mj", nu, s_inv, nu)
    log_det = 2.0 * np.log(np.diagonal(chol, axis1=-2, axis2=-1)).sum(axis=-1)  # (J,)
    log_q = -0.5 * (maha + log_det + nz * np.log(2.0 * np.pi))             # (M, J)
    # In log space: with kappa = 0 a measurement far from every component still divides
    # by the largest term instead of giving 0/0.
    with np.errstate(divide="ignore"):
        log_num = np.log(p_d * mix.weights)[None, :] + log_q                # (M, J)
        log_kappa = np.broadcast_to(np.log(np.asarray(clutter, dtype=float)), (n_meas,))
    log_den = _logsumexp_rows(np.concatenate([log_kappa[:, None], log_num], axis=1))
    with np.errstate(invalid="ignore"):
        w_det = np.exp(log_num - log_den[:, None])
    w_det[~np.isfinite(log_den)] = 0.0

    means_det = mix.means[None, :, :] + np.einsum("jdk,mjk->mjd", terms.gain, nu)
    d = mix.dim
    out = GaussianMixture(
        np.concatenate([w_missed, w_det.reshape(-1)]),
        np.concatenate([mix.means, means_det.reshape(-1, d)]),
        np.concatenate([mix.covs, np.tile(terms.covs, (n_meas, 1, 1))]))
    return UpdateResult(out, w_det)


def _logsumexp_rows(a: np.ndarray) -> np.ndarray:
    """Log-sum-exp of each row of ``a`` (M, K), shifted by the row's maximum.

    -inf for a row of -inf. scipy's ``logsumexp`` does the same with several times the
    overhead, which dominated a small update.
    """
    top = a.max(axis=1)
    shift = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        return shift + np.log(np.exp(a - shift[:, None]).sum(axis=1))


def prune_and_merge(mix: GaussianMixture, model: GmPhdModel) -> GaussianMixture:
    """Pruning, merging and capping of the mixture (Vo & Ma Table II).

    Components with weight <= T are dropped (their mass is not redistributed, as in the
    paper). Then, repeatedly, the heaviest remaining component j and every remaining i
    within U of it merge into one with the summed weight, the weighted mean and the
    moment-matched covariance ``sum_i w_i (P_i + (m - m_i)(m - m_i)^T) / w``; "within U" is
    ``(m_i - m_j)^T P_i^-1 (m_i - m_j) <= U`` (``merge_metric = candidate``, Table II as
    printed) or ``(m_i - m_j)^T P_j^-1 (m_i - m_j) <= U`` (``heaviest``, Vo's MATLAB
    ``gaus_merge.m``). If more than J_max components remain, the J_max heaviest are kept.
    The arithmetic is :func:`.gm_phd.reduce.reduce_components`'s.

    Parameters
    ----------
    mix : GaussianMixture
        J components of dimension d.
    model : GmPhdModel
        T (``prune_threshold``), U (``merge_threshold``), J_max (``max_components``),
        ``merge_metric``.

    Returns
    -------
    GaussianMixture
        At most J_max components, heaviest first.
    """
    _check_mixture(mix, model)
    return GaussianMixture(*reduce_components(
        mix.weights, mix.means, mix.covs, model.prune_threshold, model.merge_threshold,
        model.max_components, model.merge_metric))


def prune_and_merge_carrying(mix: GaussianMixture, model: GmPhdModel, values: np.ndarray
                             ) -> tuple[GaussianMixture, np.ndarray]:
    """:func:`prune_and_merge` (the same mixture, bit for bit), carrying ``values`` along.

    ``values`` (J, ...) is what each input component carries (e.g. the weight each
    measurement gave it); each output row gets the sum over the inputs merged into it,
    pruned and capped inputs' values are dropped (:func:`.gm_phd.reduce.carry`).
    """
    _check_mixture(mix, model)
    w, m, p, source = reduce_with_sources(
        mix.weights, mix.means, mix.covs, model.prune_threshold, model.merge_threshold,
        model.max_components, model.merge_metric)
    return GaussianMixture(w, m, p), carry(source, values, w.shape[0])


def extract(mix: GaussianMixture, model: GmPhdModel) -> np.ndarray:
    """Multi-target state estimate (Vo & Ma Table III).

    Each component with weight above the extraction threshold (0.5 in the paper) yields
    ``round(w)`` copies of its mean; rounding is half up (``floor(w + 1/2)``).

    Parameters
    ----------
    mix : GaussianMixture
        J components of dimension d.
    model : GmPhdModel
        ``extraction_threshold``.

    Returns
    -------
    np.ndarray, shape (N, d)
        Estimated states, in the order of the components.
    """
    _check_mixture(mix, model)
    sel = mix.weights > model.extraction_threshold
    copies = np.floor(mix.weights[sel] + 0.5).astype(int)
    return np.repeat(mix.means[sel], copies, axis=0)


def constant_p_d(p: float) -> DetectionProbability:
    """A detection probability ``p`` for every component, wherever the sensor is."""
    check_probability("p_d", np.asarray(p, dtype=float))
    p = float(p)

    def p_d(means: np.ndarray, covs: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        return np.full(means.shape[0], p)

    return p_d
