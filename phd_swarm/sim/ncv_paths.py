"""NCV targets whose whole life lies in the area and in the run (Papaioannou et al. Sec. VI-B).

Fig. 5's truth: "20 target trajectories inside the surveillance region with average lifetime
of 30 time-steps [...] birth locations uniformly distributed inside the whole area", each
target's lifetime "the ground-truth length of time for which a target evolves inside the
surveillance area". :class:`~phd_swarm.sim.ncv_targets.NcvTargets` (``lifetime_model:
cut``) draws a lifetime first and lets the area's edge and the run's end cut it: with a
30-step mean, targets are in the area ~15 steps on average. The two models here draw each
target's whole path first (NCV motion of Sec. VI-A, :func:`~phd_swarm.sim.ncv_targets.
ncv_matrices`) and choose its birth step so that the life ends by the run's end:

- ``contained``: the lifetime L is geometric on 1 .. steps (a constant death probability per
  step, truncated at the run) with mean ``lifetime_mean`` (:func:`truncated_geometric_p`;
  a mean the run cannot hold, above (steps + 1) / 2, takes the geometric of that mean capped
  at the run); the heading is uniform and the process noise drawn for the L steps; the path
  is placed
  (its start uniform among the positions that keep all of it in the box) so that it stays
  inside for its whole life. A draw whose path cannot fit (longer than the box allows at
  its heading) is redrawn, heading and noise, up to :data:`TRIES` times; then the draw that
  fits longest is kept and its life ends where it would leave. The in-area mean lifetime is
  ``lifetime_mean`` (up to the cap; docs/decisions.md). The joint law of start and heading
  is not uniform (a long path must start away from the edge it heads for), and targets
  spend less time near the edges than uniform positions would (15 % of target-steps in the
  10 m edge band, against 28 % under ``cut`` and 36 % for uniform positions).
- ``exit``: no lifetime is drawn; the start is uniform in the box and the heading uniform,
  and a target lives until it leaves E (its life is the time it takes to cross), or the
  run's end. At sqrt(2) m/s in a 100 m square that is ~33 steps on average.

With ``birth_spread`` S > 0 [s] the birth step is uniform over the steps b < S/dt with
``b + L <= steps``; with S = 0 every target is born at step 0. A target is in the truth at
steps b .. b + L - 1. Ids are the targets' indices. :meth:`NcvPaths.step` draws nothing.

The target kind ``ncv`` is registered here (:mod:`phd_swarm.sim.target_kinds`): its
``targets.lifetime_model`` chooses between :class:`~phd_swarm.sim.ncv_targets.NcvTargets`
(``cut``) and :class:`NcvPaths`.

Reference: S. Papaioannou et al., "A cooperative multi-agent probabilistic framework for
search and track missions", IEEE T-CNS, Sec. VI-A/B.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from phd_swarm.core.geometry.grid import Environment
from phd_swarm.sim.ncv_targets import NcvTargets, ncv_matrices
from phd_swarm.sim.target_kinds import TargetKind, TargetSetting, register

__all__ = ["LIFETIME_MODELS", "TRIES", "NcvPaths", "truncated_geometric_p"]

Box = tuple[float, float, float, float]

#: How a target's life is bounded: ``cut`` (:class:`~phd_swarm.sim.ncv_targets.NcvTargets`:
#: a geometric lifetime cut by leaving E and by the run's end), ``contained`` or ``exit``.
LIFETIME_MODELS = ("cut", "contained", "exit")

#: Draws of heading and noise per ``contained`` target before its life is cut to fit.
TRIES = 100


def truncated_geometric_p(mean: float, n: int) -> float | None:
    """The p of the geometric law on 1 .. n (truncated at n) whose mean is ``mean`` [steps].

    ``P(L = l) = p (1 - p)^(l - 1) / (1 - (1 - p)^n)``, whose mean
    ``1/p - n (1 - p)^n / (1 - (1 - p)^n)`` falls from (n + 1) / 2 (p -> 0, uniform) to 1
    (p = 1); solved by bisection. None if ``mean`` is not in [1, (n + 1) / 2).
    """
    if not 1.0 <= mean < (n + 1) / 2.0:
        return None

    def m(p: float) -> float:
        qn = (1.0 - p) ** n
        return 1.0 / p - n * qn / (1.0 - qn) if p < 1.0 else 1.0

    lo, hi = 1e-12, 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if m(mid) > mean else (lo, mid)
    return 0.5 * (lo + hi)


def _lifetime(rng: np.random.Generator, mean_steps: float, n: int) -> int:
    """One ``contained`` lifetime [steps] (see the module docstring): one ``random()``."""
    p = truncated_geometric_p(mean_steps, n)
    u = rng.random()
    if p is None:
        # The geometric law of that mean, capped at the run (inverse CDF).
        p = min(1.0, 1.0 / mean_steps)
        life = np.ceil(np.log1p(-u) / np.log1p(-p)) if p < 1.0 else 1.0
    else:
        qn = (1.0 - p) ** n
        life = np.ceil(np.log1p(-u * (1.0 - qn)) / np.log1p(-p)) if p < 1.0 else 1.0
    return int(min(max(life, 1.0), n))


def _relative_paths(v0: np.ndarray, length: int, f: np.ndarray, noise: np.ndarray
                    ) -> np.ndarray:
    """NCV paths started at the origin with velocities ``v0`` (T, 2): states (T, length, 4).

    ``noise`` (T, length - 1, 4) is the process noise w_k of each move (already scaled).
    """
    t = len(v0)
    out = np.zeros((t, length, 4))
    out[:, 0, 1] = v0[:, 0]
    out[:, 0, 3] = v0[:, 1]
    for k in range(1, length):
        out[:, k] = out[:, k - 1] @ f.T + noise[:, k - 1]
    return out


def _fitting_prefix(pos: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Longest prefix (T,) of each path's positions (T, L, 2) whose extent fits ``size``."""
    span = (np.maximum.accumulate(pos, axis=1) - np.minimum.accumulate(pos, axis=1))
    fits = (span <= size).all(axis=2)                                  # (T, L), monotone
    return fits.sum(axis=1)


class NcvPaths:
    """Targets on paths drawn whole in advance (see the module docstring).

    Parameters
    ----------
    paths : sequence of np.ndarray, each shape (L_i, 4)
        Each target's states ``[x, vx, y, vy]`` at the steps of its life [m, m/s], L_i >= 1.
    birth_steps : np.ndarray of int, shape (N,)
        The step of each target's first state, >= 0.
    """

    def __init__(self, paths: Sequence[np.ndarray], birth_steps: np.ndarray) -> None:
        self._paths = [np.array(p, dtype=float).reshape(-1, 4) for p in paths]
        births = np.array(birth_steps, dtype=np.int64).reshape(-1)
        if births.shape != (len(self._paths),):
            raise ValueError(f"NCV paths: expected {len(self._paths)} birth steps, got "
                             f"{births.size}")
        if (births < 0).any() or any(len(p) < 1 or not np.isfinite(p).all()
                                     for p in self._paths):
            raise ValueError("NCV paths: birth steps must be >= 0 and paths finite, with at "
                             "least one state")
        self._births = births
        self._lives = np.array([len(p) for p in self._paths], dtype=np.int64)
        self._step = 0

    @classmethod
    def sample(cls, rng: np.random.Generator, env: Environment, count: int, dt: float,
               steps: int, *, model: str = "contained", draw_box: Sequence[float] | None = None,
               speed: float = 1.0, lifetime_mean: float = 30.0, birth_spread: float = 0.0,
               q: float = 0.01, noise_form: str = "standard") -> NcvPaths:
        """``count`` targets of the lifetime ``model`` in a run of ``steps`` steps.

        Per target, in order (draws from ``rng``): ``contained``: ``random()`` (L), then up
        to :data:`TRIES` rounds of ``random()`` (heading) and ``standard_normal((L - 1, 4))``
        (noise), then ``random(2)`` (start); ``exit``: ``random(2)`` (start), ``random()``
        (heading), ``standard_normal((steps - 1, 4))``. Then ``integers`` for the birth
        step if ``birth_spread > 0``. Speed: ``speed`` per axis along the heading
        (``sqrt(2) speed`` [m/s]), as :meth:`~phd_swarm.sim.ncv_targets.NcvTargets.sample`.

        Parameters
        ----------
        rng : np.random.Generator
        env : Environment
            The surveillance region E.
        count : int
            Targets, >= 0.
        dt : float
            Step [s].
        steps : int
            Steps of the run, >= 1; every life ends by then.
        model : {"contained", "exit"}
        draw_box : (xmin, ymin, xmax, ymax), optional
            Where paths lie (``contained``) or start (``exit``); default E.
        speed, lifetime_mean, birth_spread, q, noise_form
            As :meth:`~phd_swarm.sim.ncv_targets.NcvTargets.sample` (``lifetime_mean`` [s]
            is used by ``contained`` only).
        """
        if model not in LIFETIME_MODELS[1:]:
            raise ValueError(f"NCV paths: model must be one of {LIFETIME_MODELS[1:]}, got "
                             f"{model!r}")
        n, steps = int(count), int(steps)
        if n < 0 or n != count or steps < 1:
            raise ValueError(f"NCV paths: count must be >= 0 and steps >= 1, got {count!r}, "
                             f"{steps!r}")
        if not (np.isfinite(lifetime_mean) and lifetime_mean >= dt):
            raise ValueError(f"NCV paths: lifetime_mean must be >= one step ({dt} s), got "
                             f"{lifetime_mean!r}")
        box = np.array(draw_box if draw_box is not None
                       else (env.xmin, env.ymin, env.xmax, env.ymax), dtype=float)
        lo, size = box[:2], box[2:] - box[:2]
        f, q_mat = ncv_matrices(dt, q, noise_form)
        chol = np.linalg.cholesky(q_mat + 1e-300 * np.eye(4)) if q > 0 else np.zeros((4, 4))
        spread = int(np.floor(birth_spread / dt + 1e-9))
        paths, births = [], np.zeros(n, dtype=np.int64)
        for i in range(n):
            if model == "contained":
                path = cls._contained(rng, _lifetime(rng, lifetime_mean / dt, steps), speed,
                                      f, chol, lo, size)
            else:
                path = cls._exit(rng, steps, speed, f, chol, lo, size, env)
            if spread > 0:
                births[i] = rng.integers(0, max(1, min(spread, steps - len(path) + 1)))
            paths.append(path)
        return cls(paths, births)

    @staticmethod
    def _contained(rng: np.random.Generator, life: int, speed: float, f: np.ndarray,
                   chol: np.ndarray, lo: np.ndarray, size: np.ndarray) -> np.ndarray:
        best, best_len = None, 0
        for _ in range(TRIES):
            h = 2.0 * np.pi * rng.random()
            v0 = np.sqrt(2.0) * speed * np.array([[np.cos(h), np.sin(h)]])
            noise = (rng.standard_normal((1, life - 1, 4)) @ chol.T)
            rel = _relative_paths(v0, life, f, noise)[0]
            fit = int(_fitting_prefix(rel[None, :, [0, 2]], size)[0])
            if fit > best_len:
                best, best_len = rel, fit
            if fit == life:
                break
        rel = best[:best_len]
        pos = rel[:, [0, 2]]
        low, high = pos.min(axis=0), pos.max(axis=0)
        start = lo - low + rng.random(2) * (size - (high - low))
        out = rel.copy()
        out[:, 0] += start[0]
        out[:, 2] += start[1]
        return out

    @staticmethod
    def _exit(rng: np.random.Generator, steps: int, speed: float, f: np.ndarray,
              chol: np.ndarray, lo: np.ndarray, size: np.ndarray,
              env: Environment) -> np.ndarray:
        start = lo + rng.random(2) * size
        h = 2.0 * np.pi * rng.random()
        v0 = np.sqrt(2.0) * speed * np.array([[np.cos(h), np.sin(h)]])
        noise = rng.standard_normal((1, steps - 1, 4)) @ chol.T
        out = _relative_paths(v0, steps, f, noise)[0]
        out[:, 0] += start[0]
        out[:, 2] += start[1]
        pos = out[:, [0, 2]]
        inside = ((pos >= [env.xmin, env.ymin]) & (pos <= [env.xmax, env.ymax])).all(axis=1)
        life = int(np.argmin(inside)) if not inside.all() else steps
        return out[:max(life, 1)]

    def _alive(self) -> np.ndarray:
        k = self._step
        return (self._births <= k) & (k < self._births + self._lives)

    @property
    def lifetimes(self) -> np.ndarray:
        """Steps each target lives, shape (N,) (all of them, alive or not)."""
        return self._lives.copy()

    @property
    def birth_steps(self) -> np.ndarray:
        """The step each target appears, shape (N,)."""
        return self._births.copy()

    @property
    def ids(self) -> np.ndarray:
        """Ids of the targets in the truth now, ascending, shape (N,) int64."""
        return np.flatnonzero(self._alive()).astype(np.int64)

    @property
    def states(self) -> np.ndarray:
        """States ``[x, vx, y, vy]`` of the targets in the truth now, shape (N, 4)."""
        k = self._step
        rows = [self._paths[i][k - self._births[i]] for i in np.flatnonzero(self._alive())]
        return np.array(rows, dtype=float).reshape(-1, 4)

    @property
    def positions(self) -> np.ndarray:
        """Positions of the targets in the truth now, shape (N, 2) [m], in id order."""
        return self.states[:, [0, 2]]

    def step(self, rng: np.random.Generator, dt: float) -> None:
        """Advance one step along the drawn paths (``rng`` is not used)."""
        self._step += 1


def _make_ncv(rng: np.random.Generator, scenario: TargetSetting, *, count: int,
              draw_box: Box | None, speed: float, spawn: str, lifetime_mean: float,
              birth_spread: float, process_noise: float, noise_form: str,
              lifetime_model: str) -> NcvTargets | NcvPaths:
    """The ``ncv`` targets by their lifetime model.

    ``cut`` -> :meth:`NcvTargets.sample <phd_swarm.sim.ncv_targets.NcvTargets.sample>`,
    ``contained`` and ``exit`` -> :meth:`NcvPaths.sample` over the run's steps.
    """
    if lifetime_model != "cut":
        return NcvPaths.sample(rng, scenario.env, count, scenario.dt, scenario.steps,
                               model=lifetime_model, draw_box=draw_box, speed=speed,
                               lifetime_mean=lifetime_mean, birth_spread=birth_spread,
                               q=process_noise, noise_form=noise_form)
    return NcvTargets.sample(rng, scenario.env, count, scenario.dt, spawn=spawn,
                             draw_box=draw_box, speed=speed, lifetime_mean=lifetime_mean,
                             birth_spread=birth_spread, q=process_noise, noise_form=noise_form)


def _check_ncv(scenario: TargetSetting, *, spawn: str, lifetime_model: str) -> None:
    if lifetime_model != "cut" and spawn != "uniform":
        raise ValueError(f"targets.lifetime_model: {lifetime_model} places whole paths in the "
                         f"area and needs spawn: uniform")


register(TargetKind(
    name="ncv", make=_make_ncv,
    description="Papaioannou et al. VI: nearly constant velocity, births and deaths",
    check=_check_ncv))
