"""One search-and-track agent's view of a step as a MarkerArray (Papaioannou et al.).

:func:`sat_markers` draws, under the agent's own prefix ``robot_<id>/`` (so several agents'
markers do not replace each other), with the conventions of :mod:`phd_swarm.nodes.markers`
(fixed ids, action ADD, the z = 0 plane, ``*_LIST`` markers, non-finite points left out):

- ``robot``, id 0: SPHERE_LIST, the agent;
- ``sensing``, id 0: LINE_STRIP, its sensing square S_a(s_k) (eq. 5), coloured by mode:
  blue searching, red tracking, orange yielding a tracking overlap (Sec. V-C b);
- ``plan``, id 0: LINE_STRIP from the agent through its next goal and the nodes of its
  search plan (Sec. V-B; only the goal while tracking);
- ``estimates``, id 0: SPHERE_LIST, its estimated targets.
"""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from phd_swarm.nodes import topics
from phd_swarm.nodes.markers import (
    ESTIMATE_DIAMETER,
    FOV_LINE_WIDTH,
    GOAL_LINE_WIDTH,
    ROBOT_DIAMETER,
    _finite,
    _marker,
    _points,
    _xy,
)

#: Colour of the sensing square in each mode (RGBA).
MODE_COLOURS = {"search": (0.12, 0.47, 0.71, 0.8), "track": (0.84, 0.15, 0.16, 0.9),
                "yield": (1.0, 0.5, 0.05, 0.9)}


def sat_markers(stamp: Time, frame_id: str, robot_id: int, position: np.ndarray, side: float,
                mode: str, path: np.ndarray, estimates: np.ndarray) -> MarkerArray:
    """The agent's markers for one step (see the module docstring).

    Parameters
    ----------
    stamp : builtin_interfaces.msg.Time
    frame_id : str
    robot_id : int
    position : np.ndarray, shape (2,)
        s_k [m].
    side : float
        Side of the sensing square [m].
    mode : str
        ``search``, ``track`` or ``yield``.
    path : np.ndarray, shape (P, 2)
        The next goal, then the plan's nodes [m].
    estimates : np.ndarray, shape (K, 2)
        Its estimated targets [m].
    """
    if mode not in MODE_COLOURS:
        raise ValueError(f"mode must be one of {sorted(MODE_COLOURS)}, got {mode!r}")
    prefix = topics.robot_namespace(int(robot_id)).lstrip("/") + "/"
    q = _xy(position)[:1]
    q = q[_finite(q)]

    def new(ns: str, kind: int, scale: float, colour: str) -> Marker:
        return _marker(stamp, frame_id, prefix + ns, 0, kind, scale, colour)

    robot = new("robot", Marker.SPHERE_LIST, ROBOT_DIAMETER, "robot_alive")
    robot.points = _points(q)
    square = new("sensing", Marker.LINE_STRIP, FOV_LINE_WIDTH, "fov")
    r, g, b, a = MODE_COLOURS[mode]
    square.color = ColorRGBA(r=r, g=g, b=b, a=a)
    if len(q):
        h = 0.5 * float(side)
        corners = q[0] + np.array([[-h, -h], [h, -h], [h, h], [-h, h], [-h, -h]])
        square.points = _points(corners)
    plan = new("plan", Marker.LINE_STRIP, GOAL_LINE_WIDTH, "goal_line")
    p = _xy(path)
    p = p[_finite(p)]
    plan.points = _points(np.vstack([q, p])) if len(q) and len(p) else []
    found = new("estimates", Marker.SPHERE_LIST, ESTIMATE_DIAMETER, "estimate")
    e = _xy(estimates)
    found.points = _points(e[_finite(e)])
    return MarkerArray(markers=[robot, square, plan, found])
