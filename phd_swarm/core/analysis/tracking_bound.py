"""An (approximate) upper bound on Fig. 5a's tracking ratio for a perfect sweep (Papaioannou).

Fig. 5a reports the time targets are tracked over their lifetime (0.83 for 10 agents at
C_R = 40 m). Whatever the control, a target cannot be tracked before some agent's sensing
square has covered it. This bounds how soon that can be.

**Coverage.** N agents, each with a square of side a, move at most d [m] per step (eq. 4:
``N_R Delta_R = 4 m``); a target moves at most s [m] per step. Take a target born at a
uniformly random point of the area A (Fig. 5: "birth locations are uniformly distributed
inside the whole area"), at step b. In the target's own frame each square moves at most
``d + s`` per step, and a square of side a moved by a vector u sweeps at most
``a (|u_x| + |u_y|) <= sqrt(2) a |u|`` of new area. So the region the N squares have covered,
in the target's frame, within J steps of its birth has area at most

    ``N a^2 + c J``,  ``c = sqrt(2) N a (d + s)``  [m^2].

Until the target is first in a square nobody has measured it, so the agents' motion up to
then does not depend on where it is; its birth point is uniform over A, hence the step j*
(after birth) at which it is first in a square satisfies

    ``P(j* <= J) <= G(J) = min(1, (N a^2 + c J) / |A|)``,  J = 0, 1, ...

(the target's path only shifts the covered region, which does not change its area).

**Tracking.** A target of lifetime L [steps] found at j* is tracked for at most
``(L - j*)^+`` steps (perfect tracking from the first sight on, no confirmation step). That
is decreasing in j*, so with j* replaced by a j distributed as G (the smallest law allowed),
the expectations below are upper bounds:

- pooled (Fig. 5a as a ratio of sums, today's reading): ``E[(L - j)^+] / E[L]``;
- per target (the mean of each target's ratio): ``E[(L - j)^+ / L]``.

With a geometric lifetime of mean mu (p = 1 / mu), ``E[(L - J)^+] = (1 - p)^J / p`` and the
pooled bound is ``sum_J P(j = J) (1 - p)^J``. With the paper's numbers (|A| = 100 x 100 m,
a = 10 m, d = 4 m, s = sqrt(2) m) and mu = 30 steps the pooled bound is ~0.85 for 10 agents;
docs/decisions.md puts the paper's 0.83 against it. The bound ignores the run's end, the
squares' overlaps and the area's edge (all of which lower the truth), and counts the first
sight as tracked (the filter confirms a target at its second detection).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["READINGS", "first_sight_pmf", "tracking_ratio_bound"]

#: The two readings of "tracking time normalised with the actual lifetime".
READINGS = ("pooled", "per_target")

#: Geometric lifetimes are summed up to where their tail is below this.
_TAIL = 1e-12


def _positive(name: str, value: float, strict: bool = True) -> float:
    v = float(value)
    if not (math.isfinite(v) and (v > 0.0 if strict else v >= 0.0)):
        raise ValueError(f"{name} must be finite and {'> 0' if strict else '>= 0'}, got "
                         f"{value!r}")
    return v


def first_sight_pmf(agents: int, area: float = 1e4, side: float = 10.0, move: float = 4.0,
                    target_speed: float = math.sqrt(2.0), dt: float = 1.0) -> np.ndarray:
    """P(j = J) for J = 0, 1, ..., the law G of the first sight (see the module docstring).

    Parameters
    ----------
    agents : int
        N, >= 1.
    area : float
        |A| [m^2] (100 x 100 m in Sec. VI).
    side : float
        a, the sensing square's side [m] (10).
    move : float
        d, an agent's longest move per step [m] (eq. 4: N_R Delta_R = 4).
    target_speed : float
        A target's speed [m/s] (sqrt(2): 1 m/s along each axis).
    dt : float
        Step [s].

    Returns
    -------
    np.ndarray, shape (J_max + 1,)
        Probabilities summing to 1; entry 0 is ``min(1, N a^2 / |A|)``.
    """
    if isinstance(agents, bool) or int(agents) != agents or agents < 1:
        raise ValueError(f"agents must be an integer >= 1, got {agents!r}")
    area, side = _positive("area", area), _positive("side", side)
    move = _positive("move", move, strict=False)
    s = _positive("target_speed", target_speed, strict=False) * _positive("dt", dt)
    a0 = agents * side ** 2
    c = math.sqrt(2.0) * agents * side * (move + s)
    if a0 >= area:
        return np.ones(1)
    if c == 0.0:
        raise ValueError("nothing moves (move = target_speed = 0): the bound is the first "
                         "squares' share of the area")
    j_max = math.ceil((area - a0) / c)
    g = np.minimum(1.0, (a0 + c * np.arange(j_max + 1)) / area)
    g[-1] = 1.0
    return np.diff(g, prepend=0.0)


def tracking_ratio_bound(agents: int, lifetimes: float | np.ndarray,
                         reading: str = "pooled", **geometry: float) -> float:
    """Upper bound on the tracking ratio of a perfect sweep (see the module docstring).

    Parameters
    ----------
    agents : int
        N, >= 1.
    lifetimes : float or np.ndarray
        A number: the mean [steps] of a geometric lifetime on 1, 2, ...; an array: the
        targets' lifetimes [steps] (e.g. measured in a run), each >= 1.
    reading : {"pooled", "per_target"}
        ``E[(L - j)^+] / E[L]`` or ``E[(L - j)^+ / L]``.
    **geometry
        ``area``, ``side``, ``move``, ``target_speed``, ``dt`` of :func:`first_sight_pmf`.

    Returns
    -------
    float
        The bound, in [0, 1].
    """
    if reading not in READINGS:
        raise ValueError(f"reading must be one of {READINGS}, got {reading!r}")
    pj = first_sight_pmf(agents, **geometry)
    j = np.arange(len(pj))
    if np.ndim(lifetimes) == 0:
        mu = _positive("lifetimes (mean)", float(lifetimes))
        if mu < 1.0:
            raise ValueError(f"a geometric lifetime's mean must be >= 1 step, got {mu!r}")
        p = 1.0 / mu
        n = 1 if p == 1.0 else max(1, math.ceil(math.log(_TAIL) / math.log1p(-p)))
        ell = np.arange(1, n + 1)
        pl = p * (1.0 - p) ** (ell - 1)
        pl /= pl.sum()
    else:
        ell, counts = np.unique(np.asarray(lifetimes, dtype=float).reshape(-1),
                                return_counts=True)
        if ell.size == 0 or ell[0] < 1.0 or not np.all(np.isfinite(ell)):
            raise ValueError("lifetimes must be finite and >= 1 step, at least one")
        pl = counts / counts.sum()
    tracked = np.maximum(ell[:, None] - j[None, :], 0.0)                   # (L, J)
    if reading == "pooled":
        return float((pl @ tracked @ pj) / (pl @ ell))
    return float(pl @ (tracked / ell[:, None]) @ pj)
