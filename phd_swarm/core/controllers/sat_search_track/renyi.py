"""Tracking control of Papaioannou et al. (Sec. V-C a): the Renyi-divergence reward, eq. 17-18.

A tracking agent at ``s_{k-1}`` chooses among its admissible next positions u (eq. 4,
:mod:`.agent_moves`) the one whose hypothetical measurements would most change its target
intensity. For every action u at once:

1. the predicted measurement set ``Zbar(u) = {argmax_z g(z | x, u) : x in Xhat_{k|k-1}}``
   (:func:`predicted_measurements`): for the Gaussian range-bearing likelihood the mode is the
   noise-free measurement ``h(x, u)``;
2. the pseudo-update of the predicted particles with Zbar(u), eq. 8 with the sensor at u
   (:func:`pseudo_update_weights`);
3. the reward, the Renyi divergence of order alpha between the pseudo-updated and the
   predicted multi-target densities, eq. 18 on the particles (:func:`renyi_reward`);
4. the best admissible action, ties to the lowest index (:func:`best_action`); action 0 is
   staying, so a tie with staying keeps the agent where it is.

:class:`~.tracking.RenyiTracking` bundles the parameters (Sec. VI-A: alpha = 0.5, p_D^max
= 0.99, a 10 m x 10 m sensing square, lambda_c = 10 clutter points per scan) and the four
steps.

Readings of the paper (see also docs/decisions.md):

- **Which estimates give a predicted measurement.** The paper forms Zbar(u) from every
  predicted estimate x, for every u. A target outside the sensing square S_a(u) cannot be
  detected from u (p_D = 0 there, eq. 5), so its measurement cannot be received; and in the
  pseudo-update such a measurement, if kappa(z) = 0 there (the plane-uniform clutter is zero
  outside the square), is handed to whichever detectable particles are least unlikely,
  a spurious gain. The default keeps only the estimates inside the closed square S_a(u)
  (``only_visible=True``); ``only_visible=False`` is the literal union over all estimates.
- **Sensing square.** Eq. 5 prints the square's boundary (``max{|x - s_x|, |y - s_y|} =
  a/2``); the region ``<= a/2`` is meant ("a square region with total area a^2"), closed as
  in :class:`.fov_detection.SquareFov`.
- **Clutter.** kappa(z) is per m per rad in (r, phi); the default is the plane-uniform
  clutter over the square, ``lambda_c r / a^2``
  (:func:`.range_bearing_model.clutter_density_square`), the repository's reading of
  "uniform over the measurement space"; a constant kappa is the literal one.

References
----------
S. Papaioannou, P. Kolios, T. Theocharides, C. G. Panayiotou, M. M. Polycarpou, "A
cooperative multi-agent probabilistic framework for search and track missions", IEEE Trans.
Control of Network Systems, 2021, Sec. V-C, eq. 8, 17, 18.
B. Ristic, B.-N. Vo, D. Clark, "A note on the reward function for PHD filters with sensor
control", IEEE Trans. Aerospace and Electronic Systems 47(2), 2011 (the Renyi divergence
between Poisson multi-object densities).
B. Ristic, B.-N. Vo, "Sensor control for multi-object state-space estimation using random
finite sets", Automatica 46(11), 2010 (the particle approximation of the reward).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...checks import check_finite, check_probability
from ...sensors.range_bearing_model import RangeBearingSensor, clutter_density_square, wrap_angle

__all__ = [
    "PredictedMeasurements",
    "best_action",
    "predicted_measurements",
    "pseudo_update_weights",
    "renyi_reward",
    "square_clutter",
]

#: Log of a likelihood term's ratio to the largest of its row below which it is raised to
#: this value before exp (as in :func:`.estimators.smc_phd.update`): e^-700 ~ 1e-304 of the
#: largest changes no sum, and exp is several times slower on subnormal results.
_LOG_NEGLIGIBLE = -700.0


# ---------------------------------------------------------------- checks


def _positions(name: str, a: object) -> np.ndarray:
    p = np.asarray(a, dtype=float)
    if p.size == 0 and p.ndim <= 2:
        return p.reshape(0, 2)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must have shape (K, 2) [m], got {p.shape}")
    check_finite(name, p)
    return p


def _actions(action_positions: object) -> np.ndarray:
    s = np.asarray(action_positions, dtype=float)
    if s.ndim != 2 or s.shape[1] != 2 or s.shape[0] == 0:
        raise ValueError(f"action_positions must have shape (U, 2) with U >= 1 [m], got "
                         f"{s.shape}")
    check_finite("action_positions", s)
    return s


def _side(side: object) -> float:
    h = float(side)
    if not (np.isfinite(h) and h > 0.0):
        raise ValueError(f"side (of the sensing square) must be finite and > 0 [m], got "
                         f"{side!r}")
    return h


def _alpha(alpha: object) -> float:
    a = float(alpha)
    if not 0.0 < a < 1.0:
        raise ValueError(f"alpha (Renyi order) must lie in (0, 1), got {alpha!r}")
    return a


def _weights(name: str, w: object, shape: tuple[int, ...] | None = None) -> np.ndarray:
    w = np.asarray(w, dtype=float)
    if shape is not None and w.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {w.shape}")
    check_finite(name, w)
    if np.any(w < 0.0):
        raise ValueError(f"{name} must be >= 0")
    return w


def _position_index(position_index: object, d: int) -> np.ndarray:
    idx = np.asarray(position_index)
    if (idx.shape != (2,) or not np.issubdtype(idx.dtype, np.integer) or idx[0] == idx[1]
            or np.any((idx < 0) | (idx >= d))):
        raise ValueError(f"position_index must be two distinct state indices in [0, {d}), "
                         f"got {position_index!r}")
    return idx


def _in_square(delta: np.ndarray, side: float) -> np.ndarray:
    """Whether offsets ``delta`` (..., 2) [m] from a square's centre lie in the closed square."""
    half = 0.5 * side
    return (np.abs(delta[..., 0]) <= half) & (np.abs(delta[..., 1]) <= half)


# ---------------------------------------------------------------- 1. predicted measurements


@dataclass(frozen=True, eq=False)
class PredictedMeasurements:
    """The predicted measurement sets Zbar(u) of every action, padded to one array.

    Slot (u, k) holds ``h(x_k, u)``, the noise-free range-bearing measurement of estimate k
    from action u; it belongs to Zbar(u) iff ``member[u, k]``. Slots that are not members
    still hold the (finite) h value and are ignored by :func:`pseudo_update_weights`.

    Attributes
    ----------
    z : np.ndarray, shape (U, K, 2)
        Range [m] and bearing [rad] in (-pi, pi].
    member : np.ndarray of bool, shape (U, K)
        Whether slot (u, k) is in Zbar(u).
    """

    z: np.ndarray
    member: np.ndarray

    @property
    def counts(self) -> np.ndarray:
        """|Zbar(u)| for every action, shape (U,)."""
        return self.member.sum(axis=1)

    def for_action(self, u: int) -> np.ndarray:
        """Zbar(u) as an (M_u, 2) array, in estimate order."""
        return self.z[u][self.member[u]]


def predicted_measurements(estimates: np.ndarray, action_positions: np.ndarray,
                           sensor_model: RangeBearingSensor, side: float,
                           only_visible: bool = True) -> PredictedMeasurements:
    """Predicted measurement sets Zbar(u) = {argmax_z g(z | x, u)} of every action (Sec. V-C a).

    For the Gaussian likelihood ``g(z | x, u) = N(z; h(x, u), R(r))`` the maximum over z is at
    ``z = h(x, u) = (||p - u||, atan2(p_y - u_y, p_x - u_x))``; the range-dependent sds of R
    do not move it (they depend on x, not z).

    Parameters
    ----------
    estimates : np.ndarray, shape (K, 2)
        Predicted target positions Xhat_{k|k-1} [m] (K may be 0).
    action_positions : np.ndarray, shape (U, 2)
        Agent positions after each action [m] (:func:`.agent_moves.admissible_positions`).
    sensor_model : RangeBearingSensor
        The measurement model (its ``measure`` convention: bearing counter-clockwise from x).
    side : float
        Side a of the sensing square S_a(u) [m], > 0.
    only_visible : bool
        True (default): an estimate gives a member of Zbar(u) only if it lies in the closed
        square S_a(u). False: the paper's literal union over every estimate.

    Returns
    -------
    PredictedMeasurements
        ``z`` (U, K, 2) and ``member`` (U, K).
    """
    if not isinstance(sensor_model, RangeBearingSensor):
        raise ValueError(f"sensor_model must be a RangeBearingSensor, got "
                         f"{type(sensor_model).__name__}")
    x = _positions("estimates", estimates)
    s = _actions(action_positions)
    side = _side(side)
    delta = x[None, :, :] - s[:, None, :]                               # (U, K, 2)
    z = np.stack([np.hypot(delta[..., 0], delta[..., 1]),
                  np.arctan2(delta[..., 1], delta[..., 0])], axis=-1)
    member = _in_square(delta, side) if only_visible else np.ones(delta.shape[:2], bool)
    return PredictedMeasurements(z, member)


# ---------------------------------------------------------------- 2. pseudo-update


def square_clutter(z: np.ndarray, side: float, rate: float) -> np.ndarray:
    """Plane-uniform clutter over the sensing square in (r, phi), for padded sets (U, M, 2).

    :func:`.range_bearing_model.clutter_density_square` on every slot: ``kappa = rate r / a^2``
    inside the square centred on the sensor, 0 outside [1/(m rad)]. Shape (U, M).
    """
    z = np.asarray(z, dtype=float)
    if z.ndim != 3 or z.shape[2] != 2:
        raise ValueError(f"z must have shape (U, M, 2), got {z.shape}")
    flat = clutter_density_square(z.reshape(-1, 2), np.zeros(2), side, rate)
    return flat.reshape(z.shape[:2])


def pseudo_update_weights(states: np.ndarray, weights: np.ndarray,
                          action_positions: np.ndarray, z: np.ndarray,
                          member: np.ndarray | None, p_d_inside: float, side: float,
                          sensor_model: RangeBearingSensor, clutter: float | np.ndarray,
                          position_index: tuple[int, int] = (0, 1),
                          newborn: np.ndarray | None = None) -> np.ndarray:
    """Pseudo-updated particle weights w'_i(u) of every action at once (eq. 8, Sec. V-C a).

    For action u (the sensor at u), predicted measurements Zbar(u) and predicted particles
    (w_i, x_i)::

        C_u(z)   = sum_j p_D(x_j, u) g(z | x_j, u) w_j
        w'_i(u)  = (1 - p_D(x_i, u)) w_i [i persistent]
                   + sum_{z in Zbar(u)} p_D(x_i, u) g(z | x_i, u) w_i / (kappa_u(z) + C_u(z))

    with ``p_D(x, u) = p_d_inside`` in the closed square of side ``side`` centred on u, else
    0 (eq. 5), and g the range-bearing likelihood of ``sensor_model`` (bearing difference
    wrapped). This is :func:`.estimators.smc_phd.update` for each action (same log-space
    computation: a log-sum-exp per (u, z), terms below e^-700 of a row's largest raised to
    e^-700, a measurement no particle can explain gets zero shares), on (U, M, N') arrays,
    N' the particles inside some action's square, with no loop over actions or particles.
    A particle with ``p_D w = 0`` gets exactly its missed-detection weight (smc_phd.update
    may give it a share of ~1e-304 of a row's largest).

    Parameters
    ----------
    states : np.ndarray, shape (N, d)
        Predicted particle states; the position [m] at ``position_index``.
    weights : np.ndarray, shape (N,)
        Predicted weights w_i [expected targets], finite, >= 0.
    action_positions : np.ndarray, shape (U, 2)
        Sensor position of each action [m].
    z : np.ndarray, shape (U, M, 2)
        Predicted measurements, range [m] and bearing [rad], finite in every slot
        (:attr:`PredictedMeasurements.z`).
    member : np.ndarray of bool, shape (U, M), or None
        Slots in Zbar(u) (:attr:`PredictedMeasurements.member`); None: every slot.
    p_d_inside : float
        p_D^max [-], in [0, 1].
    side : float
        Side a of the sensing square [m], > 0.
    sensor_model : RangeBearingSensor
        Range-dependent noise model.
    clutter : float or np.ndarray broadcastable to (U, M)
        kappa_u(z) [1/(m rad)], finite, >= 0: a constant, or :func:`square_clutter` of z.
    position_index : tuple of int
        State indices of x and y (``(0, 2)`` for the paper's ``[x, xdot, y, ydot]``).
    newborn : np.ndarray of bool, shape (N,), optional
        Newborn particles get no missed-detection term, as in smc_phd.update (Ristic et al.
        2012); None: all persistent (eq. 8 as printed).

    Returns
    -------
    np.ndarray, shape (U, N)
        w'_i(u) [expected targets], >= 0.
    """
    if not isinstance(sensor_model, RangeBearingSensor):
        raise ValueError(f"sensor_model must be a RangeBearingSensor, got "
                         f"{type(sensor_model).__name__}")
    x = np.asarray(states, dtype=float)
    if x.ndim != 2:
        raise ValueError(f"states must have shape (N, d), got {x.shape}")
    check_finite("states", x)
    n = x.shape[0]
    idx = _position_index(position_index, x.shape[1])
    w = _weights("weights", weights, (n,))
    s = _actions(action_positions)
    n_act = s.shape[0]
    z = np.asarray(z, dtype=float)
    if z.ndim != 3 or z.shape[0] != n_act or z.shape[2] != 2:
        raise ValueError(f"z must have shape ({n_act}, M, 2) for {n_act} actions, got "
                         f"{z.shape}")
    check_finite("z (predicted measurements, padding included)", z)
    n_meas = z.shape[1]
    if member is None:
        member = np.ones((n_act, n_meas), dtype=bool)
    member = np.asarray(member)
    if member.shape != (n_act, n_meas) or member.dtype != bool:
        raise ValueError(f"member must be a boolean array of shape ({n_act}, {n_meas}), got "
                         f"{member.dtype} {member.shape}")
    p_in = np.asarray(p_d_inside, dtype=float)
    if p_in.ndim:
        raise ValueError(f"p_d_inside must be a number, got shape {p_in.shape}")
    check_probability("p_d_inside", p_in)
    side = _side(side)
    kappa = np.asarray(clutter, dtype=float)
    try:
        kappa = np.broadcast_to(kappa, (n_act, n_meas))
    except ValueError:
        raise ValueError(f"clutter must be a number or broadcast to ({n_act}, {n_meas}), got "
                         f"shape {kappa.shape}") from None
    check_finite("clutter", kappa)
    if np.any(kappa < 0.0):
        raise ValueError("clutter must be >= 0")
    if newborn is None:
        persistent = np.ones(n, dtype=bool)
    else:
        nb = np.asarray(newborn)
        if nb.shape != (n,) or nb.dtype != bool:
            raise ValueError(f"newborn must be a boolean array of shape ({n},), got "
                             f"{nb.dtype} {nb.shape}")
        persistent = ~nb

    delta = x[None, :, idx] - s[:, None, :]                          # (U, N, 2)
    p_d = np.where(_in_square(delta, side), float(p_in), 0.0)       # (U, N)
    w_missed = np.where(persistent, (1.0 - p_d) * w, 0.0)
    detectable = p_d * w > 0.0                                      # (U, N)
    live = member & detectable.any(axis=1)[:, None]                 # (U, M)
    if n == 0 or not live.any():
        return w_missed

    # Only particles some action can detect take part (N' <= N columns); the others keep
    # their missed-detection weight under every action.
    cols = np.flatnonzero(detectable.any(axis=0))
    delta, pdw = delta[:, cols], p_d[:, cols] * w[cols]
    r = np.hypot(delta[..., 0], delta[..., 1])                      # (U, N')
    phi = np.arctan2(delta[..., 1], delta[..., 0])
    sd_r = sensor_model.zeta0 + sensor_model.beta_zeta * r
    sd_phi = sensor_model.phi0 + sensor_model.beta_phi * r
    with np.errstate(divide="ignore"):
        # log p_D w - log(2 pi sd_r sd_phi): the prior and the Gaussian's normaliser, (U, N')
        log_prior = np.log(pdw) - np.log(2.0 * np.pi * sd_r * sd_phi)
        log_kappa = np.log(kappa)
    # The (U, M, N') hot path: log p_D g w, one array reused in place.
    e_r = z[:, :, 0, None] - r[:, None, :]
    e_r /= sd_r[:, None, :]
    # Both bearings in (-pi, pi] make the difference lie in (-2 pi, 2 pi), wrapped by one
    # shift each way; wrap_angle's np.mod on the whole (U, M, N) array costs 4x as much.
    e_phi = wrap_angle(z[:, :, 1])[:, :, None] - phi[:, None, :]
    e_phi[e_phi > np.pi] -= 2.0 * np.pi
    e_phi[e_phi <= -np.pi] += 2.0 * np.pi
    e_phi /= sd_phi[:, None, :]
    e_r *= e_r
    e_phi *= e_phi
    log_num = e_r
    log_num += e_phi
    log_num *= -0.5
    log_num += log_prior[:, None, :]
    del e_phi
    top = log_num.max(axis=2)                                       # (U, M)
    explained = live & (top > -np.inf)
    top = np.where(explained, top, 0.0)
    log_num -= top[:, :, None]
    np.maximum(log_num, _LOG_NEGLIGIBLE, out=log_num)
    raw = np.exp(log_num, out=log_num)                              # p_D g w / e^top
    with np.errstate(divide="ignore"):
        log_c = np.log(raw.sum(axis=2)) + top                       # log C_u(z)
    log_den = np.logaddexp(log_kappa, log_c)
    with np.errstate(over="ignore", invalid="ignore"):
        factor = np.where(explained, np.exp(top - log_den), 0.0)    # e^top / (kappa + C)
    shares = np.matmul(factor[:, None, :], raw)[:, 0, :]            # (U, N')
    out = w_missed.copy()
    out[:, cols] += np.where(detectable[:, cols], shares, 0.0)
    return out


# ---------------------------------------------------------------- 3. reward


def renyi_reward(weights: np.ndarray, updated: np.ndarray, alpha: float = 0.5) -> np.ndarray:
    """Renyi divergence of order alpha of the pseudo-updated from the predicted density (eq. 18).

    Derivation (Ristic, Vo & Clark 2011). Eq. 17 is the Renyi divergence
    ``R_alpha = 1/(alpha - 1) log int f1(X)^alpha f0(X)^(1 - alpha) dX`` (a set integral)
    between the pseudo-updated f1 and the predicted f0 multi-object densities. The PHD filter
    takes both to be Poisson, ``f(X) = e^-lambda prod_{x in X} v(x)`` with intensity v and
    mass ``lambda = int v``, so

        ``int f1^alpha f0^(1-alpha) dX
          = sum_n 1/n! e^-(alpha lambda1 + (1-alpha) lambda0) (int v1^alpha v0^(1-alpha) dx)^n
          = exp(-alpha lambda1 - (1-alpha) lambda0 + int v1^alpha v0^(1-alpha) dx)``

    and the log undoes the exp:

        ``R_alpha = lambda0 + alpha/(1-alpha) lambda1 - 1/(1-alpha) int v1^alpha v0^(1-alpha)``

    which is eq. 18 with v0 = D_{k|k-1} (predicted) and v1 = Dbar_k (pseudo-updated).

    Particles. The pseudo-update multiplies the predicted intensity by a function,
    ``v1(x) = psi_u(x) v0(x)`` (eq. 8), so ``int v1^alpha v0^(1-alpha) = int psi_u^alpha v0``,
    an integral against v0 that the predicted particles estimate by ``sum_i psi_i^alpha
    w_i``; with ``w'_i = psi_i w_i`` this is ``sum_i w'_i^alpha w_i^(1-alpha)`` (Ristic & Vo
    2010). The masses are ``sum w`` and ``sum w'``. Hence

        ``R = sum_i w_i + alpha/(1-alpha) sum_i w'_i - 1/(1-alpha) sum_i w'_i^alpha w_i^(1-alpha)
            = 1/(1-alpha) sum_i [(1-alpha) w_i + alpha w'_i - w'_i^alpha w_i^(1-alpha)]``.

    Each bracket is >= 0 (weighted AM-GM) and zero iff ``w'_i = w_i``, so R >= 0 with
    equality iff nothing changed. It is summed in that per-particle form, each term clipped
    at 0 against rounding and exactly 0 where ``w'_i = w_i``, rather than as a difference of
    sums, which cancels badly when R is small against the mass.

    Parameters
    ----------
    weights : np.ndarray, shape (N,)
        Predicted weights w_i [expected targets], finite, >= 0.
    updated : np.ndarray, shape (N,) or (U, N)
        Pseudo-updated weights w'_i, per action (:func:`pseudo_update_weights`).
    alpha : float
        Renyi order, in (0, 1) (0.5 in Sec. VI-A).

    Returns
    -------
    float or np.ndarray, shape (U,)
        R_alpha [-] (a number of targets, like the masses), >= 0.
    """
    a = _alpha(alpha)
    w = _weights("weights", weights)
    if w.ndim != 1:
        raise ValueError(f"weights must have shape (N,), got {w.shape}")
    wp = _weights("updated", updated)
    if wp.ndim not in (1, 2) or wp.shape[-1] != w.shape[0]:
        raise ValueError(f"updated must have shape ({w.shape[0]},) or (U, {w.shape[0]}), got "
                         f"{wp.shape}")
    term = (1.0 - a) * w + a * wp - wp**a * w ** (1.0 - a)
    # Unchanged particles contribute exactly 0 (the powers' rounding would leave ~1e-19 w),
    # so actions that see nothing tie exactly.
    term = np.where(wp == w, 0.0, term)
    out = np.maximum(term, 0.0).sum(axis=-1) / (1.0 - a)
    return float(out) if out.ndim == 0 else out


# ---------------------------------------------------------------- 4. choice


def best_action(rewards: np.ndarray, admissible: np.ndarray | None = None,
                tie_rtol: float = 1e-9) -> int:
    """Index of the largest reward among the admissible actions; ties to the lowest index.

    Rewards within ``tie_rtol * |best|`` of the best count as ties, so that actions equal
    in exact arithmetic but not in rounding (symmetric placements, another BLAS on another
    robot) are broken the same way everywhere. With action 0 = staying (:mod:`.agent_moves`),
    a tie with staying keeps the agent still.

    Parameters
    ----------
    rewards : np.ndarray, shape (U,)
        Finite rewards.
    admissible : np.ndarray of bool, shape (U,), optional
        Actions allowed (:func:`.agent_moves.admissible_positions`); None: all.
    tie_rtol : float
        Relative tolerance of a tie, >= 0 (0: exact ties only).

    Returns
    -------
    int
        The chosen action index.
    """
    r = np.asarray(rewards, dtype=float)
    if r.ndim != 1 or r.size == 0:
        raise ValueError(f"rewards must have shape (U,) with U >= 1, got {r.shape}")
    check_finite("rewards", r)
    if admissible is None:
        ok = np.ones(r.shape, dtype=bool)
    else:
        ok = np.asarray(admissible)
        if ok.shape != r.shape or ok.dtype != bool:
            raise ValueError(f"admissible must be a boolean array of shape {r.shape}, got "
                             f"{ok.dtype} {ok.shape}")
    if not ok.any():
        raise ValueError("no admissible action (admissible is all False)")
    tol = float(tie_rtol)
    if not (np.isfinite(tol) and tol >= 0.0):
        raise ValueError(f"tie_rtol must be finite and >= 0, got {tie_rtol!r}")
    best = r[ok].max()
    return int(np.flatnonzero(ok & (r >= best - tol * abs(best)))[0])
