"""Which target label a GM-PHD component and an extracted estimate carry (labelled reading).

With a sensor that identifies the targets it detects
(:mod:`phd_swarm.core.sensors.disk_labelled`: a detection carries its target's label, a
clutter point 0), Shirsat & Berman's reward set holds tuples <l, v> (eq. 19) and its union
is by label (``reward_union: label`` of ``shirsat_gmphd``;
:func:`phd_swarm.core.estimators.shirsat.reward_sets.union_by_label`). An estimate takes the label
of the measurement that formed it. For the GM-PHD of Vo & Ma (Tables I-III) each component
carries one label, bookkeeping beside the mixture that changes none of its numbers:

1. a birth (eq. 39-40) has no label (0);
2. prediction (eq. 27-29): a survivor keeps its label;
3. update (eq. 33-38): the missed-detection term of a component keeps the component's
   label; the term that measurement z updated takes z's label (0 for clutter), whatever
   the component's label was: the measurement is what the sensor identified now;
4. pruning and merging (Vo & Ma Table II): a merged component takes the label of the
   heaviest component of its group, the one the others merge into (the lead of
   :func:`.gm_phd.team.prune_and_merge_rows`); a label is not averaged. A target's updated
   component outweighs the clutter and birth terms near it in the paper's setting
   (weights ~0.9 against 0.02-0.1), so the lead is nearly always the target's;
5. extraction (Vo & Ma Table III): each of the round(w) copies of a component's mean
   carries the component's label; an estimate whose label is 0 (from clutter, or a birth
   or survivor no identified measurement reached) is an estimate of X^_k, but it is not
   added to the reward set: the labelled reward holds identified targets only.

So the union by label adds a target when its robot first extracts an estimate that a
measurement of it formed, and never adds a clutter point: the sensor identifies targets,
the filter does not see the truth (which target a label belongs to is unknown to it, and
an undetected target gets no label).
"""

from __future__ import annotations

import numpy as np

from ...scan import Scan


def measurement_labels(scan: Scan) -> np.ndarray:
    """The label of each measurement of ``scan``, (M,) int64.

    Raises
    ------
    ValueError
        If the scan has measurements but no labels: the labelled reading needs a sensor
        that identifies targets (``sensor: disk_labelled``; the ROS stack refuses that
        sensor, as its messages carry no labels).
    """
    if len(scan.labels) == len(scan.z):
        return scan.labels
    raise ValueError(f"scan of robot {scan.robot_id} at step {scan.step}: {len(scan.z)} "
                     f"measurements without labels; shirsat_gmphd's reward_union: label "
                     f"needs a sensor that identifies targets (e.g. sensor: disk_labelled)")


def posterior_labels(births: int, prior: np.ndarray, z_labels: np.ndarray | None
                     ) -> np.ndarray:
    """Labels of the updated components (steps 1-3 of the module docstring).

    Parameters
    ----------
    births : int
        The birth components, first in the predicted mixture (label 0).
    prior : np.ndarray of int64, shape (J_s,)
        The predicted survivors' labels, after the births.
    z_labels : np.ndarray of int64, shape (M,), or None
        The measurements' labels; None if the robot updated with no measurement (the
        mixture is then the missed-detection terms alone).

    Returns
    -------
    np.ndarray of int64, shape (J (1 + M),), J = births + J_s
        In the order of :func:`.gm_phd.filter.update_with_terms`'s mixture: the J missed-detection
        terms, then J terms per measurement.
    """
    missed = np.concatenate([np.zeros(births, dtype=np.int64), prior])
    if z_labels is None:
        return missed
    return np.concatenate([missed, np.repeat(np.asarray(z_labels, dtype=np.int64),
                                             missed.size)])


def estimate_labels(weights: np.ndarray, labels: np.ndarray, threshold: float) -> np.ndarray:
    """The label of each estimate of :func:`.gm_phd.filter.extract` (step 5), (N,) int64.

    ``labels`` (J,) are the components' (of weights ``weights`` (J,)); a component above
    ``threshold`` gives ``floor(w + 1/2)`` estimates, each with its label.
    """
    sel = weights > threshold
    copies = np.floor(weights[sel] + 0.5).astype(int)
    return np.repeat(labels[sel], copies)
