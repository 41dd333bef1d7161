"""The disk sensor (Dames 2020 Sec. II-B): a field-of-view disk, position measurements.

Registered as the ``disk`` sensor (:mod:`phd_swarm.core.registry`); its instance is a
:class:`DiskSensor` over the scenario's models (``scenario.models``), with which the world
simulates scans, and the grid PHD filters them with the same models.

Simulation: ground truth to a noisy measurement set with misses and clutter.

It draws from the same models the filter assumes (Dames eq. 9-11): each target in the field
of view is detected with probability p_d and measured as z ~ N(x, variance I); clutter is a
Poisson number (mean ``clutter.density * fov_area``) of points uniform in the field-of-view
disk. All randomness comes from the Generator passed in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import registry
from ..models import PhdModels
from . import base


@dataclass(frozen=True)
class DiskSensor(base.Sensor):
    """The disk sensor's models: p_d in the disk (eq. 9), N(x, variance I) (eq. 10), clutter.

    Attributes
    ----------
    models : PhdModels
        ``detection`` (p_d, radius [m]), ``measurement`` (variance [m^2]) and ``clutter``
        (density [1/m^2], eq. 11); the scenario's, which the grid PHD filters with.
    """

    models: PhdModels

    def detection_probability(self, points: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """p_d inside the disk of the sensor at ``pose``, 0 outside (eq. 9); (N,)."""
        return self.models.detection.probability(points, pose)

    def simulate(self, rng: np.random.Generator, pose: np.ndarray,
                 targets: np.ndarray) -> np.ndarray:
        """:func:`simulate_scan` with these models."""
        return simulate_scan(rng, self.models, pose, targets)


def simulate_scan(rng: np.random.Generator, models: PhdModels, sensor: np.ndarray,
                  targets: np.ndarray) -> np.ndarray:
    """One measurement set for a sensor at ``sensor`` looking at ``targets``.

    Parameters
    ----------
    rng : np.random.Generator
        Source of all randomness (detections, noise, clutter), consumed in a fixed order.
    models : PhdModels
        Detection (p_d, radius), measurement variance and clutter density.
    sensor : np.ndarray, shape (2,)
        Sensor position q [m].
    targets : np.ndarray, shape (N, 2)
        True target positions [m].

    Returns
    -------
    np.ndarray, shape (M, 2)
        Detections of targets (in target order) followed by clutter points [m].
    """
    hits, clutter, _ = draw_scan(rng, models, sensor, targets)
    return np.concatenate([hits, clutter], axis=0)


def draw_scan(rng: np.random.Generator, models: PhdModels, sensor: np.ndarray,
              targets: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The draws of :func:`simulate_scan`, kept apart: detections, clutter and who was seen.

    In this order from ``rng``: one ``random(N)`` (detections), one
    ``standard_normal((D, 2))`` (noise), one ``poisson`` (the clutter count C) and one
    ``random((C, 2))`` (clutter radius and angle). A sensor that adds to the positions (the
    tag reader of :mod:`.disk_labelled`) draws them here, so its positions are these.

    Returns
    -------
    hits : np.ndarray, shape (D, 2)
        Measurements of the detected targets, in target order [m].
    clutter : np.ndarray, shape (C, 2)
        Clutter points [m].
    detected : np.ndarray of bool, shape (N,)
        Which targets were detected.
    """
    sensor = np.asarray(sensor, dtype=float)[:2]
    targets = np.asarray(targets, dtype=float).reshape(-1, 2)
    det = models.detection
    detected = rng.random(targets.shape[0]) < det.probability(targets, sensor)
    noise = rng.standard_normal((int(detected.sum()), 2)) * np.sqrt(models.measurement.variance)
    hits = targets[detected] + noise
    n_clutter = rng.poisson(models.clutter.expected_count(det.fov_area))
    # Uniform in the disk: radius ~ R sqrt(U), angle ~ 2 pi U.
    u = rng.random((n_clutter, 2))
    r = det.radius * np.sqrt(u[:, 0])
    a = 2.0 * np.pi * u[:, 1]
    clutter = sensor + np.stack([r * np.cos(a), r * np.sin(a)], axis=1)
    return hits, clutter, detected


def _setup(scenario, system, **runtime) -> DiskSensor:
    return DiskSensor(scenario.models)


registry.register(
    "sensor", "disk", lambda sensor, rid: sensor, setup=_setup,
    description="Disk field of view, p_d inside, position measurements with Gaussian noise, "
                "Poisson clutter uniform in the disk (Dames 2020 eq. 9-11).",
    provides=("disk_fov", "position_measurement"), simulate=base.simulate)
