"""What a robot with a Gaussian-mixture estimator publishes (:mod:`phd_swarm.core.outputs`).

Shared by the GM-PHD estimators (Sung & Tokekar's, Shirsat & Berman's): the components of
the mixture (Vo & Ma; Sung & Tokekar Layer 1), the targets with their tracks (Layers 2-3,
for an estimator that keeps tracks) and the markers a viewer draws. Their faces are in
:mod:`phd_swarm.nodes.faces.gaussian_mixture` and
:mod:`phd_swarm.nodes.faces.mixture_markers`.
"""

from __future__ import annotations

from ...outputs import Observation, Output

_FACES = "phd_swarm.nodes.faces"

#: The robot's GM-PHD components of the step.
COMPONENTS = Output(
    "components", "phd_swarm_msgs/msg/GaussianMixture", f"{_FACES}.gaussian_mixture:COMPONENTS",
    "The robot's GM-PHD components: weights, means, covariances (float64, exact); the "
    "monitor and evaluate.sh compute the estimator's figures from them.")

#: The robot's targets with their tracks.
TRACKS = Output(
    "tracks", "phd_swarm_msgs/msg/TrackSet", f"{_FACES}.gaussian_mixture:TRACKS",
    "The robot's targets with their track ids, life lengths, confirmed flags, weights and "
    "covariances (Sung & Tokekar Sec. V-E, V-F).")

#: What a viewer draws of the robot's mixture.
MARKERS = Output(
    "markers", "visualization_msgs/msg/MarkerArray", f"{_FACES}.mixture_markers:MARKERS",
    "Covariance ellipses, targets and confirmed track ids, field of view and planned path "
    "(and the reward set, where the estimator keeps one), for RViz2 / Foxglove.",
    qos="OBSERVATION")

#: Builds what a Gaussian-mixture estimator's ``figures`` hook reads from its robot's outputs.
VIEW = f"{_FACES}.gaussian_mixture:estimator_view"


def observation(*inputs: str, meetings: str = "") -> Observation:
    """How the observers read a Gaussian-mixture estimator.

    Per robot ``components`` and ``inputs``; the union of the robots' estimates scored; the
    figures from :data:`VIEW`.
    """
    return Observation(inputs=("components", *inputs), view=VIEW, meetings=meetings)
