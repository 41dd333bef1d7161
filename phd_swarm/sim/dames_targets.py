"""Dames (2020) Sec. IV's true targets: static (IV-A) and walking with births (IV-B).

- :class:`StaticTargets`: Sec. IV-A, targets drawn uniformly from a 120 x 120 m square
  around the map, those outside E discarded; they never move. Registered as the target
  kind ``static`` (Shirsat & Berman's and Sung & Tokekar's stationary targets are drawn the
  same way over their maps).
- :class:`DamesWalkers`: Sec. IV-B, differential-drive targets at 1 m/s whose heading takes
  N(0, 0.1 rad) steps at 10 Hz; a target leaves the truth set when it leaves E (true
  survival 1 until then) and births are drawn from the birth PHD of eq. 14. Registered as
  ``dames_walk``.

Every population exposes ``positions`` ((N, 2) [m], read-only), ``ids`` ((N,) int64,
read-only; an id is never reused, not even after its target has left) and
``step(rng, dt)``, which advances the truth by ``dt`` seconds. All randomness comes from the
Generator passed in, consumed in the order documented on each ``step``, so a run is
reproducible bit for bit from its seed.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.models import BoundaryBirth
from phd_swarm.sim.target_checks import check_box, check_count, check_nonneg, frozen
from phd_swarm.sim.target_kinds import TargetKind, TargetSetting, register

__all__ = ["BIRTH_HEADINGS", "DamesWalkers", "StaticTargets", "boundary_ring_area",
           "sample_boundary_ring", "substeps_per_step"]

#: How a newborn of :class:`DamesWalkers` is headed (see :meth:`DamesWalkers.step`).
BIRTH_HEADINGS = ("uniform", "inward")


def substeps_per_step(dt: float, heading_rate: float) -> int:
    """Number of heading updates in one step, ``dt * heading_rate``, which must be whole.

    Dames Sec. IV-B: the heading is updated at 10 Hz and the sensor runs at 2 Hz, so one
    0.5 s step holds 5 updates.

    Raises
    ------
    ValueError
        If ``dt * heading_rate`` is not a positive whole number (to 1e-9 relative).
    """
    n = float(dt) * float(heading_rate)
    k = int(round(n)) if np.isfinite(n) else 0
    if k < 1 or abs(n - k) > 1e-9 * max(1.0, n):
        raise ValueError(f"dt * heading_rate must be a whole number >= 1 of heading updates "
                         f"per step, got {dt} s * {heading_rate} Hz = {n}")
    return k


def boundary_ring_area(env: Environment, margin: float) -> float:
    """Area [m^2] of the ring of points within ``margin`` [m] of the boundary of E.

    It is E minus the inner rectangle shrunk by ``margin`` on every side (all of E when
    that rectangle is empty), the support of the birth PHD of Dames eq. 14.
    """
    inner_w = max(0.0, env.width - 2.0 * margin)
    inner_h = max(0.0, env.height - 2.0 * margin)
    return env.area - inner_w * inner_h


def sample_boundary_ring(u: np.ndarray, env: Environment, margin: float) -> np.ndarray:
    """Map uniforms to points uniform on the boundary ring of E (exact area sampling).

    The ring ``{x in E : ||x - dE|| <= margin}`` is cut into four disjoint rectangles: the
    bottom and top strips of full width and height ``m = min(margin, H/2)``, and the left
    and right strips of width ``min(margin, W/2)`` between them. ``u[:, 0]`` picks a strip
    with probability proportional to its area; ``u[:, 1:]`` place the point uniformly in it.

    Parameters
    ----------
    u : np.ndarray, shape (N, 3)
        Independent uniforms on [0, 1).
    env : Environment
        The environment E.
    margin : float
        Ring width [m], > 0.

    Returns
    -------
    np.ndarray, shape (N, 2)
        Points in the ring [m].
    """
    u = np.asarray(u, dtype=float).reshape(-1, 3)
    my = min(margin, env.height / 2.0)
    mx = min(margin, env.width / 2.0)
    mid_h = env.height - 2.0 * my
    # Strips as (x0, y0, width, height): bottom, top, left, right.
    strips = np.array([
        [env.xmin, env.ymin, env.width, my],
        [env.xmin, env.ymax - my, env.width, my],
        [env.xmin, env.ymin + my, mx, mid_h],
        [env.xmax - mx, env.ymin + my, mx, mid_h],
    ])
    areas = strips[:, 2] * strips[:, 3]
    cum = np.cumsum(areas) / areas.sum()
    k = np.minimum(np.searchsorted(cum, u[:, 0], side="right"), 3)
    s = strips[k]
    return s[:, :2] + u[:, 1:] * s[:, 2:]


class StaticTargets:
    """Targets that never move (Dames Sec. IV-A).

    Parameters
    ----------
    positions : np.ndarray, shape (N, 2)
        Target positions [m].
    ids : np.ndarray of int, shape (N,), optional
        Their ids; default ``0..N-1``.
    """

    def __init__(self, positions: np.ndarray, ids: np.ndarray | None = None) -> None:
        p = np.array(positions, dtype=float).reshape(-1, 2)
        i = np.arange(len(p)) if ids is None else np.array(ids, dtype=np.int64).reshape(-1)
        if i.shape != (len(p),) or len(np.unique(i)) != len(i):
            raise ValueError("ids must be unique, one per target")
        self._positions = frozen(p)
        self._ids = frozen(i.astype(np.int64))

    @classmethod
    def sample(cls, rng: np.random.Generator, env: Environment, count: int,
               draw_box: Sequence[float]) -> StaticTargets:
        """Draw ``count`` targets uniformly in ``draw_box``, keep those inside E (Sec. IV-A).

        Dames draws 10, 30 or 50 targets from a 120 x 120 m square around the 100 x 100 m map
        and discards those outside, so the kept count is Binomial(count, 100^2 / 120^2)
        (mean 20.8 for 30; the paper reports 20.0 over its 10 trials).

        Parameters
        ----------
        rng : np.random.Generator
            Consumed as one ``rng.random((count, 2))`` call.
        env : Environment
            The map E; targets on its boundary are kept.
        count : int
            Number of targets drawn, >= 0.
        draw_box : sequence of 4 floats
            ``(xmin, ymin, xmax, ymax)`` of the drawing square [m].

        Returns
        -------
        StaticTargets
            The kept targets, ids ``0..kept-1`` in drawing order.
        """
        n = check_count("count", count)
        b = check_box("draw_box", draw_box)
        p = b[:2] + rng.random((n, 2)) * (b[2:] - b[:2])
        return cls(p[env.contains(p)])

    @property
    def positions(self) -> np.ndarray:
        """Target positions, shape (N, 2) [m], read-only."""
        return self._positions

    @property
    def ids(self) -> np.ndarray:
        """Target ids, shape (N,) int64, read-only."""
        return self._ids

    def step(self, rng: np.random.Generator, dt: float) -> None:
        """Identity motion: nothing changes and ``rng`` is not touched."""


class DamesWalkers:
    """Dames (2020) Sec. IV-B moving targets: constant speed, random-walk heading, births.

    Each target has a position and a heading. A step of ``dt`` seconds is made of
    ``dt * heading_rate`` sub-steps of ``1 / heading_rate`` seconds; in each sub-step the
    heading changes by Delta theta ~ N(0, heading_sd^2) and then the target moves
    ``speed / heading_rate`` metres along the new heading. A target whose position after any
    sub-step lies outside E is removed for good ("the true targets survive with probability
    1 until their motion causes them to leave the environment").

    Births (eq. 14): after the motion, Poisson(lambda) targets are added with
    ``lambda = birth.density * ring area`` (the integral of b over E, 0.1 per step for the
    paper's 5.26e-5 per m^2 on the 1900 m^2 ring within 5 m of the boundary of the
    100 x 100 m map), placed uniformly on that ring ("targets were added to the true target
    set by drawing samples from the birth PHD") with a heading uniform in [0, 2 pi). They
    appear at the end of the step, as births enter the prediction (eq. 3) without motion.

    Parameters
    ----------
    env : Environment
        The map E.
    positions : np.ndarray, shape (N, 2)
        Initial positions [m], inside E.
    headings : np.ndarray, shape (N,)
        Initial headings [rad].
    speed : float
        Forward speed [m/s], >= 0 (paper: 1).
    heading_sd : float
        Standard deviation of each heading change [rad], >= 0 (paper: 0.1).
    heading_rate : float
        Heading updates per second [Hz], > 0 (paper: 10).
    birth : BoundaryBirth or None
        Birth PHD; None (or zero density or margin) for no births.
    """

    def __init__(self, env: Environment, positions: np.ndarray, headings: np.ndarray,
                 speed: float = 1.0, heading_sd: float = 0.1, heading_rate: float = 10.0,
                 birth: BoundaryBirth | None = None,
                 birth_heading: str = "uniform") -> None:
        p = np.array(positions, dtype=float).reshape(-1, 2)
        h = np.array(headings, dtype=float).reshape(-1)
        if h.shape != (len(p),):
            raise ValueError(f"got {len(h)} headings for {len(p)} targets")
        if not np.all(env.contains(p)):
            raise ValueError("initial target positions must lie inside the environment")
        self.env = env
        self.speed = check_nonneg("speed", speed)
        self.heading_sd = check_nonneg("heading_sd", heading_sd)
        self.heading_rate = check_nonneg("heading_rate", heading_rate, positive=True)
        self.birth = birth
        if birth_heading not in BIRTH_HEADINGS:
            raise ValueError(f"birth_heading must be one of {BIRTH_HEADINGS}, "
                             f"got {birth_heading!r}")
        self.birth_heading = birth_heading
        self._positions = frozen(p)
        self._headings = frozen(h)
        self._ids = frozen(np.arange(len(p), dtype=np.int64))
        self._next_id = len(p)

    @classmethod
    def sample(cls, rng: np.random.Generator, env: Environment, count: int,
               speed: float = 1.0, heading_sd: float = 0.1, heading_rate: float = 10.0,
               birth: BoundaryBirth | None = None,
               birth_heading: str = "uniform") -> DamesWalkers:
        """Initial population: ``count`` targets uniform in E, headings uniform in [0, 2 pi).

        The paper gives the initial number of targets (10, 20 or 30) but not how they are
        placed; we draw them uniformly in E so that the initial count is exact.

        ``rng`` is consumed as ``rng.random((count, 2))`` (positions), then
        ``rng.random(count)`` (headings).
        """
        n = check_count("count", count)
        lo = np.array([env.xmin, env.ymin])
        p = lo + rng.random((n, 2)) * np.array([env.width, env.height])
        h = 2.0 * np.pi * rng.random(n)
        return cls(env, p, h, speed, heading_sd, heading_rate, birth, birth_heading)

    @property
    def positions(self) -> np.ndarray:
        """Target positions, shape (N, 2) [m], read-only."""
        return self._positions

    @property
    def headings(self) -> np.ndarray:
        """Target headings, shape (N,) [rad], read-only, not wrapped to [0, 2 pi)."""
        return self._headings

    @property
    def ids(self) -> np.ndarray:
        """Target ids, shape (N,) int64, read-only; new births get fresh, larger ids."""
        return self._ids

    @property
    def expected_births(self) -> float:
        """Expected births per step, the integral of b over E (Dames eq. 14: 0.1)."""
        b = self.birth
        if b is None or b.density == 0.0 or b.margin == 0.0:
            return 0.0
        return b.density * boundary_ring_area(self.env, b.margin)

    def step(self, rng: np.random.Generator, dt: float) -> None:
        """Advance ``dt`` seconds: motion, removal of targets that left E, births.

        ``rng`` is consumed in this order, whatever the outcome:

        1. ``rng.standard_normal((N, S))``: heading changes of the N current targets over the
           ``S = dt * heading_rate`` sub-steps (row = target in id order);
        2. ``rng.poisson(lambda)``: the number of births B (skipped when lambda = 0);
        3. ``rng.random((B, 3))``: birth positions (:func:`sample_boundary_ring`);
        4. ``rng.random(B)``: birth headings: u times 2 pi (``birth_heading="uniform"``), or
           the direction to the centre of E plus (u - 1/2) pi (``"inward"``: uniform over
           the half-plane of headings facing the centre).
        """
        s = substeps_per_step(dt, self.heading_rate)
        n = len(self._positions)
        headings = self._headings[:, None] + np.cumsum(
            self.heading_sd * rng.standard_normal((n, s)), axis=1)
        d = self.speed / self.heading_rate
        path = self._positions[:, None, :] + np.cumsum(
            d * np.stack([np.cos(headings), np.sin(headings)], axis=-1), axis=1)
        stay = np.all(self.env.contains(path), axis=1)
        positions = path[stay, -1]
        last_heading = headings[stay, -1]
        ids = self._ids[stay]

        lam = self.expected_births
        if lam > 0.0:
            b = int(rng.poisson(lam))
            born_p = sample_boundary_ring(rng.random((b, 3)), self.env, self.birth.margin)
            u = rng.random(b)
            if self.birth_heading == "inward":
                to_centre = np.array([self.env.xmin + 0.5 * self.env.width,
                                      self.env.ymin + 0.5 * self.env.height]) - born_p
                born_h = np.arctan2(to_centre[:, 1], to_centre[:, 0]) + np.pi * (u - 0.5)
            else:
                born_h = 2.0 * np.pi * u
            positions = np.concatenate([positions, born_p])
            last_heading = np.concatenate([last_heading, born_h])
            ids = np.concatenate([ids, self._next_id + np.arange(b, dtype=np.int64)])
            self._next_id += b
        self._positions = frozen(positions.reshape(-1, 2))
        self._headings = frozen(last_heading)
        self._ids = frozen(ids.astype(np.int64))


def _make_static(rng: np.random.Generator, scenario: TargetSetting, *, count: int,
                 draw_box: tuple[float, float, float, float] | None,
                 layout_seed: int | None) -> StaticTargets:
    """The ``static`` targets: :meth:`StaticTargets.sample` in ``draw_box``.

    Drawn from a generator of ``layout_seed`` alone instead of ``rng`` if it is set, so
    every run has the same targets (Shirsat & Berman Sec. VI: "the positions of the targets
    were kept the same over all 100 runs").
    """
    if layout_seed is not None:
        rng = np.random.default_rng(np.random.SeedSequence(layout_seed))
    return StaticTargets.sample(rng, scenario.env, count, draw_box)


def _check_static(scenario: TargetSetting, *, draw_box: Sequence[float] | None) -> None:
    if draw_box is None:
        raise ValueError("targets.draw_box is required for static targets")


def _make_dames_walk(rng: np.random.Generator, scenario: TargetSetting, *, count: int,
                     speed: float, heading_sd: float, heading_rate: float, birth: bool,
                     birth_heading: str) -> DamesWalkers:
    """The ``dames_walk`` targets: :meth:`DamesWalkers.sample`.

    With ``birth``, newborns are drawn from the filter's birth PHD ``models.birth`` (eq. 14,
    "the birth model matched the true statistics of the targets").
    """
    return DamesWalkers.sample(rng, scenario.env, count, speed, heading_sd, heading_rate,
                               scenario.models.birth if birth else None, birth_heading)


def _check_dames_walk(scenario: TargetSetting, *, heading_rate: float) -> None:
    try:
        substeps_per_step(scenario.dt, heading_rate)
    except ValueError as exc:
        raise ValueError(f"targets.heading_rate: {exc}") from None


register(TargetKind(
    name="static", make=_make_static,
    description="Dames IV-A: drawn uniformly in draw_box, those outside the map dropped, "
                "never moving",
    check=_check_static))

register(TargetKind(
    name="dames_walk", make=_make_dames_walk,
    description="Dames IV-B: a constant speed and a random-walk heading, gone on leaving "
                "the map, born on its boundary ring",
    check=_check_dames_walk))
