"""One robot's view of a step as a ``visualization_msgs/MarkerArray``: Sung & Tokekar's layers.

A robot that runs Sung & Tokekar's system (one robot with a GM-PHD, a disk field of view,
a track layer and a planner, :mod:`phd_swarm.core.controllers.sung_planners`) shows once
per step, with :class:`RobotMarkers`, what it believes and where it goes: the components
of its GM-PHD (Layer 1, Sec. V, Fig. 3), its targets with their tracks (Layers 2 and 3,
Sec. V-E and V-F; a track is confirmed once its life l reaches l_Threshold, tentative
before), its disk field of view (Fig. 6), itself and its planned path
(:meth:`~phd_swarm.core.controllers.base.Controller.planned_path`, Sec. V-G and VI-A).

The conventions of :mod:`phd_swarm.nodes.markers` hold (fixed ids and action ADD, the
z = 0 plane of ``frame_id``, ``*_LIST`` markers, non-finite points left out, empty inputs
giving valid markers, colours by name), with one exception: the track ids are texts, one
marker each, so the ones no longer shown are sent with action DELETE (still no DELETEALL).
Every namespace lies under the robot's own prefix, ``robot_<id>/`` (the node namespace
``/robot_<id>`` without its slash, :func:`phd_swarm.nodes.topics.robot_namespace`), so
the markers of several robots do not replace each other and each can be toggled in the
viewer. Colours are :data:`phd_swarm.nodes.markers.COLOURS` where the thing is the same
(robot, field of view, text, the goal line as the path) and :data:`ROBOT_COLOURS` for the
rest.

At most :data:`MAX_COMPONENTS` components are drawn, the heaviest first (a mixture before
pruning may hold thousands; 200 ellipses are 9,600 points). Cost measured on the
development machine (2026-11-22, best of 300 calls): :meth:`RobotMarkers.build` for 100
components, 20 tracks (10 confirmed) and a 15-point path takes about 3 ms to build and
5 ms to serialise, nearly all of it the 4,800 ellipse points and their per-point colours
(the colours are half the serialising); :func:`~phd_swarm.nodes.markers.world_markers`
for 100 robots took 4 ms and 3.5 ms in the same session. A mixture of 1,000 components,
cut to the heaviest 200, took 14 ms to build (one call).

Reference: Y. Sung and P. Tokekar, "GM-PHD filter for searching and tracking an unknown
number of targets with a mobile sensor with limited FOV", IEEE T-ASE, 2022.
"""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from phd_swarm.nodes import topics
from phd_swarm.nodes.face import Face, Step
from phd_swarm.nodes.faces.gaussian_mixture import (
    MixtureArrays,
    TrackArrays,
    mixture_arrays,
    track_arrays,
)
from phd_swarm.nodes.markers import (
    COLOURS,
    FOV_LINE_WIDTH,
    FOV_SEGMENTS,
    GOAL_LINE_WIDTH,
    ROBOT_DIAMETER,
    _finite,
    _marker,
    _points,
    _segments,
    _xy,
    marker_size,
)

#: RGBA of the things :data:`~phd_swarm.nodes.markers.COLOURS` does not have (tab10 hues).
#: A component's alpha is this alpha times its weight clipped to
#: [:data:`MIN_ALPHA`, 1].
ROBOT_COLOURS: dict[str, tuple[float, float, float, float]] = {
    "component": (0.58, 0.40, 0.74, 1.0),         # purple
    "track_confirmed": (0.17, 0.63, 0.17, 1.0),   # green
    "track_tentative": (0.74, 0.74, 0.13, 0.7),   # translucent olive
    "reward": (0.09, 0.75, 0.81, 0.9),            # cyan: a reward set's targets
}

#: Most components drawn, the heaviest first.
MAX_COMPONENTS = 200
#: Edges of each ellipse polygon (vertices on the ellipse).
ELLIPSE_SEGMENTS = 24
#: Mahalanobis radius of the ellipses: the 2-sigma contour of each component's position.
ELLIPSE_SIGMA = 2.0
#: Lightest alpha factor of a component (its weight is clipped to [MIN_ALPHA, 1]).
MIN_ALPHA = 0.2

#: Sizes [m]: line widths, sphere diameters, text height.
ELLIPSE_LINE_WIDTH = 0.1
TRACK_DIAMETER = 1.2
TRACK_ID_HEIGHT = 1.2
TRACK_ID_OFFSET = 1.2        # labels sit this far along +y of their target
PATH_LINE_WIDTH = 2 * GOAL_LINE_WIDTH


def _colour(name: str, alpha: float = 1.0) -> ColorRGBA:
    """RGBA of ``name`` in ``ROBOT_COLOURS`` or ``COLOURS``, its alpha times ``alpha``."""
    r, g, b, a = ROBOT_COLOURS.get(name) or COLOURS[name]
    return ColorRGBA(r=r, g=g, b=b, a=a * alpha)


def ellipse_vertices(means: np.ndarray, covs: np.ndarray, sigma: float = ELLIPSE_SIGMA,
                     segments: int = ELLIPSE_SEGMENTS) -> np.ndarray:
    """Vertices of the ``sigma`` contours of 2D Gaussians, all components at once.

    With P = V diag(lambda) V^T (``numpy.linalg.eigh``) the contour is
    mu + sigma V diag(sqrt(lambda)) [cos t, sin t]^T, whose points lie at Mahalanobis
    distance ``sigma`` from mu for every t.

    Parameters
    ----------
    means : np.ndarray, shape (J, 2)
        Position means [m].
    covs : np.ndarray, shape (J, 2, 2)
        Symmetric positive semi-definite position covariances [m^2].
    sigma : float
        Mahalanobis radius.
    segments : int
        Vertices per ellipse, at t = 2 pi i / segments.

    Returns
    -------
    np.ndarray, shape (J, segments, 2)
        Vertices [m]; NaN for a covariance with a negative eigenvalue.
    """
    means = np.asarray(means, dtype=float).reshape(-1, 2)
    covs = np.asarray(covs, dtype=float).reshape(-1, 2, 2)
    if len(means) == 0:
        return np.empty((0, segments, 2))
    lam, vec = np.linalg.eigh(covs)                              # (J, 2), (J, 2, 2)
    with np.errstate(invalid="ignore"):
        axes = vec * (sigma * np.sqrt(lam))[:, None, :]          # columns: semi-axes
    t = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    unit = np.stack([np.cos(t), np.sin(t)])                      # (2, S)
    return means[:, None, :] + np.einsum("jab,bs->jsa", axes, unit)


class RobotMarkers:
    """Builds one robot's MarkerArray per step.

    It keeps the number of track-id texts it showed last, to DELETE the ones no longer
    shown.

    Namespaces and markers, each under the prefix ``robot_<id>/`` (ids fixed, so each
    :meth:`build` replaces the previous one):

    - ``robot``, id 0: SPHERE_LIST holding the robot (no sphere if its position is not
      finite), diameter :data:`~phd_swarm.nodes.markers.ROBOT_DIAMETER`, blue.
    - ``fov``, id 0: LINE_STRIP, the closed regular polygon of
      :data:`~phd_swarm.nodes.markers.FOV_SEGMENTS` edges inscribed in the sensing disk
      (:data:`~phd_swarm.nodes.markers.FOV_SEGMENTS` + 1 points, the first repeated),
      translucent blue.
    - ``components``, id 0: LINE_LIST of the 2-sigma ellipses of the position block of
      the heaviest :data:`MAX_COMPONENTS` components (:func:`ellipse_vertices`), each a
      closed polygon of :data:`ELLIPSE_SEGMENTS` edges (2 x 24 points), purple, per-point
      colours whose alpha scales with the component's weight clipped to
      [:data:`MIN_ALPHA`, 1]. Components with a non-finite weight, mean or covariance, or
      a covariance with a negative eigenvalue, are left out.
    - ``targets``, id 0: SPHERE_LIST of the targets, diameter :data:`TRACK_DIAMETER`,
      per-point colours green (confirmed track) or translucent olive (tentative track).
    - ``track_ids``, ids 0..n-1: TEXT_VIEW_FACING, the track id of each confirmed target
      with a finite position, in the order given, :data:`TRACK_ID_OFFSET` along +y, white;
      ids n..m-1, m the count shown by the previous call: action DELETE.
    - ``path``, id 0: LINE_STRIP from the robot through the planned waypoints, translucent
      orange; no points when fewer than two of them are finite.

    Parameters
    ----------
    robot_id : int
        The robot's id (the namespace prefix).
    frame_id : str
        Header frame of every marker (the world frame).
    fov_radius : float
        Sensing radius [m], finite and >= 0 (0 draws no field of view).
    size : float
        Multiplies every size, line width and label offset
        (:func:`~phd_swarm.nodes.markers.marker_size` of the map).

    Raises
    ------
    ValueError
        If ``fov_radius`` is negative or not finite.
    """

    def __init__(self, robot_id: int, frame_id: str, fov_radius: float,
                 size: float = 1.0) -> None:
        if not (math.isfinite(fov_radius) and fov_radius >= 0.0):
            raise ValueError(f"fov_radius must be a finite number >= 0, got {fov_radius!r}")
        self.robot_id = int(robot_id)
        self.frame_id = frame_id
        self.fov_radius = float(fov_radius)
        self.size = float(size)
        self.prefix = topics.robot_namespace(self.robot_id).lstrip("/") + "/"
        angle = np.linspace(0.0, 2.0 * np.pi, FOV_SEGMENTS + 1)
        angle[-1] = 0.0  # closes the strip on its first point exactly
        self._ring = self.fov_radius * np.stack([np.cos(angle), np.sin(angle)], axis=1)
        self._texts = 0

    def _new(self, stamp: Time, ns: str, marker_id: int, kind: int, scale: float,
             colour: str) -> Marker:
        """:func:`~phd_swarm.nodes.markers._marker` under the prefix, any named colour."""
        m = _marker(stamp, self.frame_id, self.prefix + ns, marker_id, kind,
                    self.size * scale, "robot_id")
        m.color = _colour(colour)
        return m

    def build(self, stamp: Time, position: np.ndarray, mixture: MixtureArrays | None,
              tracks: TrackArrays | None, path: np.ndarray,
              rewards: np.ndarray | None = None) -> MarkerArray:
        """The robot's markers for one step (see the class docstring).

        Parameters
        ----------
        stamp : builtin_interfaces.msg.Time
            Header stamp of every marker (sim time of the step).
        position : np.ndarray, shape (2,)
            The robot's position [m].
        mixture : MixtureArrays or None
            Its GM-PHD: weights (J,), means (J, d) and covariances (J, d, d), d >= 2, the
            first two coordinates the position [m]; None: no components.
        tracks : TrackArrays or None
            Its targets with their tracks (N of them); None: no targets.
        path : np.ndarray, shape (P, 2)
            The planned waypoints [m], in visiting order (P may be 0).
        rewards : np.ndarray, shape (K, 2), optional
            Its reward set (Shirsat & Berman's M_k) [m]; None: no ``rewards`` marker.

        Returns
        -------
        MarkerArray
            ``robot``, ``fov``, ``components``, ``targets``, ``track_ids`` (n ADD, then
            the DELETE ones), ``path``, in that order, then ``rewards`` if given.

        Raises
        ------
        ValueError
            If the mixture's or the tracks' arrays disagree in length or the mixture's
            dimension is below 2.
        """
        q = _xy(position)[:1]
        here = bool(len(q)) and bool(_finite(q)[0])
        q = q if here else np.empty((0, 2))

        robot = self._new(stamp, "robot", 0, Marker.SPHERE_LIST, ROBOT_DIAMETER,
                          "robot_alive")
        robot.points = _points(q)

        fov = self._new(stamp, "fov", 0, Marker.LINE_STRIP, FOV_LINE_WIDTH, "fov")
        if here and self.fov_radius > 0.0:
            fov.points = _points(q + self._ring)

        markers = [robot, fov, self._components(stamp, mixture), *self._tracks(stamp, tracks),
                   self._path(stamp, q, path)]
        if rewards is not None:
            reward = self._new(stamp, "rewards", 0, Marker.CUBE_LIST, TRACK_DIAMETER,
                               "reward")
            pts = _xy(rewards)
            reward.points = _points(pts[_finite(pts)])
            markers.append(reward)
        return MarkerArray(markers=markers)

    def _components(self, stamp: Time, mixture: MixtureArrays | None) -> Marker:
        marker = self._new(stamp, "components", 0, Marker.LINE_LIST, ELLIPSE_LINE_WIDTH,
                           "component")
        if mixture is None:
            return marker
        w = np.asarray(mixture.weights, dtype=float).reshape(-1)
        j = len(w)
        if j == 0:
            return marker
        means = np.asarray(mixture.means, dtype=float).reshape(j, -1)
        d = means.shape[1]
        if d < 2:
            raise ValueError(f"mixture: means of dimension {d}, need at least 2 (x, y)")
        covs = np.asarray(mixture.covs, dtype=float)
        if covs.size != j * d * d:
            raise ValueError(f"mixture: {covs.size} covariance values for {j} components "
                             f"of dimension {d}")
        means = means[:, :2]
        covs = covs.reshape(j, d, d)[:, :2, :2]
        ok = np.isfinite(w) & _finite(means) & np.isfinite(covs).all(axis=(1, 2))
        keep = np.flatnonzero(ok)
        keep = keep[np.argsort(-w[keep], kind="stable")[:MAX_COMPONENTS]]
        vertices = ellipse_vertices(means[keep], covs[keep])
        drawn = np.isfinite(vertices).all(axis=(1, 2))  # a negative eigenvalue gives NaN
        vertices, keep = vertices[drawn], keep[drawn]
        n = len(keep)
        if n == 0:
            return marker
        starts = np.arange(n) * ELLIPSE_SEGMENTS
        marker.points = _segments(vertices.reshape(-1, 2), starts, starts + ELLIPSE_SEGMENTS)
        alpha = np.clip(w[keep], MIN_ALPHA, 1.0)
        # One ColorRGBA per component, referenced by each of its 2S points.
        shades = [_colour("component", a) for a in alpha.tolist()]
        owner = np.repeat(np.arange(n), 2 * ELLIPSE_SEGMENTS).tolist()
        marker.colors = [shades[i] for i in owner]
        return marker

    def _tracks(self, stamp: Time, tracks: TrackArrays | None) -> list[Marker]:
        targets = self._new(stamp, "targets", 0, Marker.SPHERE_LIST, TRACK_DIAMETER,
                            "track_confirmed")
        if tracks is None:
            pos, confirmed, ids = np.empty((0, 2)), np.empty(0, bool), np.empty(0, int)
        else:
            pos = _xy(tracks.positions)
            confirmed = np.asarray(tracks.confirmed, dtype=bool).reshape(-1)
            ids = np.asarray(tracks.track_ids, dtype=np.int64).reshape(-1)
            if confirmed.shape != (len(pos),) or ids.shape != (len(pos),):
                raise ValueError(f"tracks: expected one track id and one confirmed flag "
                                 f"per target: {len(pos)} positions, {ids.size} ids, "
                                 f"{confirmed.size} flags")
        ok = _finite(pos)
        targets.points = _points(pos[ok])
        colour = (_colour("track_tentative"), _colour("track_confirmed"))
        targets.colors = [colour[c] for c in confirmed[ok].tolist()]

        shown = ok & confirmed
        texts = []
        for i, (tid, (x, y)) in enumerate(zip(ids[shown].tolist(), pos[shown].tolist(),
                                              strict=True)):
            text = self._new(stamp, "track_ids", i, Marker.TEXT_VIEW_FACING,
                             TRACK_ID_HEIGHT, "robot_id")
            text.pose.position = Point(x=x, y=y + self.size * TRACK_ID_OFFSET)
            text.text = str(tid)
            texts.append(text)
        n = len(texts)
        for i in range(n, self._texts):
            stale = self._new(stamp, "track_ids", i, Marker.TEXT_VIEW_FACING,
                              TRACK_ID_HEIGHT, "robot_id")
            stale.action = Marker.DELETE
            texts.append(stale)
        self._texts = n
        return [targets, *texts]

    def _path(self, stamp: Time, q: np.ndarray, path: np.ndarray) -> Marker:
        line = self._new(stamp, "path", 0, Marker.LINE_STRIP, PATH_LINE_WIDTH, "goal_line")
        way = _xy(path)
        pts = np.vstack([q, way[_finite(way)]])
        if len(pts) >= 2:
            line.points = _points(pts)
        return line


def _markers(step: Step, memo: dict) -> MarkerArray:
    if "markers" not in memo:
        scenario = step.agent.team.scenario
        memo["markers"] = RobotMarkers(step.robot_id, step.frame_id,
                                       float(scenario.models.detection.radius),
                                       marker_size(scenario.env))
    return memo["markers"].build(
        step.stamp(), step.agent.position, mixture_arrays(step),
        track_arrays(step) if step.provides("estimator", "tracks") else None,
        step.agent.controller.planned_path(),
        step.agent.estimator.reward_set() if step.provides("estimator", "reward_set")
        else None)


#: Output ``markers`` of a Gaussian-mixture estimator: its components, tracks, field of
#: view and planned path (and its reward set, if it keeps one).
MARKERS = Face(MarkerArray, _markers)
