"""The disk sensor (Dames 2020 Sec. II-B): a field-of-view disk, position measurements.

Registered as the ``disk`` sensor (:mod:`phd_swarm.core.registry`); the world simulates scans
with it and the grid PHD filters them with the same models (``scenario.models``).

Simulation: ground truth to a noisy measurement set with misses and clutter.

It draws from the same models the filter assumes (Dames eq. 9-11): each target in the field
of view is detected with probability p_d and measured as z ~ N(x, variance I); clutter is a
Poisson number (mean ``clutter.density * fov_area``) of points uniform in the field-of-view
disk. All randomness comes from the Generator passed in.
"""

from __future__ import annotations

import numpy as np

from .. import registry
from ..models import PhdModels


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


def _setup(scenario, system, **runtime) -> PhdModels:
    return scenario.models


registry.register(
    "sensor", "disk", lambda models, rid: models, setup=_setup,
    description="Disk field of view, p_d inside, position measurements with Gaussian noise, "
                "Poisson clutter uniform in the disk (Dames 2020 eq. 9-11).",
    provides=("disk_fov", "position_measurement"), simulate=simulate_scan)
