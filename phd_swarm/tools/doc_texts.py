"""The prose of the generated docs: what each topic, inbox kind and scenario key means.

:mod:`phd_swarm.tools.gen_docs` renders docs/topics.md and docs/parameters.md from the code
(the topic table, the QoS profiles, the parts' declared outputs and options, the node
parameters, the presets' values) and from the words here, which only a person can write.
A topic, inbox kind or scenario key without its line here fails the render, so the docs
cannot fall behind the code.
"""

from __future__ import annotations

from phd_swarm.config import node_params
from phd_swarm.core.params import ParamSpec
from phd_swarm.nodes import topics
from phd_swarm.sim import presets
from phd_swarm.sim.target_kinds import lookup
from phd_swarm.sim.targets import TARGET_KINDS

#: Displayed name of a robot topic: ``/robot_<id>/<relative>``.
ROBOT_PATTERN = "/robot_<id>/{}"

#: One line per topic, keyed by the name shown in docs/topics.md (team topics absolute,
#: robot topics as ``/robot_<id>/<relative>``).
DESCRIPTIONS: dict[str, str] = {
    topics.CLOCK: "Sim time t = k dt of step k; every node runs with `use_sim_time`.",
    topics.WORLD_TRUTH: "True targets (ids, positions) at step k; for observers and "
                        "evaluation only, robots never read it.",
    topics.WORLD_ROBOTS: "Team state: robot ids, positions and alive flags at the start of "
                         "step k; robots initialise from it, observers follow the team.",
    topics.WORLD_MARKERS: "Robots (alive / dead), their ids and fields of view, true "
                          "targets, for RViz2 / Foxglove (`markers.world_markers`).",
    topics.MONITOR_METRICS: "OSPA and its parts, true / extracted / expected cardinality, "
                            "robots alive and reporting, messages per robot.",
    topics.MONITOR_ESTIMATES: "Targets extracted from the team PHD (observation only).",
    topics.MONITOR_DENSITY: "Team PHD assembled from the robots' density windows.",
    topics.MONITOR_DENSITY_GRID: "The team PHD as an occupancy grid for RViz2 / Foxglove: "
                                 "0..100, 100 = a PHD of 1 target per m^2 or more "
                                 "(`occupancy.FULL_DENSITY`, docs/ros.md); origin and "
                                 "resolution of the grid, the world frame.",
    topics.MONITOR_MARKERS: "Cells, goals and extracted estimates; the nodes of a walk's "
                            "grid graph (every 100 steps) and the robots meeting "
                            "(Shirsat & Berman); for RViz2 / Foxglove "
                            "(`markers.team_markers`).",
    topics.DIAGNOSTICS: "Health of the world, each robot and the recorder "
                        "(`diagnostic_msgs`: state, step lag, contacts, timeouts, rejected "
                        "messages, dead peers; steps and lag; messages written and gaps) at "
                        "OK / WARN / ERROR (thresholds in docs/ros.md).",
    topics.WORLD_OUTPUTS: "The step's poses and measurement sets of every robot, each "
                          "under its per-robot topic name, as one bundle for the "
                          "observers (see below).",
    topics.TEAM_STATUS: "Every robot's status (as `/robot_<id>/status`), for the world's "
                        "lockstep hand-shake and the observers.",
    topics.TEAM_OUTPUTS: "A robot's goal, estimates and declared outputs of a step, each "
                         "under its per-robot topic name, as one bundle for the observers.",
    ROBOT_PATTERN.format("measurements"): "Measurement set Z_r^k and sensor position q^k "
                                          "from the simulated sensor; starts the robot's "
                                          "step.",
    ROBOT_PATTERN.format("pose"): "The robot's pose at step k (world frame).",
    ROBOT_PATTERN.format("goal"): "Goal chosen by the controller for the next move "
                                  "(Dames eq. 8, Chen eq. 3).",
    ROBOT_PATTERN.format("status"): "READY at start-up, then STEP_DONE with goal, power "
                                    "weight and counters: the world's lockstep hand-shake; "
                                    "WORKING once per tick_period while a step lasts "
                                    "or the robot waits for the next (liveness).",
    ROBOT_PATTERN.format("estimates"): "Targets extracted from the robot's local PHD (its "
                                       "owned bins, or its own Gaussian mixture).",
    ROBOT_PATTERN.format("inbox"): "Protocol messages from one contact, packed per tick: "
                                   "kinds, offsets and the CDR bytes of each (see Inboxes "
                                   "above).",
}

#: Meaning and unit of every flattened scenario key (``scenario.<key>``), in display order.
SCENARIO_MEANINGS: dict[str, str] = {
    "preset": "Preset that the other keys override: "
              + ", ".join(f"{p.name} ({p.paper})" for p in presets.registered()) + ".",
    "name": "Label of the run (default: the preset's name).",
    "env.xmin": "Map E: smallest x [m].",
    "env.ymin": "Map E: smallest y [m].",
    "env.xmax": "Map E: largest x [m].",
    "env.ymax": "Map E: largest y [m].",
    "resolution": "Side of the filter's square bins [m]; must tile E (Dames 1, Chen 0.1).",
    "models.detection.p_d": "Detection probability inside the sensing disk (Dames eq. 9).",
    "models.detection.radius": "Sensing radius, the disk field of view [m] (Dames eq. 9).",
    "models.measurement.variance": "Measurement noise variance per axis [m^2] "
                                   "(Dames eq. 10).",
    "models.clutter.density": "Clutter intensity [1/m^2]; expected clutter per scan = "
                              "density x field-of-view area (Dames eq. 11).",
    "models.motion.sd": "Filter's motion model: s.d. of the per-step Gaussian walk [m]; "
                        "0 = static targets.",
    "models.motion.truncation": "Longest step of that walk [m] (finite support for the "
                                "distributed prediction; docs/models.md).",
    "models.survival.p_near": "Survival probability within `survival.margin` of the "
                              "boundary, 1 elsewhere (Dames eq. 13).",
    "models.survival.margin": "Width of that boundary ring [m]; 0: p_s = 1 everywhere.",
    "models.birth.density": "Birth PHD within `birth.margin` of the boundary "
                            "[targets/m^2 per step] (Dames eq. 14).",
    "models.birth.margin": "Width of the birth ring [m]; 0: no birth.",
    "models.initial_density": "Prior PHD [targets/m^2] (Dames: 1e-4, one target expected "
                              "on 100 x 100 m).",
    "dt": "Time step [s]: one scan, one filter update and one move per step (2 Hz: 0.5).",
    "duration": "Length of the run [s]; steps = round(duration / dt).",
    "robots": "Team size R.",
    "robot_start_box": "Robots start uniformly in this box, (xmin, ymin, xmax, ymax) [m], "
                       "inside E.",
    "robot_max_speed": "Speed limit of the holonomic robots [m/s].",
    "robot_start_grid": "If set, robots start on random nodes of a grid of this spacing [m] "
                        "inside robot_start_box (Shirsat & Berman); unset: uniform in the box.",
    "targets.kind": "True population: "
                    + ", ".join(f"{k} ({lookup(k).description})" for k in TARGET_KINDS) + ".",
    "targets.count": "static: targets drawn (those outside E are dropped); dames_walk: "
                     "initial number; clustered_walk: sum of per_cluster; turning_walk: "
                     "number; ncv: targets over the run (born at their birth times).",
    "targets.draw_box": "static: the square targets are drawn from, (xmin, ymin, xmax, "
                        "ymax) [m]; turning_walk: where they start; ncv: where they appear "
                        "(spawn uniform; default the map).",
    "targets.speed": "dames_walk: forward speed [m/s]; turning_walk: speed [m/s]; ncv: speed "
                     "per axis [m/s] along a random heading.",
    "targets.heading_sd": "dames_walk: s.d. of each heading change [rad].",
    "targets.heading_rate": "dames_walk: heading updates per second [Hz]; dt x "
                            "heading_rate must be whole.",
    "targets.birth": "dames_walk: draw births from the filter's birth PHD (`models.birth`).",
    "targets.birth_heading": "dames_walk: a newborn's heading, `inward` (uniform over the "
                             "half-plane facing the map centre) or `uniform` (any direction).",
    "targets.clusters": "clustered_walk: the cluster boxes, four numbers (xmin, ymin, xmax, "
                        "ymax) [m] each, flattened into one list.",
    "targets.per_cluster": "clustered_walk: targets in each cluster.",
    "targets.step_sd": "clustered_walk: per-axis s.d. of the walk's velocity [m/s].",
    "targets.max_speed": "clustered_walk: speed cap [m/s].",
    "targets.turn_every": "turning_walk: seconds between two random headings [s].",
    "targets.spawn": "ncv: targets appear at the centre of the map or uniformly in draw_box.",
    "targets.lifetime_mean": "ncv: mean lifetime, geometric [s] (Papaioannou: 60, Fig. 5: 30).",
    "targets.birth_spread": "ncv: birth times uniform over [0, birth_spread) [s]; 0: all at "
                            "the start.",
    "targets.process_noise": "ncv: q of the NCV process noise [m^2/s^3] (Papaioannou: 1).",
    "targets.noise_form": "ncv: standard NCV Q, or the printed [[T/3, T/2], [T/2, T]].",
    "targets.lifetime_model": "ncv: cut (a geometric lifetime cut by leaving the area and "
                              "the run's end), contained (paths placed inside the area for "
                              "a geometric lifetime of lifetime_mean, within the run) or exit "
                              "(a target lives until it leaves the area, within the run); "
                              "docs/decisions.md.",
    "targets.layout_seed": "static: if set, targets drawn from this seed alone, the same in "
                           "every run (Shirsat & Berman Table 1); unset: from the run's seed.",
    "extraction_threshold": "Target-extraction threshold as a density [targets/m^2]; the "
                            "per-bin threshold is this x resolution^2.",
    "ospa_c": "OSPA cut-off c [m].",
    "ospa_p": "OSPA order p >= 1.",
    "seed": "Seed of the world's random streams and the robots' own, >= 0.",
    "system.sensor": "The system's sensor model (see System parts below).",
    "system.estimator": "The system's estimator (see System parts below).",
    "system.exchange": "The system's exchange between robots (see System parts below).",
    "system.controller": "The system's controller (see System parts below); "
                         "`run_swarm.sh --controller` sets it.",
}

#: Parameter tables of docs/parameters.md: (heading, config-file block, specs).
NODE_TABLES: tuple[tuple[str, str, tuple[ParamSpec, ...]], ...] = (
    ("Every node", "/**", node_params.SHARED),
    ("World simulator (node `/world`)", "world", node_params.WORLD),
    ("Robot (node `/robot_<id>/robot`)", "/**/robot", node_params.ROBOT),
    ("Team monitor (node `/monitor`)", "monitor", node_params.MONITOR),
    ("Recorder (node `/recorder`)", "recorder", node_params.RECORDER),
    ("Live view (node `/viewer`, docs/view.md)", "viewer", node_params.VIEWER),
)

_GENERATED = ("<!-- Generated by `python -m phd_swarm.tools.gen_docs` from {sources}; "
              "do not edit by hand. -->")

#: What each inbox kind carries (the kinds of an InboxMessage, docs/topics.md).
INBOX_KINDS: dict[str, str] = {
    "state": "A contact's state: position, power weight, cell radius (Dames Alg. 1 line 1).",
    "cell": "A contact's cell, neighbour ids and contact table (Alg. 1 line 3, "
            "docs/protocol.md).",
    "measurements": "A contact's measurement set and sensor position, sent to the owners of "
                    "its field of view (Alg. 2 line 6).",
    "eta_partial": "Partial sums eta^r_z (eq. 5 over the sender's bins) for the receiver's "
                   "measurements (Alg. 2 line 20).",
    "eta_total": "eta_z = clutter + the partials in robot-id order, from the active robot "
                 "(Alg. 2 line 18).",
    "particles": "Bins changing owner, or phantom particles for the prediction (Alg. 1 "
                 "line 6, Sec. III-B), with Chen's alpha and n.",
    "rewards": "The reward set of a robot on the same node (or in radio range), sent at a "
               "renewal epoch (Shirsat & Berman Alg. 2-3).",
    "sat": "An agent in radio range: its position, mode, predicted targets, joint-plan "
           "members and (by the event rule) search map (Papaioannou et al. V-B c-d, V-C b).",
}

TOPICS_TEMPLATE = """\
{generated}

# Topics

## Names

- World topics live under `/world`, the team monitor's under `/monitor`, and `/clock` at the
  root. Each robot runs in its own namespace `/robot_<id>` (REP 144) and uses relative
  names inside it, so one node and one parameter block serve every robot: robot 3's
  measurements are `/robot_3/measurements`, its node is `/robot_3/robot`.
- Every header carries the world frame (`world_frame_id`, default `map`, REP 105) and a sim
  time stamp: the world owns `/clock` and every node runs with `use_sim_time` (see
  [deployment](deployment.md)).
- Message definitions: [messages](messages.md); the protocol: [protocol](protocol.md).

## Inboxes

Protocol traffic is published to the *receiver's* inbox: robot j sends what it has for robot
i in one tick as one `phd_swarm_msgs/InboxMessage` on `/robot_<i>/inbox`. The message lists
the protocol messages' kinds (below) and holds each as its kind's ROS message serialised as
CDR, `data[offsets[n]:offsets[n + 1]]`; `phd_swarm.nodes.inbox.messages` decodes it into ROS
messages (robots decode the CDR straight into numpy, `phd_swarm.nodes.cdr`). So each robot
subscribes to one inbox whatever the team size, receives exactly the messages addressed to
it, and handles O(neighbours) messages per step (its contacts, docs/protocol.md) rather than
O(team); a sender creates a publisher to a contact's inbox when it first needs one. One
topic per robot rather than one per kind keeps a crowded start, where every robot is every
other's contact, at N (N - 1) inbox writers instead of 6 N (N - 1)
([decisions](decisions.md)). Inbox writers are reliable and transient-local with a short
history, so the first message of a publisher created a moment ago is not lost: it is
delivered when the new publisher matches the inbox's subscription. Readers keep a deep queue
so that a burst is never overwritten before the executor takes it. In a run with a key
(`auth_key_file`; `run_swarm.sh` makes one per run) the message ends with `mac`, an
HMAC-SHA256 of its bytes under the key, and a robot rejects an envelope without the right
one, as it does a measurement set on `/robot_<i>/measurements` ([ros](ros.md)).

{inbox_table}

## Inspecting a run with the ros2 CLI

The `ros2` command comes with a native ROS 2 Jazzy install (`ros-jazzy-ros-base`); the
PyPI wheels of the default install do not include it. Run it on a host of the run, in a
shell with the run's `ROS_DOMAIN_ID` and `ROS_AUTOMATIC_DISCOVERY_RANGE` (and
`ROS_DISCOVERY_SERVER` with `ROS_SUPER_CLIENT=TRUE` if the run uses a discovery server, see
[deployment](deployment.md)), after `source /opt/ros/jazzy/setup.bash` and the
`install/local_setup.bash` of a native build of this repository (needed to decode the
`phd_swarm_msgs` types):

```bash
ros2 topic list                              # every topic below, for each robot
ros2 topic echo /monitor/metrics             # OSPA, cardinalities, messages per robot
ros2 topic hz /clock                         # steps per wall second
ros2 topic info -v /robot_3/inbox            # who writes robot 3's inbox, with QoS
ros2 param list /robot_3/robot               # a robot's parameters, scenario.* included
ros2 param get /world scenario.robots
```

If `ros2 topic list` misses topics after the environment changed, restart the CLI's
daemon (`ros2 daemon stop`): it keeps the settings it was started with.

## Team topics

{team_table}

`/team/status`, `/team/outputs` and `/world/outputs` carry what the observers (world,
monitor, recorder) read of every robot, so that each observer holds a few readers whatever
the team size: the statuses on one topic, each robot's other outputs of a step (goal,
estimates, its system's outputs below) as one `MessageBundle`, and the world's poses and
measurement sets of a step as one bundle. A bundle keeps each message's own topic name and
CDR bytes (`phd_swarm.nodes.bundle.unpack_cdr` cuts one); the recorder writes each message
under that name, so a log holds the per-robot topics, not these three. Jazzy has no keyed
topics: the key is the sender in the message ([decisions](decisions.md), "Team topics").

## Per-robot topics

Each in the robot's namespace `/robot_<id>`. The robot reads its `measurements` and
`inbox` here. What a robot writes, and the world's `pose` of it, is written here whenever a
reader is matched (a person with `ros2 topic echo`, RViz2, the viewer): such a reader sees
the steps from when it matched on; the observers get every step from the team topics.

{robot_table}

## QoS profiles

Defined in `phd_swarm/nodes/qos.py`; all keep the last N messages (KEEP_LAST). Writer and
reader may keep different depths: depth does not affect compatibility.

{qos_table}
"""

PARAMETERS_TEMPLATE = """\
{generated}

# Parameters

## Config files

A run is configured by one file (`config/*.yaml`), a standard ROS 2 parameter file that
every node of the run is started with (`--ros-args --params-file FILE`):

```yaml
/**:                      # every node
  ros__parameters:
    use_sim_time: true
    world_frame_id: map
    scenario:             # a preset plus overrides (the scenario keys below)
      preset: dames_static
      robots: 20
      targets: {{count: 30}}
      system: {{controller: phd}}   # sensor, estimator, exchange, controller, options
world:     {{ros__parameters: {{mode: lockstep}}}}
/**/robot: {{ros__parameters: {{tick_period: 1.0}}}}  # every robot, in any namespace
monitor:   {{ros__parameters: {{}}}}
recorder:  {{ros__parameters: {{}}}}
```

- The `/**` block holds the scenario and the parameters every node has; the other blocks
  configure one node each. `/**/robot` matches the robot node in every namespace
  `/robot_<id>`; the robot id itself comes from the command line (`-p robot_id:=3`).
- `phd_swarm.config.load_run_config` checks a file before any process starts: unknown
  blocks or keys, wrong types and values out of range fail with the file and key in the
  message. The scenario is a preset plus overrides; keys left out take the preset's value.
- In a parameter file the scenario becomes dotted parameters (`scenario.targets.count`).
  Lists of boxes (`targets.clusters`) are flat lists of 4k numbers, because ROS parameters
  hold flat lists only.
- Every node declares the scenario as **read-only** `scenario.*` parameters, so all nodes
  run the same scenario and `ros2 param get /robot_3/robot scenario.dt` shows what was
  used. The recorder stores the run's parameter file (its `params_file`) in the MCAP
  metadata.

## Node parameters

Read-only parameters are fixed at start-up (set them in the config file or with
`-p name:=value`); `ros2 param describe` shows the same description and range.

{node_tables}

## Scenario parameters

Declared by every node as read-only `scenario.<key>`; set in the `/**` block under
`scenario:`. The columns give each preset's value; "-" marks a key the preset leaves unset
(its target kind does not use it).

{scenario_table}

## System parts

`scenario.system` names one registered part per role (docs/architecture.md) and their
options, `scenario.system.options.<name>`; a part's options are declared only when it is
chosen. `scenario.system.plugins` lists modules or `.py` files that register more parts.

{parts_table}

{options_table}
"""


