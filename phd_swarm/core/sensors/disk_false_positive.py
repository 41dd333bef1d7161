"""Disk sensor with at most one false positive per scan (Sung & Tokekar 2022 Sec. VI-A.1).

Registered as the ``disk_false_positive`` sensor (:mod:`phd_swarm.core.registry`). A target
inside the field-of-view disk of radius r (``scenario.models.detection.radius``) is detected
with probability p(D|F) (``models.detection.p_d``; the paper's eq. 9) and measured as
z ~ N(x, R) with R = ``models.measurement.variance`` I. Then, with probability
``false_positive_prob`` (0, 10 or 20 % in Table I), one false measurement uniform in the
disk: "We generate one false positive detection, located uniformly at random within the FOV,
with the given probability."

The filter's clutter intensity for this sensor is the expected number of false positives
spread over the disk, kappa = ``false_positive_prob`` / (pi r^2) [1/m^2]
(:func:`clutter_intensity`), which is the first-moment (PHD) description of a Bernoulli
clutter process with a uniform density.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import registry
from ..models import PhdModels
from ..params import ParamSpec
from . import base

FALSE_POSITIVE_PROB = ParamSpec(
    "false_positive_prob", 0.1, "disk_false_positive: probability of one false measurement "
    "per scan, uniform in the FoV disk (Sung & Tokekar Table I: 0, 0.1, 0.2)",
    low=0.0, high=1.0)


@dataclass(frozen=True)
class DiskFalsePositiveSensor(base.Sensor):
    """The sensor's models: the scenario's disk and noise, and the false-positive rate.

    Attributes
    ----------
    models : PhdModels
        ``detection`` (p(D|F), radius [m]) and ``measurement`` (variance [m^2]).
    false_positive_prob : float
        Probability of one false measurement per scan [-].
    """

    models: PhdModels
    false_positive_prob: float

    @property
    def radius(self) -> float:
        """FoV radius r [m]."""
        return float(self.models.detection.radius)

    def clutter_intensity(self) -> float:
        """Clutter intensity kappa = false_positive_prob / (pi r^2) [1/m^2] in the disk."""
        return self.false_positive_prob / (np.pi * self.radius ** 2)

    def detection_probability(self, points: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """p(D|F) inside the disk of the sensor at ``pose``, 0 outside (eq. 9); (N,)."""
        return self.models.detection.probability(points, pose)

    def simulate(self, rng: np.random.Generator, pose: np.ndarray,
                 targets: np.ndarray) -> np.ndarray:
        """:func:`simulate_scan` of this sensor."""
        return simulate_scan(rng, self, pose, targets)


def simulate_scan(rng: np.random.Generator, sensor_model: DiskFalsePositiveSensor,
                  sensor: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """One measurement set for a sensor at ``sensor`` looking at ``targets``.

    Draws, in this order: one ``random(N)`` (detections), one ``standard_normal((D, 2))``
    (noise of the D detections), one ``random()`` (is there a false positive) and, if so,
    one ``random(2)`` (its radius and angle, uniform in the disk).

    Returns
    -------
    np.ndarray, shape (M, 2)
        Detections in target order, then the false positive if any [m].
    """
    sensor = np.asarray(sensor, dtype=float)[:2]
    targets = np.asarray(targets, dtype=float).reshape(-1, 2)
    detected = rng.random(targets.shape[0]) < sensor_model.detection_probability(targets, sensor)
    variance = sensor_model.models.measurement.variance
    noise = rng.standard_normal((int(detected.sum()), 2)) * np.sqrt(variance)
    hits = targets[detected] + noise
    if rng.random() >= sensor_model.false_positive_prob:
        return hits
    u = rng.random(2)
    r = sensor_model.radius * np.sqrt(u[0])
    a = 2.0 * np.pi * u[1]
    false = sensor + np.array([[r * np.cos(a), r * np.sin(a)]])
    return np.concatenate([hits, false], axis=0)


def _setup(scenario, system, **runtime) -> DiskFalsePositiveSensor:
    return DiskFalsePositiveSensor(scenario.models, float(system.option("false_positive_prob")))


registry.register(
    "sensor", "disk_false_positive", lambda sensor_model, rid: sensor_model, setup=_setup,
    description="Disk field of view, p(D|F) inside, position measurements with Gaussian "
                "noise, one false positive per scan with a probability, uniform in the disk "
                "(Sung & Tokekar 2022 Sec. VI-A).",
    options=(FALSE_POSITIVE_PROB,),
    provides=("disk_fov", "position_measurement"), simulate=base.simulate)
