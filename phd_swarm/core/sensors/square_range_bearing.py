"""Square field of view, range-bearing measurements (Papaioannou et al. Sec. IV-C, VI-A).

Registered as the ``square_range_bearing`` sensor (:mod:`phd_swarm.core.registry`). An agent
at s senses the closed axis-aligned square S_a(s) of side a centred on it (eq. 5: 10 m); a
target inside is detected with probability p_D^max (0.99) and measured as
``z = h(x, s) + v``, range [m] and bearing [rad] with range-dependent noise sds
(:class:`~.range_bearing_model.RangeBearingSensor`: zeta0 = 1 m,
beta_zeta = 5e-5, phi0 = pi/180 rad, beta_phi = 1e-5 rad/m). Clutter: a Poisson number of
points (mean ``clutter_rate``, 10) "uniformly distributed over the measurement space":
uniform in range over [0, ``clutter_max_range``] (not stated; the 100 m area's diagonal)
and in bearing, kappa = rate / (2 pi r_max), so few fall in the square
(``clutter_space: square`` puts them all uniformly in the square in the plane instead,
kappa of :func:`~.range_bearing_model.clutter_density_square`;
docs/decisions.md).

Measurements are (range, bearing) pairs, shape (M, 2), not positions: only estimators that
require ``range_bearing_measurement`` can take them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import registry
from ..params import ParamSpec
from . import base
from .range_bearing_model import RangeBearingSensor, clutter_density_square

OPTIONS = (
    ParamSpec("sensing_side", 10.0, "square_range_bearing: side a of the square sensing area "
              "[m] (eq. 5; Sec. VI-A: 10)", low=0.0),
    ParamSpec("p_d_max", 0.99, "square_range_bearing: detection probability inside the "
              "square (eq. 5; Sec. VI-A: 0.99)", low=0.0, high=1.0),
    ParamSpec("clutter_rate", 10.0, "square_range_bearing: expected clutter points per scan, "
              "uniform over the sensing square (Sec. VI-A: 10)", low=0.0),
    ParamSpec("clutter_space", "polar", "square_range_bearing: clutter uniform over the "
              "measurement space of range [0, clutter_max_range] and bearing (-pi, pi] "
              "(polar, as printed) or over the sensing square in the plane (square)",
              choices=("polar", "square")),
    ParamSpec("clutter_max_range", 141.42, "square_range_bearing: the range end of the "
              "measurement space with clutter_space polar [m] (not stated; default the "
              "diagonal of the 100 m area)", low=0.0),
    ParamSpec("range_sd", 1.0, "square_range_bearing: zeta0, range noise sd at zero range "
              "[m] (Sec. VI-A: 1)", low=0.0),
    ParamSpec("range_sd_slope", 5e-5, "square_range_bearing: beta_zeta, growth of the range "
              "sd per metre of range (Sec. VI-A: 5e-5)", low=0.0),
    ParamSpec("bearing_sd", float(np.pi / 180.0), "square_range_bearing: phi0, bearing noise "
              "sd at zero range [rad] (Sec. VI-A: pi/180)", low=0.0),
    ParamSpec("bearing_sd_slope", 1e-5, "square_range_bearing: beta_phi, growth of the "
              "bearing sd [rad/m] (Sec. VI-A: 1e-5)", low=0.0),
)


@dataclass(frozen=True)
class SquareRangeBearing(base.Sensor):
    """The sensor's models (see the module docstring).

    Attributes
    ----------
    side : float
        Side a of the sensing square [m], > 0.
    p_d : float
        p_D^max inside the square [-].
    clutter_rate : float
        Expected clutter points per scan [-], >= 0.
    model : RangeBearingSensor
        h(x, s) and the range-dependent noise.
    """

    side: float = 10.0
    p_d: float = 0.99
    clutter_rate: float = 10.0
    model: RangeBearingSensor = field(default_factory=RangeBearingSensor)
    clutter_max_range: float | None = None

    def __post_init__(self) -> None:
        if not (np.isfinite(self.side) and self.side > 0.0):
            raise ValueError(f"square_range_bearing: sensing_side must be > 0 m, "
                             f"got {self.side!r}")
        if not 0.0 <= self.p_d <= 1.0:
            raise ValueError(f"square_range_bearing: p_d_max must lie in [0, 1], "
                             f"got {self.p_d!r}")
        if not (np.isfinite(self.clutter_rate) and self.clutter_rate >= 0.0):
            raise ValueError(f"square_range_bearing: clutter_rate must be >= 0, "
                             f"got {self.clutter_rate!r}")

    def inside(self, points: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """Which points (N, 2) [m] lie in the closed square S_a(sensor) (eq. 5), (N,) bool."""
        d = np.abs(np.asarray(points, dtype=float).reshape(-1, 2)
                   - np.asarray(sensor, dtype=float).reshape(2))
        return (d <= 0.5 * self.side).all(axis=1)

    def detection_probability(self, points: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """p_D^max inside the closed square S_a(pose), 0 outside (eq. 5); (N,)."""
        return np.where(self.inside(points, pose), self.p_d, 0.0)

    def simulate(self, rng: np.random.Generator, pose: np.ndarray,
                 targets: np.ndarray) -> np.ndarray:
        """:func:`simulate_scan` of this sensor."""
        return simulate_scan(rng, self, pose, targets)

    @property
    def polar_clutter_density(self) -> float | None:
        """The constant kappa [1/(m rad)] of clutter uniform in (r, phi), or None."""
        if self.clutter_max_range is None:
            return None
        return self.clutter_rate / (2.0 * np.pi * self.clutter_max_range)

    def clutter_intensity(self, z: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """kappa(z) (M,) [1/(m rad)]: plane-uniform over the square, or uniform in (r, phi)."""
        if self.clutter_max_range is None:
            return clutter_density_square(z, sensor, self.side, self.clutter_rate)
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        inside = (z[:, 0] >= 0.0) & (z[:, 0] <= self.clutter_max_range)
        return np.where(inside, self.polar_clutter_density, 0.0)


def simulate_scan(rng: np.random.Generator, sensor_model: SquareRangeBearing,
                  sensor: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """One measurement set (M, 2) of (range [m], bearing [rad]): detections, then clutter.

    Draws, in this order: one ``random(N)`` (detections), one ``standard_normal((D, 2))``
    (noise of the D detections), one ``poisson`` (clutter count C), one ``random((C, 2))``
    (clutter positions, uniform in the square, or in (range, bearing) with
    ``clutter_max_range``).
    """
    s = np.asarray(sensor, dtype=float).reshape(-1)[:2]
    x = np.asarray(targets, dtype=float).reshape(-1, 2)
    detected = rng.random(len(x)) < sensor_model.detection_probability(x, s)
    hits = sensor_model.model.simulate(rng, x[detected], s)
    n = rng.poisson(sensor_model.clutter_rate)
    u = rng.random((n, 2))
    if sensor_model.clutter_max_range is not None:
        clutter = np.stack([u[:, 0] * sensor_model.clutter_max_range,
                            np.pi - 2.0 * np.pi * u[:, 1]], axis=1)
        return np.concatenate([hits, clutter], axis=0)
    clutter = s + (u - 0.5) * sensor_model.side
    return np.concatenate([hits, sensor_model.model.measure(clutter, s)], axis=0)


def _setup(scenario, system, **runtime) -> SquareRangeBearing:
    opt = {spec.name: system.option(spec.name) for spec in OPTIONS}
    return SquareRangeBearing(
        float(opt["sensing_side"]), float(opt["p_d_max"]), float(opt["clutter_rate"]),
        RangeBearingSensor(float(opt["range_sd"]), float(opt["range_sd_slope"]),
                           float(opt["bearing_sd"]), float(opt["bearing_sd_slope"])),
        float(opt["clutter_max_range"]) if opt["clutter_space"] == "polar" else None)


registry.register(
    "sensor", "square_range_bearing", lambda sensor_model, rid: sensor_model, setup=_setup,
    description="Square field of view, p_D inside, range and bearing with range-dependent "
                "noise, Poisson clutter uniform over the square (Papaioannou et al. Sec. IV-C, "
                "VI-A).",
    options=OPTIONS, provides=("square_fov", "range_bearing_measurement"),
    simulate=base.simulate)
