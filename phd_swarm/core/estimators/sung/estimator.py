"""Sung & Tokekar's search-and-track estimator: GM-PHD with a limited FoV, targets, tracks.

Registered as the ``sung_gmphd`` estimator (:mod:`phd_swarm.core.registry`). One step, in
the order of the paper's flowchart (Fig. 4; section numbers are the paper's):

1. prediction (Alg. 1 steps 1-2): F = I, Q = ``process_noise_sd``^2 I, p_S = 1; with
   ``gp_prediction`` the mean of every component that carried a confirmed track at the last
   step is replaced by the GP prediction of eq. 8 from the track's recent history
   (:mod:`.gp_motion`, Sec. V-B): its extracted targets (``gp_input = estimates``) or only
   its detections (``detections``, :mod:`.gp_detections`); the others keep the linear
   model;
2. update (Alg. 1 step 4): p_D = p(D|F) p(F) (eq. 9) with p(F) the component's Gaussian
   mass in the FoV disk (eq. 10, :class:`.fov_detection.DiskFov`), the missed-detection terms
   between the p_D thresholds pushed away from the robot (eq. 11, ``fov_rule``), the
   detection terms of Vo & Ma Table I; clutter kappa = the sensor's false-positive rate
   over the disk area;
3. pruning and merging (Sec. V-C, Vo & Ma Table II; ``merge_metric``: the merge distance in
   the heaviest component's metric by default, :mod:`.gm_phd.reduce`);
4. new components (Sec. V-D): one per measurement, weight 1, covariance R, pruned and
   merged with the mixture at once (``newborn_merge = same_step``; the paper: a newborn
   of a known target "will merge to the corresponding existing component") or only at
   the next step's reduction (``next_step``: until then every detected target is two
   components, two targets and two tracks);
5. targets (Layer 2, Sec. V-E): one per component above the extraction threshold
   (``extraction = per_component``, the paper's "turns some components into targets"),
   or round(w) copies of its mean (``rounded``, Vo & Ma Table III);
6. tracks (Layer 3, Sec. V-F): :class:`.tracks.TrackLayer` with the merging threshold as
   gate and l_threshold = ``confirm_after``; with ``gp_input = detections`` each track's
   detection of the step, the measurement its target's component is mostly made of
   (:func:`.gp_detections.majority_measurement`), is added to its detection history.

The initial belief (Sec. V-A, VI-A) comes from an "external source": with
``initial_belief`` = ``exact`` one component per true target (``scenario.initial_truth``),
``under`` for half of them, ``over`` for all plus half as many more at uniform positions
in the map; each mean is ``initial_offset`` metres off the true position in a uniform
direction (or, with ``initial_offset_draw = rayleigh``, a Gaussian offset whose mean length
is ``initial_offset``), covariance ``initial_variance`` I, weight 1. The draws come from the
prior stream of the scenario seed (:data:`PRIOR_STREAM`), never from the robot's.
docs/decisions.md records each reading.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import registry
from ...params import ParamSpec
from ...scan import Scan
from ...sensors.fov_detection import DiskFov
from ..base import Estimator
from ..gm_phd.births import PerMeasurementBirth
from ..gm_phd.estimator import GmPhdEstimator
from ..gm_phd.filter import GaussianMixture, GmPhdModel, prune_and_merge, prune_and_merge_carrying
from ..gm_phd.outputs import COMPONENTS, MARKERS, TRACKS, observation
from ..gm_phd.reduce import MERGE_METRIC_OPTION
from ..tracks import TrackLayer
from .figures import step_figures
from .gp_detections import GP_INPUT_OPTION, DetectionHistories, majority_measurement
from .gp_motion import GpHyperparameters, predict_tracks

#: Child of the scenario seed's SeedSequence that draws the initial belief (the world uses
#: children 0-2, the robots 3).
PRIOR_STREAM = 4

#: Initial beliefs (Sec. VI-A.2): components per true target.
BELIEFS = ("exact", "under", "over", "none")

OPTIONS = (
    ParamSpec("fov_rule", True, "sung_gmphd: the limited-FoV update rule (Alg. 1 lines 5-7, "
              "eq. 11) on a no-detection event"),
    ParamSpec("p_d_lower", 0.4, "sung_gmphd: lower p_D threshold of the limited-FoV rule",
              low=0.0, high=1.0),
    ParamSpec("p_d_upper", 0.6, "sung_gmphd: upper p_D threshold of the limited-FoV rule",
              low=0.0, high=1.0),
    ParamSpec("fov_push_to", "paper", "sung_gmphd: how far eq. 11 pushes a component: as "
              "printed, by p_D times its distance to the robot (paper), or just until its "
              "p_D is p_d_lower (threshold)", choices=("paper", "threshold")),
    ParamSpec("p_d_model", "integrated", "sung_gmphd: p(F) integrated over the component "
              "(eq. 10) or taken at its mean", choices=("integrated", "mean")),
    ParamSpec("process_noise_sd", 0.1, "sung_gmphd: sd of the linear model's random step "
              "per step and axis [m] (Q = sd^2 I; not stated in the paper)", low=0.0),
    ParamSpec("prune_threshold", 0.001, "sung_gmphd: pruning weight threshold T (Fig. 6)",
              low=0.0),
    ParamSpec("merge_threshold", 10.0, "sung_gmphd: merging threshold U, also the track "
              "gate (Fig. 6: 10)", low=0.0, high=1e6),
    ParamSpec("merge_distance", "squared", "sung_gmphd: U bounds the squared Mahalanobis "
              "distance (Vo & Ma) or the distance itself (then U^2 is used)",
              choices=("squared", "distance")),
    MERGE_METRIC_OPTION,
    ParamSpec("max_components", 100, "sung_gmphd: cap J_max on the components after "
              "merging (not stated in the paper)", low=1),
    ParamSpec("extraction_threshold", 0.5, "sung_gmphd: weight above which a component is "
              "a target (Sec. V-E, Fig. 6)", low=0.0),
    ParamSpec("extraction", "per_component", "sung_gmphd: one target per component above "
              "the threshold (Sec. V-E, per_component) or round(w) copies of its mean (Vo & "
              "Ma Table III, rounded)", choices=("per_component", "rounded")),
    ParamSpec("newborn_merge", "same_step", "sung_gmphd: the new components of Sec. V-D are "
              "pruned and merged with the mixture before the targets are extracted "
              "(same_step) or only at the next step's reduction (next_step)",
              choices=("same_step", "next_step")),
    ParamSpec("confirm_after", 3, "sung_gmphd: l_threshold, the life length from which a "
              "track is confirmed (Fig. 6)", low=1),
    ParamSpec("initial_belief", "exact", "sung_gmphd: initial components per true target "
              "(Sec. VI-A.2): exact (10), under (5), over (15) or none", choices=BELIEFS),
    ParamSpec("initial_offset", 15.0, "sung_gmphd: offset of each initial mean from its "
              "true target [m] (Sec. VI-A.1: 'average mean offset of 15')", low=0.0),
    ParamSpec("initial_offset_draw", "fixed", "sung_gmphd: the offset's length is exactly "
              "initial_offset (fixed) or Rayleigh with that mean (rayleigh)",
              choices=("fixed", "rayleigh")),
    ParamSpec("initial_variance", 50.0, "sung_gmphd: diagonal of the initial covariances "
              "[m^2] (Sec. VI-A.1)", low=0.0),
    ParamSpec("gp_prediction", False, "sung_gmphd: predict the components of confirmed "
              "tracks by GP regression (Sec. V-B, eq. 7-8)"),
    GP_INPUT_OPTION,
    ParamSpec("gp_signal_sd", 16.67, "sung_gmphd: GP signal sd sigma_f [m] (eq. 7; default "
              "fitted by tools/fit_gp.py on the turning walk)", low=0.0),
    ParamSpec("gp_length_scale", 472.0, "sung_gmphd: GP length-scale lambda [steps] (eq. 7)",
              low=0.0),
    ParamSpec("gp_noise_sd", 1.0, "sung_gmphd: GP noise sd sigma_n [m] (eq. 8)", low=0.0),
    ParamSpec("gp_window", 100, "sung_gmphd: points of a track's history the GP regresses on",
              low=2),
)


@dataclass(frozen=True)
class SungSetup:
    """What every robot's estimator shares: the model, the detection and the prior."""

    model: GmPhdModel
    fov: DiskFov
    fov_push: tuple[float, float] | None
    fov_push_to: str
    confirm_after: int
    rounded_extraction: bool
    merge_newborns: bool
    gp: GpHyperparameters | None
    initial: GaussianMixture
    gp_input: str = "estimates"


class SungEstimator(Estimator):
    """One robot's GM-PHD, targets and tracks (see the module docstring).

    Attributes
    ----------
    gmphd : GmPhdEstimator
        Layer 1, the components (``gmphd.mixture``).
    tracks : TrackLayer
        Layer 3.
    detections : DetectionHistories or None
        Each track's detections (``gp_prediction`` with ``gp_input = detections`` only).
    step : int
        The step of the last update (-1 before the first).
    """

    def __init__(self, setup: SungSetup) -> None:
        self.setup = setup
        on_detections = setup.gp is not None and setup.gp_input == "detections"
        self.gmphd = GmPhdEstimator(setup.model, setup.initial, p_d=setup.fov,
                                    birth=PerMeasurementBirth(1.0), fov_push=setup.fov_push,
                                    fov_push_to=setup.fov_push_to,
                                    record_shares=on_detections)
        self.detections = DetectionHistories() if on_detections else None
        self.tracks = TrackLayer(setup.model.merge_threshold, setup.confirm_after)
        self.step = -1
        self._component_track = np.full(len(setup.initial), -1)
        self._targets = np.empty((0, 2))
        self._target_covs = np.empty((0, 2, 2))
        self._target_weights = np.empty(0)
        self._target_tracks = np.empty(0, dtype=int)

    # ------------------------------------------------------------------ layer 1
    @property
    def mixture(self) -> GaussianMixture:
        """The components (Layer 1); what the Gaussian planners read."""
        return self.gmphd.mixture

    def predict(self) -> None:
        """Alg. 1 steps 1-2: the linear model, and GP for components on confirmed tracks."""
        carried = self._component_track
        self.gmphd.predict()
        if self.setup.gp is None or not carried.size:
            return
        # Track ids are 0, 1, 2... in creation order: the rows of ``tracks.tracks``.
        tracks, need = self.tracks.tracks, self.tracks.confirm_after
        rows = [i for i, tid in enumerate(carried.tolist())
                if tid >= 0 and tracks[tid].life >= need]
        w = self.setup.gp.window
        if self.detections is None:
            histories = [tracks[carried[i]].window(w) for i in rows]
        else:
            # A confirmed track never detected has nothing to regress on: F = I.
            rows = [i for i in rows if self.detections.count(carried[i])]
            histories = [self.detections.window(carried[i], w) for i in rows]
        if not rows:
            return
        # A detection history stops growing out of view: cache its factor, not its weights.
        predicted = predict_tracks(histories, np.full(len(rows), self.step + 1.0),
                                   self.setup.gp,
                                   "offsets" if self.detections is None else "gaps")
        mix = self.gmphd.mixture
        means = mix.means.copy()
        means[rows, :2] = predicted
        self.gmphd.mixture = GaussianMixture(mix.weights, means, mix.covs)

    def update(self, scan: Scan) -> None:
        """Alg. 1 step 4, pruning and merging, new components, targets and tracks."""
        self.gmphd.update(scan)
        self.step = int(scan.step)
        shares = self.gmphd.shares
        if self.setup.merge_newborns and len(scan.z):
            if self.detections is None:
                self.gmphd.mixture = prune_and_merge(self.gmphd.mixture, self.setup.model)
            else:
                self.gmphd.mixture, shares = prune_and_merge_carrying(
                    self.gmphd.mixture, self.setup.model, shares)
        mix = self.gmphd.mixture
        sel = np.flatnonzero(mix.weights > self.setup.model.extraction_threshold)
        if self.setup.rounded_extraction:
            sel = np.repeat(sel, np.floor(mix.weights[sel] + 0.5).astype(int))
        component = sel
        ids = self.tracks.update(self.step, mix.means[component, :2],
                                 mix.covs[component][:, :2, :2])
        track_of = np.full(len(mix), -1)
        # The first copy of a component names its track (assigned last, so it wins).
        track_of[component[::-1]] = ids[::-1]
        self._component_track = track_of
        self._targets = mix.means[component, :2]
        self._target_covs = mix.covs[component][:, :2, :2]
        self._target_weights = mix.weights[component]
        self._target_tracks = ids
        if self.detections is not None and len(scan.z):
            self._record_detections(scan, shares, component, ids)

    def _record_detections(self, scan: Scan, shares: np.ndarray, component: np.ndarray,
                           ids: np.ndarray) -> None:
        """Each target's track gets the measurement its component is mostly made of."""
        mix = self.gmphd.mixture
        z_of = majority_measurement(shares, mix.weights)[component]
        hit = z_of >= 0
        if not hit.any():
            return
        # A component repeated by rounded extraction is on as many tracks: one z each.
        positions, _ = self.gmphd.measurement.positions(scan.z, scan.sensor)
        self.detections.record(self.step, ids[hit], positions[z_of[hit]])

    # ------------------------------------------------------------ layers 2 and 3
    def estimates(self) -> np.ndarray:
        """The targets of the last update (Layer 2), shape (N, 2) [m]."""
        return self._targets.copy()

    def expected_count(self) -> float:
        """The sum of the components' weights."""
        return self.gmphd.expected_count()

    def targets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Layer 2 with its tracks.

        Positions (N, 2) [m], covariances (N, 2, 2), the weights of their components (N,)
        and their track ids (N,).
        """
        return (self._targets.copy(), self._target_covs.copy(), self._target_weights.copy(),
                self._target_tracks.copy())

    def confirmed_mask(self) -> np.ndarray:
        """Which targets of the last update are on a confirmed track, shape (N,) bool."""
        # Track ids are 0, 1, 2... in creation order: the rows of ``tracks.tracks``.
        life = np.array([self.tracks.tracks[i].life for i in self._target_tracks.tolist()],
                        dtype=int)
        return life >= self.tracks.confirm_after

    def export_state(self) -> dict[str, np.ndarray]:
        """The components as plain arrays (what would travel between robots)."""
        return self.gmphd.export_state()

    def import_state(self, arrays: dict[str, np.ndarray], where: str = "mixture") -> None:
        """Replace the components with checked arrays; targets follow at the next update."""
        self.gmphd.import_state(arrays, where)
        self._component_track = np.full(len(self.gmphd.mixture), -1)


# --------------------------------------------------------------------------- set-up
def initial_belief(kind: str, truth: np.ndarray, offset: float, draw: str, variance: float,
                   env: Any, rng: np.random.Generator) -> GaussianMixture:
    """The initial components of Sec. VI-A (see the module docstring).

    Parameters
    ----------
    kind : {"exact", "under", "over", "none"}
    truth : np.ndarray, shape (N, 2)
        True target positions at step 0 [m].
    offset : float
        Mean offset length [m].
    draw : {"fixed", "rayleigh"}
        Offset length exactly ``offset``, or Rayleigh-distributed with mean ``offset``.
    variance : float
        Diagonal of each covariance [m^2].
    env : Environment
        The map (``over``: where the extra components are drawn).
    rng : np.random.Generator
        Consumed in this order: one ``permutation(N)`` (``under``: which targets),
        one ``random(K)`` (directions), one ``random(K)`` (Rayleigh lengths, ``rayleigh``
        only), one ``random((N // 2, 2))`` (``over``: the extra means).
    """
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    n = len(truth)
    if kind == "none" or n == 0:
        return GaussianMixture.empty(2)
    centres = truth[np.sort(rng.permutation(n)[:n // 2])] if kind == "under" else truth
    k = len(centres)
    angle = 2.0 * np.pi * rng.random(k)
    length = np.full(k, float(offset))
    if draw == "rayleigh":
        # Rayleigh(sigma) has mean sigma sqrt(pi / 2); inverse-CDF sampling.
        sigma = offset / np.sqrt(np.pi / 2.0)
        length = sigma * np.sqrt(-2.0 * np.log1p(-rng.random(k)))
    means = centres + length[:, None] * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    if kind == "over":
        lo = np.array([env.xmin, env.ymin])
        hi = np.array([env.xmax, env.ymax])
        means = np.concatenate([means, lo + rng.random((n // 2, 2)) * (hi - lo)])
    j = len(means)
    return GaussianMixture(np.ones(j), means, np.broadcast_to(variance * np.eye(2),
                                                              (j, 2, 2)).copy())


def _setup(scenario: Any, system: Any, **runtime: Any) -> SungSetup:
    opt = system.option
    radius = float(scenario.models.detection.radius)
    variance = float(scenario.models.measurement.variance)
    # The sensor's own clutter model if it has one (disk_false_positive), else the
    # scenario's uniform clutter density.
    sensor_model = system.parts()["sensor"].setup(scenario, system)
    kappa = (sensor_model.clutter_intensity() if hasattr(sensor_model, "clutter_intensity")
             else float(scenario.models.clutter.density))
    u = float(opt("merge_threshold"))
    if opt("merge_distance") == "distance":
        u = u * u
    lower, upper = float(opt("p_d_lower")), float(opt("p_d_upper"))
    if lower > upper:
        raise ValueError(f"system.options: p_d_lower ({lower}) must not exceed p_d_upper "
                         f"({upper})")
    q = float(opt("process_noise_sd")) ** 2
    model = GmPhdModel(
        F=np.eye(2), Q=max(q, 1e-12) * np.eye(2), H=np.eye(2), R=variance * np.eye(2),
        p_s=1.0, birth_weights=np.empty(0), birth_means=np.empty((0, 2)),
        birth_covs=np.empty((0, 2, 2)),
        clutter_intensity=kappa,
        prune_threshold=float(opt("prune_threshold")), merge_threshold=u,
        merge_metric=str(opt("merge_metric")),
        max_components=int(opt("max_components")),
        extraction_threshold=float(opt("extraction_threshold")))
    fov = DiskFov(radius, float(scenario.models.detection.p_d),
                  integrate=opt("p_d_model") == "integrated")
    gp = GpHyperparameters(float(opt("gp_signal_sd")), float(opt("gp_length_scale")),
                           float(opt("gp_noise_sd")), int(opt("gp_window"))) \
        if opt("gp_prediction") else None
    _, truth = scenario.initial_truth()
    rng = np.random.default_rng(np.random.SeedSequence(scenario.seed,
                                                       spawn_key=(PRIOR_STREAM,)))
    initial = initial_belief(opt("initial_belief"), truth, float(opt("initial_offset")),
                             opt("initial_offset_draw"), float(opt("initial_variance")),
                             scenario.env, rng)
    return SungSetup(model, fov, (lower, upper) if opt("fov_rule") else None,
                     opt("fov_push_to"), int(opt("confirm_after")), opt("extraction") == "rounded",
                     opt("newborn_merge") == "same_step", gp, initial, str(opt("gp_input")))


registry.register(
    "estimator", "sung_gmphd", lambda setup, rid: SungEstimator(setup), setup=_setup,
    description="GM-PHD with a limited-FoV detection model and update rule, a track layer "
                "and GP motion prediction (Sung & Tokekar 2022 Sec. V).",
    options=OPTIONS, provides=("gaussian_mixture", "tracks"), requires=("disk_fov",),
    outputs=(COMPONENTS, TRACKS, MARKERS), observation=observation("tracks"),
    figures=step_figures)
