"""``visualization_msgs/MarkerArray`` builders that show a run in RViz2 and Foxglove.

Pure functions from numpy arrays to messages (no Node): the world publishes
:func:`world_markers_cdr` on ``/world/markers`` and the team monitor
:func:`team_markers_cdr` on ``/monitor/markers`` once per step. These two write the CDR
bytes of the MarkerArray directly (:mod:`phd_swarm.nodes.cdr`: a marker's points are one
numpy array, never a ``Point`` object each), which rclpy publishes as they are;
:func:`world_markers` and :func:`team_markers` return the same markers as a message.

Conventions, shared by every marker built here:

- Each namespace uses fixed marker ids and action ADD, so the markers of step k+1 replace
  those of step k in the viewer (no DELETEALL, hence no flicker); ``lifetime`` is 0 (kept
  until replaced).
- Everything lies in the z = 0 plane of ``frame_id`` (the world frame, REP 105); scales are
  in metres, chosen for the papers' 100 x 100 m maps and multiplied by ``size``, which the
  world and the monitor set to :func:`marker_size` of the scenario's map (Shirsat &
  Berman's 5 x 5 m arena draws its robots 0.05 m wide, not 1 m).
- Many things of one kind go into one ``*_LIST`` marker rather than one marker each: a
  MarkerArray of 100 robots then holds a handful of markers, which keeps building,
  serialising and rendering cheap.
- Points with a non-finite coordinate are left out: RViz2 rejects a whole marker that
  holds one of them.
- Empty inputs give valid markers with no points.
- Line markers built with :func:`_segments` (the robots' markers) may hold the same
  ``Point`` object twice (the end of one edge is the start of the next) to halve the
  objects built per step; treat them as read-only.

Colours (RGBA) are listed in :data:`COLOURS`. Cost measured on the development machine
(2026-12-03, quiet): the world's markers for 100 robots and 100 targets (4800
field-of-view points, 100 labels, 146 kB) took 16 ms to build as messages and 10 ms to
serialise; :func:`world_markers_cdr` writes the same bytes in ~6 ms.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Vector3
from rclpy.serialization import deserialize_message
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from phd_swarm.nodes import cdr

#: RGBA of each kind of thing shown (tab10-like hues that read on RViz2's dark grey and on
#: Foxglove's light and dark themes).
COLOURS: dict[str, tuple[float, float, float, float]] = {
    "robot_alive": (0.12, 0.47, 0.71, 1.0),   # blue
    "robot_dead": (0.5, 0.5, 0.5, 0.5),       # translucent grey
    "robot_id": (1.0, 1.0, 1.0, 1.0),         # white text
    "fov": (0.12, 0.47, 0.71, 0.6),           # translucent blue
    "target": (0.84, 0.15, 0.16, 1.0),        # red
    "cell": (0.75, 0.75, 0.75, 0.8),          # light grey
    "goal": (1.0, 0.5, 0.05, 1.0),            # orange
    "goal_line": (1.0, 0.5, 0.05, 0.6),       # translucent orange
    "estimate": (0.17, 0.63, 0.17, 0.6),      # translucent green
    "grid_node": (0.75, 0.75, 0.75, 0.5),     # translucent light grey
    "meeting": (0.98, 0.84, 0.1, 0.8),        # yellow
}

#: Sizes [m]: sphere/cube diameters and edge lengths, line widths, text height.
ROBOT_DIAMETER = 1.0
ROBOT_ID_HEIGHT = 1.5
ROBOT_ID_OFFSET = 1.5        # labels sit this far along +y of the robot, beside its sphere
FOV_LINE_WIDTH = 0.1
FOV_SEGMENTS = 24
TARGET_SIZE = 0.8
CELL_LINE_WIDTH = 0.15
GOAL_DIAMETER = 0.6
GOAL_LINE_WIDTH = 0.05
ESTIMATE_DIAMETER = 1.5      # larger than a target's cube, so a hit shows the cube inside
GRID_NODE_SIZE = 0.08
MEETING_DIAMETER = 1.2       # around the robots' spheres at a renewal epoch


def marker_size(env: object) -> float:
    """The size factor of a map's markers: its larger side over 100 m.

    1 for the papers' 100 x 100 m maps; ``env`` has ``xmin``, ``xmax``, ``ymin``, ``ymax``.
    """
    return max(env.xmax - env.xmin, env.ymax - env.ymin) / 100.0


def _rgba(name: str) -> ColorRGBA:
    r, g, b, a = COLOURS[name]
    return ColorRGBA(r=r, g=g, b=b, a=a)


def _xy(values: object) -> np.ndarray:
    """Anything array-like of positions -> float (N, 2), rows with NaN/inf kept."""
    return np.asarray(values, dtype=float).reshape(-1, 2)


def _points(xy: np.ndarray) -> list[Point]:
    # tolist() yields Python floats, which Point takes without conversion (faster than
    # iterating over numpy scalars).
    return [Point(x=x, y=y) for x, y in xy.tolist()]


def _marker(stamp: Time, frame_id: str, ns: str, marker_id: int, kind: int,
            scale: float, colour: str) -> Marker:
    """A marker with header, ns, id, type, action ADD, uniform scale and colour."""
    return Marker(header=Header(stamp=stamp, frame_id=frame_id), ns=ns, id=marker_id,
                  type=kind, action=Marker.ADD,
                  scale=Vector3(x=scale, y=scale, z=scale), color=_rgba(colour))


def _segments(vertices: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> list[Point]:
    """LINE_LIST points of closed polygons stored back to back in ``vertices``.

    Polygon ``k`` is ``vertices[starts[k]:ends[k]]``; each of its V vertices starts one
    edge to the next vertex, the last one back to the first, so it adds 2V points.
    """
    if len(vertices) == 0:
        return []
    pts = _points(vertices)
    return [pts[i] for i in _segment_index(len(vertices), starts, ends).tolist()]


def _segment_index(n: int, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Indices (2n,) of the LINE_LIST points of closed polygons stored back to back.

    Each vertex, then the next one of its polygon (the last one's is the first).
    """
    nxt = np.arange(1, n + 1)
    nxt[ends - 1] = starts
    return np.stack([np.arange(n), nxt], axis=1).ravel()


def _finite(xy: np.ndarray) -> np.ndarray:
    return np.isfinite(xy).all(axis=1)


# Codec values (:mod:`phd_swarm.nodes.cdr`): a marker is a dict of its fields, its points an
# (N, 2) array (z = 0), a colour a dict; fields left out take Marker()'s defaults.
def _rgba_fields(name: str) -> dict[str, float]:
    r, g, b, a = COLOURS[name]
    return {"r": r, "g": g, "b": b, "a": a}


def _marker_fields(stamp: Time, frame_id: str, ns: str, marker_id: int, kind: int,
                   scale: float, colour: str, points: np.ndarray | None = None
                   ) -> dict[str, object]:
    """:func:`_marker` as codec values, with ``points`` (N, 2) [m] if given."""
    out = {"header": {"stamp": {"sec": stamp.sec, "nanosec": stamp.nanosec},
                      "frame_id": frame_id},
           "ns": ns, "id": marker_id, "type": kind, "action": Marker.ADD,
           "scale": (scale, scale, scale), "color": _rgba_fields(colour)}
    if points is not None:
        out["points"] = points
    return out


def _segment_xy(vertices: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """:func:`_segments` as an (2V, 2) array: the LINE_LIST points of closed polygons."""
    if len(vertices) == 0:
        return vertices.reshape(0, 2)
    return vertices[_segment_index(len(vertices), starts, ends)]


def _marker_array(markers: list[dict[str, object]]) -> bytes:
    return cdr.encode(MarkerArray, {"markers": markers})


def world_markers_cdr(stamp: Time, frame_id: str, positions: np.ndarray, alive: np.ndarray,
                      fov_radius: float, targets: np.ndarray,
                      ids: np.ndarray | None = None, *, size: float = 1.0) -> bytes:
    """The world's view of a step: robots, their ids and fields of view, true targets.

    Namespaces and markers (ids fixed, so each call replaces the previous one):

    - ``robots``, id 0: SPHERE_LIST, one sphere of diameter :data:`ROBOT_DIAMETER` per
      robot, per-point colours ``COLOURS["robot_alive"]`` (blue) or
      ``COLOURS["robot_dead"]`` (translucent grey).
    - ``robot_ids``, id = robot id: TEXT_VIEW_FACING with the id, :data:`ROBOT_ID_HEIGHT`
      high, :data:`ROBOT_ID_OFFSET` along +y of the robot, white. The label of a robot
      whose position is not finite is sent with action DELETE (so a stale one goes away).
    - ``fov``, id 0: LINE_LIST, for every live robot a regular polygon of
      :data:`FOV_SEGMENTS` edges inscribed in the sensing disk, line width
      :data:`FOV_LINE_WIDTH`, translucent blue.
    - ``targets``, id 0: CUBE_LIST, one cube of side :data:`TARGET_SIZE` per target, red.

    Parameters
    ----------
    stamp : builtin_interfaces.msg.Time
        Header stamp of every marker (sim time of the step).
    frame_id : str
        Header frame of every marker (the world frame).
    positions : np.ndarray, shape (R, 2)
        Robot positions [m]; row r is robot ``ids[r]``.
    alive : np.ndarray of bool, shape (R,)
        Whether each robot is alive.
    fov_radius : float
        Sensing radius [m], finite and >= 0 (0 draws no field of view).
    targets : np.ndarray, shape (N, 2)
        True target positions [m].
    ids : np.ndarray of int, shape (R,), optional
        Robot ids for the labels; default ``0..R-1``.

    Returns
    -------
    bytes
        The CDR of a MarkerArray: ``robots``, ``robot_ids`` (R markers), ``fov``,
        ``targets``, in that order.

    Raises
    ------
    ValueError
        If ``alive`` or ``ids`` do not have one entry per robot, or ``fov_radius`` is
        negative or not finite.
    """
    pos = _xy(positions)
    live = np.asarray(alive, dtype=bool).reshape(-1)
    rid = np.arange(len(pos)) if ids is None else np.asarray(ids, dtype=np.int64).reshape(-1)
    if live.shape != (len(pos),) or rid.shape != (len(pos),):
        raise ValueError(f"expected one alive flag and one id per robot: {len(pos)} "
                         f"positions, {live.size} alive flags, {rid.size} ids")
    if not (math.isfinite(fov_radius) and fov_radius >= 0.0):
        raise ValueError(f"fov_radius must be a finite number >= 0, got {fov_radius!r}")
    ok = _finite(pos)

    robots = _marker_fields(stamp, frame_id, "robots", 0, Marker.SPHERE_LIST,
                            size * ROBOT_DIAMETER, "robot_alive", pos[ok])
    colour = (_rgba_fields("robot_dead"), _rgba_fields("robot_alive"))
    robots["colors"] = [colour[a] for a in live[ok].tolist()]

    label = _marker_fields(stamp, frame_id, "robot_ids", 0, Marker.TEXT_VIEW_FACING,
                           size * ROBOT_ID_HEIGHT, "robot_id")
    labels = []
    for r, (x, y), good in zip(rid.tolist(), pos.tolist(), ok.tolist(), strict=True):
        if good:
            labels.append({**label, "id": r, "pose": {"position": (x, y + size * ROBOT_ID_OFFSET,
                                                                   0.0)},
                           "text": str(r)})
        else:
            labels.append({**label, "id": r, "action": Marker.DELETE})

    fov = _marker_fields(stamp, frame_id, "fov", 0, Marker.LINE_LIST, size * FOV_LINE_WIDTH,
                         "fov")
    centres = pos[ok & live]
    if len(centres) and fov_radius > 0.0:
        angle = np.linspace(0.0, 2.0 * np.pi, FOV_SEGMENTS, endpoint=False)
        ring = fov_radius * np.stack([np.cos(angle), np.sin(angle)], axis=1)
        vertices = (centres[:, None, :] + ring[None, :, :]).reshape(-1, 2)
        starts = np.arange(len(centres)) * FOV_SEGMENTS
        fov["points"] = _segment_xy(vertices, starts, starts + FOV_SEGMENTS)

    tgt = _xy(targets)
    cubes = _marker_fields(stamp, frame_id, "targets", 0, Marker.CUBE_LIST,
                           size * TARGET_SIZE, "target", tgt[_finite(tgt)])
    return _marker_array([robots, *labels, fov, cubes])


def world_markers(stamp: Time, frame_id: str, positions: np.ndarray, alive: np.ndarray,
                  fov_radius: float, targets: np.ndarray,
                  ids: np.ndarray | None = None, *, size: float = 1.0) -> MarkerArray:
    """:func:`world_markers_cdr` as a message (same arguments and errors)."""
    return deserialize_message(world_markers_cdr(stamp, frame_id, positions, alive,
                                                 fov_radius, targets, ids, size=size),
                               MarkerArray)


def team_markers_cdr(stamp: Time, frame_id: str, cells: Mapping[int, np.ndarray],
                     positions: Mapping[int, np.ndarray], goals: Mapping[int, np.ndarray],
                     estimates: np.ndarray, *, grid_nodes: np.ndarray | None = None,
                     meeting_ids: Sequence[int] | None = None, size: float = 1.0) -> bytes:
    """The team's view of a step: cells, goals and the extracted target estimates.

    Namespaces and markers (ids fixed, so each call replaces the previous one):

    - ``cells``, id 0: LINE_LIST of the edges of every cell polygon, light grey, line
      width :data:`CELL_LINE_WIDTH`. A cell of V >= 3 vertices adds V edges (2V points),
      closing the polygon; cells with fewer than 3 vertices, or with a non-finite vertex,
      are left out.
    - ``goals``, id 0: SPHERE_LIST of the goals, diameter :data:`GOAL_DIAMETER`, orange.
    - ``goals``, id 1: LINE_LIST, one line from each robot to its goal (robots that have
      both a position and a goal, in id order), width :data:`GOAL_LINE_WIDTH`,
      translucent orange.
    - ``estimates``, id 0: SPHERE_LIST, diameter :data:`ESTIMATE_DIAMETER`, translucent
      green (a target's cube shows inside the sphere of a correct estimate).
    - ``grid``, id 0, only with ``grid_nodes``: POINTS at the nodes of a walk's grid graph
      (Shirsat & Berman Sec. II), :data:`GRID_NODE_SIZE`, translucent light grey.
    - ``meetings``, id 0, only with ``meeting_ids``: SPHERE_LIST at the positions of the
      robots that merged their sets at the step (a renewal epoch), diameter
      :data:`MEETING_DIAMETER`, yellow; empty when nobody met.

    Parameters
    ----------
    stamp : builtin_interfaces.msg.Time
        Header stamp of every marker.
    frame_id : str
        Header frame of every marker.
    cells : Mapping[int, np.ndarray]
        Robot id -> its cell's vertices, shape (V, 2) [m], in order around the polygon.
    positions : Mapping[int, np.ndarray]
        Robot id -> position, shape (2,) [m].
    goals : Mapping[int, np.ndarray]
        Robot id -> goal, shape (2,) [m].
    estimates : np.ndarray, shape (M, 2)
        Extracted target positions [m].
    grid_nodes : np.ndarray, shape (S, 2), optional
        Node positions of the robots' grid graph [m].
    meeting_ids : sequence of int, optional
        Robots at a meeting this step (those without a position are left out).

    Returns
    -------
    bytes
        The CDR of a MarkerArray: ``cells``, ``goals`` (spheres), ``goals`` (lines),
        ``estimates``, then ``grid`` and ``meetings`` when asked for, in that order.
    """
    polygons = [v for v in (_xy(cells[k]) for k in sorted(cells))
                if len(v) >= 3 and _finite(v).all()]
    edges = _marker_fields(stamp, frame_id, "cells", 0, Marker.LINE_LIST,
                           size * CELL_LINE_WIDTH, "cell")
    if polygons:
        sizes = np.array([len(v) for v in polygons])
        ends = np.cumsum(sizes)
        edges["points"] = _segment_xy(np.concatenate(polygons), ends - sizes, ends)

    goal_ids = sorted(goals)
    goal_xy = _xy([goals[k] for k in goal_ids])
    spheres = _marker_fields(stamp, frame_id, "goals", 0, Marker.SPHERE_LIST,
                             size * GOAL_DIAMETER, "goal", goal_xy[_finite(goal_xy)])

    linked = [k for k in goal_ids if k in positions]
    pairs = np.stack([_xy([positions[k] for k in linked]), _xy([goals[k] for k in linked])],
                     axis=1)
    pairs = pairs[np.isfinite(pairs).all(axis=(1, 2))]
    lines = _marker_fields(stamp, frame_id, "goals", 1, Marker.LINE_LIST,
                           size * GOAL_LINE_WIDTH, "goal_line", pairs.reshape(-1, 2))

    est = _xy(estimates)
    found = _marker_fields(stamp, frame_id, "estimates", 0, Marker.SPHERE_LIST,
                           size * ESTIMATE_DIAMETER, "estimate", est[_finite(est)])

    extra = []
    if grid_nodes is not None:
        nodes = _xy(grid_nodes)
        extra.append(_marker_fields(stamp, frame_id, "grid", 0, Marker.POINTS,
                                    size * GRID_NODE_SIZE, "grid_node",
                                    nodes[_finite(nodes)]))
    if meeting_ids is not None:
        at = _xy([positions[k] for k in sorted(set(meeting_ids)) if k in positions])
        extra.append(_marker_fields(stamp, frame_id, "meetings", 0, Marker.SPHERE_LIST,
                                    size * MEETING_DIAMETER, "meeting", at[_finite(at)]))
    return _marker_array([edges, spheres, lines, found, *extra])


def team_markers(stamp: Time, frame_id: str, cells: Mapping[int, np.ndarray],
                 positions: Mapping[int, np.ndarray], goals: Mapping[int, np.ndarray],
                 estimates: np.ndarray, *, grid_nodes: np.ndarray | None = None,
                 meeting_ids: Sequence[int] | None = None, size: float = 1.0) -> MarkerArray:
    """:func:`team_markers_cdr` as a message (same arguments)."""
    return deserialize_message(team_markers_cdr(stamp, frame_id, cells, positions, goals,
                                                estimates, grid_nodes=grid_nodes,
                                                meeting_ids=meeting_ids, size=size),
                               MarkerArray)
