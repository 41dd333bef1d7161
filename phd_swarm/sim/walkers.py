"""Targets that walk in boxes or on turning lines: Chen et al.'s clusters, Sung & Tokekar's.

- :class:`ClusteredWalkers` (Chen, Dames & Park 2021 Sec. 4): a Gaussian random walk
  capped at a maximum speed, reflected into each target's own cluster box
  (:func:`reflect_into`);
- :class:`TurningWalkers` (Sung & Tokekar 2022 Sec. VI-A.4): straight lines at a constant
  speed, a new random heading every so often and at the map's edge.

They are registered as the target kinds ``clustered_walk`` and ``turning_walk``
(:mod:`phd_swarm.sim.target_kinds`); Dames' static targets and walkers are in
:mod:`phd_swarm.sim.dames_targets`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from phd_swarm.core.geometry.grid import Environment
from phd_swarm.sim.target_checks import (
    check_box,
    check_count,
    check_inside,
    check_nonneg,
    frozen,
)
from phd_swarm.sim.target_kinds import TargetKind, TargetSetting, register

__all__ = ["ClusteredWalkers", "TurningWalkers", "reflect_into"]

Box = tuple[float, float, float, float]


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
        self.step_sd = check_nonneg("step_sd", step_sd)
        self.max_speed = check_nonneg("max_speed", max_speed)
        c = np.zeros(len(p), dtype=np.int64) if cluster is None else np.asarray(cluster)
        self._cluster = frozen(np.array(c, dtype=np.int64).reshape(-1))
        self._positions = frozen(p)
        self._ids = frozen(np.arange(len(p), dtype=np.int64))

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
        boxes = np.array([check_box(f"clusters[{i}]", c) for i, c in enumerate(clusters)],
                         dtype=float).reshape(-1, 4)
        counts = np.array([check_count(f"per_cluster[{i}]", k)
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
        dt = check_nonneg("dt", dt)
        inc = (self.step_sd * dt) * rng.standard_normal((len(self._positions), 2))
        length = np.hypot(inc[:, 0], inc[:, 1])
        cap = self.max_speed * dt
        scale = np.where(length > cap, cap / np.where(length > 0, length, 1.0), 1.0)
        moved = self._positions + inc * scale[:, None]
        self._positions = frozen(reflect_into(moved, self._lo, self._hi))


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
        self._positions = frozen(p)
        self._headings = h
        self._ids = frozen(np.arange(len(p), dtype=np.int64))
        self.speed = check_nonneg("speed", speed)
        self.turn_every = check_nonneg("turn_every", turn_every, positive=True)
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
        n = check_count("count", count)
        b = check_box("draw_box", draw_box if draw_box is not None
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
        self._positions = frozen(np.clip(nxt, self._lo, self._hi))


def _make_clustered_walk(rng: np.random.Generator, scenario: TargetSetting, *,
                         clusters: tuple[Box, ...], per_cluster: tuple[int, ...],
                         step_sd: float, max_speed: float) -> ClusteredWalkers:
    """The ``clustered_walk`` targets: :meth:`ClusteredWalkers.sample`."""
    return ClusteredWalkers.sample(rng, clusters, per_cluster, step_sd, max_speed)


def _check_clustered_walk(scenario: TargetSetting, *, count: int, clusters: tuple[Box, ...],
                          per_cluster: tuple[int, ...]) -> None:
    if not clusters or len(per_cluster) != len(clusters):
        raise ValueError(f"targets.per_cluster needs one count per cluster: got "
                         f"{len(per_cluster)} counts for {len(clusters)} clusters")
    if sum(per_cluster) != count:
        raise ValueError(f"targets.count ({count}) must equal "
                         f"sum(targets.per_cluster) ({sum(per_cluster)})")
    for i, box in enumerate(clusters):
        check_inside(f"targets.clusters[{i}]", box, scenario.env)


def _make_turning_walk(rng: np.random.Generator, scenario: TargetSetting, *, count: int,
                       draw_box: Box | None, speed: float,
                       turn_every: float) -> TurningWalkers:
    """The ``turning_walk`` targets: :meth:`TurningWalkers.sample` (``draw_box`` default E)."""
    return TurningWalkers.sample(rng, scenario.env, count, draw_box, speed, turn_every)


register(TargetKind(
    name="clustered_walk", make=_make_clustered_walk,
    description="Chen Sec. 4: a Gaussian random walk capped at max_speed, each target in "
                "its cluster box",
    check=_check_clustered_walk))

register(TargetKind(
    name="turning_walk", make=_make_turning_walk,
    description="Sung VI-A.4: straight lines, a new random heading every turn_every "
                "seconds and at the map's edge"))
