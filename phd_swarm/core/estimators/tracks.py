"""Track layer over extracted targets: persistent ids, tentative and confirmed tracks.

Sung & Tokekar (Sec. V-F, "Layer 3") keep the trajectories of individual targets on top of
the GM-PHD's extracted targets (Layer 2), track-to-estimate:

- a track is its id and the history of the states associated with it (its life length l is
  the number of associations);
- a target (an extracted state with its covariance) is associated with the track whose
  last state lies within the gate, the Mahalanobis threshold of the merging step,
  ``(t - x)^T P^-1 (t - x) <= gate`` with P the target's covariance (as in Vo & Ma's merge,
  a squared distance);
- each track takes at most one target per step and each target at most one track: the
  gating (target, track) pairs are taken in increasing distance (ties: the older track),
  a pair whose target or track is already taken is skipped. So when several targets gate
  one track the nearest keeps it (the paper: new tracks "if more than one target is
  associated with an existing track") and the others take their next gating track, or
  start a new track, with a new id, as does a target that no track gates. The copies of
  one heavy component (Vo & Ma Table III extracts round(w) targets at its mean) thus keep
  the tracks they had, one each, instead of starting new ones every step;
- a track is *tentative* while l < ``confirm_after`` (l_threshold, 3 in the paper) and
  *confirmed* from then on. A track that gets no target keeps its history: the paper does
  not end tracks, and a searched-for target out of view is still there.

The distances are one (targets x tracks) array, computed with the last states of the
tracks kept in one array; only the gating pairs (a few per target) are visited one by one.

Reference: Y. Sung and P. Tokekar, "GM-PHD filter for searching and tracking an unknown
number of targets with a mobile sensor with limited FOV", IEEE T-ASE, 2022, Sec. V-F.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..checks import check_finite, check_positive_int, check_spd


@dataclass
class Track:
    """One target's trajectory.

    Attributes
    ----------
    track_id : int
        Persistent id, never reused.
    steps : list of int
        Steps at which a target was associated with the track.
    states : list of np.ndarray
        The associated states, shape (d,) each, in the units of the state.
    """

    track_id: int
    steps: list[int] = field(default_factory=list)
    states: list[np.ndarray] = field(default_factory=list)

    @property
    def life(self) -> int:
        """Life length l: the number of associations."""
        return len(self.states)

    @property
    def last(self) -> np.ndarray:
        """The latest associated state (d,)."""
        return self.states[-1]

    def window(self, w: int) -> tuple[np.ndarray, np.ndarray]:
        """The last ``min(w, life)`` steps (n,) and states (n, d), as read-only arrays.

        Kept in arrays beside the lists (grown by doubling), so that a GP prediction over
        the recent history (Sec. V-B) does not restack it every step.
        """
        n = self.life
        if self._size != n:                      # the lists were appended to directly
            self._steps_buf = np.asarray(self.steps, dtype=float)
            self._states_buf = np.asarray(self.states, dtype=float).reshape(n, -1)
            self._size = n
        lo = max(0, n - int(w))
        steps, states = self._steps_buf[lo:n], self._states_buf[lo:n]
        steps.flags.writeable = False
        states.flags.writeable = False
        return steps, states

    def append(self, step: int, state: np.ndarray) -> None:
        """Associate ``state`` (d,) at ``step``: the lists and the arrays."""
        state = np.array(state, dtype=float)
        if self._size == len(self.states):
            n = self._size
            if n == self._steps_buf.shape[0]:
                cap = max(16, 2 * n)
                steps = np.empty(cap)
                states = np.empty((cap, state.shape[0]))
                if n:
                    steps[:n] = self._steps_buf[:n]
                    states[:n] = self._states_buf[:n]
                self._steps_buf, self._states_buf = steps, states
            self._steps_buf[n] = step
            self._states_buf[n] = state
            self._size = n + 1
        self.steps.append(int(step))
        self.states.append(state)

    _steps_buf: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False,
                                   compare=False)
    _states_buf: np.ndarray = field(default_factory=lambda: np.empty((0, 0)), repr=False,
                                    compare=False)
    _size: int = field(default=0, repr=False, compare=False)


class TrackLayer:
    """Tracks kept from the targets extracted each step (Sung & Tokekar Sec. V-F).

    Parameters
    ----------
    gate : float
        Squared Mahalanobis threshold of an association (the merging threshold U), > 0.
    confirm_after : int
        l_threshold: a track is confirmed once its life length reaches it (3 in the paper).
    """

    def __init__(self, gate: float, confirm_after: int = 3) -> None:
        gate = float(gate)
        if not np.isfinite(gate) or gate <= 0.0:
            raise ValueError(f"gate must be finite and > 0, got {gate!r}")
        self.gate = gate
        self.confirm_after = check_positive_int("confirm_after", confirm_after)
        self.tracks: list[Track] = []
        self._next_id = 0
        #: Row i: the last state of ``tracks[i]``; grown by doubling, ``len(tracks)`` rows
        #: used (tracks never end, so restacking them every step would grow with the run).
        self._last = np.empty((0, 0))

    def confirmed(self) -> list[Track]:
        """The tracks whose life length has reached ``confirm_after``."""
        return [t for t in self.tracks if t.life >= self.confirm_after]

    def tentative(self) -> list[Track]:
        """The tracks not confirmed yet."""
        return [t for t in self.tracks if t.life < self.confirm_after]

    def update(self, step: int, states: np.ndarray, covs: np.ndarray) -> np.ndarray:
        """Associate this step's targets with the tracks; returns each target's track id.

        Parameters
        ----------
        step : int
            The step of the targets.
        states : np.ndarray, shape (N, d)
            Extracted target states (e.g. the means of the GM-PHD components above the
            extraction threshold).
        covs : np.ndarray, shape (N, d, d)
            Their covariances, SPD (the components' covariances).

        Returns
        -------
        np.ndarray of int, shape (N,)
            The id of the track each target now belongs to.
        """
        states = np.asarray(states, dtype=float)
        covs = np.asarray(covs, dtype=float)
        if states.ndim != 2 or covs.shape != (states.shape[0], states.shape[1],
                                               states.shape[1]):
            raise ValueError(f"states must be (N, d) and covs (N, d, d), got {states.shape} "
                             f"and {covs.shape}")
        check_finite("states", states)
        n = states.shape[0]
        ids = np.full(n, -1)
        if n == 0:
            return ids
        check_spd("covs", covs)
        if self.tracks:
            last = self._last[:len(self.tracks)]                          # (T, d)
            diff = last[None, :, :] - states[:, None, :]                  # (N, T, d)
            dist = np.sum((diff @ np.linalg.inv(covs)) * diff, axis=2)    # (N, T)
            rows, cols = np.nonzero(dist <= self.gate)
            order = np.lexsort((cols, dist[rows, cols]))                  # ties: older
            taken = set()
            for i, t in zip(rows[order].tolist(), cols[order].tolist(), strict=True):
                if ids[i] >= 0 or t in taken:
                    continue
                taken.add(t)
                ids[i] = self.tracks[t].track_id
                self.tracks[t].append(step, states[i])
                self._last[t] = states[i]
        new = np.flatnonzero(ids < 0)
        if new.size:
            self._reserve(len(self.tracks) + new.size, states.shape[1])
        for i in new:
            track = Track(self._next_id)
            track.append(step, states[i])
            self._next_id += 1
            self._last[len(self.tracks)] = states[i]
            self.tracks.append(track)
            ids[i] = track.track_id
        return ids

    def _reserve(self, rows: int, dim: int) -> None:
        """Room for ``rows`` last states of dimension ``dim`` (capacity doubles)."""
        if self._last.shape[1] != dim:
            if self.tracks:
                raise ValueError(f"states have dimension {dim}, the tracks "
                                 f"{self._last.shape[1]}")
            self._last = np.empty((0, dim))
        if rows > self._last.shape[0]:
            grown = np.empty((max(rows, 2 * self._last.shape[0], 16), dim))
            grown[:len(self.tracks)] = self._last[:len(self.tracks)]
            self._last = grown
