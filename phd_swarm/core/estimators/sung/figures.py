"""The figures of Sung & Tokekar's evaluation, per step, from the estimator and the truth.

Tables I-V and Figs. 8-10 of the paper report, over the steps of a run:

- ``components``: the number of GM-PHD components (Layer 1);
- ``tracks``: the number of confirmed tracks, counted as the confirmed tracks that hold a
  target at this step (tracks never end, Sec. V-F; a track of a target the robot has lost
  stops being counted once its component is pruned);
- ``weights_components``: the sum of all components' weights, the PHD's expected number;
- ``weights_tracks``: the sum of the weights of the components behind confirmed tracks
  (each component once);
- ``mahal_closest`` / ``mahal_second``: the Mahalanobis distance
  sqrt((x - m)^T P^-1 (x - m)) of each true target x to its closest and second-closest
  confirmed track (mean m, covariance P of the track's target), averaged over the true
  targets (Table II: "computed by averaging the values of ten true targets"), with
  ``mahal_closest_sq`` the average square, for the standard deviation over targets and
  steps; NaN when there are fewer confirmed tracks than needed;
- ``largest_variance``: the largest eigenvalue of a confirmed track's covariance [m^2]
  (Fig. 10, "largest variance of targets"); NaN without confirmed tracks;
- ``ospa_tracks``: OSPA (order p, cut-off c; the paper's 2 and 100 m) between the truth and
  the confirmed tracks' positions (Fig. 8e).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...ospa import ospa_components

#: Names of the per-step figures, in order.
FIGURES = ("components", "tracks", "weights_components", "weights_tracks", "mahal_closest",
           "mahal_closest_sq", "mahal_second", "largest_variance", "ospa_tracks")


def mahalanobis_to_tracks(truth: np.ndarray, means: np.ndarray,
                          covs: np.ndarray) -> np.ndarray:
    """Distances sqrt((x - m)^T P^-1 (x - m)) of each truth x to each track (m, P).

    Parameters
    ----------
    truth : np.ndarray, shape (N, 2)
    means : np.ndarray, shape (T, 2)
    covs : np.ndarray, shape (T, 2, 2), SPD

    Returns
    -------
    np.ndarray, shape (N, T), sorted along axis 1 (closest first).
    """
    diff = truth[:, None, :] - means[None, :, :]
    d2 = np.einsum("ntd,tde,nte->nt", diff, np.linalg.inv(covs), diff)
    return np.sort(np.sqrt(np.maximum(d2, 0.0)), axis=1)


def step_figures(estimators: list[Any], truth: np.ndarray, c: float,
                 p: float) -> dict[str, float]:
    """The figures of one step (see the module docstring) of a one-robot team.

    The paper's figures (its tracks, their Mahalanobis distances) are those of its one
    robot; a team of several has none (an empty dict), so a multi-robot run is scored by
    OSPA and cardinality alone rather than stopped (the monitor called this every step).

    Parameters
    ----------
    estimators : list of SungEstimator
        The team's estimators; the paper's team is one robot.
    truth : np.ndarray, shape (N, 2)
        True target positions at the step [m].
    c, p : float
        OSPA cut-off [m] and order.
    """
    if len(estimators) != 1:
        return {}
    est = estimators[0]
    positions, covs, weights, track_ids = est.targets()
    return track_figures(est.mixture.weights, positions, covs, weights, track_ids,
                         est.confirmed_mask(), truth, c, p)


def track_figures(component_weights: np.ndarray, positions: np.ndarray, covs: np.ndarray,
                  weights: np.ndarray, track_ids: np.ndarray, confirmed: np.ndarray,
                  truth: np.ndarray, c: float, p: float) -> dict[str, float]:
    """The figures of one step from arrays: what a robot publishes, or a log holds.

    Parameters
    ----------
    component_weights : np.ndarray, shape (J,)
        The weights of the GM-PHD components (Layer 1).
    positions, covs, weights, track_ids, confirmed : np.ndarray
        The targets (Layer 2): positions (N, 2) [m], covariances (N, 2, 2), the weights of
        their components (N,), their track ids (N,) and whether each track is confirmed
        (N,) bool.
    truth : np.ndarray, shape (M, 2)
        True target positions at the step [m].
    c, p : float
        OSPA cut-off [m] and order.
    """
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    confirmed = np.asarray(confirmed, dtype=bool)
    ids, first = np.unique(track_ids[confirmed], return_index=True)
    pos_c, cov_c = positions[confirmed][first], covs[confirmed][first]
    # A component with weight >= 1.5 gives several targets: count its weight once.
    _, comp_first = np.unique(positions[confirmed], axis=0, return_index=True)
    weights_tracks = float(weights[confirmed][comp_first].sum())
    nan = float("nan")
    closest = second = closest_sq = nan
    if len(ids) and len(truth):
        d = mahalanobis_to_tracks(truth, pos_c, cov_c)
        closest = float(d[:, 0].mean())
        closest_sq = float((d[:, 0] ** 2).mean())
        if d.shape[1] > 1:
            second = float(d[:, 1].mean())
    largest = float(np.linalg.eigvalsh(cov_c)[:, -1].max()) if len(ids) else nan
    return {"components": float(len(component_weights)), "tracks": float(len(ids)),
            "weights_components": float(np.sum(component_weights)),
            "weights_tracks": weights_tracks,
            "mahal_closest": closest, "mahal_closest_sq": closest_sq, "mahal_second": second,
            "largest_variance": largest,
            "ospa_tracks": float(ospa_components(truth, pos_c, c, p).distance)}
