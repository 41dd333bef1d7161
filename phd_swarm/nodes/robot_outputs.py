"""What a robot node publishes when it finishes a step, by what its system's parts provide.

Every robot writes ``goal`` and ``estimates`` (and the node its ``status``, last); the
other outputs come with capabilities (:func:`phd_swarm.nodes.completeness.robot_outputs`):

===============  ==========================  ============================================
topic            type                        when the system's ...
===============  ==========================  ============================================
``density``      ``DensityGrid``             estimator provides ``grid_density`` (its
                                             owned bins, Dames eq. 2; ``publish_density``)
``cell``         ``CellPolygon``             exchange provides ``cell`` (Dames Alg. 1)
``components``   ``GaussianMixture``         estimator provides ``gaussian_mixture``
                                             (Vo & Ma; Sung & Tokekar Layer 1)
``tracks``       ``TrackSet``                estimator provides ``tracks`` (Sung & Tokekar
                                             Layers 2-3)
``markers``      ``MarkerArray``             estimator provides ``gaussian_mixture``
                                             (ellipses, tracks, FoV, path; not a step topic),
                                             or the controller ``sat_modes`` (the sensing
                                             square by mode, the plan, the estimates)
``reward_set``   ``RewardSet``               estimator provides ``reward_set`` (Shirsat &
                                             Berman M_k, with the robots met at the step)
``search_map``   ``DensityGrid``             estimator provides ``search_map`` (Papaioannou
                                             et al.'s search values p_v, one per node)
``sat_state``    ``SatState``                controller provides ``sat_modes``: tracking
                                             or searching next, the predicted targets, the
                                             joint plan's agents (no map: ``search_map``)
``plan``         ``nav_msgs/Path``           controller provides ``sat_modes``: the next
                                             goal, then the search plan's nodes
===============  ==========================  ============================================

The estimates are the estimator's own (``estimates()``), or for a grid PHD that the exchange
runs, those of the robot's owned bins. :meth:`RobotOutputs.status_fields` gives what the
status reports of the step (bins owned, PHD mass, dead peers).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from geometry_msgs.msg import Point
from nav_msgs.msg import Path
from visualization_msgs.msg import MarkerArray

from phd_swarm.core.agent import Agent
from phd_swarm.core.controllers.base import Decision
from phd_swarm.core.exchange.sat_share import SatMsg
from phd_swarm.nodes import convert, gm_convert
from phd_swarm.nodes.completeness import robot_outputs
from phd_swarm.nodes.meet_merge_wire import reward_set
from phd_swarm.nodes.qos import publisher_qos
from phd_swarm.nodes.sat_markers import sat_markers
from phd_swarm.nodes.sat_share_wire import sat_state
from phd_swarm_msgs.msg import (
    CellPolygon,
    DensityGrid,
    GaussianMixture,
    RewardSet,
    SatState,
    TargetSet,
    TrackSet,
)

#: ROS type of each step output a capability brings (goal and status are the node's).
TYPES = {"density": DensityGrid, "cell": CellPolygon, "estimates": TargetSet,
         "components": GaussianMixture, "tracks": TrackSet, "reward_set": RewardSet,
         "search_map": DensityGrid, "sat_state": SatState, "plan": Path}


class RobotOutputs:
    """The step outputs of one robot node (see the module docstring).

    Parameters
    ----------
    node : rclpy.node.Node
        The robot node (publishers are made on it, relative to its namespace).
    agent : Agent
        The robot's agent.
    publish_density : bool
        Publish the grid PHD window (``density``) when the estimator has one.
    publish_markers : bool
        Publish ``markers`` when the estimator is a Gaussian mixture.
    """

    def __init__(self, node: Any, agent: Agent, publish_density: bool,
                 publish_markers: bool = True) -> None:
        self.agent = agent
        self.robot_id = agent.robot_id
        scenario = agent.team.scenario
        self.dt = scenario.dt
        self.grid = scenario.grid
        self.frame_id = node.params["world_frame_id"]
        parts = agent.team.parts
        self.kinds = robot_outputs(scenario.system, publish_density)
        self.grid_estimator = "grid_density" in parts["estimator"].provides
        self.pubs = {k: node.create_publisher(TYPES[k], k, publisher_qos("STEP"))
                     for k in self.kinds if k in TYPES}
        self.markers = None
        self.sat_markers = publish_markers and "sat_state" in self.kinds
        if self.sat_markers:
            self.markers_pub = node.create_publisher(MarkerArray, "markers",
                                                     publisher_qos("OBSERVATION"))
        if publish_markers and "components" in self.kinds:
            from phd_swarm.nodes.robot_markers import RobotMarkers

            self.markers = RobotMarkers(self.robot_id, self.frame_id,
                                        float(scenario.models.detection.radius))
            self.markers_pub = node.create_publisher(MarkerArray, "markers",
                                                     publisher_qos("OBSERVATION"))

    def matched(self, observers: int) -> bool:
        """Whether ``observers`` subscribers matched the density window (if published)."""
        pub = self.pubs.get("density")
        return pub is None or pub.get_subscription_count() >= observers

    def publish(self, k: int, decision: Decision) -> None:
        """Publish step ``k``'s outputs (all but the goal and the status)."""
        ex, est = self.agent.exchange, self.agent.estimator
        h = convert.header(k, self.dt, self.frame_id)
        if "density" in self.pubs:
            self.pubs["density"].publish(convert.density_grid(
                self.robot_id, k, self.grid, ex.bins, ex.weights, self.dt, self.frame_id))
        if "cell" in self.pubs:
            position = self.agent.position
            self.pubs["cell"].publish(CellPolygon(
                header=h, robot_id=self.robot_id, step=k,
                generator=Point(x=float(position[0]), y=float(position[1])),
                power_weight=float(decision.power_weight), vertices=convert.points(ex.cell),
                neighbour_ids=convert.u32(ex.neighbours)))
        if self.grid_estimator:
            points, expected = est.estimates(ex.bins, ex.weights), est.expected_count(ex.weights)
        else:
            points, expected = est.estimates(), est.expected_count()
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        self.pubs["estimates"].publish(convert.target_set(
            self.robot_id, k, np.arange(len(points)), points, expected, self.dt,
            self.frame_id))
        mixture = tracks = None
        if "components" in self.pubs:
            mix = est.mixture
            mixture = gm_convert.MixtureArrays(mix.weights, mix.means, mix.covs)
            self.pubs["components"].publish(gm_convert.gaussian_mixture(
                self.robot_id, k, mix.weights, mix.means, mix.covs, self.dt, self.frame_id))
        if "tracks" in self.pubs:
            tracks = track_arrays(est)
            self.pubs["tracks"].publish(gm_convert.track_set(self.robot_id, k, tracks,
                                                             self.dt, self.frame_id))
        if "reward_set" in self.pubs:
            self.pubs["reward_set"].publish(reward_set(
                self.robot_id, k, est.reward_set(), self.dt, self.frame_id,
                getattr(ex, "met", ())))
        if "search_map" in self.pubs:
            grid = est.setup.grid.grid
            self.pubs["search_map"].publish(convert.density_grid(
                self.robot_id, k, grid, np.arange(grid.size), est.search, self.dt,
                self.frame_id))
        if "sat_state" in self.pubs:
            ctl = self.agent.controller
            self.pubs["sat_state"].publish(sat_state(SatMsg(
                self.robot_id, k, np.asarray(self.agent.position, dtype=float),
                bool(ctl.tracking), est.predicted_states()[:, :2], np.empty(0),
                tuple(ctl.plan_members)), self.dt, self.frame_id))
        if "plan" in self.pubs:
            self.pubs["plan"].publish(Path(header=h, poses=[
                convert.pose_stamped(q, k, self.dt, self.frame_id)
                for q in self.agent.controller.planned_path()]))
        if self.sat_markers:
            ctl = self.agent.controller
            mode = ("yield" if ctl.yielding else "track") if ctl.tracking or ctl.yielding \
                else "search"
            self.markers_pub.publish(sat_markers(
                convert.stamp(k, self.dt), self.frame_id, self.robot_id, self.agent.position,
                float(est.setup.sensor.side), mode, ctl.planned_path(), points))
        if self.markers is not None:
            self.markers_pub.publish(self.markers.build(
                convert.stamp(k, self.dt), self.agent.position, mixture, tracks,
                self.agent.controller.planned_path(),
                est.reward_set() if "reward_set" in self.pubs else None))

    def status_fields(self) -> dict[str, Any]:
        """What the status of the step reports of the estimate: bins, mass, dead peers."""
        ex, est = self.agent.exchange, self.agent.estimator
        if self.grid_estimator:
            return {"owned_bins": int(ex.bins.size), "mass": float(np.sum(ex.weights)),
                    "dead_ids": convert.u32(sorted(ex.dead))}
        return {"owned_bins": 0, "mass": float(est.expected_count()),
                "dead_ids": convert.u32(sorted(getattr(ex, "dead", ())))}


def track_arrays(estimator: Any) -> gm_convert.TrackArrays:
    """An estimator's targets with their tracks (``targets()``, ``confirmed_mask()``)."""
    positions, covs, weights, ids = estimator.targets()
    life = np.array([estimator.tracks.tracks[i].life for i in ids.tolist()], dtype=np.int64)
    return gm_convert.TrackArrays(ids, life, estimator.confirmed_mask(), weights, positions,
                                  covs)
