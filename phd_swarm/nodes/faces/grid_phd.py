"""The ROS face of the ``grid_phd`` estimator: the robot's PHD window on ``density``.

A robot publishes the PHD of the bins it owns at the end of a step (Dames eq. 2, the
window the exchange keeps, ``exchange.bins`` and ``exchange.weights``); the monitor adds
the windows of the team into the team PHD image, exact in float64 since each bin has one
owner.
"""

from __future__ import annotations

from phd_swarm.nodes import convert
from phd_swarm.nodes.face import Face, Step
from phd_swarm_msgs.msg import DensityGrid


def _density(step: Step, memo: dict) -> DensityGrid:
    ex = step.agent.exchange
    return convert.density_grid(step.robot_id, step.k, step.agent.team.scenario.grid,
                                ex.bins, ex.weights, step.dt, step.frame_id)


#: Output ``density``: the robot's owned bins and their PHD weights.
DENSITY = Face(DensityGrid, _density)
