"""The processes of a run, as one plain list: what ``run_swarm.sh`` and the launch files start.

:func:`swarm_plan` turns a resolved run config and the run's options into a
:class:`SwarmPlan`: the resolved parameter file to write, the environment (DDS kept on
loopback as ``run_swarm`` chooses it) and the processes in start order, each a
:class:`NodeProcess` (console script and module, node name, namespace, parameter file,
parameter overrides, up marker). :mod:`phd_swarm.tools.run_swarm` starts them as child
processes; ``launch/swarm.launch.py`` turns the same list into ``launch_ros`` ``Node``
actions (:mod:`phd_swarm.tools.launch_actions`), so the two cannot drift.
:func:`world_process` and :func:`robot_process` are the single processes of
``scripts/run_world.sh`` / ``world.launch.py`` and ``scripts/run_robot.sh`` /
``robot.launch.py``.

No process lists topics: every node learns them from the config (the parts of its
system declare their outputs, :func:`phd_swarm.nodes.topics.declared_outputs`).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from phd_swarm.config import RunConfig, load_run_config
from phd_swarm.logs.mcap_log import LogError, read_metadata
from phd_swarm.nodes.auth import write_key
from phd_swarm.nodes.completeness import Completeness, verdict_window
from phd_swarm.nodes.ros_params import ros_refusal
from phd_swarm.nodes.topics import robot_namespace
from phd_swarm.tools.dds import CLIENT_VARS, dds_env
from phd_swarm.tools.hosts import HostLayout

#: The package's console scripts (setup.py ``console_scripts``, installed by colcon into
#: ``lib/phd_swarm/`` where ``ros2 run`` finds them) that start nodes: executable -> module
#: whose ``main()`` it runs.
NODE_EXECUTABLES = {
    "world": "phd_swarm.nodes.world",
    "robot": "phd_swarm.nodes.robot",
    "team": "phd_swarm.nodes.team",
    "monitor": "phd_swarm.nodes.monitor",
    "recorder": "phd_swarm.nodes.recorder",
    "viewer": "phd_swarm.nodes.viewer",
}

#: The package's tools as console scripts: executable -> module whose ``main()`` it runs.
TOOL_EXECUTABLES = {
    "run_swarm": "phd_swarm.tools.run_swarm",
    "check_config": "phd_swarm.tools.check_config",
    "evaluate": "phd_swarm.tools.evaluate",
    "replay": "phd_swarm.tools.replay",
    "sweep": "phd_swarm.tools.sweep",
    "log_check": "phd_swarm.tools.log_check",
    "view_server": "phd_swarm.tools.view_server",
}

#: With ``--discovery-server auto`` (the default), start phd_swarm's discovery server above
#: this many processes. 50 robot processes, 2 steps: ready in 17 s instead of 61 s on 2
#: cores, 29 s instead of 110 s on one (docs/deployment.md). Smaller runs keep simple
#: discovery, which the ROS docs and the ros2 CLI expect.
AUTO_SERVER_PROCESSES = 30

#: With ``--dds auto``, use the repository's Fast DDS profile above this many processes:
#: Jazzy's LOCALHOST discovery probes 32 participant ports per host (docs/deployment.md).
AUTO_PROFILE_PROCESSES = 30

#: Log lines that say the recorder and the monitor are up (their subscriptions made).
RECORDER_UP = "recording "
MONITOR_UP = "monitor: watching "

#: Start-up allowance per process [s]: the least ``ready_timeout`` of the world and the
#: robots is this times the number of processes. 53 processes (50 robots) took ~130 s from
#: the first robot's start to the world's step 0 on 2 cores (docs/deployment.md).
STARTUP_S_PER_PROCESS = 3.0

#: Seconds a process gets to stop after SIGINT before it is killed, when a run is stopped.
STOP_GRACE = 6.0

#: Seconds the recorder gets to finish its log after SIGINT: it may wait up to 10 s for late
#: step messages (recorder ``SETTLE_MAX``), and a killed recorder loses its last chunk. With
#: 6 s, an interrupted run in the test suite once lost a robot's last two statuses.
RECORDER_STOP_GRACE = 30.0

#: ROS_DOMAIN_ID of a run when the caller has none (as scripts/env.sh).
DEFAULT_DOMAIN_ID = "42"

#: The run's key in its folder (nodes/auth.py): made by whoever starts the run.
KEY_FILE = "run.key"


@dataclass(frozen=True)
class NodeProcess:
    """One process of a run: ``python -m module`` or the console script ``executable``.

    Attributes
    ----------
    name : str
        The process's name in the run (its log: ``logs/<name>.log``): ``world``,
        ``robot_3``, ``robots_0-9``.
    executable : str
        Its console script (``ros2 run phd_swarm <executable>``).
    module : str
        The module whose ``main()`` the executable runs (``python -m <module>``).
    node_name : str or None
        The name of its one node; None for a process of several (a team).
    namespace : str or None
        Its node's namespace (``/robot_3``), set with ``-r __ns:=``.
    ros_prefix : tuple of str
        ROS arguments every process of the run gets first: the parameter file.
    parameters : tuple of (str, str)
        Parameter overrides (``-p name:=value``), after the parameter file.
    arguments : tuple of str
        Program arguments before ``--ros-args`` (a team's ``--ids 0-9``).
    up_marker : str or None
        Text of the log line that says the process is up.
    echo : bool
        Whether its progress lines are shown (world, monitor).
    nice : int
        Its niceness (robot processes, ``--robot-nice``).
    stop_grace : float
        Seconds it gets after SIGINT before it is killed [s].
    host : str or None
        The host it runs on (``--hosts``; None: this machine).
    prefix : tuple of str
        Words put before its command to run it on its host (``ip netns exec NS``).
    env : tuple of (str, str)
        Variables added to the run's environment for it (its host's DDS profile).
    """

    name: str
    executable: str
    node_name: str | None = None
    namespace: str | None = None
    ros_prefix: tuple[str, ...] = ()
    parameters: tuple[tuple[str, str], ...] = ()
    arguments: tuple[str, ...] = ()
    up_marker: str | None = None
    echo: bool = False
    nice: int = 0
    stop_grace: float = STOP_GRACE
    host: str | None = None
    prefix: tuple[str, ...] = ()
    env: tuple[tuple[str, str], ...] = ()

    @property
    def module(self) -> str:
        """The module whose ``main()`` the executable runs."""
        return NODE_EXECUTABLES[self.executable]

    def ros_args(self) -> list[str]:
        """The arguments after ``--ros-args``: parameter file, namespace, overrides."""
        out = list(self.ros_prefix)
        if self.namespace:
            out += ["-r", f"__ns:={self.namespace}"]
        for name, value in self.parameters:
            out += ["-p", f"{name}:={value}"]
        return out

    def argv(self) -> list[str]:
        """The command line after the program: ``arguments --ros-args ros_args()``."""
        return [*self.arguments, "--ros-args", *self.ros_args()]


def params_args(params: str | Path | None) -> tuple[str, ...]:
    """``("--params-file", params)``, or nothing without a file."""
    return () if params is None else ("--params-file", str(params))


def world_process(params: str | Path | None) -> NodeProcess:
    """The world simulator, node ``/world`` (``scripts/run_world.sh``, ``world.launch.py``)."""
    return NodeProcess("world", "world", node_name="world", ros_prefix=params_args(params),
                       echo=True)


def robot_process(robot_id: int, params: str | Path | None,
                  ros_prefix: Sequence[str] | None = None, nice: int = 0) -> NodeProcess:
    """Robot ``robot_id``: node ``robot`` in ``/robot_<id>`` (``scripts/run_robot.sh``).

    ``ros_prefix`` replaces the parameter file's arguments when given (``run_swarm``'s
    common arguments). Up once it logged that its system is built.
    """
    prefix = params_args(params) if ros_prefix is None else tuple(ros_prefix)
    return NodeProcess(f"robot_{robot_id}", "robot", node_name="robot",
                       namespace=robot_namespace(robot_id), ros_prefix=prefix,
                       parameters=(("robot_id", str(int(robot_id))),),
                       up_marker=f"robot {robot_id}: system ", nice=nice)


def robot_processes(robots: int | Sequence[int], per: int, ros_prefix: Sequence[str],
                    nice: int = 0) -> list[NodeProcess]:
    """The robot processes of a team: one per robot, or ``per`` per process.

    ``robots``: the team size (ids ``0..robots-1``), or the ids themselves (a host's
    robots, ``--hosts``). A process of several robots runs :mod:`phd_swarm.nodes.team`
    (``--ids a-b``, or ``--ids a,b,c`` for ids that are not a range), each node in its own
    namespace; it is up when its last robot is.
    """
    ids = list(range(robots)) if isinstance(robots, int) else [int(i) for i in robots]
    step = max(1, per)
    out = []
    for k in range(0, len(ids), step):
        group = ids[k:k + step]
        first, last = group[0], group[-1]
        if per <= 1:
            out.append(robot_process(first, None, ros_prefix, nice))
            continue
        spec = (f"{first}-{last}" if group == list(range(first, last + 1))
                else ",".join(map(str, group)))
        out.append(NodeProcess(f"robots_{first}-{last}", "team",
                               ros_prefix=tuple(ros_prefix), arguments=("--ids", spec),
                               up_marker=f"robot {last}: system ", nice=nice))
    return out


def observer_processes(params: str | Path, record: bool) -> list[NodeProcess]:
    """The recorder (if ``record``) and the monitor, started and up before the robots."""
    out = []
    if record:
        out.append(NodeProcess("recorder", "recorder", node_name="recorder",
                               ros_prefix=params_args(params), up_marker=RECORDER_UP,
                               stop_grace=RECORDER_STOP_GRACE))
    out.append(NodeProcess("monitor", "monitor", node_name="monitor",
                           ros_prefix=params_args(params), up_marker=MONITOR_UP, echo=True))
    return out


def find_config(path: str | Path) -> Path:
    """A config file: ``path`` as given, else the installed ``share/phd_swarm/config/<path>``.

    So ``ros2 launch phd_swarm swarm.launch.py config:=dames_static.yaml`` works from any
    directory. ValueError naming both places if neither exists.
    """
    given = Path(path).expanduser()
    if given.is_file() or given.is_absolute():
        return given.resolve()
    try:
        from ament_index_python.packages import (
            PackageNotFoundError,
            get_package_share_directory,
        )

        shared = Path(get_package_share_directory("phd_swarm")) / "config" / given
    except (ImportError, PackageNotFoundError):
        shared = None
    if shared is not None and shared.is_file():
        return shared
    where = f" nor {shared}" if shared is not None else ""
    raise ValueError(f"config {path}: no such file (neither {given.resolve()}{where})")


def resolve_config(config: str | Path, *, robots: int | None = None,
                   targets: int | None = None, duration: float | None = None,
                   seed: int | None = None, controller: str | None = None,
                   realtime: bool = False, robot: Mapping[str, Any] | None = None
                   ) -> RunConfig:
    """The config ``config`` with a run's overrides applied (ValueError on bad values).

    ``targets`` spreads a clustered population over its clusters; ``robot``: robot node
    parameters (the fault options); ``realtime``: the world's ``mode``. In real time (by
    ``realtime`` or the config's own ``mode``) the robots' ``revive_every`` is the world's
    ``step_timeout`` in steps, unless the config or ``robot`` sets it
    (:mod:`phd_swarm.nodes.silence`), and the monitor's ``verdict_window`` is the world's
    (:func:`phd_swarm.nodes.completeness.verdict_window`), unless the config sets it.
    """
    rc = load_run_config(config)
    s = rc.scenario
    changes: dict[str, Any] = {}
    if robots is not None:
        changes["robots"] = robots
    if duration is not None:
        changes["duration"] = duration
    if seed is not None:
        changes["seed"] = seed
    if targets is not None:
        t = s.targets
        if t.kind == "clustered_walk" and t.per_cluster:
            n = len(t.per_cluster)
            per = tuple(targets // n + (1 if i < targets % n else 0) for i in range(n))
            changes["targets"] = replace(t, count=targets, per_cluster=per)
        else:
            changes["targets"] = replace(t, count=targets)
    try:
        scenario = s.with_overrides(**changes) if changes else s
        if controller:
            scenario = scenario.with_system(controller=controller)
    except ValueError as exc:
        raise ValueError(f"{config}: command-line override: {exc}") from None
    refusal = ros_refusal(scenario.system)
    if refusal:
        raise ValueError(f"{config}: scenario.system: {refusal}")
    world = {"mode": "realtime"} if realtime else {}
    robot = dict(robot or {})
    if (realtime or rc.param("world", "mode") == "realtime") and "revive_every" not in robot \
            and "revive_every" not in rc.nodes.get("robot", {}):
        wall_dt = scenario.dt / float(rc.param("world", "realtime_factor"))
        robot["revive_every"] = max(1, math.ceil(float(rc.param("world", "step_timeout"))
                                                 / wall_dt))
    out = rc.with_overrides(scenario, robot=robot, world=world)
    window = verdict_window(out)
    if window == 1 or "verdict_window" in rc.nodes.get("monitor", {}):
        return out
    return out.with_overrides(monitor={"verdict_window": window})


def run_name(rc: RunConfig) -> str:
    """The default name of a run: ``<scenario>-<controller>-r<robots>-s<seed>``."""
    s = rc.scenario
    return f"{s.name}-{s.system.label()}-r{s.robots}-s{s.seed}"


def fresh_run_dir(parent: Path, name: str) -> Path:
    """``parent/name``, or ``name-2``, ``name-3``... so no earlier run is overwritten."""
    path, n = parent / name, 1
    while path.exists():
        n += 1
        path = parent / f"{name}-{n}"
    path.mkdir(parents=True)
    return path


def ready_timeouts(rc: RunConfig, processes: int) -> dict[str, float]:
    """The world's and the robots' ``ready_timeout`` for a run of ``processes`` processes.

    Start-up takes longer with more processes (imports, then DDS discovery, CPU-bound on a
    small machine): where the config leaves a ``ready_timeout`` at its default, it is at
    least :data:`STARTUP_S_PER_PROCESS` x ``processes``, so that a large team is not given
    up on while it is still coming up. A ``ready_timeout`` the config sets is kept.
    """
    allowance = STARTUP_S_PER_PROCESS * processes
    out = {}
    for kind in ("world", "robot"):
        value = float(rc.param(kind, "ready_timeout"))
        out[kind] = value if "ready_timeout" in rc.nodes.get(kind, {}) else max(value,
                                                                                allowance)
    return out


@dataclass(frozen=True)
class SwarmOptions:
    """How a run is laid out: processes, recording, discovery (``run_swarm.sh`` options)."""

    robots_per_process: int = 1
    record: bool = True
    record_inboxes: bool = False
    #: ``auto`` (the repository's Fast DDS profile above :data:`AUTO_PROFILE_PROCESSES`),
    #: ``localhost`` or ``profile``.
    dds: str = "auto"
    #: ``auto`` (above :data:`AUTO_SERVER_PROCESSES`), ``on`` or ``off``.
    discovery_server: str = "auto"
    robot_nice: int = 0
    #: Where the processes run (``--hosts``): None for this machine, on loopback.
    hosts: HostLayout | None = None
    #: A live view's viewer node is one more observer of the world (``--view``).
    view: bool = False


@dataclass(frozen=True)
class SwarmPlan:
    """A whole run: its resolved config, environment and processes in start order.

    Attributes
    ----------
    rc : RunConfig
        The resolved config with the run's node parameters (observers, ready timeouts,
        output paths); write it to :attr:`params` before starting anything.
    run_dir : Path
        The run's directory (``summary.json``, ``run.mcap``, ``config.yaml``, ``logs/``).
    params : Path
        The resolved parameter file every process reads (``run_dir/config.yaml``).
    env : dict
        The processes' environment: the caller's, DDS on loopback (Jazzy's LOCALHOST, or
        the repository's profile for large runs), ``ROS_DOMAIN_ID`` (the caller's, else
        42), no discovery-server client variables.
    use_server : bool
        Whether the run needs phd_swarm's discovery server on 127.0.0.1.
    observers, robots : tuple of NodeProcess
        Started first and up (their up markers) before the robots; then the robots.
    world : NodeProcess
        Started last: it waits for every robot and observer to be ready.
    hosts : HostLayout or None
        The hosts the processes are placed on (``--hosts``), None on this machine.
    files : dict
        Files to write before starting anything: each host's Fast DDS profile.
    key : Path or None
        The run's key to make before starting anything (``auth.write_key``, mode 0600), which
        the shared parameter ``auth_key_file`` names; None if the config names its own.
    """

    rc: RunConfig
    run_dir: Path
    params: Path
    env: dict[str, str] = field(repr=False)
    use_server: bool
    observers: tuple[NodeProcess, ...]
    robots: tuple[NodeProcess, ...]
    world: NodeProcess
    hosts: HostLayout | None = None
    files: dict[Path, str] = field(default_factory=dict, repr=False)
    key: Path | None = None

    @property
    def processes(self) -> tuple[NodeProcess, ...]:
        """Every process, in start order."""
        return (*self.observers, *self.robots, self.world)

    def write_files(self) -> None:
        """Write what the processes read before any starts: parameters, profiles, the key."""
        self.rc.write_params(self.params)
        for path, text in self.files.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        if self.key is not None:
            write_key(self.key)

    def env_changes(self, base: Mapping[str, str]) -> tuple[dict[str, str], list[str]]:
        """What :attr:`env` sets and unsets relative to ``base``: ``(set, unset)``."""
        changed = {k: v for k, v in self.env.items() if base.get(k) != v}
        return changed, sorted(k for k in base if k not in self.env)


def swarm_plan(rc: RunConfig, run_dir: Path, options: SwarmOptions | None = None,
               base_env: Mapping[str, str] | None = None) -> SwarmPlan:
    """The processes of a run of ``rc`` into ``run_dir`` (``run_swarm.sh`` and swarm.launch.py).

    The world and the robots wait for ``observers`` (the monitor, and the recorder when
    recording; the world also for the viewer with ``options.view``); their
    ``ready_timeout`` grows with the number of processes (:func:`ready_timeouts`); the
    monitor writes ``summary.json`` and exits when done; the recorder writes ``run.mcap``
    for the config's team (``discover`` off). Above 30 processes DDS uses the
    repository's profile and a discovery server (``options``).
    ``base_env``: the caller's environment (default ``os.environ``).
    """
    options = SwarmOptions() if options is None else options
    s = rc.scenario
    record = options.record
    observers = 2 if record else 1
    per = max(1, options.robots_per_process)
    processes = -(-s.robots // per) + 2 + int(record)
    ready = ready_timeouts(rc, processes)
    params = run_dir / "config.yaml"
    # A key of its own per run (nodes/auth.py), unless the config names one.
    key = None if rc.param("robot", "auth_key_file") else run_dir / KEY_FILE
    if key is not None:
        rc = replace(rc, shared={**rc.shared, "auth_key_file": str(key)})
    rc = rc.with_overrides(
        world={"observers": observers + int(options.view), "ready_timeout": ready["world"]},
        robot={"observers": observers, "ready_timeout": ready["robot"]},
        monitor={"summary_path": str(run_dir / "summary.json"), "exit_when_done": True},
        recorder={"output": str(run_dir / "run.mcap"), "params_file": str(params),
                  "discover": False, "record_inboxes": bool(options.record_inboxes)})
    use_server = options.discovery_server == "on" or (
        options.discovery_server == "auto" and processes > AUTO_SERVER_PROCESSES)
    # The server's clients use the profile's transport too: UDP bound to 127.0.0.1.
    env = dds_env(os.environ if base_env is None else base_env,
                  use_server or options.dds == "profile"
                  or (options.dds == "auto" and processes > AUTO_PROFILE_PROCESSES))
    env.setdefault("ROS_DOMAIN_ID", DEFAULT_DOMAIN_ID)
    env["PYTHONUNBUFFERED"] = "1"
    for var in CLIENT_VARS:
        env.pop(var, None)
    common = params_args(params)
    plan = SwarmPlan(rc=rc, run_dir=run_dir, params=params, env=env, use_server=use_server,
                     observers=tuple(observer_processes(params, record)),
                     robots=tuple(robot_processes(s.robots, per, common,
                                                  options.robot_nice)),
                     world=world_process(params), key=key)
    return plan if options.hosts is None else on_hosts(plan, options.hosts, per,
                                                       options.robot_nice)


def on_hosts(plan: SwarmPlan, layout: HostLayout, per: int, nice: int = 0) -> SwarmPlan:
    """``plan`` with its processes placed on ``layout``'s hosts (``run_swarm.sh --hosts``).

    The world, monitor and recorder on the observers' host, the robots on theirs
    (:meth:`HostLayout.robot_hosts`), each process with its host's prefix and its host's
    Fast DDS profile (written to ``run_dir/dds/<host>.xml``); a discovery server, if the
    layout asks for one, on the observers' host. ValueError if the layout does not fit the
    team.
    """
    placed = layout.robot_hosts(plan.rc.scenario.robots)
    files = {plan.run_dir / "dds" / f"{h.name}.xml": layout.profile(h.name)
             for h in layout.hosts}

    def place(p: NodeProcess, host: str) -> NodeProcess:
        profile = str(plan.run_dir / "dds" / f"{host}.xml")
        return replace(p, host=host, prefix=layout.host(host).run,
                       env=(("FASTRTPS_DEFAULT_PROFILES_FILE", profile),
                            ("FASTDDS_DEFAULT_PROFILES_FILE", profile)))

    env = {k: v for k, v in plan.env.items()
           if k not in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")}
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"
    common = params_args(plan.params)
    robots = [place(p, host) for host, ids in placed.items()
              for p in robot_processes(ids, per, common, nice)]
    return replace(plan, env=env, use_server=layout.discovery == "server", hosts=layout,
                   files=files,
                   observers=tuple(place(p, layout.observers) for p in plan.observers),
                   robots=tuple(robots), world=place(plan.world, layout.observers))


def node_env(base: Mapping[str, str]) -> dict[str, str]:
    """What a single node started by hand sets (as ``scripts/env.sh``): ``{name: value}``.

    DDS on loopback (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) and ``ROS_DOMAIN_ID`` 42
    unless the caller chose others (a multi-host run sets the range explicitly,
    docs/deployment.md).
    """
    return {"ROS_AUTOMATIC_DISCOVERY_RANGE": base.get("ROS_AUTOMATIC_DISCOVERY_RANGE")
            or "LOCALHOST",
            "ROS_DOMAIN_ID": base.get("ROS_DOMAIN_ID") or DEFAULT_DOMAIN_ID,
            "PYTHONUNBUFFERED": "1"}


def log_completeness(mcap: Path) -> Completeness | None:
    """The recorder's completeness report stored in ``mcap`` (None if there is none)."""
    try:
        meta = read_metadata(mcap).get("phd_swarm.completeness")
    except (LogError, OSError):
        return None
    return None if meta is None else Completeness.from_dict(json.loads(meta["report"]))


def finish_summary(summary: dict[str, Any], rc: RunConfig, run_dir: Path
                   ) -> Completeness | None:
    """Add the run's own fields to the monitor's ``summary`` (in place); returns the report.

    ``log_completeness`` (the recorder's report read back from ``run.mcap``, None without
    a log), ``controller``, ``system``, ``mode``, ``complete`` (every step of the scenario
    was run) and ``run_dir``.
    """
    mcap = run_dir / "run.mcap"
    report = log_completeness(mcap) if mcap.exists() else None
    summary["log_completeness"] = None if report is None else report.to_dict()
    summary.update({"controller": rc.scenario.system.controller,
                    "system": rc.scenario.system.to_dict(),
                    "mode": rc.param("world", "mode"),
                    "complete": summary["steps"] == rc.scenario.steps,
                    "run_dir": str(run_dir)})
    return report
