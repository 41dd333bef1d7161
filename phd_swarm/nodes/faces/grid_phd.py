"""The ROS faces of the ``grid_phd`` estimator: the robot's PHD window, exact and for viewers.

A robot publishes the PHD of the bins it owns at the end of a step (Dames eq. 2, the
window the exchange keeps, ``exchange.bins`` and ``exchange.weights``) on ``density``; the
monitor adds the windows of the team into the team PHD image, exact in float64 since each
bin has one owner. The same window goes out on ``density_grid`` as a
``nav_msgs/OccupancyGrid`` (:mod:`phd_swarm.nodes.occupancy`: 100 = 1 target per m^2), for
RViz2 and Foxglove; the window is built once per step for both.
"""

from __future__ import annotations

from nav_msgs.msg import OccupancyGrid

from phd_swarm.nodes import convert, occupancy
from phd_swarm.nodes.face import Face, Step
from phd_swarm_msgs.msg import DensityGrid

#: Key of the step's window in ``Step.cache``.
_WINDOW = "grid_phd.window"


def _window(step: Step) -> DensityGrid:
    msg = step.cache.get(_WINDOW)
    if msg is None:
        ex = step.agent.exchange
        msg = step.cache[_WINDOW] = convert.density_grid(
            step.robot_id, step.k, step.agent.team.scenario.grid, ex.bins, ex.weights,
            step.dt, step.frame_id)
    return msg


def _density(step: Step, memo: dict) -> DensityGrid:
    return _window(step)


def _density_grid(step: Step, memo: dict) -> OccupancyGrid:
    return occupancy.from_density(_window(step))


#: Output ``density``: the robot's owned bins and their PHD weights.
DENSITY = Face(DensityGrid, _density)

#: Output ``density_grid``: the same window as an occupancy grid (0..100).
DENSITY_GRID = Face(OccupancyGrid, _density_grid)
