"""Ground-truth target populations of the simulated world, with stable integer ids.

Four populations, one per experiment of the papers:

- :class:`StaticTargets`: Dames (2020) Sec. IV-A, targets drawn uniformly from a 120 x 120 m
  square around the map, those outside E discarded; they never move.
- :class:`DamesWalkers`: Dames (2020) Sec. IV-B, differential-drive targets at 1 m/s whose
  heading takes N(0, 0.1 rad) steps at 10 Hz; a target leaves the truth set when it leaves
  E (true survival 1 until then) and births are drawn from the birth PHD of eq. 14.
- :class:`ClusteredWalkers`: Chen, Dames & Park (2021) Sec. 4, a Gaussian random walk with
  a maximum speed of 3 m/s inside square sub-regions (clusters).
- :class:`TurningWalkers`: Sung & Tokekar (2022) Sec. VI-A.4, straight lines at 0.05 m/s
  with a new random heading every 400 s and at the boundary.

Every population exposes ``positions`` ((N, 2) [m], read-only), ``ids`` ((N,) int64,
read-only; an id is never reused, not even after its target has left) and
``step(rng, dt)``, which advances the truth by ``dt`` seconds. All randomness comes from the
Generator passed in, consumed in the order documented on each ``step``, so a run is
reproducible bit for bit from its seed.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from phd_swarm.core.grid import Environment
from phd_swarm.core.models import BoundaryBirth
from phd_swarm.sim.ncv_paths import NcvPaths, make_ncv_targets
from phd_swarm.sim.ncv_targets import NcvTargets

if TYPE_CHECKING:
    from phd_swarm.sim.scenario import Scenario

Box = tuple[float, float, float, float]


#: How a newborn of :class:`DamesWalkers` is headed (see :meth:`DamesWalkers.step`).
BIRTH_HEADINGS = ("uniform", "inward")


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def _check_box(name: str, box: Sequence[float]) -> np.ndarray:
    b = np.asarray(box, dtype=float).reshape(-1)
    if b.shape != (4,) or not np.all(np.isfinite(b)) or not (b[2] > b[0] and b[3] > b[1]):
        raise ValueError(f"{name} must be (xmin, ymin, xmax, ymax) with xmax > xmin and "
                         f"ymax > ymin, got {box!r}")
    return b


def _check_count(name: str, count: int) -> int:
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 0:
        raise ValueError(f"{name} must be an integer >= 0, got {count!r}")
    return int(count)


def _check_nonneg(name: str, value: float, positive: bool = False) -> float:
    ok = np.isfinite(value) and (value > 0 if positive else value >= 0)
    if not ok:
        raise ValueError(f"{name} must be a finite number {'> 0' if positive else '>= 0'}, "
                         f"got {value!r}")
    return float(value)


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
        self._positions = _frozen(p)
        self._ids = _frozen(i.astype(np.int64))

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
        n = _check_count("count", count)
        b = _check_box("draw_box", draw_box)
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
        self.speed = _check_nonneg("speed", speed)
        self.heading_sd = _check_nonneg("heading_sd", heading_sd)
        self.heading_rate = _check_nonneg("heading_rate", heading_rate, positive=True)
        self.birth = birth
        if birth_heading not in BIRTH_HEADINGS:
            raise ValueError(f"birth_heading must be one of {BIRTH_HEADINGS}, "
                             f"got {birth_heading!r}")
        self.birth_heading = birth_heading
        self._positions = _frozen(p)
        self._headings = _frozen(h)
        self._ids = _frozen(np.arange(len(p), dtype=np.int64))
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
        n = _check_count("count", count)
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
        self._positions = _frozen(positions.reshape(-1, 2))
        self._headings = _frozen(last_heading)
        self._ids = _frozen(ids.astype(np.int64))


def reflect_into(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Fold points into the boxes ``[lo, hi]`` by mirror reflection at their edges.

    A coordinate that overshoots an edge by ``e`` ends ``e`` inside it (repeatedly, for
    overshoots longer than the box). The fold is 1-Lipschitz and the identity inside the
    box, so it never lengthens a step that starts inside. All arrays broadcast to (N, 2).
    """
    span = hi - lo
    y = np.mod(x - lo, 2.0 * span)
    y = np.where(y > span, 2.0 * span - y, y)
    # lo + y can round past hi by an ulp.
    return np.clip(lo + y, lo, hi)


class ClusteredWalkers:
    """Chen, Dames & Park (2021) Sec. 4: a Gaussian random walk confined to cluster boxes.

    "Targets move within the sub-regions following a Gaussian random walk at a maximum speed
    of 3 m/s." Each step of ``dt`` seconds adds an isotropic Gaussian increment with per-axis
    standard deviation ``step_sd * dt`` [m], shortens it to at most ``max_speed * dt`` [m]
    (keeping its direction), and reflects the result at the edges of the target's own box.

    The paper gives only the maximum speed. We read the walk as a velocity drawn each step,
    so ``step_sd`` is a speed [m/s]; the default ``max_speed / 3`` (1 m/s, a 0.5 m per-axis
    step at 2 Hz) makes the maximum speed the 3-sigma speed per axis: the cap shortens
    exp(-4.5) = 1.1 % of the steps. The filter's own model is a 0.35 m walk (Chen Sec. 4),
    so, as in Dames Sec. IV-B, truth and model differ.

    Parameters
    ----------
    positions : np.ndarray, shape (N, 2)
        Initial positions [m], each inside its box.
    boxes : np.ndarray, shape (N, 4)
        Each target's box ``(xmin, ymin, xmax, ymax)`` [m].
    step_sd : float
        Per-axis standard deviation of the velocity [m/s], >= 0.
    max_speed : float
        Largest speed [m/s], >= 0.
    cluster : np.ndarray of int, shape (N,), optional
        Cluster index of each target (for reporting); default all 0.
    """

    def __init__(self, positions: np.ndarray, boxes: np.ndarray, step_sd: float,
                 max_speed: float, cluster: np.ndarray | None = None) -> None:
        p = np.array(positions, dtype=float).reshape(-1, 2)
        b = np.array(boxes, dtype=float).reshape(-1, 4)
        if len(b) != len(p):
            raise ValueError(f"got {len(b)} boxes for {len(p)} targets")
        self._lo = b[:, :2]
        self._hi = b[:, 2:]
        if np.any(p < self._lo) or np.any(p > self._hi):
            raise ValueError("initial target positions must lie inside their boxes")
        self.step_sd = _check_nonneg("step_sd", step_sd)
        self.max_speed = _check_nonneg("max_speed", max_speed)
        c = np.zeros(len(p), dtype=np.int64) if cluster is None else np.asarray(cluster)
        self._cluster = _frozen(np.array(c, dtype=np.int64).reshape(-1))
        self._positions = _frozen(p)
        self._ids = _frozen(np.arange(len(p), dtype=np.int64))

    @classmethod
    def sample(cls, rng: np.random.Generator, clusters: Sequence[Sequence[float]],
               per_cluster: Sequence[int], step_sd: float = 1.0,
               max_speed: float = 3.0) -> ClusteredWalkers:
        """Place ``per_cluster[c]`` targets uniformly in box ``clusters[c]``, cluster by cluster.

        ``rng`` is consumed as one ``rng.random((sum(per_cluster), 2))`` call; ids run
        ``0..N-1`` in cluster order.
        """
        if len(clusters) != len(per_cluster):
            raise ValueError(f"got {len(per_cluster)} counts for {len(clusters)} clusters")
        boxes = np.array([_check_box(f"clusters[{i}]", c) for i, c in enumerate(clusters)],
                         dtype=float).reshape(-1, 4)
        counts = np.array([_check_count(f"per_cluster[{i}]", k)
                           for i, k in enumerate(per_cluster)], dtype=np.int64)
        cluster = np.repeat(np.arange(len(counts)), counts)
        b = boxes[cluster]
        p = b[:, :2] + rng.random((len(cluster), 2)) * (b[:, 2:] - b[:, :2])
        return cls(p, b, step_sd, max_speed, cluster)

    @property
    def positions(self) -> np.ndarray:
        """Target positions, shape (N, 2) [m], read-only."""
        return self._positions

    @property
    def ids(self) -> np.ndarray:
        """Target ids, shape (N,) int64, read-only (no births, no deaths)."""
        return self._ids

    @property
    def cluster(self) -> np.ndarray:
        """Cluster index of each target, shape (N,), read-only."""
        return self._cluster

    @property
    def boxes(self) -> np.ndarray:
        """Each target's box ``(xmin, ymin, xmax, ymax)``, shape (N, 4) [m]."""
        return np.concatenate([self._lo, self._hi], axis=1)

    def step(self, rng: np.random.Generator, dt: float) -> None:
        """Advance ``dt`` seconds: one capped Gaussian increment, reflected into the box.

        ``rng`` is consumed as one ``rng.standard_normal((N, 2))`` call (row = target in id
        order).
        """
        dt = _check_nonneg("dt", dt)
        inc = (self.step_sd * dt) * rng.standard_normal((len(self._positions), 2))
        length = np.hypot(inc[:, 0], inc[:, 1])
        cap = self.max_speed * dt
        scale = np.where(length > cap, cap / np.where(length > 0, length, 1.0), 1.0)
        moved = self._positions + inc * scale[:, None]
        self._positions = _frozen(reflect_into(moved, self._lo, self._hi))


class TurningWalkers:
    """Targets on straight lines that turn every so often (Sung & Tokekar Sec. VI-A.4).

    "The targets are designed to move in a straight line and change their moving directions
    randomly at every 400 time steps. The targets move at a speed of 0.05 m/s [...] If the
    targets reach the environment boundary, then they pick a random direction that keeps
    them within the environment." Every target moves at ``speed`` along its heading; every
    ``turn_every`` seconds each takes a new heading uniform on [0, 2 pi); a target whose next
    position would leave E instead takes a heading uniform over those that keep that step
    inside (drawn by rejection from 16 uniform candidates; if none fits, it heads for the
    centre of E). No births, no deaths.

    Parameters
    ----------
    env : Environment
        The map E.
    positions : np.ndarray, shape (N, 2)
        Initial positions [m], inside E.
    headings : np.ndarray, shape (N,)
        Initial headings [rad].
    speed : float
        Speed [m/s], >= 0.
    turn_every : float
        Seconds between two heading draws, > 0.
    """

    #: Candidate headings drawn per target at the boundary (rejection sampling).
    CANDIDATES = 16

    def __init__(self, env: Environment, positions: np.ndarray, headings: np.ndarray,
                 speed: float, turn_every: float) -> None:
        p = np.array(positions, dtype=float).reshape(-1, 2)
        h = np.array(headings, dtype=float).reshape(-1)
        if h.shape != (len(p),):
            raise ValueError(f"headings must have shape ({len(p)},), got {h.shape}")
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(h))):
            raise ValueError("positions and headings must be finite")
        self._env = env
        self._lo = np.array([env.xmin, env.ymin])
        self._hi = np.array([env.xmax, env.ymax])
        self._positions = _frozen(p)
        self._headings = h
        self._ids = _frozen(np.arange(len(p), dtype=np.int64))
        self.speed = _check_nonneg("speed", speed)
        self.turn_every = _check_nonneg("turn_every", turn_every, positive=True)
        self._clock = 0.0

    @classmethod
    def sample(cls, rng: np.random.Generator, env: Environment, count: int,
               draw_box: Sequence[float] | None, speed: float,
               turn_every: float) -> TurningWalkers:
        """``count`` targets uniform in ``draw_box`` (default E) with uniform headings.

        ``rng`` is consumed as one ``random((count, 2))`` call (positions, the same draw as
        :meth:`StaticTargets.sample` in a box inside E) then one ``random(count)`` call
        (headings).
        """
        n = _check_count("count", count)
        b = _check_box("draw_box", draw_box if draw_box is not None
                       else (env.xmin, env.ymin, env.xmax, env.ymax))
        p = b[:2] + rng.random((n, 2)) * (b[2:] - b[:2])
        p = np.clip(p, [env.xmin, env.ymin], [env.xmax, env.ymax])
        return cls(env, p, 2.0 * np.pi * rng.random(n), speed, turn_every)

    @property
    def positions(self) -> np.ndarray:
        """Target positions, shape (N, 2) [m], read-only."""
        return self._positions

    @property
    def headings(self) -> np.ndarray:
        """Headings, shape (N,) [rad] (a copy)."""
        return self._headings.copy()

    @property
    def ids(self) -> np.ndarray:
        """Target ids ``0..N-1``, shape (N,) int64, read-only."""
        return self._ids

    def step(self, rng: np.random.Generator, dt: float) -> None:
        """Advance by ``dt`` seconds.

        Order of draws: when a turn is due (the clock reaches a multiple of
        ``turn_every``), one ``random(N)`` call for the new headings; then, if some targets
        would leave E, one ``random((B, CANDIDATES))`` call for the B of them.
        """
        n = len(self._positions)
        before = int(np.floor(self._clock / self.turn_every + 1e-9))
        self._clock += dt
        after = int(np.floor(self._clock / self.turn_every + 1e-9))
        if after > before and n:
            self._headings = 2.0 * np.pi * rng.random(n)
        step = self.speed * dt
        nxt = self._positions + step * np.stack([np.cos(self._headings),
                                                 np.sin(self._headings)], axis=1)
        out = np.flatnonzero(np.any((nxt < self._lo) | (nxt > self._hi), axis=1))
        if out.size:
            cand = 2.0 * np.pi * rng.random((out.size, self.CANDIDATES))
            ends = (self._positions[out, None, :]
                    + step * np.stack([np.cos(cand), np.sin(cand)], axis=2))
            ok = np.all((ends >= self._lo) & (ends <= self._hi), axis=2)
            centre = (self._lo + self._hi) / 2.0 - self._positions[out]
            inward = np.arctan2(centre[:, 1], centre[:, 0])
            first = np.argmax(ok, axis=1)
            chosen = np.where(ok.any(axis=1), cand[np.arange(out.size), first], inward)
            self._headings[out] = chosen
            nxt[out] = self._positions[out] + step * np.stack([np.cos(chosen),
                                                               np.sin(chosen)], axis=1)
        self._positions = _frozen(np.clip(nxt, self._lo, self._hi))


Targets = (StaticTargets | DamesWalkers | ClusteredWalkers | TurningWalkers | NcvTargets
           | NcvPaths)


def make_targets(rng: np.random.Generator, scenario: Scenario) -> Targets:
    """Initial target population of ``scenario`` (its ``targets`` config), drawn from ``rng``.

    ``static`` -> :meth:`StaticTargets.sample` (from a generator of ``targets.layout_seed``
    instead, if set), ``dames_walk`` -> :meth:`DamesWalkers.sample`
    (with the filter's birth PHD ``scenario.models.birth`` when ``targets.birth``),
    ``clustered_walk`` -> :meth:`ClusteredWalkers.sample`, ``turning_walk`` ->
    :meth:`TurningWalkers.sample`, ``ncv`` -> :func:`~phd_swarm.sim.ncv_paths.make_ncv_targets`.
    """
    cfg = scenario.targets
    if cfg.kind == "static":
        if cfg.layout_seed is not None:  # the same targets in every run
            rng = np.random.default_rng(np.random.SeedSequence(cfg.layout_seed))
        return StaticTargets.sample(rng, scenario.env, cfg.count, cfg.draw_box)
    if cfg.kind == "dames_walk":
        return DamesWalkers.sample(rng, scenario.env, cfg.count, cfg.speed, cfg.heading_sd,
                                   cfg.heading_rate,
                                   scenario.models.birth if cfg.birth else None,
                                   cfg.birth_heading)
    if cfg.kind == "clustered_walk":
        return ClusteredWalkers.sample(rng, cfg.clusters, cfg.per_cluster, cfg.step_sd,
                                       cfg.max_speed)
    if cfg.kind == "turning_walk":
        return TurningWalkers.sample(rng, scenario.env, cfg.count, cfg.draw_box, cfg.speed,
                                     cfg.turn_every)
    if cfg.kind == "ncv":
        return make_ncv_targets(rng, scenario)
    raise ValueError(f"unknown target kind {cfg.kind!r}")
