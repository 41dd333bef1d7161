"""Gaussian mixtures and track sets as ROS messages, and their checks on the way in.

A robot whose estimator provides ``gaussian_mixture`` publishes its components as a
``phd_swarm_msgs/GaussianMixture`` on ``components``; one that provides ``tracks``
publishes its targets with their tracks as a ``phd_swarm_msgs/TrackSet`` on ``tracks``
(:data:`COMPONENTS`, :data:`TRACKS`). The monitor and the log readers take them back with
:func:`mixture_from_ros` and :func:`tracks_from_ros`, which raise
:class:`~phd_swarm.nodes.convert.InvalidMessage` naming the field of a message that cannot
be right (lengths that disagree, non-finite numbers, negative weights, covariances that are
not symmetric positive definite). Numbers travel as float64: what a log holds is the
filter's state, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from phd_swarm.core.checks import check_spd
from phd_swarm.nodes.convert import InvalidMessage, f64, header, points, u32, xy
from phd_swarm.nodes.face import Face, Step
from phd_swarm_msgs.msg import GaussianMixture, TrackSet


@dataclass(frozen=True)
class MixtureArrays:
    """A Gaussian mixture as arrays: weights (J,), means (J, d), covariances (J, d, d)."""

    weights: np.ndarray
    means: np.ndarray
    covs: np.ndarray


@dataclass(frozen=True)
class TrackArrays:
    """Targets with their tracks, as arrays (element i is target i).

    Attributes
    ----------
    track_ids, life : np.ndarray of int, shape (N,)
    confirmed : np.ndarray of bool, shape (N,)
    weights : np.ndarray, shape (N,)
    positions : np.ndarray, shape (N, 2) [m]
    covs : np.ndarray, shape (N, 2, 2) [m^2]
    """

    track_ids: np.ndarray
    life: np.ndarray
    confirmed: np.ndarray
    weights: np.ndarray
    positions: np.ndarray
    covs: np.ndarray


def gaussian_mixture(source_id: int, step: int, weights: np.ndarray, means: np.ndarray,
                     covs: np.ndarray, dt: float, frame_id: str) -> GaussianMixture:
    """A ``GaussianMixture`` of components (weights (J,), means (J, d), covs (J, d, d))."""
    means = np.asarray(means, dtype=float)
    dim = means.shape[1] if means.ndim == 2 else 2
    return GaussianMixture(header=header(step, dt, frame_id), source_id=int(source_id),
                           step=int(step), dim=int(dim), weights=f64(weights),
                           means=f64(means.ravel()), covariances=f64(np.ravel(covs)))


def mixture_from_ros(msg: GaussianMixture, max_components: int) -> MixtureArrays:
    """The checked arrays of a ``GaussianMixture``; InvalidMessage naming the problem."""
    d, j = int(msg.dim), len(msg.weights)
    if d < 1:
        raise InvalidMessage(f"dim: {d}, must be at least 1")
    if j > max_components:
        raise InvalidMessage(f"weights: {j} components, more than {max_components}")
    if len(msg.means) != j * d or len(msg.covariances) != j * d * d:
        raise InvalidMessage(f"means / covariances: {len(msg.means)} / "
                             f"{len(msg.covariances)} values for {j} components of dim {d}")
    weights = np.frombuffer(msg.weights, dtype=np.float64) if j else np.empty(0)
    means = np.frombuffer(msg.means, dtype=np.float64).reshape(j, d)
    covs = np.frombuffer(msg.covariances, dtype=np.float64).reshape(j, d, d)
    if not np.all(np.isfinite(weights)) or np.any(weights < 0):
        raise InvalidMessage("weights: non-finite or negative weight")
    if not np.all(np.isfinite(means)):
        raise InvalidMessage("means: non-finite value")
    _check_covs(covs, "covariances")
    return MixtureArrays(weights, means, covs)


def track_set(source_id: int, step: int, tracks: TrackArrays, dt: float,
              frame_id: str) -> TrackSet:
    """A ``TrackSet`` of targets with their tracks."""
    return TrackSet(header=header(step, dt, frame_id), source_id=int(source_id),
                    step=int(step), track_ids=u32(tracks.track_ids), life=u32(tracks.life),
                    confirmed=[bool(c) for c in tracks.confirmed],
                    weights=f64(tracks.weights), positions=points(tracks.positions),
                    covariances=f64(np.ravel(tracks.covs)))


def tracks_from_ros(msg: TrackSet, max_targets: int) -> TrackArrays:
    """The checked arrays of a ``TrackSet``; InvalidMessage naming the problem."""
    n = len(msg.track_ids)
    if n > max_targets:
        raise InvalidMessage(f"track_ids: {n} targets, more than {max_targets}")
    lengths = {"life": len(msg.life), "confirmed": len(msg.confirmed),
               "weights": len(msg.weights), "positions": len(msg.positions),
               "covariances": len(msg.covariances) / 4}
    wrong = [name for name, m in lengths.items() if m != n]
    if wrong:
        raise InvalidMessage(f"{', '.join(wrong)}: not one per target ({n} track ids)")
    weights = np.array(msg.weights, dtype=float)
    if not np.all(np.isfinite(weights)) or np.any(weights < 0):
        raise InvalidMessage("weights: non-finite or negative weight")
    covs = np.array(msg.covariances, dtype=float).reshape(n, 2, 2)
    _check_covs(covs, "covariances")
    return TrackArrays(np.array(msg.track_ids, dtype=np.int64),
                       np.array(msg.life, dtype=np.int64),
                       np.array(msg.confirmed, dtype=bool), weights,
                       xy(msg.positions, "positions"), covs)


def _check_covs(covs: np.ndarray, field: str) -> None:
    if not len(covs):
        return
    try:
        check_spd(field, covs)
    except ValueError as exc:
        raise InvalidMessage(str(exc)) from None


class EstimatorView:
    """A robot's estimator as its messages show it, for an estimator part's ``figures`` hook.

    It has what the hooks read: ``mixture.weights``, ``targets()`` and ``confirmed_mask()``
    (with tracks), ``reward_set()`` (with a reward set). The monitor and the log readers
    compute a system's figures (e.g.
    :func:`phd_swarm.core.estimators.sung.figures.step_figures`) from a robot's
    ``components``, ``tracks`` and ``reward_set`` with it, as the in-memory engine does from
    the estimator.
    """

    def __init__(self, mixture: MixtureArrays, tracks: TrackArrays | None = None,
                 rewards: np.ndarray | None = None,
                 met: np.ndarray | None = None) -> None:
        self.mixture = mixture
        self.tracks = tracks
        self.rewards = rewards
        #: The robots whose reward sets were merged at the step (``reward_set.met_ids``).
        self.met = np.empty(0, dtype=np.int64) if met is None else met

    def targets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Positions (N, 2), covariances (N, 2, 2), weights (N,) and track ids (N,)."""
        t = self._need(self.tracks, "tracks")
        return t.positions, t.covs, t.weights, t.track_ids

    def confirmed_mask(self) -> np.ndarray:
        """Which targets are on a confirmed track, (N,) bool."""
        return self._need(self.tracks, "tracks").confirmed

    def reward_set(self) -> np.ndarray:
        """The reward set M_k (K, 2) [m]."""
        return self._need(self.rewards, "reward_set")

    @staticmethod
    def _need(value, what: str):
        if value is None:
            raise AttributeError(f"the robot published no {what}")
        return value


def mixture_arrays(step: Step) -> MixtureArrays:
    """The robot's GM-PHD components at the step (made once per step, shared by faces)."""
    if "mixture" not in step.cache:
        mix = step.agent.estimator.mixture
        step.cache["mixture"] = MixtureArrays(mix.weights, mix.means, mix.covs)
    return step.cache["mixture"]


def track_arrays(step: Step) -> TrackArrays:
    """The robot's targets with their tracks at the step (made once, shared by faces).

    From the estimator's ``targets()``, ``confirmed_mask()`` and track layer.
    """
    if "tracks" not in step.cache:
        est = step.agent.estimator
        positions, covs, weights, ids = est.targets()
        life = np.array([est.tracks.tracks[i].life for i in ids.tolist()], dtype=np.int64)
        step.cache["tracks"] = TrackArrays(ids, life, est.confirmed_mask(), weights,
                                           positions, covs)
    return step.cache["tracks"]


def _components(step: Step, memo: dict) -> GaussianMixture:
    mix = mixture_arrays(step)
    return gaussian_mixture(step.robot_id, step.k, mix.weights, mix.means, mix.covs,
                            step.dt, step.frame_id)


def _tracks(step: Step, memo: dict) -> TrackSet:
    return track_set(step.robot_id, step.k, track_arrays(step), step.dt, step.frame_id)


#: Most components / targets a received message may hold (bigger ones are refused).
MAX_RECEIVED = 100_000

#: Output ``components``: the robot's GM-PHD components (Vo & Ma; Sung & Tokekar Layer 1).
COMPONENTS = Face(GaussianMixture, _components,
                  read=lambda msg: mixture_from_ros(msg, MAX_RECEIVED))
#: Output ``tracks``: the robot's targets with their tracks (Sung & Tokekar Layers 2-3).
TRACKS = Face(TrackSet, _tracks, read=lambda msg: tracks_from_ros(msg, MAX_RECEIVED))


def estimator_view(values: dict[str, Any]) -> EstimatorView:
    """What a Gaussian-mixture estimator's ``figures`` hook reads of a robot.

    Built from the robot's read outputs: ``components``, and ``tracks`` and ``reward_set``
    where the estimator is observed through them (the observation's ``view``).
    """
    rewards, met = values.get("reward_set", (None, None))
    return EstimatorView(values["components"], values.get("tracks"), rewards, met)
