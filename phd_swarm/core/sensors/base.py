"""The sensor role: what a robot's sensor sees of the targets, and how it measures them.

A sensor part's instance (what its registry entry's ``setup`` makes of the scenario, and
``make`` hands every robot) is the sensor's model: the field of view with its detection
probability, and the measurement process, noise and clutter included. The world simulates
each robot's scan with it (the part's ``simulate`` hook, :func:`simulate`); the estimators
filter the scans with the same model, each through what its system needs of it (the disk's
p_D and Gaussian noise, the square's range-bearing likelihood and clutter intensity). What
the measurements are, and so which estimators can take them, the part declares with its
capabilities (``position_measurement``, ``range_bearing_measurement``, ``target_label``).

The models several parts and estimators share live beside the parts:
:mod:`.fov_detection` (p_D of a Gaussian component in a disk or square field of view, Sung &
Tokekar eq. 9-10) and :mod:`.range_bearing_model` (Papaioannou et al.'s range-bearing
measurement, Sec. VI-A).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np


class Sensor(ABC):
    """A sensor's model: p_D over the field of view, and one simulated scan."""

    @abstractmethod
    def detection_probability(self, points: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """p_D(x | s) of a target at each of ``points`` (N, 2) [m] seen from ``pose`` (2,) [m].

        Returns
        -------
        np.ndarray, shape (N,)
            Detection probability [-], in [0, 1]; 0 outside the field of view.
        """

    @abstractmethod
    def simulate(self, rng: np.random.Generator, pose: np.ndarray,
                 targets: np.ndarray) -> np.ndarray:
        """One measurement set of the targets at ``targets`` (N, 2) [m] from ``pose`` (2,) [m].

        Every random number comes from ``rng``, drawn in an order the part documents.

        Returns
        -------
        np.ndarray, shape (M, m)
            The measurements, detections then clutter, in the units the part declares
            (positions [m], or range [m] and bearing [rad]).
        """


class LabellingSensor(Sensor):
    """A sensor that also identifies the targets it detects (capability ``target_label``)."""

    @abstractmethod
    def simulate_labelled(self, rng: np.random.Generator, pose: np.ndarray,
                          targets: np.ndarray, ids: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`~Sensor.simulate` and a label per measurement (M,) int64, 0 for none.

        ``ids`` (N,) are the targets' ids; the measurements are those :meth:`simulate`
        draws from the same ``rng``.
        """


def simulate(rng: np.random.Generator, sensor: Sensor, pose: np.ndarray,
             targets: np.ndarray) -> np.ndarray:
    """A sensor part's ``simulate`` hook (:mod:`phd_swarm.core.registry`): ``sensor.simulate``.

    Parameters
    ----------
    rng : np.random.Generator
        The world's sensor stream.
    sensor : Sensor
        The part's instance (its ``setup``'s result).
    pose : np.ndarray, shape (2,)
        Sensor position [m].
    targets : np.ndarray, shape (N, 2)
        True target positions [m].
    """
    return sensor.simulate(rng, pose, targets)


def simulate_labelled(rng: np.random.Generator, sensor: LabellingSensor, pose: np.ndarray,
                      targets: np.ndarray, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A labelling sensor part's ``simulate_labelled`` hook: ``sensor.simulate_labelled``."""
    return sensor.simulate_labelled(rng, pose, targets, ids)
