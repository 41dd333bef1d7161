"""The disk sensor that also reads each detected target's identity, as a tag reader would.

Registered as the ``disk_labelled`` sensor (:mod:`phd_swarm.core.registry`). Shirsat &
Berman's targets carry "a unique identification label" (Sec. II) and a reward set holds
tuples <l, v> (eq. 19). This sensor is that reading made explicit: a *sensor* that
identifies the targets it detects (an RFID or fiducial-tag reader, a camera that reads a
number painted on the target), not a filter that sees the truth. What it measures:

- positions exactly as the ``disk`` sensor (:mod:`.disk`, Dames eq. 9-11): each target in
  the field-of-view disk detected with probability p_d, measured as z ~ N(x, variance I),
  and a Poisson number of clutter points uniform in the disk. The random numbers are drawn
  in the same order from the same stream, so a run with this sensor measures the same
  positions as the same run with ``disk``, bit for bit (tested); only the labels are added;
- a label per measurement: a detection carries its target's tag, ``target id + 1``, and a
  clutter point carries 0, "no label" (clutter is not a tagged object, so the reader reads
  nothing there). Tags are >= 1 so that 0 can mean "none" on the wire as well
  (``phd_swarm_msgs/MeasurementSet.labels``).

The reader never mislabels and never reads a tag it does not also detect (a missed target
gives neither a position nor a tag). The estimators' models are those of ``disk``
(``scenario.models``); an estimator that uses the labels says so (``shirsat_gmphd``'s
``reward_union: label``) and refuses a sensor that does not provide ``target_label``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import registry
from ..models import PhdModels
from . import base
from .disk import DiskSensor, draw_scan

#: The label of a measurement that identifies no target (clutter).
NO_LABEL = 0


def tags(ids: np.ndarray) -> np.ndarray:
    """The tag a target of id ``ids`` carries: ``id + 1`` (>= 1; 0 is :data:`NO_LABEL`)."""
    return np.asarray(ids, dtype=np.int64).reshape(-1) + 1


def simulate_labelled_scan(rng: np.random.Generator, models: PhdModels, sensor: np.ndarray,
                           targets: np.ndarray, ids: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray]:
    """One measurement set and its labels for a sensor at ``sensor`` looking at ``targets``.

    The draws of :func:`phd_swarm.core.sensors.disk.draw_scan`, so the positions are the
    ``disk`` sensor's.

    Parameters
    ----------
    rng : np.random.Generator
        Source of all randomness.
    models : PhdModels
        Detection (p_d, radius), measurement variance and clutter density.
    sensor : np.ndarray, shape (2,)
        Sensor position q [m].
    targets : np.ndarray, shape (N, 2)
        True target positions [m].
    ids : np.ndarray of int, shape (N,)
        The targets' ids (``World.truth``), >= 0.

    Returns
    -------
    z : np.ndarray, shape (M, 2)
        Detections of targets (in target order) followed by clutter points [m].
    labels : np.ndarray of int64, shape (M,)
        The detected targets' tags (:func:`tags`), then :data:`NO_LABEL` for each clutter
        point.
    """
    targets = np.asarray(targets, dtype=float).reshape(-1, 2)
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    if ids.shape[0] != targets.shape[0]:
        raise ValueError(f"{ids.shape[0]} ids for {targets.shape[0]} targets")
    hits, clutter, detected = draw_scan(rng, models, sensor, targets)
    labels = np.concatenate([tags(ids[detected]),
                             np.full(clutter.shape[0], NO_LABEL, np.int64)])
    return np.concatenate([hits, clutter], axis=0), labels


def simulate_scan(rng: np.random.Generator, models: PhdModels, sensor: np.ndarray,
                  targets: np.ndarray) -> np.ndarray:
    """The positions of :func:`simulate_labelled_scan` alone (the ``simulate`` of a sensor)."""
    targets = np.asarray(targets, dtype=float).reshape(-1, 2)
    return simulate_labelled_scan(rng, models, sensor, targets,
                                  np.arange(targets.shape[0]))[0]


@dataclass(frozen=True)
class LabelledDiskSensor(DiskSensor, base.LabellingSensor):
    """The disk sensor's models (:class:`~.disk.DiskSensor`) and its tag reader."""

    def simulate(self, rng: np.random.Generator, pose: np.ndarray,
                 targets: np.ndarray) -> np.ndarray:
        """:func:`simulate_scan` with these models (the ``disk`` sensor's positions)."""
        return simulate_scan(rng, self.models, pose, targets)

    def simulate_labelled(self, rng: np.random.Generator, pose: np.ndarray,
                          targets: np.ndarray, ids: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
        """:func:`simulate_labelled_scan` with these models."""
        return simulate_labelled_scan(rng, self.models, pose, targets, ids)


def _setup(scenario, system, **runtime) -> LabelledDiskSensor:
    return LabelledDiskSensor(scenario.models)


registry.register(
    "sensor", "disk_labelled", lambda sensor, rid: sensor, setup=_setup,
    description="The disk sensor (disk field of view, p_d, Gaussian position noise, Poisson "
                "clutter) that also reads the identity tag of each target it detects, as a "
                "tag reader would; clutter carries no tag (Shirsat & Berman Sec. II, eq. 19).",
    provides=("disk_fov", "position_measurement", "target_label"), simulate=base.simulate,
    simulate_labelled=base.simulate_labelled)
