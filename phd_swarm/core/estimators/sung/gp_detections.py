"""What Sung & Tokekar's GP regresses on: a track's estimates or its detections (Sec. V-B).

Eq. 8 predicts a confirmed track's component from "the history of mean values of
components" M^d at the steps K, and the text before it says that "noisy measurements of
the state of the targets are fed as input to GP regression". Two readings, the option
``gp_input`` of ``sung_gmphd``:

- ``estimates`` (the default, the form the committed rows were made with): the history is
  the track's states, the target extracted for it at every step it was associated
  (:class:`.tracks.TrackLayer`). Out of view p_D ~ 0, so the component keeps its weight and
  stays extracted and associated, and its history fills with the GP's own predictions;
- ``detections``: the history holds only the measured positions of the detections
  associated with the track, at their steps (:class:`DetectionHistories`). A track with
  no new detection is predicted from that history alone (eq. 8 at the next step, with the
  last detection steps as K: the GP extrapolates in time from them); a confirmed track
  with no detection yet (a component of the initial belief, never seen) keeps the linear
  model, as a component on no confirmed track does.

Which detection is a track's at step k (:func:`majority_measurement`). The GM-PHD does
not assign measurements; it shares each measurement z among the components (Vo & Ma
Table I step 4: the detection term of component j by z has weight w_j(z), and the w_j(z)
of one z sum to at most 1, the rest being clutter's), then merges (Table II) and, in Sung
& Tokekar, adds one newborn of weight 1 at z (Sec. V-D). Following the weights through the
reduction (:func:`.gm_phd.filter.prune_and_merge_carrying`), each component c of step k has a
share s_c(z): the summed weight of the detection terms by z and of z's newborn merged into
c. z is the detection of c when it makes up more than half of c's weight,
``s_c(z) > w_c / 2`` (so at most one z per component; ties cannot occur). The track the
track layer associates c's target with at step k gets z. A track whose target is out of
view is made of missed-detection terms only and gets nothing; a target detected in view
is made mostly of its detection term and newborn (~2 of a weight of ~2); a new track's
first point is the detection whose newborn started it. A detection reaches more than one
track only where the reduction leaves more than one component made mostly of it:
``newborn_merge = next_step`` (the newborn and the updated component are two targets)
and ``extraction = rounded`` (copies of one component on several tracks).
docs/decisions.md records the reading.

Reference: Y. Sung and P. Tokekar, "GM-PHD filter for searching and tracking an unknown
number of targets with a mobile sensor with limited FOV", IEEE T-ASE, 2022, Sec. V-B,
eq. 7-8, Sec. V-D, V-F.
"""

from __future__ import annotations

import numpy as np

from ...params import ParamSpec
from ..tracks import Track

#: The readings of the GP's input history (module docstring).
GP_INPUTS = ("estimates", "detections")

GP_INPUT_OPTION = ParamSpec(
    "gp_input", "estimates", "sung_gmphd: what a confirmed track's GP (eq. 8) regresses on: "
    "the targets extracted for the track at every associated step (estimates) or only the "
    "measured positions of the detections associated with it (detections, Sec. V-B: 'noisy "
    "measurements ... are fed as input to GP regression')", choices=GP_INPUTS)


def majority_measurement(shares: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The measurement each component is mostly made of, or -1.

    Parameters
    ----------
    shares : np.ndarray, shape (J, M)
        s_c(z): the weight measurement z brought to component c
        (:attr:`.gm_phd.estimator.GmPhdEstimator.shares`).
    weights : np.ndarray, shape (J,)
        w_c, the components' weights.

    Returns
    -------
    np.ndarray of int, shape (J,)
        The z with ``s_c(z) > w_c / 2`` (at most one exists, since the shares of a
        component sum to at most its weight), else -1.
    """
    shares = np.asarray(shares, dtype=float)
    weights = np.asarray(weights, dtype=float)
    if shares.ndim != 2 or shares.shape[0] != weights.shape[0]:
        raise ValueError(f"shares must have shape ({weights.shape[0]}, M), got {shares.shape}")
    out = np.full(weights.shape[0], -1)
    if shares.shape[1] == 0:
        return out
    best = np.argmax(shares, axis=1)
    ok = shares[np.arange(shares.shape[0]), best] > 0.5 * weights
    out[ok] = best[ok]
    return out


class DetectionHistories:
    """Per track id, the steps and measured positions of the detections associated with it.

    Each history is a :class:`.tracks.Track` (its ``states`` are measured positions, its
    ``life`` the number of detections), so a GP window over it (:meth:`window`) costs no
    restacking.
    """

    def __init__(self) -> None:
        self._by_id: dict[int, Track] = {}

    def record(self, step: int, track_ids: np.ndarray, positions: np.ndarray) -> None:
        """Append ``positions[i]`` (N, d) [m] at ``step`` to the history of ``track_ids[i]``.

        A track appears at most once per step (the track layer gives each track at most
        one target a step); a repeated id in one call is refused.
        """
        ids = np.asarray(track_ids, dtype=int).reshape(-1)
        positions = np.asarray(positions, dtype=float)
        if positions.shape[:1] != ids.shape:
            raise ValueError(f"positions must have shape ({ids.size}, d), got "
                             f"{positions.shape}")
        if np.unique(ids).size != ids.size:
            raise ValueError(f"a track gets at most one detection per step, got {ids}")
        for tid, pos in zip(ids.tolist(), positions, strict=True):
            history = self._by_id.setdefault(tid, Track(tid))
            if history.steps and history.steps[-1] >= step:
                raise ValueError(f"track {tid}: step {step} is not after its last detection "
                                 f"({history.steps[-1]})")
            history.append(step, pos)

    def count(self, track_id: int) -> int:
        """The number of detections of a track (0 for an id never detected)."""
        history = self._by_id.get(int(track_id))
        return 0 if history is None else history.life

    def window(self, track_id: int, w: int) -> tuple[np.ndarray, np.ndarray]:
        """The last ``min(w, count)`` steps (n,) and positions (n, d) of a detected track."""
        return self._by_id[int(track_id)].window(w)

    def history(self, track_id: int) -> tuple[list[int], list[np.ndarray]]:
        """All the steps and positions of a track's detections (empty lists if none)."""
        h = self._by_id.get(int(track_id))
        return ([], []) if h is None else (list(h.steps), list(h.states))
