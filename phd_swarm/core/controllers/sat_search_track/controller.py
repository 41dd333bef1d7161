"""Papaioannou et al.'s search-and-track control: plan and search, track by Rényi, yield overlaps.

Registered as the ``sat_search_track`` controller. At the end of step k an agent at s_k
chooses one of the 17 admissible moves of eq. 4 (:mod:`.agent_moves`):

- **Mode** (Sec. III, V-C): tracking while its filter has targets (X^_k or a tentative
  detection not empty, from the ``papaioannou_sat`` estimator's ``track_states``; a step
  tracking tentative detections only is a *look*), searching otherwise (always with
  ``track_targets: false``); an agent told to yield a tracking overlap searches while its
  square still overlaps the other agent's.
- **Search** (Sec. V-B): it follows a plan over the unvisited nodes of its search map
  (p_v <= ``search_beta``): its own greedy least-cost path (the heuristic replacing P1), or,
  in a step at which it received other agents' maps (the exchange's event rule), the joint
  plan of Alg. 1 over itself and those agents, of which it takes its own path. A node is
  dropped from the plan once it is searched; a plan run out is made anew. The move is the
  admissible one closest to the plan's next node. ``search_mode: random`` is Fig. 1's
  baseline (no plan, a random admissible move towards unvisited nodes).
- **Track** (Sec. V-C a): the move that maximises the Rényi divergence (eq. 18, alpha) between
  the predicted target density and its pseudo-update with the measurements predicted from
  X^_{k+1|k} (:mod:`.renyi`). The prediction to k+1 is the mean one:
  each particle moved by F without noise, its weight times p_S (the agent's random
  generator is not spent on planning).
- **Overlap** (Sec. V-C b): with every agent in range that also tracks, the squares' overlap
  and eq. 19 on the exchanged predicted multi-target states (the estimates only, the
  estimator's ``predicted_states``) feed a 3-step window per pair
  (:mod:`.tracking_overlap`); when it fires (the window's sum of DeltaL, or
  with ``overlap_threshold_form: mean`` their mean, is <= Q_th), the agent
  :func:`.tracking_overlap.pick_switcher` names switches to search.
  :attr:`SatSearchTrack.overlap_step` says what the test did at the last decision.

Reference: S. Papaioannou et al., "A cooperative multi-agent probabilistic framework for
search and track missions", IEEE T-CNS, Sec. V-B, V-C.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import registry
from ...estimators.papaioannou import search_map as sm
from ...outputs import Output
from ...params import ParamSpec
from ..base import Controller, Decision, Knowledge
from .agent_moves import action_offsets, admissible_positions
from .search_plan import (
    SearchPlan,
    greedy_path,
    joint_paths,
    random_search_action,
    search_action,
)
from .tracking import RenyiTracking
from .tracking_overlap import THRESHOLD_FORMS, OverlapWindow, pick_switcher, squares_overlap

OPTIONS = (
    ParamSpec("move_step", 2.0, "sat_search_track: radial step Delta_R of eq. 4 [m] (Sec. "
              "VI-A: 2)", low=0.0),
    ParamSpec("move_rings", 2, "sat_search_track: N_R of eq. 4 (Sec. VI-A: 2)", low=1),
    ParamSpec("move_directions", 8, "sat_search_track: N_theta of eq. 4 (Sec. VI-A: 8)",
              low=1),
    ParamSpec("search_beta", 0.9, "sat_search_track: beta, a node is unvisited when its "
              "search value is <= beta (not stated; 0.9 = revisit after ~105 steps at "
              "J = 0.999)", low=0.0, high=1.0),
    ParamSpec("track_targets", True, "sat_search_track: switch to tracking when the filter "
              "has targets (false: search only, Fig. 4's search task)"),
    ParamSpec("search_mode", "planned", "sat_search_track: planned search (Sec. V-B) or "
              "Fig. 1's random baseline", choices=("planned", "random")),
    ParamSpec("alg1_first", "lowest", "sat_search_track: Alg. 1's first agent: the lowest "
              "id, or the printed delta mod |S| order (the second)",
              choices=("lowest", "literal")),
    ParamSpec("renyi_alpha", 0.5, "sat_search_track: alpha of eq. 17-18 (Sec. VI-A: 0.5)",
              low=0.0, high=1.0),
    ParamSpec("predict_all_estimates", False, "sat_search_track: predicted measurements "
              "from every estimate (the printed union), not only those inside the square"),
    ParamSpec("overlap_detection", True, "sat_search_track: detect and resolve tracking "
              "overlaps (Sec. V-C b; Fig. 5b compares without)"),
    ParamSpec("overlap_threshold", 0.9, "sat_search_track: Q_th of the cumulative overlap "
              "score [m] (Sec. VI-A: 0.9)", low=0.0),
    ParamSpec("overlap_threshold_form", "sum", "sat_search_track: Q_th bounds the sum of the "
              "window's eq. 19 scores (sum, as printed) or their mean (mean: Q_th per step)",
              choices=THRESHOLD_FORMS),
    ParamSpec("overlap_window", 3, "sat_search_track: steps of the overlap window (Sec. VI-A: "
              "3)", low=1),
    ParamSpec("overlap_cutoff", 10.0, "sat_search_track: OSPA cut-off c of eq. 19 [m] (not "
              "stated)", low=0.0),
)


@dataclass(frozen=True)
class SatControlSetup:
    """What every agent's controller shares.

    Attributes
    ----------
    offsets : np.ndarray, shape (U, 2)
        The moves of eq. 4 [m], staying first.
    bounds : tuple
        The surveillance region (xmin, ymin, xmax, ymax) [m].
    tracking : RenyiTracking
    beta : float
    random_search : bool
    alg1_first : str
    track_targets : bool
        False: search only (Fig. 4's search task).
    overlap : bool
    overlap_threshold, overlap_cutoff : float
    overlap_window : int
    seed : int
        The run's seed (for the overlap's choice of who switches).
    overlap_form : str
        What Q_th bounds, ``sum`` or ``mean`` (:meth:`.OverlapWindow.detected`).
    """

    offsets: np.ndarray
    bounds: tuple[float, float, float, float]
    tracking: RenyiTracking
    beta: float
    random_search: bool
    alg1_first: str
    overlap: bool
    overlap_threshold: float
    overlap_window: int
    overlap_cutoff: float
    seed: int
    track_targets: bool = True
    overlap_form: str = "sum"


@dataclass(frozen=True)
class OverlapStep:
    """What the tracking-overlap test did at one decision of one agent.

    Attributes
    ----------
    tested : int
        Windows that were full and finite (every step's squares overlapped and both sets
        were non-empty), i.e. compared with Q_th.
    fired : int
        Windows within Q_th (tracking overlaps detected).
    best : float
        The smallest Q [m] of the full windows (the sum of DeltaL), inf if none.
    """

    tested: int = 0
    fired: int = 0
    best: float = float("inf")


class SatSearchTrack(Controller):
    """One agent's control (see the module docstring)."""

    def __init__(self, setup: SatControlSetup, robot_id: int) -> None:
        self.setup = setup
        self.robot_id = int(robot_id)
        #: Whether the last decision was a tracking move (the exchange sends it).
        self.tracking = False
        #: The agents of the current joint plan, itself included ((id,) alone).
        self.plan_members: tuple[int, ...] = (self.robot_id,)
        self.plan: SearchPlan | None = None
        self.goal: np.ndarray | None = None
        self._nodes: np.ndarray | None = None
        self._windows: dict[int, OverlapWindow] = {}
        #: Agents this one yielded a tracking overlap to (it searches while near them).
        self.yielding: set[int] = set()
        #: The last decision's mode: ``search``, ``track``, or ``look`` (tracking tentative
        #: detections only).
        self.mode = "search"
        #: What the tracking-overlap test did at the last decision.
        self.overlap_step = OverlapStep()
        self.stats = {"track_steps": 0, "search_steps": 0, "look_steps": 0,
                      "overlap_tests": 0, "overlaps_resolved": 0, "plans": 0,
                      "joint_plans": 0}

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """The move of step k+1 (see the module docstring)."""
        est = knowledge.estimator
        view = knowledge.local
        messages = view.messages if view is not None else {}
        s = self.setup
        side = s.tracking.side
        position = np.asarray(knowledge.position, dtype=float).reshape(2)
        predicted = est.predicted_states()
        targets = est.track_states() if hasattr(est, "track_states") else predicted
        self.overlap_step = OverlapStep()
        if s.overlap:
            self._overlaps(knowledge.step, position, predicted[:, :2], messages, side)
        self.yielding = {j for j in self.yielding if j in messages
                         and squares_overlap(position, messages[j].position, side)}
        positions, admissible = admissible_positions(position, s.offsets, s.bounds)
        if len(targets) and not self.yielding and s.track_targets:
            action = self._track(est, targets, positions, admissible)
            self.tracking = True
            self.mode = "track" if len(predicted) else "look"
            self.stats["track_steps"] += 1
            self.stats["look_steps"] += self.mode == "look"
        else:
            action = self._search(est, view, position, positions, admissible, rng)
            self.tracking = False
            self.mode = "search"
            self.stats["search_steps"] += 1
        self.goal = positions[action].copy()
        return Decision(goal=self.goal.copy(), power_weight=0.0)

    # -------------------------------------------------------------------- track
    def _track(self, est: Any, predicted: np.ndarray, positions: np.ndarray,
               admissible: np.ndarray) -> int:
        setup = est.setup
        p = est.particles
        states = p.states @ setup.f.T
        action, _ = self.setup.tracking.choose(states, setup.p_s * p.weights, predicted[:, :2],
                                               positions, admissible)
        return int(action)

    # ------------------------------------------------------------------- search
    def _search(self, est: Any, view: Any, position: np.ndarray, positions: np.ndarray,
                admissible: np.ndarray, rng: np.random.Generator) -> int:
        s = self.setup
        grid = est.setup.grid
        self._nodes = grid.positions
        if s.random_search:
            return int(random_search_action(rng, positions, admissible, grid, est.search,
                                            s.beta))
        partners = tuple(view.maps_from) if view is not None else ()
        if partners:
            self._joint_plan(grid, est.search, position, view, partners)
        if self.plan is not None:
            self.plan.advance(est.search)
        if self.plan is None or self.plan.done:
            self._own_plan(grid, est.search, position)
        if self.plan.done:
            # Everything is searched above beta: head for the least recently searched node.
            node = int(np.argmin(est.search))
        else:
            node = self.plan.next_node()
        return int(search_action(positions, admissible, grid.positions[node]))

    def _targets(self, values: np.ndarray) -> np.ndarray:
        return sm.unvisited(values, self.setup.beta)

    def _own_plan(self, grid: Any, values: np.ndarray, position: np.ndarray) -> None:
        self.plan = SearchPlan(greedy_path(grid.positions, position, self._targets(values)))
        self.plan_members = (self.robot_id,)
        self.stats["plans"] += 1

    def _joint_plan(self, grid: Any, values: np.ndarray, position: np.ndarray, view: Any,
                    partners: tuple[int, ...]) -> None:
        ids = [self.robot_id, *partners]
        where = np.array([position, *(view.messages[j].position for j in partners)])
        paths = joint_paths(grid.positions, ids, where, self._targets(values),
                            first=self.setup.alg1_first)
        self.plan = SearchPlan(paths[self.robot_id])
        self.plan_members = tuple(sorted(ids))
        self.stats["joint_plans"] += 1

    # ------------------------------------------------------------------ overlap
    def _overlaps(self, step: int, position: np.ndarray, mine: np.ndarray,
                  messages: dict[int, Any], side: float) -> None:
        s = self.setup
        for j in list(self._windows):
            if j not in messages:
                del self._windows[j]
        if not self.tracking:
            self._windows.clear()
            return
        tested, fired, best = 0, 0, float("inf")
        for j, m in messages.items():
            if not m.tracking:
                self._windows.pop(j, None)
                continue
            window = self._windows.setdefault(j, OverlapWindow(s.overlap_window,
                                                               s.overlap_cutoff))
            q = window.push(step, squares_overlap(position, m.position, side), mine,
                            m.predicted)
            if q is None or not np.isfinite(q):
                continue
            tested += 1
            best = min(best, q)
            if window.detected(s.overlap_threshold, s.overlap_form):
                window.reset()
                fired += 1
                if pick_switcher(s.seed, step, self.robot_id, j) == self.robot_id:
                    self.yielding.add(j)
        self.overlap_step = OverlapStep(tested, fired, best)
        self.stats["overlap_tests"] += tested
        self.stats["overlaps_resolved"] += fired

    def planned_path(self) -> np.ndarray:
        """The next move's goal, then (searching) the plan's remaining nodes, (P, 2) [m]."""
        if self.goal is None:
            return np.empty((0, 2))
        if self.tracking or self.plan is None or self._nodes is None:
            return self.goal.reshape(1, 2).copy()
        return np.vstack([self.goal.reshape(1, 2), self._nodes[self.plan.nodes]])


def _setup(scenario: Any, system: Any, **runtime: Any) -> SatControlSetup:
    opt = {spec.name: system.option(spec.name) for spec in OPTIONS}
    sensor = system.parts()["sensor"].setup(scenario, system)
    env = scenario.env
    reach = float(opt["move_step"]) * int(opt["move_rings"])
    if float(scenario.robot_max_speed) * float(scenario.dt) < reach * (1.0 - 1e-9):
        raise ValueError(f"sat_search_track: the longest move of eq. 4 is {reach:g} m, more "
                         f"than robot_max_speed * dt = {scenario.robot_max_speed:g} x "
                         f"{scenario.dt:g} m; raise robot_max_speed")
    tracking = RenyiTracking(alpha=float(opt["renyi_alpha"]), side=float(sensor.side),
                             p_d_inside=float(sensor.p_d),
                             clutter_rate=float(sensor.clutter_rate),
                             clutter_density=sensor.polar_clutter_density,
                             sensor_model=sensor.model,
                             only_visible=not bool(opt["predict_all_estimates"]))
    return SatControlSetup(
        action_offsets(float(opt["move_step"]), int(opt["move_rings"]),
                       int(opt["move_directions"])),
        (env.xmin, env.ymin, env.xmax, env.ymax), tracking, float(opt["search_beta"]),
        opt["search_mode"] == "random", str(opt["alg1_first"]),
        bool(opt["overlap_detection"]), float(opt["overlap_threshold"]),
        int(opt["overlap_window"]), float(opt["overlap_cutoff"]), int(scenario.seed),
        bool(opt["track_targets"]), str(opt["overlap_threshold_form"]))


_FACE = "phd_swarm.nodes.faces.search_and_track"

#: What an agent publishes of its mode and plans: its own state, its plan, its markers.
OUTPUTS = (
    Output("sat_state", "phd_swarm_msgs/msg/SatState", f"{_FACE}:SAT_STATE",
           "The agent's own state: tracking or searching next, its predicted targets and "
           "joint-plan agents (Papaioannou et al. Sec. V; no map)."),
    Output("plan", "nav_msgs/msg/Path", f"{_FACE}:PLAN",
           "The agent's next goal, then (searching) the nodes of its search plan in order "
           "(Papaioannou et al. Sec. V-B)."),
    Output("markers", "visualization_msgs/msg/MarkerArray", f"{_FACE}:MARKERS",
           "The sensing square coloured by mode (search, track, yield), the plan and the "
           "estimates, for RViz2 / Foxglove.", qos="OBSERVATION"),
)

registry.register(
    "controller", "sat_search_track", lambda setup, rid: SatSearchTrack(setup, rid),
    setup=_setup, options=OPTIONS,
    description="Search by plans over the unvisited nodes (greedy, Alg. 1 with agents met), "
                "track by the Rényi divergence over the 17 moves, resolve tracking overlaps "
                "(Papaioannou et al. Sec. V-B, V-C).",
    provides=("sat_modes",), requires=("particles", "search_map"), outputs=OUTPUTS)
