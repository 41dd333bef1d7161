"""Gaussian-process motion prediction of confirmed tracks (Sung & Tokekar 2022, Sec. V-B).

Sung & Tokekar predict the mean of a confirmed track's component at step k by regressing
each coordinate d of the track's recent history on time, with the squared-exponential
kernel (eq. 7)::

    K(k, k') = sigma_f^2 exp(-(k - k')^2 / (2 lambda^2))

and the GP posterior mean (eq. 8)::

    m_k^d = K(k, K) [K(K, K) + sigma_n^2 I]^-1 M^d

where K is the set of steps of the history, M^d the history's means along dimension d,
sigma_f [units of the state] the signal standard deviation, lambda [steps] the length
scale and sigma_n [units of the state] the noise standard deviation. Every dimension uses
the same kernel, so one Cholesky factor per track serves all d coordinates. Only the last
``window`` points are used (the paper's footnote 3: GPML took 0.29 s, 0.35 s and 3.53 s
for histories of 100, 1000 and 5000 points); the cost is O(W^3) per track per step for
the factorisation plus O(W^2 d) for the solves, with W the window, batched over tracks.

Two readings of the prior mean (:attr:`GpHyperparameters.mean`):

- ``"zero"``: eq. 8 as printed, a zero-mean GP. Far from the origin the posterior mean
  decays toward 0 m away from the data, so with positions of ~100 m and a length scale of
  a few steps the one-step prediction is pulled toward the origin.
- ``"window"`` (default): the window's average ``M_bar^d`` is the prior mean,
  ``m_k^d = M_bar^d + K(k, K) [K(K, K) + sigma_n^2 I]^-1 (M^d - M_bar^d)``: the
  extrapolation decays to the recent average, and the prediction is equivariant under a
  translation of the track.

The hyperparameters are fitted offline (:func:`fit_hyperparameters`) by maximising a log
marginal likelihood summed over the non-overlapping windows of ``window`` consecutive
points (stride = window by default) of every training track and every dimension, with
L-BFGS-B over (log sigma_f, log lambda, log sigma_n) and analytic gradients. For
``"zero"`` the likelihood is Rasmussen & Williams eq. 2.30; for ``"window"`` it is the
restricted likelihood of the window's deviations from its average (R&W Sec. 2.7, eq. 2.45
with a flat prior on a constant mean), which, like the predictor, does not depend on
where the track is. The paper learns sigma_f and lambda offline and calls sigma_n a
hyperparameter learned from data; it gives no values.

References: Y. Sung and P. Tokekar, "GM-PHD filter for searching and tracking an unknown
number of targets with a mobile sensor with limited FOV", IEEE T-ASE, 2022, Sec. V-B,
eq. 7-8. C. E. Rasmussen and C. K. I. Williams, "Gaussian Processes for Machine
Learning", MIT Press, 2006, eq. 2.30, 2.45, 5.9.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.linalg import cho_solve
from scipy.optimize import minimize

from ...checks import check_finite, check_positive_int

MEANS = ("zero", "window")

#: What :func:`predict_next` caches across calls: the weights by the offsets k - K, or
#: the Cholesky factor by the gaps between the steps K.
CACHES = ("offsets", "gaps")

_LOG_2PI = float(np.log(2.0 * np.pi))


@dataclass(frozen=True)
class GpHyperparameters:
    """Hyperparameters of the GP motion predictor (Sung & Tokekar eq. 7-8).

    Attributes
    ----------
    signal_sd : float
        sigma_f, the signal standard deviation (eq. 7) [units of the state], > 0.
    length_scale : float
        lambda, the length scale (eq. 7) [steps], > 0.
    noise_sd : float
        sigma_n, the noise standard deviation (eq. 8) [units of the state], > 0.
    window : int
        W, the number of most recent track points regressed on, >= 2.
    mean : str
        Prior mean: ``"window"`` (the window's average) or ``"zero"`` (eq. 8 as printed).
    """

    signal_sd: float
    length_scale: float
    noise_sd: float
    window: int
    mean: str = "window"

    def __post_init__(self) -> None:
        for name in ("signal_sd", "length_scale", "noise_sd"):
            v = getattr(self, name)
            try:
                x = float(v)
            except (TypeError, ValueError):
                raise ValueError(f"{name} must be a number, got {v!r}") from None
            if not np.isfinite(x) or x <= 0.0:
                raise ValueError(f"{name} must be finite and > 0, got {v!r}")
            object.__setattr__(self, name, x)
        object.__setattr__(self, "window", check_positive_int("window", self.window, 2))
        if self.mean not in MEANS:
            raise ValueError(f"mean must be one of {MEANS}, got {self.mean!r}")


def _se(diff: np.ndarray, signal_sd: float, length_scale: float) -> np.ndarray:
    """Eq. 7 on an array of step differences (any shape)."""
    return signal_sd**2 * np.exp(-0.5 * (diff / length_scale) ** 2)


def se_kernel(a: np.ndarray, b: np.ndarray, hp: GpHyperparameters) -> np.ndarray:
    """Squared-exponential kernel matrix K(a, b) (Sung & Tokekar eq. 7).

    Parameters
    ----------
    a : np.ndarray, shape (n,)
        Steps.
    b : np.ndarray, shape (m,)
        Steps.
    hp : GpHyperparameters
        Uses ``signal_sd`` and ``length_scale``.

    Returns
    -------
    np.ndarray, shape (n, m)
        ``sigma_f^2 exp(-(a_i - b_j)^2 / (2 lambda^2))`` [units of the state squared].
    """
    a = _steps("a", a)
    b = _steps("b", b)
    return _se(a[:, None] - b[None, :], hp.signal_sd, hp.length_scale)


def _steps(name: str, v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.ndim != 1:
        raise ValueError(f"{name} must have shape (n,), got {v.shape}")
    check_finite(name, v)
    return v


def predict_next(times: np.ndarray, means: np.ndarray, k_next: np.ndarray,
                 hp: GpHyperparameters, cache: str = "offsets") -> np.ndarray:
    """GP posterior means of N tracks at one step each (Sung & Tokekar eq. 8), batched.

    Every track has the same number W of points (the caller groups tracks by length:
    :func:`predict_tracks`); W is the length given, not ``hp.window``. Eq. 8 is
    ``a^T (M - prior) + prior`` with ``a = [K(K, K) + sigma_n^2 I]^-1 K(K, k)``, which
    depends only on the offsets ``k - K``: one Cholesky factor per distinct offset
    pattern, cached across calls (a track associated at every step has the same pattern
    at every step), so a step costs O(W d) per track once its pattern is known, O(W^3)
    for a new pattern.

    A track whose history stops growing (fed only by detections, out of view) has a new
    offset pattern at every step. ``cache = "gaps"`` serves it: the Cholesky factor of
    ``K(K, K) + sigma_n^2 I`` depends only on the gaps between the steps K, so it is
    cached by those (the same for the whole time a history does not change, and for a
    track detected at every step), and ``a`` is two triangular solves, O(W^2), per call.
    The two caches give the same ``a`` to rounding, not bit for bit; ``offsets`` is the
    form the committed results were made with.

    Parameters
    ----------
    times : np.ndarray, shape (N, W)
        Steps of each track's points.
    means : np.ndarray, shape (N, W, d)
        The track's means at those steps [units of the state].
    k_next : np.ndarray, shape (N,)
        The step to predict each track at.
    hp : GpHyperparameters
        Kernel, noise and prior mean (``hp.window`` is not used here).
    cache : {"offsets", "gaps"}
        What is cached across calls (see above).

    Returns
    -------
    np.ndarray, shape (N, d)
        Predicted means [units of the state].
    """
    if cache not in CACHES:
        raise ValueError(f"cache must be one of {CACHES}, got {cache!r}")
    times = np.asarray(times, dtype=float)
    means = np.asarray(means, dtype=float)
    k_next = np.asarray(k_next, dtype=float)
    if times.ndim != 2 or times.shape[1] < 1:
        raise ValueError(f"times must have shape (N, W) with W >= 1, got {times.shape}")
    n, w = times.shape
    if means.ndim != 3 or means.shape[:2] != (n, w):
        raise ValueError(f"means must have shape ({n}, {w}, d), got {means.shape}")
    if k_next.shape != (n,):
        raise ValueError(f"k_next must have shape ({n},), got {k_next.shape}")
    check_finite("times", times)
    check_finite("means", means)
    check_finite("k_next", k_next)
    if n == 0:
        return np.empty((0, means.shape[2]))

    if hp.mean == "window":
        prior = means.mean(axis=1)                                    # (N, d)
    else:
        prior = np.zeros((n, means.shape[2]))
    resid = means - prior[:, None, :]                                 # (N, W, d)
    # Eq. 8 is linear in M: m = a^T (M - prior) + prior with a = [K(K,K) + s_n^2 I]^-1
    # K(K, k), which depends only on the offsets k - K. A track seen at every step has
    # the offsets W, ..., 1 at every step, so the distinct offset patterns are few: each
    # is solved once and cached (:func:`_weights`).
    offsets = np.ascontiguousarray(k_next[:, None] - times)           # (N, W)
    if cache == "offsets":
        weights = np.stack([_weights(row.tobytes(), w, hp) for row in offsets])
    else:
        gaps = np.ascontiguousarray(times - times[:, -1:])            # (N, W)
        weights = np.stack([
            cho_solve((_factor(g.tobytes(), w, hp), True),
                      _se(o, hp.signal_sd, hp.length_scale), check_finite=False)
            for g, o in zip(gaps, offsets, strict=True)])
    return prior + np.einsum("nw,nwd->nd", weights, resid)


@lru_cache(maxsize=4096)
def _factor(gaps: bytes, w: int, hp: GpHyperparameters) -> np.ndarray:
    """Lower Cholesky factor of ``K(K, K) + sigma_n^2 I`` for the steps ``K - K_W`` (bytes).

    Read-only (shared through the cache).
    """
    t = np.frombuffer(gaps, dtype=float, count=w)
    gram = _se(t[:, None] - t[None, :], hp.signal_sd, hp.length_scale)
    gram[np.arange(w), np.arange(w)] += hp.noise_sd**2
    chol = np.linalg.cholesky(gram)
    chol.flags.writeable = False
    return chol


@lru_cache(maxsize=4096)
def _weights(offsets: bytes, w: int, hp: GpHyperparameters) -> np.ndarray:
    """``a = [K(K, K) + sigma_n^2 I]^-1 K(K, k)`` for the offsets ``k - K`` (bytes of W floats).

    One Cholesky factor and two triangular solves; read-only (shared through the cache).
    """
    d = np.frombuffer(offsets, dtype=float, count=w)
    gram = _se(d[:, None] - d[None, :], hp.signal_sd, hp.length_scale)
    gram[np.arange(w), np.arange(w)] += hp.noise_sd**2
    chol = np.linalg.cholesky(gram)
    k_star = _se(d, hp.signal_sd, hp.length_scale)
    a = np.linalg.solve(chol.T, np.linalg.solve(chol, k_star))
    a.flags.writeable = False
    return a


def _track_pair(item: object, where: str, values: str, dim: int | None,
                min_len: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """One track ``(steps (T,), values (T, d))`` of a sequence, checked.

    ``dim`` is the d of the tracks before it (None for the first); ``min_len`` the fewest
    points T allowed. Errors name ``where`` and ``values``.
    """
    try:
        steps, vals = item  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError(f"{where} must be a pair (steps, {values})") from None
    steps = np.asarray(steps, dtype=float)
    vals = np.asarray(vals, dtype=float)
    if steps.ndim != 1 or steps.shape[0] < min_len:
        raise ValueError(f"{where} steps must have shape (T,) with T >= {min_len}, "
                         f"got {steps.shape}")
    d = (vals.shape[1] if vals.ndim == 2 else -1) if dim is None else dim
    if vals.shape != (steps.shape[0], d) or d < 1:
        raise ValueError(f"{where} {values} must have shape ({steps.shape[0]}, d) with d >= 1 "
                         f"the same for all tracks, got {vals.shape}")
    check_finite(f"{where} steps", steps)
    check_finite(f"{where} {values}", vals)
    return steps, vals


def predict_tracks(histories: Sequence[tuple[np.ndarray, np.ndarray]],
                   k_next: float | np.ndarray, hp: GpHyperparameters,
                   cache: str = "offsets") -> np.ndarray:
    """Predicted means of N tracks of any length at a step (eq. 8 on the last points).

    Each track contributes its last ``min(T_i, hp.window)`` points; tracks are grouped by
    that length and each group is one :func:`predict_next` call. A track with a single
    point predicts that point (whatever ``hp.mean``: a one-point window has no motion to
    extrapolate, and the zero-mean formula would only shrink it toward the origin).

    Parameters
    ----------
    histories : sequence of (steps, states)
        Per track, ``steps`` shape (T_i,) strictly increasing, ``states`` shape (T_i, d)
        [units of the state], T_i >= 1, the same d for all tracks.
    k_next : float or np.ndarray, shape (N,)
        The step to predict at, one for all tracks or one per track.
    hp : GpHyperparameters
        Kernel, noise, window and prior mean.
    cache : {"offsets", "gaps"}
        What :func:`predict_next` caches: ``gaps`` for histories that stop growing.

    Returns
    -------
    np.ndarray, shape (N, d)
        Predicted means [units of the state]; shape (0, 0) for no tracks.
    """
    n = len(histories)
    k_next = np.asarray(k_next, dtype=float)
    if k_next.ndim == 0:
        k_next = np.full(n, float(k_next))
    if k_next.shape != (n,):
        raise ValueError(f"k_next must be a scalar or have shape ({n},), got {k_next.shape}")
    check_finite("k_next", k_next)
    if n == 0:
        return np.empty((0, 0))

    steps_list, states_list = [], []
    dim = None
    for i, item in enumerate(histories):
        steps, states = _track_pair(item, f"histories[{i}]", "states", dim, min_len=1)
        dim = states.shape[1]
        if np.any(np.diff(steps) <= 0.0):
            raise ValueError(f"histories[{i}] steps must be strictly increasing")
        steps_list.append(steps[-hp.window:])
        states_list.append(states[-hp.window:])

    lengths = np.array([s.shape[0] for s in steps_list])
    out = np.empty((n, dim))
    for w in np.unique(lengths):
        idx = np.flatnonzero(lengths == w)
        states = np.stack([states_list[i] for i in idx])
        if w == 1:
            out[idx] = states[:, 0, :]
            continue
        times = np.stack([steps_list[i] for i in idx])
        out[idx] = predict_next(times, states, k_next[idx], hp, cache)
    return out


# ------------------------------------------------------------------ fitting (offline)


def _lml_and_grad(times: np.ndarray, values: np.ndarray, log_params: np.ndarray,
                  mean: str, want_grad: bool) -> tuple[float, np.ndarray]:
    """Summed log marginal likelihood of B windows and its gradient in the log parameters.

    ``times`` (B, n), ``values`` (B, n, d); the d columns share the window's kernel. The
    gradient is R&W eq. 5.9, ``1/2 tr((a a^T - P) dK/dtheta)`` summed over columns, with
    ``P = K^-1`` ("zero") or the restricted ``P = K^-1 - K^-1 1 1^T K^-1 / (1^T K^-1 1)``
    ("window"), for which ``a = P y`` and the same form holds.
    """
    sf, ell, sn = np.exp(log_params)
    b, n, d = values.shape
    diff2 = (times[:, :, None] - times[:, None, :]) ** 2
    kf = sf**2 * np.exp(-0.5 * diff2 / ell**2)
    gram = kf + sn**2 * np.eye(n)
    chol = np.linalg.cholesky(gram)
    inv = np.linalg.inv(chol)                                           # L^-1
    kinv = np.swapaxes(inv, 1, 2) @ inv                                 # (B, n, n)
    logdet = 2.0 * np.log(np.diagonal(chol, axis1=1, axis2=2)).sum(axis=1)  # (B,)
    if mean == "zero":
        p = kinv
        lml = -0.5 * np.einsum("bid,bij,bjd->", values, kinv, values) \
            - 0.5 * d * logdet.sum() - 0.5 * b * d * n * _LOG_2PI
    else:
        k1 = kinv.sum(axis=2)                                           # K^-1 1, (B, n)
        s = k1.sum(axis=1)                                              # 1^T K^-1 1, (B,)
        p = kinv - k1[:, :, None] * k1[:, None, :] / s[:, None, None]
        # density of the window's deviations from its average on their (n-1)-dim subspace
        lml = -0.5 * np.einsum("bid,bij,bjd->", values, p, values) \
            - 0.5 * d * (logdet + np.log(s) - np.log(n)).sum() \
            - 0.5 * b * d * (n - 1) * _LOG_2PI
    if not want_grad:
        return float(lml), np.zeros(3)
    a = p @ values                                                      # (B, n, d)
    aat = np.einsum("bid,bjd->bij", a, a)
    inner = aat - d * p                                                 # (B, n, n)
    dk = (2.0 * kf, kf * diff2 / ell**2)
    grad = np.array([0.5 * np.sum(inner * dk[0]), 0.5 * np.sum(inner * dk[1]),
                     0.5 * 2.0 * sn**2 * np.trace(inner, axis1=1, axis2=2).sum()])
    return float(lml), grad


def _windows(tracks: Sequence[tuple[np.ndarray, np.ndarray]], window: int, stride: int,
             name: str = "tracks") -> tuple[np.ndarray, np.ndarray]:
    """Stacked windows (times (B, W), values (B, W, d)) of ``window`` consecutive points."""
    times, values = [], []
    dim = None
    for i, item in enumerate(tracks):
        steps, pos = _track_pair(item, f"{name}[{i}]", "positions", dim)
        dim = pos.shape[1]
        starts = np.arange(0, steps.shape[0] - window + 1, stride)
        if starts.size:
            idx = starts[:, None] + np.arange(window)
            times.append(steps[idx])
            values.append(pos[idx])
    if not times:
        raise ValueError(f"{name} must hold at least one track of >= {window} points")
    return np.concatenate(times), np.concatenate(values)


def log_marginal_likelihood(tracks: Sequence[tuple[np.ndarray, np.ndarray]],
                            hp: GpHyperparameters, stride: int | None = None) -> float:
    """Log marginal likelihood of training tracks, summed over windows and dimensions.

    Every window of ``hp.window`` consecutive points, starting every ``stride`` points
    (default ``hp.window``: non-overlapping), of every track, each dimension independent
    with the same kernel (eq. 7) plus noise ``sigma_n^2 I``:

    - ``hp.mean == "zero"``: R&W eq. 2.30,
      ``-1/2 y^T K^-1 y - 1/2 log|K| - n/2 log 2 pi``;
    - ``hp.mean == "window"``: the log density of the window's deviations from its
      average, in orthonormal coordinates of the (n-1)-dim subspace they lie in,
      ``-1/2 y^T P y - 1/2 log|K| - 1/2 log(1^T K^-1 1) + 1/2 log n - (n-1)/2 log 2 pi``
      with ``P = K^-1 - K^-1 1 1^T K^-1 / (1^T K^-1 1)`` (R&W eq. 2.45 with a flat prior
      on a constant mean, plus the constant 1/2 log n); unchanged by adding a constant to
      a window.

    Parameters
    ----------
    tracks : sequence of (steps, positions)
        ``steps`` shape (T,), ``positions`` shape (T, d) [units of the state]; tracks
        shorter than the window contribute nothing, at least one must not be.
    hp : GpHyperparameters
        The hyperparameters evaluated; ``hp.window`` is the window length.
    stride : int, optional
        Steps between window starts, >= 1.

    Returns
    -------
    float
        The summed log likelihood [nats].
    """
    stride = hp.window if stride is None else check_positive_int("stride", stride)
    times, values = _windows(tracks, hp.window, stride)
    params = np.log([hp.signal_sd, hp.length_scale, hp.noise_sd])
    return _lml_and_grad(times, values, params, hp.mean, want_grad=False)[0]


def fit_hyperparameters(tracks: Sequence[tuple[np.ndarray, np.ndarray]], window: int,
                        mean: str = "window", init: GpHyperparameters | None = None,
                        stride: int | None = None) -> GpHyperparameters:
    """Hyperparameters maximising :func:`log_marginal_likelihood` on training tracks.

    L-BFGS-B over (log sigma_f, log lambda, log sigma_n) with the analytic gradient
    (R&W eq. 5.9), from ``init`` or from a start read off the data: sigma_f the standard
    deviation of the values (of the deviations from the window average for ``"window"``),
    sigma_n = sigma_f / 10, lambda = a quarter of the median window span. The search is
    bounded so the kernel matrix stays factorable: sigma_f and sigma_n within
    [1e-4, 1e3] times that standard deviation, lambda within [1e-2, 1e2] times the median
    window span. One local optimum is found; a start far from the data's scales can end in
    another (e.g. everything explained as noise).

    Parameters
    ----------
    tracks : sequence of (steps, positions)
        Training tracks, ``steps`` shape (T,), ``positions`` shape (T, d) [units of the
        state], e.g. noisy observations of targets' motion.
    window : int
        W, the window length (>= 2), the same as will be used for prediction.
    mean : str
        ``"window"`` or ``"zero"``, the prior mean the hyperparameters are for.
    init : GpHyperparameters, optional
        Starting point (its window and mean are ignored).
    stride : int, optional
        Steps between window starts, >= 1; default ``window`` (non-overlapping windows).

    Returns
    -------
    GpHyperparameters
        The fitted hyperparameters with ``window`` and ``mean``.
    """
    window = check_positive_int("window", window, 2)
    if mean not in MEANS:
        raise ValueError(f"mean must be one of {MEANS}, got {mean!r}")
    if init is not None and not isinstance(init, GpHyperparameters):
        raise ValueError(f"init must be a GpHyperparameters, got {type(init).__name__}")
    stride = window if stride is None else check_positive_int("stride", stride)
    times, values = _windows(tracks, window, stride)

    centred = values - values.mean(axis=1, keepdims=True) if mean == "window" else values
    scale = float(np.sqrt(np.mean(centred**2)))
    if scale == 0.0:
        raise ValueError("tracks must not be constant within every window")
    span = float(np.median(times[:, -1] - times[:, 0]))
    if span <= 0.0:
        raise ValueError("tracks steps must increase within a window")
    if init is None:
        x0 = np.log([scale, span / 4.0, scale / 10.0])
    else:
        x0 = np.log([init.signal_sd, init.length_scale, init.noise_sd])
    bounds = [(np.log(1e-4 * scale), np.log(1e3 * scale)),
              (np.log(1e-2 * span), np.log(1e2 * span)),
              (np.log(1e-4 * scale), np.log(1e3 * scale))]
    x0 = np.clip(x0, [lo for lo, _ in bounds], [hi for _, hi in bounds])
    # Normalise by the number of values so the objective is O(1) whatever the data size,
    # and L-BFGS-B's absolute tolerances mean the same thing for every training set.
    count = values.size

    def objective(x: np.ndarray) -> tuple[float, np.ndarray]:
        lml, grad = _lml_and_grad(times, values, x, mean, want_grad=True)
        return -lml / count, -grad / count

    res = minimize(objective, x0, jac=True, method="L-BFGS-B", bounds=bounds)
    sf, ell, sn = np.exp(res.x)
    return GpHyperparameters(sf, ell, sn, window, mean)
