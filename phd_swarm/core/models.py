"""Target and sensor models of the grid PHD filter, with the papers' values as presets.

Units: positions in metres. Densities are per m^2 (the measurement likelihood g, the clutter
PHD c and the birth PHD b); the grid carries *masses* (expected target counts per bin), so
a density is turned into a bin mass by multiplying by the bin area (the bin-centre rule).

Sources: Dames (2020) eq. 9-11 (sensor) and eq. 13-14 (survival, birth), Sec. IV-B (motion);
Chen, Dames & Park (2021) Sec. 4 (Gaussian random walk, p_s = 1, no birth).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.special import ndtr

from .geometry.grid import Grid


def _check_positive(name: str, value: float, allow_zero: bool = False) -> None:
    ok = np.isfinite(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be a finite number {bound}, got {value!r}")


def _check_probability(name: str, value: float) -> None:
    if not (np.isfinite(value) and 0.0 <= value <= 1.0):
        raise ValueError(f"{name} must be a probability in [0, 1], got {value!r}")


@dataclass(frozen=True)
class DiskDetection:
    """Detection probability p_d(x | q) of a disk sensor (Dames eq. 9).

    ``p_d`` inside a disk of ``radius`` [m] around the sensor, 0 outside. The disk is also
    the sensor's field of view F.
    """

    p_d: float = 0.8
    radius: float = 5.0

    def __post_init__(self) -> None:
        _check_probability("detection.p_d", self.p_d)
        _check_positive("detection.radius", self.radius)

    @property
    def fov_area(self) -> float:
        """Area of the field of view [m^2]."""
        return float(np.pi * self.radius ** 2)

    def probability(self, points: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """p_d at each point for a sensor at ``sensor``; points (N, 2) -> (N,)."""
        d2 = np.sum((np.asarray(points, dtype=float) - np.asarray(sensor)[:2]) ** 2, axis=-1)
        return np.where(d2 <= self.radius ** 2, self.p_d, 0.0)


@dataclass(frozen=True)
class GaussianMeasurement:
    """Measurement likelihood g(z | x, q) = N(z; x, variance * I_2) (Dames eq. 10).

    A density per m^2 in z; the paper's variance is 0.25 m^2.
    """

    variance: float = 0.25

    def __post_init__(self) -> None:
        _check_positive("measurement.variance", self.variance)

    def likelihood(self, z: np.ndarray, x: np.ndarray) -> np.ndarray:
        """g(z_m | x_j) for measurements z (M, 2) and states x (N, 2) -> (M, N) [1/m^2]."""
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        x = np.asarray(x, dtype=float).reshape(-1, 2)
        d2 = ((z[:, None, 0] - x[None, :, 0]) ** 2 + (z[:, None, 1] - x[None, :, 1]) ** 2)
        return np.exp(-0.5 * d2 / self.variance) / (2.0 * np.pi * self.variance)


@dataclass(frozen=True)
class UniformClutter:
    """Clutter PHD c(z | q): a constant ``density`` per m^2 (Dames eq. 11: 3.66e-3).

    The simulated sensor draws clutter uniformly inside its field of view (expected count
    ``density * fov_area`` = 0.287 for a 5 m disk). The filter evaluates the constant
    density of eq. 11 for *every* received measurement, including a true detection that
    noise pushed just outside the disk: this is the paper's literal model, and it keeps
    eta_z (eq. 5) away from zero for such measurements.
    """

    density: float = 3.66e-3

    def __post_init__(self) -> None:
        _check_positive("clutter.density", self.density, allow_zero=True)

    def intensity(self, z: np.ndarray) -> np.ndarray:
        """c(z | q) for each measurement, z (M, 2) -> (M,) [1/m^2]."""
        return np.full(np.asarray(z).reshape(-1, 2).shape[0], self.density)

    def expected_count(self, fov_area: float) -> float:
        """Expected number of clutter points per scan over a field of view of ``fov_area``."""
        return self.density * fov_area


@dataclass(frozen=True)
class RandomWalkMotion:
    """Target motion f(x | xi) as a random walk on the grid: a discrete kernel.

    ``sd`` is the per-step standard deviation [m] of an isotropic Gaussian step;
    ``truncation`` [m] bounds the step length (Dames Sec. IV-B: sd 0.35 m, truncated at
    2 m). ``sd = 0`` is the identity model (static targets). Chen's Gaussian random walk has
    infinite support; the distributed filter needs a finite one (Dames Sec. III-B), so it is
    truncated at ``truncation`` too (default 4 sd, which drops exp(-8) = 3.4e-4 of a step's
    mass before renormalisation); ``docs/models.md`` explains the choice.

    The kernel weight of an offset of (kx, ky) bins is the Gaussian's mass over that
    offset bin (a product of normal-CDF differences), kept if the offset's centre distance
    is within ``truncation`` and renormalised to sum to 1 (a truncated Gaussian).
    """

    sd: float = 0.0
    truncation: float = 0.0

    def __post_init__(self) -> None:
        _check_positive("motion.sd", self.sd, allow_zero=True)
        _check_positive("motion.truncation", self.truncation, allow_zero=True)
        if self.sd > 0 and self.truncation <= 0:
            raise ValueError("motion.truncation must be > 0 for a random walk (sd > 0)")

    @property
    def is_identity(self) -> bool:
        """True for static targets: the kernel is the single centre bin."""
        return self.sd == 0.0

    @property
    def support_radius(self) -> float:
        """Largest distance a target can move in one step [m] (0 for static targets)."""
        return 0.0 if self.is_identity else self.truncation

    def kernel(self, resolution: float) -> np.ndarray:
        """Discrete motion kernel, shape (2K+1, 2K+1), sums to 1; centre = no motion.

        ``kernel[K + ky, K + kx]`` is the probability of moving by (kx, ky) bins.
        """
        if self.is_identity:
            return np.ones((1, 1))
        k = int(np.floor(self.truncation / resolution + 1e-9))
        off = np.arange(-k, k + 1)
        edges = (off[:, None] + np.array([-0.5, 0.5])[None, :]) * resolution / self.sd
        mass1d = ndtr(edges[:, 1]) - ndtr(edges[:, 0])
        ker = mass1d[:, None] * mass1d[None, :]
        dist = resolution * np.hypot(off[:, None], off[None, :])
        ker = np.where(dist <= self.truncation + 1e-9 * resolution, ker, 0.0)
        return ker / ker.sum()


@dataclass(frozen=True)
class BoundarySurvival:
    """Survival probability p_s(x) near the boundary (Dames eq. 13).

    ``p_near`` within ``margin`` [m] of the boundary, 1 elsewhere (the paper: 0.5 within
    2 m). ``margin = 0`` gives p_s = 1 everywhere.
    """

    p_near: float = 1.0
    margin: float = 0.0

    def __post_init__(self) -> None:
        _check_probability("survival.p_near", self.p_near)
        _check_positive("survival.margin", self.margin, allow_zero=True)

    def probability(self, grid: Grid) -> np.ndarray:
        """p_s at every bin centre, shape (grid.size,)."""
        d = grid.env.distance_to_boundary(grid.centres)
        return np.where(d <= self.margin, self.p_near, 1.0) if self.margin > 0 \
            else np.ones(grid.size)


@dataclass(frozen=True)
class BoundaryBirth:
    """Birth PHD b(x) near the boundary (Dames eq. 14).

    ``density`` per m^2 within ``margin`` [m] of the boundary, 0 elsewhere (the paper:
    5.26e-5 within 5 m, 0.1 expected births per step on 100 x 100 m).
    """

    density: float = 0.0
    margin: float = 0.0

    def __post_init__(self) -> None:
        _check_positive("birth.density", self.density, allow_zero=True)
        _check_positive("birth.margin", self.margin, allow_zero=True)

    def mass(self, grid: Grid) -> np.ndarray:
        """Birth mass per bin, b(x_j) * bin_area, shape (grid.size,)."""
        if self.density == 0.0 or self.margin == 0.0:
            return np.zeros(grid.size)
        d = grid.env.distance_to_boundary(grid.centres)
        return np.where(d <= self.margin, self.density * grid.bin_area, 0.0)


@dataclass(frozen=True)
class PhdModels:
    """All models of one grid PHD filter, plus the initial weight per m^2.

    ``initial_density`` [targets/m^2] gives every bin the prior mass
    ``initial_density * bin_area`` (Dames Sec. IV: 1e-4 per 1 m bin, one target expected
    on 100 x 100 m).
    """

    detection: DiskDetection = field(default_factory=DiskDetection)
    measurement: GaussianMeasurement = field(default_factory=GaussianMeasurement)
    clutter: UniformClutter = field(default_factory=UniformClutter)
    motion: RandomWalkMotion = field(default_factory=RandomWalkMotion)
    survival: BoundarySurvival = field(default_factory=BoundarySurvival)
    birth: BoundaryBirth = field(default_factory=BoundaryBirth)
    initial_density: float = 1e-4

    def __post_init__(self) -> None:
        _check_positive("initial_density", self.initial_density, allow_zero=True)


def dames_static() -> PhdModels:
    """Dames (2020) Sec. IV-A: static targets, p_s = 1, no birth."""
    return PhdModels()


def dames_moving() -> PhdModels:
    """Dames (2020) Sec. IV-B: truncated Gaussian walk (0.35 m, 2 m), eq. 13-14."""
    return PhdModels(motion=RandomWalkMotion(sd=0.35, truncation=2.0),
                     survival=BoundarySurvival(p_near=0.5, margin=2.0),
                     birth=BoundaryBirth(density=5.26e-5, margin=5.0))


def chen_clustered() -> PhdModels:
    """Chen, Dames & Park (2021) Sec. 4: Gaussian walk sd 0.35 m, p_s = 1, no birth."""
    return PhdModels(motion=RandomWalkMotion(sd=0.35, truncation=4 * 0.35))



def sung_tokekar() -> PhdModels:
    """Sung & Tokekar (2022) Sec. VI-A: disk FoV of radius 25 m, p(D|F) = 0.98.

    The measurement noise is not stated; we take R = 1 m^2 I (docs/decisions.md). False
    positives are the sensor's own (one per step with a probability, not a Poisson density:
    :mod:`phd_swarm.core.sensors.disk_false_positive`); the grid models are unused.
    """
    return PhdModels(detection=DiskDetection(p_d=0.98, radius=25.0),
                     measurement=GaussianMeasurement(variance=1.0))


def shirsat_berman() -> PhdModels:
    """Shirsat & Berman (2021) Sec. VI: disk FoV of radius 0.6 m, p_D = 0.8 inside (eq. 22).

    Measurements z = x + v with R = 0.25 m^2 I (H = I, eq. 21); clutter Poisson with
    intensity lambda_C A_s U(z), lambda_C = 3.98e-3 per m^2, uniform over the FoV disk
    (A_s = 1.13 m^2). The grid models are unused (the robots run a GM-PHD).
    """
    return PhdModels(detection=DiskDetection(p_d=0.8, radius=0.6),
                     measurement=GaussianMeasurement(variance=0.25),
                     clutter=UniformClutter(density=3.98e-3))

