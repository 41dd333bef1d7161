"""An agent's tracking control (Papaioannou et al. Sec. V-C a), its parameters and its choice.

:class:`RenyiTracking` holds the settings of Sec. VI-A (alpha = 0.5, p_D^max = 0.99, a 10 m
x 10 m sensing square, lambda_c = 10 clutter points per scan) and runs the four steps of
:mod:`.renyi` (eq. 8, 17, 18) for every admissible action at once, then picks the best.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...sensors.range_bearing_model import RangeBearingSensor
from .renyi import (
    _alpha,
    _side,
    best_action,
    predicted_measurements,
    pseudo_update_weights,
    renyi_reward,
    square_clutter,
)


@dataclass(frozen=True)
class RenyiTracking:
    """Tracking control of one agent: predicted measurements, pseudo-update, reward, choice.

    Attributes
    ----------
    alpha : float
        Renyi order, in (0, 1) (0.5, Sec. VI-A).
    side : float
        Side a of the sensing square [m] (10, Sec. VI-A).
    p_d_inside : float
        p_D^max [-] (0.99, Sec. VI-A).
    clutter_rate : float
        lambda_c, clutter points per scan [-], >= 0 (10, Sec. VI-A); spread uniformly over
        the sensing square in the plane (:func:`square_clutter`).
    clutter_density : float or None
        If given, a constant kappa [1/(m rad)] used instead (the literal "uniform over the
        measurement space").
    sensor_model : RangeBearingSensor
        Range-bearing noise (the paper's by default).
    only_visible : bool
        Predicted measurements only of estimates inside S_a(u) (True) or of all (False);
        see :func:`predicted_measurements`.
    position_index : tuple of int
        State indices of x and y in the particle states.
    tie_rtol : float
        Relative tolerance of a tie between rewards (:func:`best_action`).
    """

    alpha: float = 0.5
    side: float = 10.0
    p_d_inside: float = 0.99
    clutter_rate: float = 10.0
    clutter_density: float | None = None
    sensor_model: RangeBearingSensor = field(default_factory=RangeBearingSensor)
    only_visible: bool = True
    position_index: tuple[int, int] = (0, 1)
    tie_rtol: float = 1e-9

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha", _alpha(self.alpha))
        object.__setattr__(self, "side", _side(self.side))
        p = float(self.p_d_inside)
        if not 0.0 <= p <= 1.0:
            raise ValueError(f"p_d_inside must lie in [0, 1], got {self.p_d_inside!r}")
        object.__setattr__(self, "p_d_inside", p)
        rate = float(self.clutter_rate)
        if not (np.isfinite(rate) and rate >= 0.0):
            raise ValueError(f"clutter_rate must be finite and >= 0, got {self.clutter_rate!r}")
        object.__setattr__(self, "clutter_rate", rate)
        if self.clutter_density is not None:
            k = float(self.clutter_density)
            if not (np.isfinite(k) and k >= 0.0):
                raise ValueError(f"clutter_density must be finite and >= 0, got "
                                 f"{self.clutter_density!r}")
            object.__setattr__(self, "clutter_density", k)
        if not isinstance(self.sensor_model, RangeBearingSensor):
            raise ValueError(f"sensor_model must be a RangeBearingSensor, got "
                             f"{type(self.sensor_model).__name__}")
        t = float(self.tie_rtol)
        if not (np.isfinite(t) and t >= 0.0):
            raise ValueError(f"tie_rtol must be finite and >= 0, got {self.tie_rtol!r}")
        object.__setattr__(self, "tie_rtol", t)
        object.__setattr__(self, "position_index", tuple(int(i) for i in self.position_index))

    def rewards(self, states: np.ndarray, weights: np.ndarray, estimates: np.ndarray,
                action_positions: np.ndarray, newborn: np.ndarray | None = None
                ) -> np.ndarray:
        """Reward of eq. 18 of every action, shape (U,) [-].

        Parameters
        ----------
        states : np.ndarray, shape (N, d)
            Predicted particle states (position at ``position_index``).
        weights : np.ndarray, shape (N,)
            Predicted weights.
        estimates : np.ndarray, shape (K, 2)
            Predicted target positions Xhat_{k|k-1} [m].
        action_positions : np.ndarray, shape (U, 2)
            Agent position after each action [m].
        newborn : np.ndarray of bool, shape (N,), optional
            See :func:`pseudo_update_weights`.
        """
        pred = predicted_measurements(estimates, action_positions, self.sensor_model,
                                      self.side, self.only_visible)
        if self.clutter_density is not None:
            kappa: float | np.ndarray = self.clutter_density
        else:
            kappa = square_clutter(pred.z, self.side, self.clutter_rate)
        updated = pseudo_update_weights(states, weights, action_positions, pred.z,
                                        pred.member, self.p_d_inside, self.side,
                                        self.sensor_model, kappa, self.position_index,
                                        newborn)
        return renyi_reward(weights, updated, self.alpha)

    def choose(self, states: np.ndarray, weights: np.ndarray, estimates: np.ndarray,
               action_positions: np.ndarray, admissible: np.ndarray | None = None,
               newborn: np.ndarray | None = None) -> tuple[int, np.ndarray]:
        """The best admissible action (ties to the lowest index) and every action's reward.

        Parameters are those of :meth:`rewards`, plus ``admissible`` (U,) bool (None: all).

        Returns
        -------
        action : int
            Index into ``action_positions``.
        rewards : np.ndarray, shape (U,)
            Eq. 18 of every action, admissible or not.
        """
        r = self.rewards(states, weights, estimates, action_positions, newborn)
        return best_action(r, admissible, self.tie_rtol), r
