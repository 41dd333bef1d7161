"""Render ``docs/topics.md`` and ``docs/parameters.md`` from the code's own tables.

Usage::

    python -m phd_swarm.tools.gen_docs            # (re)write both files
    python -m phd_swarm.tools.gen_docs --check    # exit 1 with a diff summary if stale
    python -m phd_swarm.tools.gen_docs --plugins my_parts.py --out DIR
                                                  # topics.md and parameters.md of the
                                                  # built-in parts and a plugin's, in DIR

The tables come from :mod:`phd_swarm.nodes.topics` (names, types, QoS names, writers,
rates), :mod:`phd_swarm.nodes.qos` (what each QoS name means for writer and reader),
:mod:`phd_swarm.config.node_params` (node parameters) and the scenario presets of
:mod:`phd_swarm.sim.scenario` (through :func:`phd_swarm.config.flatten`, exactly the
``scenario.*`` parameters the nodes declare). What the code cannot say, one line per topic
and per scenario key, is kept here in :data:`DESCRIPTIONS` and :data:`SCENARIO_MEANINGS`;
rendering fails if one is missing, so a new topic or field cannot go undocumented, and the
test suite runs ``--check`` so the files never go stale.

The package's docs show its own parts only. A user who adds a system from outside the
package (``scenario.system.plugins``) gets the same two files with the plugin's parts in
them, their declared outputs in the topic table and their options in the parameter
tables, with ``--plugins`` (modules or ``.py`` files, as ``system.plugins`` takes them)
and ``--out``.
"""

from __future__ import annotations

import argparse
import difflib
import os
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rclpy.qos import QoSProfile

from phd_swarm.config import flatten, node_params, scenario_to_dict
from phd_swarm.core import registry
from phd_swarm.core.params import ParamSpec
from phd_swarm.nodes import qos, topics
from phd_swarm.sim.presets import PRESETS
from phd_swarm.sim.scenario import TARGET_KINDS

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
    topics.MONITOR_MARKERS: "Cells, goals and extracted estimates; the nodes of a walk's "
                            "grid graph (every 100 steps) and the robots meeting "
                            "(Shirsat & Berman); for RViz2 / Foxglove "
                            "(`markers.team_markers`).",
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
    "preset": f"Preset that the other keys override: {', '.join(PRESETS)}.",
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
    "targets.kind": "True population: static (Dames IV-A), dames_walk (Dames IV-B), "
                    "clustered_walk (Chen Sec. 4), turning_walk (Sung VI-A.4), ncv "
                    "(Papaioannou et al.: nearly constant velocity, births and deaths).",
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
so that a burst is never overwritten before the executor takes it.

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

## Per-robot topics

Each in the robot's namespace `/robot_<id>`.

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


# ---------------------------------------------------------------------------- helpers
def _cell(text: Any) -> str:
    """Text safe inside a Markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _value(value: Any) -> str:
    """A parameter value as written in a YAML parameter file."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f"'{value}'" if value == "" else value
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    return repr(value)


def _missing(what: str, keys: set[str], table: str) -> None:
    if keys:
        raise ValueError(f"{what} without a line in phd_swarm/tools/gen_docs.py {table}: "
                         f"{sorted(keys)}")


# ----------------------------------------------------------------------------- topics
def _documented_parts(plugins: Sequence[str] = ()) -> list[tuple[str, str, Any]]:
    """(role, name, part) of every built-in part, and of the parts ``plugins`` register.

    ``plugins``: modules or ``.py`` files (as ``system.plugins`` lists them), imported here;
    a plugin loaded into this process by other means (a test, a sweep) is not documented.
    """
    registry.load_plugins(plugins)
    # A part belongs to the module that defines its make (as the registry tells owners).
    modules = {registry.plugin_module_name(p) if p.endswith(".py") or "/" in p else p
               for p in plugins}
    out = []
    for role in registry.ROLES:
        for name in registry.names(role):
            part = registry.lookup(role, name)
            module = part.make.__module__
            if module.startswith("phd_swarm.") or module in modules:
                out.append((role, name, part))
    return out


def documented_topics(plugins: Sequence[str] = ()
                      ) -> list[tuple[str, tuple[str, str, str, str], str]]:
    """Every topic as shown in docs/topics.md: name, (type, QoS name, writer, rate), text.

    Team topics first, by their absolute names, then the robot topics as
    ``/robot_<id>/<relative>``: those of every robot, then the outputs the registered parts
    declare (:mod:`phd_swarm.core.outputs`), one row per declaration with the parts that
    make it: the built-in parts and those ``plugins`` register (:func:`_documented_parts`).
    """
    team = [(name, spec, DESCRIPTIONS.get(name, "")) for name, spec in topics.TEAM_TOPICS.items()]
    own = [(ROBOT_PATTERN.format(rel), spec, DESCRIPTIONS.get(ROBOT_PATTERN.format(rel), ""))
           for rel, spec in topics.ROBOT_TOPICS.items()]
    by: dict[Any, dict[str, list[str]]] = {}
    for role, name, part in _documented_parts(plugins):
        for out in part.outputs:
            by.setdefault(out, {}).setdefault(role, []).append(f"`{name}`")

    def makers(roles: dict[str, list[str]]) -> str:
        return "; ".join(f"{role}{'s' if len(n) > 1 else ''} {', '.join(n)}"
                         for role, n in roles.items())

    declared = [(ROBOT_PATTERN.format(o.topic),
                 (o.type, o.qos, "robot", f"{topics.output_rate(o)} ({makers(roles)})"),
                 o.description) for o, roles in sorted(by.items(), key=lambda i: i[0].topic)]
    return team + own[:-1] + declared + own[-1:]


def _depths(writer: QoSProfile, reader: QoSProfile) -> str:
    if writer.depth == reader.depth:
        return f"depth {writer.depth}"
    return f"depth {writer.depth} (writer) / {reader.depth} (reader)"


def qos_summary(name: str) -> str:
    """One-line meaning of the QoS named ``name`` (a key of :data:`qos.BY_NAME`).

    E.g. ``reliable, transient local, depth 16 (writer) / 1000 (reader)``.
    """
    writer, reader = qos.BY_NAME[name]
    if (writer.reliability, writer.durability) != (reader.reliability, reader.durability):
        return (f"writer {_policy(writer)}, {_depths(writer, writer)}; reader "
                f"{_policy(reader)}, {_depths(reader, reader)}")
    return f"{_policy(writer)}, {_depths(writer, reader)}"


def _policy(p: QoSProfile) -> str:
    return (f"{p.reliability.name.lower().replace('_', ' ')}, "
            f"{p.durability.name.lower().replace('_', ' ')}")


def _plugin_sources(plugins: Sequence[str]) -> str:
    """What the generated line adds for ``plugins`` (nothing without)."""
    return f" and the plugins {', '.join(plugins)}" if plugins else ""


def render_topics(plugins: Sequence[str] = ()) -> str:
    """The text of docs/topics.md; with ``plugins``, their parts' outputs too."""
    shown = documented_topics(plugins)
    _missing("topics", {n for n, _, text in shown if not text}, "DESCRIPTIONS")
    _missing("inbox kinds", set(topics.INBOX) - set(INBOX_KINDS), "INBOX_KINDS")
    header = ("topic", "type", "QoS", "writer", "rate", "description")

    def rows(names: list[tuple[str, tuple[str, str, str, str], str]]) -> list[list[str]]:
        return [[f"`{name}`", f"`{typ}`", f"`{q}`: {qos_summary(q)}", writer, rate, text]
                for name, (typ, q, writer, rate), text in names]

    n_team = len(topics.TEAM_TOPICS)
    used = {q for _, (_, q, _, _), _ in shown}
    qos_rows = []
    for name, (writer, reader) in qos.BY_NAME.items():
        qos_rows.append([f"`{name}`", _policy(writer), writer.depth, _policy(reader),
                         reader.depth, "yes" if name in used else "no"])
    qos_table = _table(("name", "writer", "writer depth", "reader", "reader depth",
                        "used by a topic"), qos_rows)
    return TOPICS_TEMPLATE.format(
        generated=_GENERATED.format(
            sources="phd_swarm/nodes/topics.py, qos.py and the parts' declared outputs"
                    + _plugin_sources(plugins)),
        team_table=_table(header, rows(shown[:n_team])),
        robot_table=_table(header, rows(shown[n_team:])),
        inbox_table=_table(("kind", "type", "carries"),
                           [[f"`{k}`", f"`{topics.INBOX[k]}`", text]
                            for k, text in INBOX_KINDS.items()]),
        qos_table=qos_table)


# ------------------------------------------------------------------------- parameters
_ROS_TYPE = {bool: "bool", int: "integer", float: "double", str: "string"}


def _range(spec: ParamSpec) -> str:
    if spec.choices:
        return "one of " + ", ".join(spec.choices)
    if spec.low is not None and spec.high is not None:
        return f"[{_value(spec.default.__class__(spec.low))}, " \
               f"{_value(spec.default.__class__(spec.high))}]"
    if spec.low is not None:
        return f">= {_value(spec.low)}"
    if spec.high is not None:
        return f"<= {_value(spec.high)}"
    return ""


def scenario_defaults() -> dict[str, dict[str, Any]]:
    """Preset name -> its flattened scenario parameters (keys without ``scenario.``)."""
    return {name: flatten(scenario_to_dict(make())) for name, make in PRESETS.items()}


def _kinds_using(key: str, meaning: str) -> set[str] | None:
    """Target kinds a ``targets.*`` field applies to (None: every preset).

    Read from the clauses of its meaning: ``"dames_walk: ..."``,
    ``"static: ...; dames_walk: ..."``.
    """
    if not key.startswith("targets.") or key == "targets.kind":
        return None
    kinds = set(re.findall(r"(?:^|; )(\w+): ", meaning)) & set(TARGET_KINDS)
    return kinds or None


def render_parameters(plugins: Sequence[str] = ()) -> str:
    """The text of docs/parameters.md; with ``plugins``, their parts and options too."""
    tables = []
    for heading, block, specs in NODE_TABLES:
        rows = [[f"`{s.name}`", _ROS_TYPE[type(s.default)], f"`{_value(s.default)}`",
                 _range(s), "yes" if s.read_only else "no", s.description] for s in specs]
        tables.append(f"### {heading}\n\nConfig-file block `{block}`.\n\n"
                      + _table(("name", "type", "default", "range", "read-only",
                                "description"), rows))

    defaults = scenario_defaults()
    # A preset's part options are listed with the parts (the options table below).
    keys = {k for flat in defaults.values() for k in flat if not k.startswith("system.options.")}
    _missing("scenario keys", keys - set(SCENARIO_MEANINGS), "SCENARIO_MEANINGS")
    rows = []
    for key, meaning in SCENARIO_MEANINGS.items():
        if key not in keys:
            continue
        kinds = _kinds_using(key, meaning)
        values = [f"`{_value(flat[key])}`"
                  if key in flat and (kinds is None or flat["targets.kind"] in kinds) else "-"
                  for flat in defaults.values()]
        rows.append([f"`scenario.{key}`", *values, meaning])
    scenario_table = _table(("parameter", *defaults, "meaning"), rows)
    # The package's own parts (and those of the plugins asked for): a plugin a test or
    # sweep has loaded into this process is not part of the docs.
    parts = [part for _, _, part in _documented_parts(plugins)]
    parts_table = _table(("role", "name", "options", "provides", "requires", "description"),
                         [[p.role, f"`{p.name}`",
                           ", ".join(f"`{o.name}`" for o in p.options) or "-",
                           ", ".join(sorted(p.provides)) or "-",
                           ", ".join(sorted(p.requires)) or "-", p.description]
                          for p in parts])
    options = {o.name: o for p in parts for o in p.options}
    options_table = _table(("option", "type", "default", "range", "description"),
                           [[f"`scenario.system.options.{o.name}`", _ROS_TYPE[type(o.default)],
                             f"`{_value(o.default)}`", _range(o), o.description]
                            for o in sorted(options.values(), key=lambda o: o.name)])
    return PARAMETERS_TEMPLATE.format(
        generated=_GENERATED.format(sources="phd_swarm/config/node_params.py, the scenario "
                                            "presets and the registry"
                                            + _plugin_sources(plugins)),
        node_tables="\n\n".join(tables), scenario_table=scenario_table,
        parts_table=parts_table, options_table=options_table)


# ------------------------------------------------------------------------------ files
#: Generated files, relative to the repository root, and their renderers.
FILES: dict[str, Callable[..., str]] = {
    "docs/topics.md": render_topics,
    "docs/parameters.md": render_parameters,
}


def generate() -> dict[str, str]:
    """Relative path -> the text it should have."""
    return {path: render() for path, render in FILES.items()}


def write_with_plugins(out: Path, plugins: Sequence[str]) -> list[Path]:
    """Write topics.md and parameters.md of the built-in parts and ``plugins`` into ``out``.

    ``plugins``: modules or ``.py`` files that register parts (as ``system.plugins``).
    Returns the files written.
    """
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for path, render in FILES.items():
        target = out / Path(path).name
        target.write_text(render(plugins))
        written.append(target)
    return written


def check(root: Path, max_lines: int = 40) -> list[str]:
    """Differences between the files under ``root`` and what would be generated.

    Returns
    -------
    list of str
        Empty when every file is up to date; else, per stale file, a summary line and the
        first ``max_lines`` lines of a unified diff (file on disk -> generated).
    """
    out: list[str] = []
    for path, text in generate().items():
        target = root / path
        current = target.read_text() if target.exists() else None
        if current == text:
            continue
        if current is None:
            out.append(f"{path}: missing")
            continue
        diff = list(difflib.unified_diff(current.splitlines(), text.splitlines(),
                                         f"{path} (on disk)", f"{path} (generated)",
                                         lineterm=""))
        changed = sum(1 for d in diff if d[:1] in "+-" and d[:3] not in ("+++", "---"))
        out.append(f"{path}: out of date ({changed} lines differ)")
        out.extend(diff[:max_lines])
        if len(diff) > max_lines:
            out.append(f"... {len(diff) - max_lines} more diff lines")
    return out


def write(root: Path) -> list[Path]:
    """Write every generated file under ``root``; returns the files that changed."""
    changed = []
    for path, text in generate().items():
        target = root / path
        if not target.exists() or target.read_text() != text:
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(text)
            changed.append(target)
    return changed


def main(argv: Sequence[str] | None = None) -> int:
    """Command line; returns the exit code (1 if ``--check`` finds stale files)."""
    parser = argparse.ArgumentParser(prog="python -m phd_swarm.tools.gen_docs",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true",
                        help="do not write; exit 1 and show a diff if a file is stale")
    parser.add_argument("--root", type=Path,
                        default=Path(os.environ.get("PHD_SWARM_ROOT", ".")),
                        help="repository root (default: $PHD_SWARM_ROOT, set by "
                             "scripts/env.sh, else the current directory)")
    parser.add_argument("--plugins", nargs="+", default=[], metavar="PLUGIN",
                        help="also document the parts these modules or .py files register "
                             "(with --out; the package's docs show its own parts only)")
    parser.add_argument("--out", type=Path,
                        help="with --plugins: the directory to write topics.md and "
                             "parameters.md into")
    args = parser.parse_args(argv)
    if args.plugins or args.out is not None:
        if args.check or not args.plugins or args.out is None:
            parser.error("--plugins and --out go together, without --check (docs/ shows "
                         "the package's own parts)")
        try:
            written = write_with_plugins(args.out, args.plugins)
        except registry.RegistryError as exc:
            parser.error(str(exc))
        print("\n".join(f"wrote {p}" for p in written))
        return 0
    if args.check:
        problems = check(args.root)
        if problems:
            print("\n".join(problems))
            print("run `python -m phd_swarm.tools.gen_docs` to regenerate", file=sys.stderr)
            return 1
        print(f"{', '.join(FILES)}: up to date")
        return 0
    changed = write(args.root)
    print("\n".join(f"wrote {p}" for p in changed) or "nothing to do: up to date")
    return 0


if __name__ == "__main__":
    sys.exit(main())
