"""The estimator role: a robot's belief about the targets.

An estimator predicts (the motion of the targets between two scans), updates with a scan
taken from a sensor pose, and gives its estimates: target positions and the expected number
of targets. The agent (:class:`phd_swarm.core.agent.Agent`) calls :meth:`Estimator.predict`
then :meth:`Estimator.update` with the robot's own scan at the start of each step, before
the exchange runs; what the exchange carries between robots (a merged target set, a search
map) it reads from and writes to the estimator.

One exception, declared when the part registers (``runs_in_exchange=True``): Dames' grid
PHD is distributed over the robots' cells, its bins move from robot to robot with the
cells and its update needs the neighbours' eta sums, so the ``voronoi_phd`` exchange runs
that filter itself and the agent leaves it alone (:mod:`.grid_phd.estimator`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from ..scan import Scan


class Estimator(ABC):
    """Predict, update with a scan, estimates (one instance per robot, or per team)."""

    @abstractmethod
    def predict(self) -> None:
        """Prediction over one time step (the targets' motion, survival and births)."""

    @abstractmethod
    def update(self, scan: Scan) -> None:
        """Update with one measurement set taken from ``scan.sensor``."""

    @abstractmethod
    def estimates(self) -> np.ndarray:
        """Estimated target positions, shape (N, 2) [m]."""

    @abstractmethod
    def expected_count(self) -> float:
        """Expected number of targets (the PHD's mass)."""

    def export_state(self) -> dict[str, np.ndarray]:
        """The estimator's state as plain arrays, what travels between robots.

        Estimators whose state does not travel (the grid PHD, whose bins move with the
        cells) do not override it.
        """
        raise NotImplementedError(f"{type(self).__name__} has no exportable state")

    def import_state(self, arrays: dict[str, np.ndarray], where: str = "state") -> None:
        """Replace the state with ``arrays`` from :meth:`export_state`, checked.

        A malformed field is refused with a ``ValueError`` naming ``where``.
        """
        raise NotImplementedError(f"{type(self).__name__} has no importable state")
