"""A picture of the standard views of a run, drawn from the topics RViz2 and Foxglove show.

Neither viewer runs where the docs are built, so ``docs/images/views_snapshot.png`` is not
a screenshot: it is :func:`phd_swarm.tools.plots.draw_snapshot` fed from the topics that
``config/rviz/swarm.rviz`` and ``config/foxglove/swarm.json`` display, read back from a
recorded run (an MCAP log):

- ``/monitor/density_grid`` (``nav_msgs/OccupancyGrid``): the team PHD, turned back into
  masses per bin (:func:`phd_swarm.nodes.occupancy.to_mass`, exact to the grid's 1 % steps);
- ``/world/markers``: robots (alive or dead, by their colour), their ids, true targets;
  the fields of view are drawn as disks of the scenario's sensing radius;
- ``/monitor/markers``: cells (the ``cells`` line list, rejoined into polygons), goals and
  the team's estimates.

``python -m phd_swarm.tools.views_snapshot RUN.mcap [--step K] [-o OUT.png]`` (the last
step with a grid by default).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np
from nav_msgs.msg import OccupancyGrid
from visualization_msgs.msg import Marker, MarkerArray

from phd_swarm.logs.mcap_log import LogError, open_log
from phd_swarm.nodes import occupancy
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.markers import COLOURS, ROBOT_ID_OFFSET
from phd_swarm.tools.plots import Frame, save_snapshot
from phd_swarm.tools.run_log import config_from_log, deserialize

#: The topics drawn, as the viewers' configs name them.
TOPICS = (T.MONITOR_DENSITY_GRID, T.WORLD_MARKERS, T.MONITOR_MARKERS)


def _step(stamp: Any, dt: float) -> int:
    return int(round((stamp.sec + stamp.nanosec * 1e-9) / dt))


def _xy(points: Any) -> np.ndarray:
    return np.array([[p.x, p.y] for p in points], dtype=float).reshape(-1, 2)


def polygons(marker: Marker) -> list[np.ndarray]:
    """The closed polygons of a ``LINE_LIST`` of polygon edges (:mod:`~phd_swarm.nodes.markers`).

    Each polygon's edges run from each vertex to the next, the last back to the first, so
    a polygon ends at the edge that returns to its first vertex.
    """
    pts = _xy(marker.points)
    out, start, current = [], None, []
    for a, b in zip(pts[0::2], pts[1::2], strict=True):
        if start is None:
            start, current = a, []
        current.append(a)
        if np.array_equal(b, start):
            out.append(np.array(current))
            start = None
    return out


def _world(markers: list[Marker]) -> tuple[dict[int, np.ndarray], set[int], np.ndarray]:
    """Robots by id, the live ones and the true targets of ``/world/markers``."""
    by_ns: dict[str, list[Marker]] = {}
    for m in markers:
        by_ns.setdefault(m.ns, []).append(m)
    labels = sorted((m.id, m.pose.position.x, m.pose.position.y - ROBOT_ID_OFFSET)
                    for m in by_ns.get("robot_ids", ()) if m.action == Marker.ADD)
    robots = {rid: np.array([x, y]) for rid, x, y in labels}
    alive_alpha = COLOURS["robot_alive"][3]
    spheres = by_ns.get("robots", [])
    colours = spheres[0].colors if spheres else []
    alive = {rid for (rid, _, _), c in zip(labels, colours, strict=False)
             if np.isclose(c.a, alive_alpha)}
    targets = by_ns.get("targets", [])
    return robots, alive, _xy(targets[0].points) if targets else np.empty((0, 2))


def _team(markers: list[Marker], robots: dict[int, np.ndarray]
          ) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray], np.ndarray]:
    """Cells and goals by robot, and the team's estimates, of ``/monitor/markers``.

    A cell or a goal belongs to the robot nearest to its centroid or its line's start.
    """
    ids = sorted(robots)
    pos = np.array([robots[r] for r in ids]).reshape(-1, 2)

    def owner(xy: np.ndarray) -> int:
        return ids[int(np.argmin(np.linalg.norm(pos - xy, axis=1)))]

    cells: dict[int, np.ndarray] = {}
    goals: dict[int, np.ndarray] = {}
    estimates = np.empty((0, 2))
    for m in markers:
        if m.ns == "cells" and ids:
            cells.update((owner(p.mean(axis=0)), p) for p in polygons(m))
        elif m.ns == "goals" and m.id == 1 and ids:
            pts = _xy(m.points)
            goals.update((owner(a), b) for a, b in zip(pts[0::2], pts[1::2], strict=True))
        elif m.ns == "estimates":
            estimates = _xy(m.points)
    return cells, goals, estimates


def views_frame(path: str | Path, step: int | None = None) -> Frame:
    """The snapshot of ``step`` (default: the last with a team grid) of the log at ``path``.

    Raises
    ------
    LogError
        If the log holds no run config, no ``/monitor/density_grid`` (a run without a grid
        PHD, or recorded before it existed) or nothing of ``step``.
    """
    path = Path(path)
    with open_log(path) as log:
        rc = config_from_log(path, log.metadata())
        s = rc.scenario
        grids: dict[int, OccupancyGrid] = {}
        views: dict[str, dict[int, list[Marker]]] = {T.WORLD_MARKERS: {}, T.MONITOR_MARKERS: {}}
        for rec in log.messages(list(TOPICS), decode=False):
            if rec.topic == T.MONITOR_DENSITY_GRID:
                msg = deserialize(rec, OccupancyGrid, path)
                grids[_step(msg.header.stamp, s.dt)] = msg
            else:
                msg = deserialize(rec, MarkerArray, path)
                if msg.markers:
                    k = _step(msg.markers[0].header.stamp, s.dt)
                    views[rec.topic][k] = list(msg.markers)
    if not grids:
        raise LogError(f"{path}: no {T.MONITOR_DENSITY_GRID} in the log (a system without a "
                       "grid PHD, or a log from before the views)")
    k = max(grids) if step is None else step
    if k not in grids or any(k not in v for v in views.values()):
        raise LogError(f"{path}: step {k} is not in all of {', '.join(TOPICS)}")
    robots, alive, truth = _world(views[T.WORLD_MARKERS][k])
    cells, goals, estimates = _team(views[T.MONITOR_MARKERS][k], robots)
    env = s.env
    return Frame(
        t=k * s.dt, step=k, extent=(env.xmin, env.ymin, env.xmax, env.ymax),
        phd=occupancy.to_mass(grids[k]), robots=robots, alive=alive,
        fov_radius=s.models.detection.radius, cells=cells, goals=goals, truth=truth,
        estimates=estimates,
        title=(f"{s.name}, {s.robots} robots, step {k} (t = {k * s.dt:.1f} s): "
               f"{', '.join(TOPICS)}, drawn from a recorded run with matplotlib (not an "
               "RViz2 screenshot)"))


def main(argv: list[str] | None = None) -> int:
    """Command line: draw the views of a log's step into a PNG (see the module docstring)."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("log", type=Path, help="a recorded run (run.mcap)")
    p.add_argument("--step", type=int, default=None, help="step (default: the last)")
    p.add_argument("-o", "--out", type=Path, default=Path("views_snapshot.png"))
    args = p.parse_args(argv)
    try:
        frame = views_frame(args.log, args.step)
    except LogError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(save_snapshot(frame, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
