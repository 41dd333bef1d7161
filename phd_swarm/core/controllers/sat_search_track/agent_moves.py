"""The admissible moves of Papaioannou et al.'s agents (eq. 4): a polar lattice of next positions.

An agent at ``s`` may move to ``s + l1 Delta_R (cos(l2 Delta_theta), sin(l2 Delta_theta))``
with ``l1 = 1 .. N_R``, ``l2 = 0 .. N_theta - 1`` and ``Delta_theta = 2 pi / N_theta``, or
stay: ``1 + N_R N_theta`` actions, 17 for the paper's Delta_R = 2 m, N_R = 2, N_theta = 8
(Sec. VI-A). Eq. 4 prints ``l2 = 0, ..., N_theta``, which lists the direction 0 twice
(``N_theta Delta_theta = 2 pi``); the paper's count of 17 fixes the reading used here.

Action 0 is staying; then ring l1 = 1 counter-clockwise from +x, then ring 2, and so on.
The order is fixed so that a tie between actions is broken the same way everywhere (the
lowest index wins). Moves that would leave the surveillance region are not admissible.

Reference: S. Papaioannou et al., "A cooperative multi-agent probabilistic framework for
search and track missions", IEEE T-CNS, eq. 4.
"""

from __future__ import annotations

import numpy as np

__all__ = ["action_offsets", "admissible_positions"]


def action_offsets(step: float, rings: int, directions: int) -> np.ndarray:
    """The displacements of eq. 4, shape (1 + rings * directions, 2) [m]; row 0 is staying.

    Parameters
    ----------
    step : float
        Delta_R, the radial step [m], > 0.
    rings : int
        N_R >= 1.
    directions : int
        N_theta >= 1.
    """
    if not (np.isfinite(step) and step > 0.0):
        raise ValueError(f"radial step Delta_R must be a finite number > 0 [m], got {step!r}")
    if int(rings) != rings or rings < 1 or int(directions) != directions or directions < 1:
        raise ValueError(f"N_R and N_theta must be integers >= 1, got {rings!r}, "
                         f"{directions!r}")
    l1 = np.repeat(np.arange(1, int(rings) + 1), int(directions))
    l2 = np.tile(np.arange(int(directions)), int(rings))
    theta = l2 * (2.0 * np.pi / int(directions))
    ring = np.stack([l1 * step * np.cos(theta), l1 * step * np.sin(theta)], axis=1)
    return np.vstack([np.zeros((1, 2)), ring])


def admissible_positions(position: np.ndarray, offsets: np.ndarray,
                         bounds: tuple[float, float, float, float]
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Next positions of every action from ``position`` and which stay in the region.

    Parameters
    ----------
    position : np.ndarray, shape (2,)
        The agent's position s_{k-1} [m].
    offsets : np.ndarray, shape (U, 2)
        From :func:`action_offsets`.
    bounds : tuple
        (xmin, ymin, xmax, ymax) of the surveillance region [m], closed.

    Returns
    -------
    positions : np.ndarray, shape (U, 2) [m]
    admissible : np.ndarray of bool, shape (U,)
        Inside the region; staying is always admissible.
    """
    s = np.asarray(position, dtype=float).reshape(2)
    if not np.isfinite(s).all():
        raise ValueError(f"position must be finite, got {s.tolist()}")
    xmin, ymin, xmax, ymax = bounds
    pos = s + offsets
    ok = ((pos[:, 0] >= xmin) & (pos[:, 0] <= xmax) & (pos[:, 1] >= ymin)
          & (pos[:, 1] <= ymax))
    ok[0] = True
    return pos, ok
