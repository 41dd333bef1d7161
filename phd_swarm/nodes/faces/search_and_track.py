"""The ROS faces of Papaioannou et al.'s agents: search map, agent state, plan and markers.

The ``papaioannou_sat`` estimator publishes its search values p_v on ``search_map`` (one
per node of its search map, eq. 10); the ``sat_search_track`` controller publishes the
agent's own state (tracking or searching next, its predicted targets, the joint plan's
agents) on ``sat_state``, its next goal then its search plan's nodes on ``plan``
(Sec. V-B), and its sensing square coloured by mode with the plan and the estimates on
``markers`` (:func:`~phd_swarm.nodes.faces.sat_markers.sat_markers`).

Reference: S. Papaioannou, P. Kolios, T. Theocharides, C. G. Panayiotou and M. M.
Polycarpou, "Distributed search planning in 3-D environments with a dynamically varying
number of agents", 2023.
"""

from __future__ import annotations

import numpy as np
from nav_msgs.msg import Path
from visualization_msgs.msg import MarkerArray

from phd_swarm.core.exchange.sat_share import SatMsg
from phd_swarm.nodes import convert
from phd_swarm.nodes.face import Face, Step
from phd_swarm.nodes.faces.sat_markers import sat_markers
from phd_swarm.nodes.faces.sat_share import sat_state
from phd_swarm_msgs.msg import DensityGrid, SatState


def _search_map(step: Step, memo: dict) -> DensityGrid:
    est = step.agent.estimator
    grid = est.setup.grid.grid
    return convert.density_grid(step.robot_id, step.k, grid, np.arange(grid.size),
                                est.search, step.dt, step.frame_id)


def _sat_state(step: Step, memo: dict) -> SatState:
    ctl, est = step.agent.controller, step.agent.estimator
    return sat_state(SatMsg(step.robot_id, step.k, np.asarray(step.agent.position, dtype=float),
                            bool(ctl.tracking), est.predicted_states()[:, :2], np.empty(0),
                            tuple(ctl.plan_members)), step.dt, step.frame_id)


def _plan(step: Step, memo: dict) -> Path:
    return Path(header=step.header(), poses=[
        convert.pose_stamped(q, step.k, step.dt, step.frame_id)
        for q in step.agent.controller.planned_path()])


def _markers(step: Step, memo: dict) -> MarkerArray:
    ctl = step.agent.controller
    mode = (("yield" if ctl.yielding else "track") if ctl.tracking or ctl.yielding
            else "search")
    return sat_markers(step.stamp(), step.frame_id, step.robot_id, step.agent.position,
                       float(step.agent.estimator.setup.sensor.side), mode,
                       ctl.planned_path(), step.points)


#: Output ``search_map``: the agent's search values p_v (Papaioannou et al. eq. 10).
SEARCH_MAP = Face(DensityGrid, _search_map)
#: Output ``sat_state``: the agent's own state of the step (no map).
SAT_STATE = Face(SatState, _sat_state)
#: Output ``plan``: the next goal, then the search plan's nodes.
PLAN = Face(Path, _plan)
#: Output ``markers``: the sensing square by mode, the plan and the estimates.
MARKERS = Face(MarkerArray, _markers)
