"""Nearly-constant-velocity targets that are born and die (Papaioannou et al. Sec. VI).

The truth of Papaioannou et al.'s experiments: targets with state ``[x, vx, y, vy]`` moving
by the nearly-constant-velocity (NCV) model of Sec. VI-A,

    ``x_k = F x_{k-1} + w_k``, ``F = [[1, T], [0, 1]]`` per axis,
    ``w_k ~ N(0, Q)``, ``Q = q [[T^3/3, T^2/2], [T^2/2, T]]`` per axis,

with T the step [s]. The paper prints ``Q = [[T/3, T/2], [T/2, T]]`` per axis, which is the
standard form with q = 1 at its T = 1 s (``noise_form="printed"`` gives the literal matrix
for any T). Each target has a birth step and a lifetime: it enters the truth at its birth
step with its initial state and leaves it when its lifetime is over or when it leaves the
surveillance region E ("the target birth/death times vary as the targets enter and exit
the surveillance region", Sec. VI-B). Ids are the targets' indices, never reused.

Reference: S. Papaioannou et al., "A cooperative multi-agent probabilistic framework for
search and track missions", Sec. VI-A/B.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from phd_swarm.core.geometry.grid import Environment

__all__ = ["NOISE_FORMS", "SPAWNS", "NcvTargets", "ncv_matrices"]

#: Where targets appear: the centre of E (Fig. 3) or uniformly in a box (Fig. 4, 5).
SPAWNS = ("centre", "uniform")
#: The process noise: the standard NCV form with intensity q, or the printed matrix.
NOISE_FORMS = ("standard", "printed")


def ncv_matrices(dt: float, q: float, form: str = "standard") -> tuple[np.ndarray, np.ndarray]:
    """F and Q (4 x 4, state ``[x, vx, y, vy]``) of the NCV model for a step ``dt`` [s].

    ``form="standard"``: ``Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]`` per axis;
    ``"printed"``: ``Q = q [[dt/3, dt/2], [dt/2, dt]]`` per axis (the paper's matrix).
    """
    if not (np.isfinite(dt) and dt > 0.0) or not (np.isfinite(q) and q >= 0.0):
        raise ValueError(f"NCV model: dt must be > 0 and q >= 0, got dt={dt!r}, q={q!r}")
    if form not in NOISE_FORMS:
        raise ValueError(f"NCV model: noise form must be one of {NOISE_FORMS}, got {form!r}")
    f1 = np.array([[1.0, dt], [0.0, 1.0]])
    if form == "standard":
        q1 = q * np.array([[dt ** 3 / 3.0, dt ** 2 / 2.0], [dt ** 2 / 2.0, dt]])
    else:
        q1 = q * np.array([[dt / 3.0, dt / 2.0], [dt / 2.0, dt]])
    z = np.zeros((2, 2))
    return np.block([[f1, z], [z, f1]]), np.block([[q1, z], [z, q1]])


class NcvTargets:
    """NCV targets with birth steps and lifetimes (see the module docstring).

    Parameters
    ----------
    env : Environment
        The surveillance region E; a target that leaves it dies.
    states : np.ndarray, shape (N, 4)
        Each target's state ``[x, vx, y, vy]`` at its birth [m, m/s].
    birth_steps : np.ndarray of int, shape (N,)
        The step at which each target appears (0: present from the start).
    lifetimes : np.ndarray of int, shape (N,)
        Steps each target lives, >= 1 (it is in the truth at steps birth .. birth +
        lifetime - 1, unless it leaves E first).
    dt : float
        The step T [s].
    q : float
        Process noise intensity [m^2/s^3].
    noise_form : str
        ``standard`` or ``printed`` (:func:`ncv_matrices`).
    """

    def __init__(self, env: Environment, states: np.ndarray, birth_steps: np.ndarray,
                 lifetimes: np.ndarray, dt: float, q: float = 1.0,
                 noise_form: str = "standard") -> None:
        x = np.array(states, dtype=float).reshape(-1, 4)
        n = len(x)
        births = np.array(birth_steps, dtype=np.int64).reshape(-1)
        lives = np.array(lifetimes, dtype=np.int64).reshape(-1)
        if births.shape != (n,) or lives.shape != (n,):
            raise ValueError(f"NCV targets: expected {n} birth steps and lifetimes, got "
                             f"{births.size} and {lives.size}")
        if not np.isfinite(x).all() or (births < 0).any() or (lives < 1).any():
            raise ValueError("NCV targets: states must be finite, birth steps >= 0 and "
                             "lifetimes >= 1")
        self._f, q_mat = ncv_matrices(dt, q, noise_form)
        self._q_chol = np.linalg.cholesky(q_mat + 1e-300 * np.eye(4)) if q > 0 else None
        self._lo = np.array([env.xmin, env.ymin])
        self._hi = np.array([env.xmax, env.ymax])
        self._states = x
        self._births = births
        self._ends = births + lives
        self._left = np.zeros(n, dtype=bool)
        self._step = 0

    @classmethod
    def sample(cls, rng: np.random.Generator, env: Environment, count: int, dt: float, *,
               spawn: str = "uniform", draw_box: Sequence[float] | None = None,
               speed: float = 1.0, lifetime_mean: float = 60.0, birth_spread: float = 0.0,
               q: float = 1.0, noise_form: str = "standard") -> NcvTargets:
        """``count`` targets: where and when they appear, how fast and how long they live.

        - position: the centre of E (``spawn="centre"``) or uniform in ``draw_box``
          (default E);
        - velocity: ``speed`` per axis along a uniformly random heading, i.e. speed
          ``sqrt(2) speed`` [m/s] ("initialized to 1 m/s in the x-direction and 1 m/s in the
          y-direction", "random headings");
        - birth step: 0, or uniform over ``[0, birth_spread / dt)`` steps;
        - lifetime: geometric with mean ``lifetime_mean / dt`` steps (a constant death
          probability per step).

        Draws, in order: ``random((count, 2))`` (positions; uniform spawn only),
        ``random(count)`` (headings), ``integers`` for the birth steps (only if
        ``birth_spread > 0``), ``geometric`` for the lifetimes.
        """
        if spawn not in SPAWNS:
            raise ValueError(f"NCV targets: spawn must be one of {SPAWNS}, got {spawn!r}")
        n = int(count)
        if n < 0 or n != count:
            raise ValueError(f"NCV targets: count must be an integer >= 0, got {count!r}")
        if not (np.isfinite(lifetime_mean) and lifetime_mean >= dt):
            raise ValueError(f"NCV targets: lifetime_mean must be >= one step ({dt} s), got "
                             f"{lifetime_mean!r}")
        if not (np.isfinite(birth_spread) and birth_spread >= 0.0):
            raise ValueError(f"NCV targets: birth_spread must be >= 0 s, got {birth_spread!r}")
        box = np.array(draw_box if draw_box is not None
                       else (env.xmin, env.ymin, env.xmax, env.ymax), dtype=float)
        if spawn == "uniform":
            pos = box[:2] + rng.random((n, 2)) * (box[2:] - box[:2])
        else:
            pos = np.tile([(env.xmin + env.xmax) / 2.0, (env.ymin + env.ymax) / 2.0], (n, 1))
        heading = 2.0 * np.pi * rng.random(n)
        v = np.sqrt(2.0) * speed * np.stack([np.cos(heading), np.sin(heading)], axis=1)
        states = np.stack([pos[:, 0], v[:, 0], pos[:, 1], v[:, 1]], axis=1)
        spread = int(np.floor(birth_spread / dt + 1e-9))
        births = (rng.integers(0, spread, n) if spread > 0 else np.zeros(n, dtype=np.int64))
        lifetimes = rng.geometric(min(1.0, dt / lifetime_mean), n)
        return cls(env, states, births, lifetimes, dt, q, noise_form)

    def _alive(self) -> np.ndarray:
        k = self._step
        return (self._births <= k) & (k < self._ends) & ~self._left

    @property
    def ids(self) -> np.ndarray:
        """Ids of the targets in the truth now, ascending, shape (N,) int64."""
        return np.flatnonzero(self._alive()).astype(np.int64)

    @property
    def positions(self) -> np.ndarray:
        """Positions of the targets in the truth now, shape (N, 2) [m], in id order."""
        return self._states[self._alive()][:, [0, 2]].copy()

    @property
    def states(self) -> np.ndarray:
        """States ``[x, vx, y, vy]`` of the targets in the truth now, shape (N, 4)."""
        return self._states[self._alive()].copy()

    def step(self, rng: np.random.Generator, dt: float) -> None:
        """Advance one step: the targets alive now move by the NCV model; some leave E.

        Draws one ``standard_normal((A, 4))`` for the A targets alive before the move
        (none when q = 0). Targets born at the next step keep their birth state.
        """
        alive = self._alive()
        idx = np.flatnonzero(alive)
        moved = self._states[idx] @ self._f.T
        if self._q_chol is not None and idx.size:
            moved = moved + rng.standard_normal((idx.size, 4)) @ self._q_chol.T
        self._states[idx] = moved
        p = moved[:, [0, 2]]
        out = ((p < self._lo) | (p > self._hi)).any(axis=1)
        self._left[idx[out]] = True
        self._step += 1
