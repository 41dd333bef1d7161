"""Shirsat & Berman's estimator: a GM-PHD per robot and the reward set it accumulates.

Registered as the ``shirsat_gmphd`` estimator (:mod:`phd_swarm.core.registry`). Each robot
runs Vo & Ma's GM-PHD filter (Sec. V-A, Alg. 1 step 2) with the settings of Sec. VI, and
keeps its reward M_k, the set of targets it has extracted so far (Alg. 1 line d), which
robots that meet merge (eq. 6, Alg. 2-3; the ``meet_merge`` exchange calls
:meth:`ShirsatEstimator.merge_rewards`). One step k of robot a_i at position q_k:

1. prediction (eq. 27-29, Alg. 1 a): every component survives with p_S (eq. 23; 0.1 "as
   written": the paper's p_S is applied to every component at every step, so a target out
   of view is forgotten within a few steps, which is what the reward set is for), mean
   F m = m (F = I_2, static targets), covariance P + Q, Q = ``process_noise_var`` I_2
   (0.2 I_2); no spawns;
2. births (eq. 39-40): four components of weight 0.1 and covariance 0.5 I_2 on the ring of
   radius r_birth = 0.8 r_FoV around q_k (:class:`.gm_phd.births.RingBirth`). q_k is known only
   with the scan of step k, so they are added to the predicted survivors at the start of
   the update, which is v_{k|k-1} of eq. 26: births of step k around the robot's position
   at step k, updated by Z_k;
3. update (eq. 33-38, Alg. 1 b): p_D = p_D inside the FoV disk of radius r and 0 outside,
   evaluated at each component's mean (eq. 22; ``p_d_evaluation = integrated`` averages it
   over the component instead, :class:`.fov_detection.DiskFov`); H = I_2, R = the scenario's
   measurement variance times I_2; clutter kappa(z) = lambda_C A_s U(z) = lambda_C for z in
   the FoV disk, 0 outside (``clutter_region = fov``; ``everywhere``: lambda_C at every z);
4. pruning (weight <= T), merging (squared Mahalanobis distance <= U) and the cap J_max
   (Vo & Ma Table II, Alg. 1 c);
5. extraction (Vo & Ma Table III, Alg. 1 d): round(w) copies of the mean of every component
   with w > 0.5, X^_k;
6. the reward: ``M_k = M_{k-1} U X^_k`` (Alg. 1 d), a union in which a point within
   ``duplicate_distance`` of a point already in the set is the same target
   (:func:`phd_swarm.core.estimators.shirsat.reward_sets.union`; an exact union of real-valued
   estimates would add every target again at every step). With ``reward_union: label`` and a sensor
   that identifies targets (``sensor: disk_labelled``), the labelled reading of eq. 19 instead:
   each estimate carries the label of the measurement that formed it
   (:mod:`.shirsat.labels`), the union is by label
   (:func:`phd_swarm.core.estimators.shirsat.reward_sets.union_by_label`) and an estimate without a
   label (from clutter) is not added.

The default ``duplicate_distance``, 1.5 m, is three measurement standard deviations of the
paper's sensor (R = 0.25 I_2, sd 0.5 m), the usual 3-sigma gate. With p_S = 0.1 the filter
has almost no memory, so X^_k is about one measurement filtered with the births: in the
paper's setting (r = 0.6 m, p_D = 0.8) its error is 0.33 m per axis, plus a pull towards the
robot of a third of the target's offset from it (the ring's births). Every estimate the
union does not match becomes a permanent point of M_k (and of every robot that meets this
one), so the distance must cover the tails of that cloud. Measured extra points per target
(a robot at a random position within the target's FoV at each step, 100 runs), after 30 /
100 / 300 sightings: 1.0 m (2 sds): 0.9 / 1.6 / 2.3; 1.2 m (the FoV's diameter): 0.5 /
0.8 / 1.3; 1.5 m: 0.06 / 0.24 / 0.44; 2.0 m: 0 / 0.01 / 0.05. The price: targets closer
together than 1.5 m are one target of the reward set (the paper's densities, 0.12 targets
per m^2 at most, Sec. VI, put a target's nearest neighbour 1.4 m away on average for
uniformly placed targets, so a scenario should place them apart or lower the distance).

A consequence of the paper's settings worth knowing when reading t_reward: kappa is small
against the births (p_D w_gamma N(z; ...) ~ 0.02 per birth against lambda_C = 4e-3), so a
single measurement in the FoV gives a component of weight ~0.9, extracted at once: a clutter
point (lambda_C pi r^2 = 4.5e-3 per scan, ~4 in 300 steps of 3 robots) becomes a target of
X^_k and, through the union, a permanent false point of M_k and of every robot met later.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import registry
from ...checks import check_measurements
from ...outputs import Output
from ...params import ParamSpec
from ...scan import Scan
from ...sensors.fov_detection import DiskFov
from ..base import Estimator
from ..gm_phd.births import RingBirth
from ..gm_phd.filter import GaussianMixture, GmPhdModel, extract, linear_terms, update_with_terms
from ..gm_phd.outputs import COMPONENTS, MARKERS, observation
from ..gm_phd.reduce import MERGE_METRIC_OPTION
from ..gm_phd.team import PaddedMixtures, predict_rows, prune_and_merge_rows
from .figures import step_figures
from .labels import estimate_labels, measurement_labels, posterior_labels
from .reward_sets import (
    as_labels,
    as_points,
    extend,
    extend_by_label,
    union,
    union_by_label,
)

OPTIONS = (
    ParamSpec("survival_probability", 0.1, "shirsat_gmphd: p_S, applied to every component "
              "at every step (eq. 23, Sec. VI: 0.1)", low=0.0, high=1.0),
    ParamSpec("process_noise_var", 0.2, "shirsat_gmphd: process noise variance per axis "
              "[m^2] (Q = var I_2, Sec. VI: 0.2)", low=0.0),
    ParamSpec("birth_weight", 0.1, "shirsat_gmphd: weight of each of the four birth "
              "components (eq. 39: 0.1)", low=0.0),
    ParamSpec("birth_variance", 0.5, "shirsat_gmphd: diagonal of the birth covariance [m^2] "
              "(eq. 39: 0.5)", low=0.0),
    ParamSpec("birth_radius_ratio", 0.8, "shirsat_gmphd: r_birth / r_FoV, the radius of the "
              "birth ring around the robot (eq. 40: 0.8)", low=0.0),
    ParamSpec("p_d_evaluation", "mean", "shirsat_gmphd: p_D of a component taken at its mean "
              "(eq. 22, mean) or averaged over it (integrated)",
              choices=("mean", "integrated")),
    ParamSpec("clutter_region", "fov", "shirsat_gmphd: clutter intensity lambda_C inside the "
              "FoV disk and 0 outside (kappa = lambda_C A_s U(z), fov) or lambda_C at every "
              "measurement (everywhere)", choices=("fov", "everywhere")),
    ParamSpec("pruning_weight", 0.001, "shirsat_gmphd: pruning threshold T (Sec. VI: 1e-3; "
              "Vo & Ma Table II)", low=0.0),
    ParamSpec("merging_distance", 4.0, "shirsat_gmphd: merging threshold U on the squared "
              "Mahalanobis distance (Sec. VI: 4; Vo & Ma Table II)", low=0.0),
    MERGE_METRIC_OPTION,
    ParamSpec("component_cap", 100, "shirsat_gmphd: J_max, the most components kept (Vo & "
              "Ma Table II; not stated in the paper)", low=1),
    ParamSpec("extraction_weight", 0.5, "shirsat_gmphd: weight above which a component gives "
              "round(w) targets (Alg. 1 d: thresh_state = 0.5; Vo & Ma Table III)",
              low=0.0),
    ParamSpec("duplicate_distance", 1.5, "shirsat_gmphd: reward-set union: an estimate "
              "within this distance of a point of the set is the same target [m] (default: "
              "3 measurement sds of Sec. VI's sensor; the paper's exact union never matches "
              "a real-valued estimate)", low=0.0),
    ParamSpec("reward_union", "position", "shirsat_gmphd: reward-set union: an estimate is "
              "in the set when it lies within duplicate_distance of a member (position) or "
              "when its label is (label: eq. 19's <l, v> with a sensor that identifies "
              "targets, e.g. disk_labelled; estimates from clutter carry none and are not "
              "added)", choices=("position", "label")),
)


@dataclass(frozen=True, eq=False)
class ShirsatSetup:
    """What every robot's estimator shares (see the module docstring).

    Attributes
    ----------
    model : GmPhdModel
        F = I_2, Q, H = I_2, R, p_S, no fixed births or spawns; T, U, J_max, the extraction
        threshold. ``clutter_intensity`` is lambda_C [1/m^2].
    fov : DiskFov
        p_D of eq. 22 (radius r, p_D inside; at the mean or integrated).
    birth : RingBirth
        gamma_k of eq. 39-40.
    clutter_in_fov_only : bool
        kappa(z) = lambda_C inside the FoV disk and 0 outside (True), or lambda_C everywhere.
    duplicate_distance : float
        The reward-set union's distance [m]
        (:func:`phd_swarm.core.estimators.shirsat.reward_sets.union`).
    labelled : bool
        The union is by label
        (:func:`phd_swarm.core.estimators.shirsat.reward_sets.union_by_label`), the components
        carrying labels (:mod:`.shirsat.labels`); else by position.
    """

    model: GmPhdModel
    fov: DiskFov
    birth: RingBirth
    clutter_in_fov_only: bool = True
    duplicate_distance: float = 1.5
    labelled: bool = False

    def clutter(self, z: np.ndarray, sensor: np.ndarray) -> np.ndarray:
        """kappa(z) [1/m^2] at each measurement (M,) for a scan taken at ``sensor``."""
        kappa = np.full(z.shape[0], self.model.clutter_intensity)
        if self.clutter_in_fov_only:
            d2 = np.sum((z - sensor) ** 2, axis=1)
            kappa[d2 > self.fov.radius ** 2] = 0.0
        return kappa


def paper_setup(radius: float = 0.6, p_d: float = 0.8, variance: float = 0.25,
                clutter: float = 3.98e-3, **options: Any) -> ShirsatSetup:
    """The setup with Sec. VI's values, for a sensor of FoV ``radius`` [m] (no scenario).

    ``options`` override the option defaults (:data:`OPTIONS`, by name).
    """
    values = {spec.name: spec.default for spec in OPTIONS}
    unknown = set(options) - set(values)
    if unknown:
        raise ValueError(f"unknown options {sorted(unknown)}; expected some of "
                         f"{sorted(values)}")
    values.update(options)
    return make_setup(radius, p_d, variance, clutter, values)


def make_setup(radius: float, p_d: float, variance: float, clutter: float,
               opt: Mapping[str, Any]) -> ShirsatSetup:
    """The setup from the sensor's models and the options (by name, all of them)."""
    q = float(opt["process_noise_var"])
    model = GmPhdModel(
        F=np.eye(2), Q=max(q, 1e-12) * np.eye(2), H=np.eye(2),
        R=float(variance) * np.eye(2), p_s=float(opt["survival_probability"]),
        birth_weights=np.empty(0), birth_means=np.empty((0, 2)),
        birth_covs=np.empty((0, 2, 2)), clutter_intensity=float(clutter),
        prune_threshold=float(opt["pruning_weight"]),
        merge_threshold=float(opt["merging_distance"]),
        merge_metric=str(opt["merge_metric"]),
        max_components=int(opt["component_cap"]),
        extraction_threshold=float(opt["extraction_weight"]))
    fov = DiskFov(float(radius), float(p_d), integrate=opt["p_d_evaluation"] == "integrated")
    birth = RingBirth(float(opt["birth_radius_ratio"]) * float(radius),
                      float(opt["birth_weight"]), max(float(opt["birth_variance"]), 1e-12))
    return ShirsatSetup(model, fov, birth, opt["clutter_region"] == "fov",
                        float(opt["duplicate_distance"]), opt["reward_union"] == "label")


class ShirsatEstimator(Estimator):
    """One robot's GM-PHD and reward set (see the module docstring).

    Parameters
    ----------
    setup : ShirsatSetup
        The team's shared models.
    robot_id : int
        The robot's id, which orders the sets of a merge (:meth:`merge_rewards`).
    mixture : GaussianMixture, optional
        Initial intensity (2-D positions); empty by default (Sec. VI: the robots know
        nothing of the targets at the start).

    Attributes
    ----------
    robot_id : int
    step : int
        The step of the last update (-1 before the first).
    """

    def __init__(self, setup: ShirsatSetup, robot_id: int,
                 mixture: GaussianMixture | None = None) -> None:
        self.setup = setup
        self.robot_id = int(robot_id)
        self._mixture = GaussianMixture.empty(2) if mixture is None else mixture
        if self._mixture.dim != 2:
            raise ValueError(f"initial mixture has dimension {self._mixture.dim}, expected 2 "
                             f"(positions)")
        self._estimates = np.empty((0, 2))
        self._reward = np.empty((0, 2))
        # The labelled reading's bookkeeping (setup.labelled; :mod:`.shirsat.labels`): the
        # components', the estimates' and the reward members' labels, 0 for none.
        self._labels = np.zeros(len(self._mixture), dtype=np.int64)
        self._estimate_labels = np.empty(0, dtype=np.int64)
        self._reward_labels = np.empty(0, dtype=np.int64)
        self.step = -1
        #: The robots whose sets were merged at the last step (a renewal epoch), ascending.
        self.met = np.empty(0, dtype=np.int64)

    @property
    def labelled(self) -> bool:
        """Whether the reward union is by label (``reward_union: label``)."""
        return self.setup.labelled

    @property
    def mixture(self) -> GaussianMixture:
        """The current components (after the last update, or the last prediction)."""
        return self._mixture

    def predict(self) -> None:
        """Survivors (eq. 27-29): weights times p_S, covariances plus Q; births come later.

        The births of step k depend on the robot's position at step k, which comes with
        the scan: :meth:`update` adds them (eq. 26 is completed there). Computed as a team
        of one (:func:`predict_team`), so that a robot alone and in a team agree bit for bit.
        """
        predict_team([self])

    def update(self, scan: Scan) -> None:
        """Births around ``scan.sensor``, the GM-PHD update, prune and merge, X^_k, M_k.

        Eq. 26 (the survivors of :meth:`predict` plus gamma_k of eq. 39-40 at q_k =
        ``scan.sensor``), eq. 33-38 with p_D of eq. 22 and kappa at each measurement, Vo &
        Ma Tables II and III, then ``M_k = M_{k-1} U X^_k`` (Alg. 1 d). Computed as a team
        of one (:func:`update_team`).
        """
        update_team([self], [scan])

    def estimates(self) -> np.ndarray:
        """X^_k, the targets extracted at the last update (N, 2) [m] (Vo & Ma Table III)."""
        return self._estimates.copy()

    def estimate_labels(self) -> np.ndarray:
        """The label of each row of :meth:`estimates`, (N,) int64, 0 for none (a copy).

        All 0 unless the union is by label (``reward_union: label``).
        """
        if not self.setup.labelled:
            return np.zeros(len(self._estimates), dtype=np.int64)
        return self._estimate_labels.copy()

    def expected_count(self) -> float:
        """The sum of the components' weights (eq. 18)."""
        return float(self._mixture.weights.sum())

    def reward_set(self) -> np.ndarray:
        """M_k, the targets extracted so far and merged from the robots met (K, 2) [m], a copy."""
        return self._reward.copy()

    def reward_labels(self) -> np.ndarray:
        """The label of each member of :meth:`reward_set`, (K,) int64 (a copy).

        Every label is > 0 when the union is by label (``reward_union: label``); all are
        0 (none kept) under the union by position.
        """
        if not self.setup.labelled:
            return np.zeros(len(self._reward), dtype=np.int64)
        return self._reward_labels.copy()

    def merge_rewards(self, others: Mapping[int, np.ndarray],
                      labels: Mapping[int, np.ndarray] | None = None) -> None:
        """Eq. 6 at a renewal epoch: M_k becomes the union with the sets of the robots met.

        The sets, this robot's own M_k under its id and ``others`` (robot id -> that
        robot's M_k as it sent it), are taken in increasing robot id
        (:func:`phd_swarm.core.estimators.shirsat.reward_sets.union`, or
        :func:`~phd_swarm.core.estimators.shirsat.reward_sets.union_by_label` with ``labels``,
        robot id -> the labels of that robot's members, which the union by label needs), so every
        robot of a meeting that receives the others' sets ends with the same set, whatever
        order the messages came in.

        Raises
        ------
        ValueError
            If ``others`` holds this robot's own id, a set is malformed, or, under the
            union by label, a set comes without its labels (naming the robot); the reward
            set is then left as it was.
        """
        sets = {self.robot_id: self._reward}
        for rid, points in others.items():
            rid = int(rid)
            if rid == self.robot_id:
                raise ValueError(f"merge_rewards: robot {self.robot_id} received a set under "
                                 f"its own id")
            sets[rid] = as_points(points, f"reward set of robot {rid}")
        if self.setup.labelled:
            tags = {self.robot_id: self._reward_labels}
            for rid in sorted(sets.keys() - {self.robot_id}):
                if labels is None or rid not in labels:
                    raise ValueError(f"merge_rewards: the reward set of robot {rid} came "
                                     f"without labels (reward_union: label)")
                tags[rid] = as_labels(labels[rid], len(sets[rid]),
                                      f"reward set of robot {rid}")
            self._reward_labels, self._reward = union_by_label(
                [(tags[rid], sets[rid]) for rid in sorted(sets)])
        else:
            self._reward = union([sets[rid] for rid in sorted(sets)],
                                 self.setup.duplicate_distance)
        self.met = np.array(sorted(set(sets) - {self.robot_id}), dtype=np.int64)

    def export_state(self) -> dict[str, np.ndarray]:
        """The mixture as plain arrays (:meth:`.gm_phd.filter.GaussianMixture.to_arrays`)."""
        return self._mixture.to_arrays()

    def import_state(self, arrays: dict[str, np.ndarray], where: str = "mixture") -> None:
        """Replace the mixture with checked arrays; the estimates and reward set are kept.

        The new components carry no label (:mod:`.shirsat.labels`).
        """
        mix = GaussianMixture.from_arrays(arrays, where)
        if mix.dim != 2:
            raise ValueError(f"{where}: state dimension {mix.dim}, expected 2 (positions)")
        self._mixture = mix
        self._labels = np.zeros(len(mix), dtype=np.int64)


def predict_team(estimators: Sequence[ShirsatEstimator]) -> None:
    """:meth:`ShirsatEstimator.predict` of every robot, at once (:func:`.team.predict_rows`)."""
    model = _shared_setup(estimators).model
    pred = predict_rows(PaddedMixtures.from_mixtures([e.mixture for e in estimators]),
                        model.F, model.Q, model.p_s)
    for r, e in enumerate(estimators):
        e._mixture = pred.row(r)


def update_team(estimators: Sequence[ShirsatEstimator], scans: Sequence[Scan]) -> None:
    """:meth:`ShirsatEstimator.update` of every robot with its scan, at once.

    The steps of the module docstring for all robots together: births, p_D and the missed
    detections for every row of one padded array; the measurement update (eq. 33-38) for
    each robot that measured something (few do: the FoV is small); pruning and merging for
    every row (:func:`.gm_phd.team.prune_and_merge_rows`); then each robot's X^_k and M_k.
    Each robot's numbers are those it computes alone (row independence, see
    :mod:`.gm_phd.team`).
    """
    setup = _shared_setup(estimators)
    model, fov = setup.model, setup.fov
    if len(scans) != len(estimators):
        raise ValueError(f"update_team: {len(scans)} scans for {len(estimators)} robots")
    zs = [check_measurements(scan.z, 2) for scan in scans]
    z_labels = [measurement_labels(scan) for scan in scans] if setup.labelled else None
    sensors = np.array([scan.sensor for scan in scans], dtype=float).reshape(-1, 2)
    prior = PaddedMixtures.from_mixtures([e.mixture for e in estimators])
    bw, bm, bc = setup.birth.ring_rows(sensors)
    b = bw.size
    # v_{k|k-1} of eq. 26 in each row: the births, then the predicted survivors.
    mix = PaddedMixtures.empty(len(estimators), b + prior.weights.shape[1])
    mix.weights[:, :b] = bw
    mix.means[:, :b] = bm
    mix.covs[:, :b] = bc
    mix.weights[:, b:] = prior.weights
    mix.means[:, b:] = prior.means
    mix.covs[:, b:] = prior.covs
    mix.count[:] = b + prior.count
    if fov.integrate:
        p_d = np.zeros_like(mix.weights)
        for r in range(len(estimators)):
            n = mix.count[r]
            p_d[r, :n] = fov(mix.means[r, :n], mix.covs[r, :n], sensors[r])
    else:
        # DiskFov at the means (eq. 22), elementwise as DiskFov._inside.
        inside = np.hypot(mix.means[..., 0] - sensors[:, None, 0],
                          mix.means[..., 1] - sensors[:, None, 1]) <= fov.radius
        p_d = np.where(inside, fov.p_inside, 0.0)
    measured = [r for r, z in enumerate(zs) if len(z)]
    posteriors = {}
    for r in measured:
        row, n = mix.row(r), mix.count[r]
        posteriors[r] = update_with_terms(row, zs[r], linear_terms(row, model.H, model.R),
                                          p_d[r, :n], setup.clutter(zs[r], sensors[r])).mixture
    mix.weights = (1.0 - p_d) * mix.weights                      # missed detections
    width = max([mix.weights.shape[1], *(len(p) for p in posteriors.values())])
    if width > mix.weights.shape[1]:
        wider = PaddedMixtures.empty(len(estimators), width)
        n = mix.weights.shape[1]
        wider.weights[:, :n], wider.means[:, :n], wider.covs[:, :n] = (
            mix.weights, mix.means, mix.covs)
        wider.count[:] = mix.count
        mix = wider
    for r, post in posteriors.items():
        mix.set_row(r, post)
    merged = prune_and_merge_rows(mix, model.prune_threshold, model.merge_threshold,
                                  model.max_components, model.merge_metric,
                                  with_leads=setup.labelled)
    if setup.labelled:
        merged, leads = merged
        labels = [posterior_labels(b, e._labels, z_labels[r] if r in posteriors else None)
                  [leads[r]] for r, e in enumerate(estimators)]
    for r, (e, scan, mixture) in enumerate(zip(estimators, scans, merged, strict=True)):
        e._mixture = mixture
        e._estimates = extract(mixture, model)
        if setup.labelled:
            e._labels = labels[r]
            e._estimate_labels = estimate_labels(mixture.weights, e._labels,
                                                 model.extraction_threshold)
            e._reward_labels, e._reward = extend_by_label(
                e._reward_labels, e._reward, e._estimate_labels, e._estimates)
        else:
            e._reward = extend(e._reward, [e._estimates], setup.duplicate_distance)
        e.step = int(scan.step)
        e.met = np.empty(0, dtype=np.int64)


def step_team(estimators: Sequence[ShirsatEstimator], scans: Sequence[Scan]) -> None:
    """Predict and update every robot at once (the distributed engine's team step)."""
    if estimators:
        predict_team(estimators)
        update_team(estimators, scans)


def _shared_setup(estimators: Sequence[ShirsatEstimator]) -> ShirsatSetup:
    setups = {id(e.setup): e.setup for e in estimators}
    if len(setups) != 1:
        raise ValueError(f"a team step needs robots that share one setup, got {len(setups)}")
    return next(iter(setups.values()))


def _setup(scenario: Any, system: Any, **runtime: Any) -> ShirsatSetup:
    models = scenario.models
    # The sensor's own clutter model if it has one (disk_false_positive), else the
    # scenario's uniform clutter density lambda_C.
    sensor = system.parts()["sensor"]
    sensor_model = sensor.setup(scenario, system)
    kappa = (sensor_model.clutter_intensity() if hasattr(sensor_model, "clutter_intensity")
             else float(models.clutter.density))
    if system.option("reward_union") == "label" and "target_label" not in sensor.provides:
        raise ValueError(f"shirsat_gmphd: reward_union: label needs a sensor that identifies "
                         f"targets (provides target_label, e.g. disk_labelled); sensor "
                         f"{sensor.name} gives no labels")
    return make_setup(float(models.detection.radius), float(models.detection.p_d),
                      float(models.measurement.variance), kappa,
                      {spec.name: system.option(spec.name) for spec in OPTIONS})


#: The robot's own reward set of the step and the robots it met.
REWARD_SET = Output(
    "reward_set", "phd_swarm_msgs/msg/RewardSet", "phd_swarm.nodes.faces.meet_merge:REWARD_SET",
    "The robot's reward set M_k (targets extracted so far, merged with those of the robots "
    "met) and the robots met at step k (Shirsat & Berman eq. 6).")

registry.register(
    "estimator", "shirsat_gmphd", lambda setup, rid: ShirsatEstimator(setup, rid),
    setup=_setup,
    description="GM-PHD per robot with births on a ring around it and p_S applied to every "
                "component, and the reward set of the targets extracted so far, merged "
                "when robots meet (Shirsat & Berman 2021 Sec. V-VI, eq. 6, Alg. 1-3).",
    options=OPTIONS, provides=("gaussian_mixture", "reward_set"), requires=("disk_fov",),
    outputs=(COMPONENTS, REWARD_SET, MARKERS),
    observation=observation("reward_set", meetings="reward_set"), figures=step_figures,
    team_step=step_team)
