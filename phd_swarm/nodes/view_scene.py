"""What the live view draws, from the messages on the graph: pure functions, no rclpy node.

The viewer node (:mod:`phd_swarm.nodes.viewer`) takes the CDR of every message a viewer is
meant for (:mod:`phd_swarm.nodes.cdr` decodes it into dicts and numpy arrays) and turns it
here into :class:`Shape` values, which it hands to Rerun. Nothing here knows a system: the
shapes come from the message *types* the nodes publish (their declared outputs, issue "A
system is its own modules"), so a new system's markers, grids and paths appear in the view
without editing it.

- ``visualization_msgs/MarkerArray``: each marker namespace becomes entities named
  ``<ns>/points``, ``<ns>/lines`` and ``<ns>/labels`` under the topic, one shape per kind
  however many markers the namespace holds. Sphere, cube and cylinder lists, points and
  single spheres/cubes/cylinders are points (radius half the marker's scale.x); line
  lists are pairs of points, line strips one strip each (radius half the line width);
  view-facing texts are labels at their positions. The marker's pose (position and yaw)
  places its points. ``DELETE`` and ``DELETEALL`` clear the namespace / the topic.
- ``phd_swarm_msgs/DensityGrid`` and ``nav_msgs/OccupancyGrid``: a heat-map image placed on
  the map by its origin and resolution (:func:`grid_image`). Colour: the square root of the
  bin's value (a mass per bin for a PHD, a search value for a search map; occupancy in
  0..100 is read as 0..1), clipped to 0..1, on matplotlib's ``viridis``, opaque.
- ``phd_swarm_msgs/TeamState``: the robots' trails, the last :data:`TRAIL_STEPS` positions
  of each robot (:class:`Trails`).
- ``phd_swarm_msgs/TeamMetrics``: scalars against time (:func:`metric_scalars`).

Coordinates are the world frame's (x east, y north, metres); the viewer places them under
an entity that flips y so that north is up on the screen.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: Marker types (visualization_msgs/Marker constants) drawn as points.
_POINT_TYPES = {1: "cube", 2: "sphere", 3: "cylinder", 6: "cube_list", 7: "sphere_list",
                8: "points"}
_LINE_STRIP, _LINE_LIST, _TEXT, _ARROW = 4, 5, 9, 0
_DELETE, _DELETEALL = 2, 3

#: Steps of each robot's trail.
TRAIL_STEPS = 40

#: A trail's width, in robot diameters (the world's markers size the robots by the map).
TRAIL_WIDTH = 0.24

#: Fields of phd_swarm_msgs/TeamMetrics drawn, and their entity under ``metrics``.
METRIC_FIELDS = {
    "ospa": "ospa/total",
    "ospa_localisation": "ospa/localisation",
    "ospa_cardinality": "ospa/cardinality",
    "cardinality_true": "cardinality/true",
    "cardinality_estimated": "cardinality/estimated",
    "expected_cardinality": "cardinality/expected",
    "robots_alive": "robots/alive",
    "robots_reported": "robots/reporting",
}


@dataclass
class Shape:
    """One thing to draw at an entity path (relative to the topic's entity).

    ``kind`` is ``points`` (``positions`` (N, 2), ``radii`` (N,)), ``lines`` (``strips``:
    an (N, M, 2) array of equal-length strips or a list of (M_i, 2) arrays; ``radii`` one
    per strip), ``labels`` (``positions``,
    ``labels``), ``image`` (``rgba`` (H, W, 4) uint8, ``origin`` and ``resolution``: pixel
    (col, row) covers ``origin + resolution * [col, row]``, row 0 at the lowest y) or
    ``clear`` (remove what the path held). ``colours`` is (N, 4) uint8 or one RGBA.
    """

    path: str
    kind: str
    positions: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    strips: np.ndarray | list[np.ndarray] = field(default_factory=list)
    radii: np.ndarray = field(default_factory=lambda: np.empty(0))
    colours: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), np.uint8))
    labels: list[str] = field(default_factory=list)
    rgba: np.ndarray | None = None
    origin: tuple[float, float] = (0.0, 0.0)
    resolution: float = 1.0


def stamp_seconds(header: Mapping[str, Any]) -> float:
    """A std_msgs/Header's stamp in seconds (sim time for every phd_swarm message)."""
    stamp = header["stamp"]
    return stamp["sec"] + 1e-9 * stamp["nanosec"]


def _rgba8(colour: Mapping[str, float]) -> np.ndarray:
    values = np.array([colour["r"], colour["g"], colour["b"], colour["a"]], dtype=float)
    return np.clip(np.rint(255.0 * values), 0, 255).astype(np.uint8)


def _placed(marker: Mapping[str, Any], xy: np.ndarray) -> np.ndarray:
    """``xy`` (N, 2) in the marker's frame, moved by its pose (position and yaw)."""
    pose = marker["pose"]
    x, y, z, w = pose["orientation"]
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    return xy @ rot.T + pose["position"][:2]


def _colours(marker: Mapping[str, Any], n: int) -> np.ndarray:
    """(n, 4) uint8: the per-point colours if the marker has one per point, else its colour."""
    per_point = marker["colors"]
    if len(per_point) == n and n:
        values = np.array([[c["r"], c["g"], c["b"], c["a"]] for c in per_point], dtype=float)
        return np.clip(np.rint(255.0 * values), 0, 255).astype(np.uint8)
    return np.repeat(_rgba8(marker["color"])[None, :], n, axis=0)


def _finite_rows(xy: np.ndarray) -> np.ndarray:
    return np.isfinite(xy).all(axis=1)


class _Group:
    """The points, lines and labels of one marker namespace, gathered over its markers.

    Lines are kept as blocks of equal-length strips, (n, m, 2) each (a line list's pairs
    are one block), so that a namespace of equal-length strips goes to Rerun as one 3-D
    array: its fast path, ~40x faster than a list of strips (300 field-of-view edges:
    0.1 ms instead of 4 ms).
    """

    def __init__(self) -> None:
        self.points: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.strips: list[tuple[np.ndarray, float, np.ndarray]] = []
        self.labels: list[tuple[np.ndarray, str, np.ndarray]] = []

    def shapes(self, ns: str) -> list[Shape]:
        out = []
        if self.points:
            xy, r, c = (np.concatenate(parts) for parts in zip(*self.points, strict=True))
            out.append(Shape(f"{ns}/points", "points", positions=xy, radii=r, colours=c))
        if self.strips:
            blocks = [b for b, _, _ in self.strips]
            strips = np.concatenate(blocks) if len({b.shape[1] for b in blocks}) == 1 \
                else [s for b in blocks for s in b]
            out.append(Shape(f"{ns}/lines", "lines", strips=strips,
                             radii=np.concatenate([np.full(len(b), r)
                                                   for b, r, _ in self.strips]),
                             colours=np.concatenate([np.tile(c, (len(b), 1))
                                                     for b, _, c in self.strips])))
        if self.labels:
            out.append(Shape(f"{ns}/labels", "labels",
                             positions=np.stack([p for p, _, _ in self.labels]),
                             labels=[t for _, t, _ in self.labels],
                             colours=np.stack([c for _, _, c in self.labels])))
        return out


def _ns(marker: Mapping[str, Any]) -> str:
    return marker["ns"].strip("/") or "markers"


def marker_shapes(array: Mapping[str, Any]) -> list[Shape]:
    """The shapes of a decoded ``visualization_msgs/MarkerArray`` (see the module doc)."""
    groups: dict[str, _Group] = {}
    cleared: list[Shape] = []
    for m in array["markers"]:
        action = m["action"]
        if action == _DELETEALL:
            groups.clear()
            cleared = [Shape("", "clear")]
            continue
        ns = _ns(m)
        if action == _DELETE:
            cleared.append(Shape(ns, "clear"))
            continue
        group = groups.setdefault(ns, _Group())
        kind, scale = m["type"], m["scale"]
        if kind in _POINT_TYPES:
            local = np.asarray(m["points"], dtype=float)[:, :2] if kind >= 6 \
                else np.zeros((1, 2))
            xy = _placed(m, local)
            ok = _finite_rows(xy)
            colours = _colours(m, len(xy))[ok]
            group.points.append((xy[ok], np.full(int(ok.sum()), 0.5 * scale[0]), colours))
        elif kind in (_LINE_STRIP, _LINE_LIST):
            xy = _placed(m, np.asarray(m["points"], dtype=float)[:, :2])
            if kind == _LINE_STRIP:
                block = xy[_finite_rows(xy)][None]
            else:
                pairs = xy[: len(xy) // 2 * 2].reshape(-1, 2, 2)
                block = pairs[_finite_rows(pairs.reshape(-1, 4))]
            if block.shape[0] and block.shape[1] >= 2:
                group.strips.append((block, 0.5 * scale[0], _rgba8(m["color"])))
        elif kind == _TEXT:
            xy = _placed(m, np.zeros((1, 2)))[0]
            if np.isfinite(xy).all():
                group.labels.append((xy, m["text"], _rgba8(m["color"])))
        elif kind == _ARROW and len(m["points"]) >= 2:
            xy = _placed(m, np.asarray(m["points"], dtype=float)[:2, :2])
            if np.isfinite(xy).all():
                group.strips.append((xy[None], 0.5 * scale[0], _rgba8(m["color"])))
    return cleared + [s for ns, g in groups.items() for s in g.shapes(ns)]


@functools.cache
def _viridis() -> np.ndarray:
    """Matplotlib's viridis as a (256, 4) uint8 table (the table only; no figure)."""
    from matplotlib import colormaps

    lut = (255.0 * colormaps["viridis"](np.linspace(0.0, 1.0, 256))).astype(np.uint8)
    lut.flags.writeable = False
    return lut


def _heat_rgba(values: np.ndarray) -> np.ndarray:
    """(H, W) values -> (H, W, 4) uint8, opaque: viridis of sqrt(clip(v, 0, 1)).

    Opaque: Rerun's web viewer does not blend a translucent image over the view's
    background (its low-alpha pixels came out black), and viridis' dark end is the dark
    ground the markers' colours were chosen for (RViz2's).
    """
    lut = _viridis()
    v = np.sqrt(np.clip(np.nan_to_num(values, nan=0.0), 0.0, 1.0))
    rgba = lut[np.rint(255.0 * v).astype(np.intp)]
    rgba[..., 3] = 255
    return rgba


def density_values(grid: Mapping[str, Any]) -> tuple[np.ndarray, tuple[float, float], float]:
    """A decoded ``DensityGrid`` as (H, W) values, the window's lower-left corner, bin side.

    Raises
    ------
    ValueError
        If ``data`` does not hold width * height values.
    """
    w, h, res = int(grid["width"]), int(grid["height"]), float(grid["resolution"])
    data = np.asarray(grid["data"], dtype=float)
    if data.size != w * h:
        raise ValueError(f"DensityGrid of {w} x {h} bins holds {data.size} values")
    origin = (grid["x_min"] + grid["origin_col"] * res, grid["y_min"] + grid["origin_row"] * res)
    return data.reshape(h, w), origin, res


#: Largest heat map sent as it is [bins]; a larger grid (Chen's 0.1 m bins: 10^6 on the
#: 100 x 100 m map) is reduced by the bin-wise maximum over f x f blocks, f the smallest
#: integer that fits it, so its peaks stay visible and a step's image stays under 1 MB.
MAX_IMAGE_BINS = 250_000


def reduce_grid(values: np.ndarray, limit: int = MAX_IMAGE_BINS) -> tuple[np.ndarray, int]:
    """``values`` (H, W), block-reduced by its maximum to at most ``limit`` bins; and f."""
    f = max(1, int(np.ceil(np.sqrt(values.size / limit))))
    while -(-values.shape[0] // f) * -(-values.shape[1] // f) > limit:
        f += 1
    if f == 1:
        return values, 1
    h, w = -(-values.shape[0] // f) * f, -(-values.shape[1] // f) * f
    padded = np.zeros((h, w))
    padded[:values.shape[0], :values.shape[1]] = values
    return padded.reshape(h // f, f, w // f, f).max(axis=(1, 3)), f


def grid_image(values: np.ndarray, origin: tuple[float, float], resolution: float,
               path: str = "grid") -> Shape:
    """The heat-map image of (H, W) values; bin (row, col) covers origin + res * [col, row].

    Grids over :data:`MAX_IMAGE_BINS` are reduced first (:func:`reduce_grid`).
    """
    values, f = reduce_grid(np.asarray(values, dtype=float))
    return Shape(path, "image", rgba=_heat_rgba(values), origin=origin,
                 resolution=resolution * f)


def occupancy_image(grid: Mapping[str, Any], path: str = "grid") -> Shape:
    """A decoded ``nav_msgs/OccupancyGrid`` as a heat map (0..100 read as 0..1, -1 as 0)."""
    info = grid["info"]
    w, h = int(info["width"]), int(info["height"])
    data = np.asarray(grid["data"], dtype=np.int8)
    if data.size != w * h:
        raise ValueError(f"OccupancyGrid of {w} x {h} cells holds {data.size} values")
    values = np.where(data < 0, 0.0, data / 100.0).reshape(h, w)
    origin = info["origin"]["position"][:2]
    return grid_image(values, (float(origin[0]), float(origin[1])), float(info["resolution"]),
                      path)


def metric_scalars(msg: Mapping[str, Any]) -> dict[str, float]:
    """A decoded ``TeamMetrics`` as entity (under ``metrics``) -> value; NaN left out."""
    out = {}
    for name, entity in METRIC_FIELDS.items():
        value = float(msg[name])
        if np.isfinite(value):
            out[entity] = value
    return out


class Trails:
    """The last ``steps`` positions of each robot, from the world's team states.

    :meth:`add` takes one ``TeamState``'s ids and positions and returns the trails as line
    strips, one per robot with two or more finite positions. The history is one
    (steps, robots, 2) array, filled in one assignment per state; a robot that dies keeps
    its trail as it was.
    """

    def __init__(self, steps: int = TRAIL_STEPS) -> None:
        self.steps = steps
        #: Line radius [m]: TRAIL_WIDTH of the robots' spheres once their size is known.
        self.radius = 0.5 * TRAIL_WIDTH
        self._ids = np.empty(0, dtype=np.int64)
        self._history = np.full((steps, 0, 2), np.nan)
        self._count = 0

    def add(self, ids: np.ndarray, positions: np.ndarray) -> Shape:
        """Take one team state's ids and (N, 2) positions; return every trail."""
        ids = np.asarray(ids, dtype=np.int64)
        positions = np.asarray(positions, dtype=float).reshape(-1, 2)
        new = np.setdiff1d(ids, self._ids)
        if new.size:
            self._ids = np.concatenate([self._ids, new])
            self._history = np.concatenate(
                [self._history, np.full((self.steps, new.size, 2), np.nan)], axis=1)
        order = np.argsort(self._ids)
        column = order[np.searchsorted(self._ids[order], ids)]
        row = np.full((len(self._ids), 2), np.nan)
        row[column] = positions
        self._history = np.concatenate([self._history[1:], row[None]], axis=0)
        self._count += 1
        kept = np.isfinite(self._history).all(axis=2)            # (steps, robots)
        counts = kept.sum(axis=0)
        drawn = np.flatnonzero(counts >= 2)
        if drawn.size and (kept[:, drawn] == kept[:, drawn[:1]]).all():
            # The same steps for every trail (the usual case): one (robots, steps, 2) array.
            strips = np.swapaxes(self._history[kept[:, drawn[0]]][:, drawn], 0, 1)
        else:
            strips = [self._history[kept[:, j], j] for j in drawn]
        return Shape("", "lines", strips=strips, radii=np.full(len(strips), self.radius),
                     colours=np.tile(np.array([[31, 119, 180, 110]], np.uint8),
                                     (len(strips), 1)))

    @property
    def robots(self) -> int:
        """Robots seen so far."""
        return len(self._ids)
