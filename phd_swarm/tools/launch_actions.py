"""``launch`` actions for a run's plan: what the launch files of ``launch/`` return.

The processes, their parameters and environment come from :mod:`phd_swarm.tools.launch_plan`,
which ``run_swarm.sh`` starts too; this module only turns them into ``launch_ros`` ``Node``
actions (``ros2 run``'s executables, found in ``lib/phd_swarm/``) and keeps
``run_swarm``'s order and end of a run:

1. the environment of the plan (DDS on loopback, ``ROS_DOMAIN_ID``), and phd_swarm's
   discovery server first when the run is large enough to need it;
2. the observers (recorder, monitor), then, once each printed its up marker (or after
   :data:`OBSERVERS_UP_TIMEOUT` s, or when one exited), the robots and the world;
3. when the monitor has written ``summary.json`` and exited, a shutdown (every process
   gets SIGINT; the recorder closes its log); when the recorder has exited, the run's own
   fields are added to ``summary.json`` (:func:`finish_run`). If the team never comes up
   (the world's exit code 3) the launch shuts down at once; if the world ends and the
   monitor does not, after the monitor's ``end_timeout`` + 15 s.

Imported only by the launch files: ``launch`` and ``launch_ros`` are exec_depends of the
package (a native install has them; tests install them, ``scripts/ros2_tools.sh``).
"""

from __future__ import annotations

import json
import shlex
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from launch.actions import (
    EmitEvent,
    ExecuteProcess,
    LogInfo,
    OpaqueFunction,
    RegisterEventHandler,
    SetEnvironmentVariable,
    TimerAction,
    UnsetEnvironmentVariable,
)
from launch.event_handlers import OnProcessExit, OnProcessIO
from launch.events import Shutdown
from launch.launch_context import LaunchContext
from launch_ros.actions import Node

from phd_swarm.config import RunConfig, load_run_config
from phd_swarm.logs.bag_metadata import write_bag_metadata
from phd_swarm.logs.mcap_log import LogError
from phd_swarm.nodes.world import EXIT_NOT_READY
from phd_swarm.tools.dds import free_udp_port, server_env, server_profile
from phd_swarm.tools.discovery_server import UP as SERVER_UP
from phd_swarm.tools.hosts import load_layout
from phd_swarm.tools.launch_plan import (
    NodeProcess,
    SwarmOptions,
    SwarmPlan,
    find_config,
    finish_summary,
    fresh_run_dir,
    node_env,
    resolve_config,
    run_name,
    swarm_plan,
)

PACKAGE = "phd_swarm"

#: How long the robots' start waits for the observers to be up [s] (as run_swarm).
OBSERVERS_UP_TIMEOUT = 60.0

#: How long the run's start waits for the discovery server's up line [s].
SERVER_UP_TIMEOUT = 60.0

#: The arguments of ``swarm.launch.py``: name -> (default, description). ``config`` has no
#: default: it must be given.
SWARM_ARGUMENTS = {
    "config": (None, "the run's config file: a path, or the name of a file of "
                     "share/phd_swarm/config/ (dames_static.yaml)"),
    "robots": ("", "team size (default: the config's scenario.robots)"),
    "targets": ("", "number of (initial) targets (default: the config's)"),
    "duration": ("", "sim time [s] (default: the config's)"),
    "seed": ("", "random seed (default: the config's)"),
    "controller": ("", "the system's controller (default: the config's)"),
    "realtime": ("false", "fixed-rate steps instead of lockstep"),
    "record": ("true", "write run.mcap (the recorder)"),
    "record_inboxes": ("false", "also record the protocol traffic (/robot_*/inbox)"),
    "robots_per_process": ("1", "robot nodes per process (the team executable above 1)"),
    "dds": ("auto", "DDS on loopback: auto (the repository's Fast DDS profile above 30 "
                    "processes), localhost or profile"),
    "discovery_server": ("auto", "phd_swarm's discovery server on 127.0.0.1: auto (above 30 "
                                 "processes), on or off"),
    "hosts": ("", "a hosts layout file: place the processes on several hosts "
                  "(docs/deployment.md, \"Several machines\")"),
    "out": ("runs", "parent directory of the run"),
    "name": ("", "run name (default <scenario>-<controller>-r<N>-s<seed>)"),
}


def _flag(value: str, name: str) -> bool:
    """A launch argument's boolean: true/false (also 1/0, yes/no)."""
    text = value.strip().lower()
    if text in ("true", "1", "yes", "on"):
        return True
    if text in ("false", "0", "no", "off"):
        return False
    raise ValueError(f"launch argument {name}: expected true or false, got {value!r}")


def _number(value: str, name: str, kind: Callable[[str], Any]) -> Any:
    """A launch argument's number, or None when it is empty (the config's value)."""
    if not value.strip():
        return None
    try:
        return kind(value)
    except ValueError:
        raise ValueError(f"launch argument {name}: expected a number, got {value!r}") from None


def plan_from_arguments(values: Mapping[str, str], base_env: Mapping[str, str]) -> SwarmPlan:
    """The plan of the run ``swarm.launch.py``'s arguments ask for; writes its config.yaml.

    The same resolution as ``run_swarm.sh`` (:func:`~phd_swarm.tools.launch_plan.
    resolve_config`, :func:`~phd_swarm.tools.launch_plan.swarm_plan`). ValueError naming
    the argument or the config key on bad input.
    """
    rc = resolve_config(
        find_config(values["config"]),
        robots=_number(values["robots"], "robots", int),
        targets=_number(values["targets"], "targets", int),
        duration=_number(values["duration"], "duration", float),
        seed=_number(values["seed"], "seed", int),
        controller=values["controller"] or None,
        realtime=_flag(values["realtime"], "realtime"))
    per = _number(values["robots_per_process"], "robots_per_process", int) or 1
    record = _flag(values["record"], "record")
    record_inboxes = _flag(values["record_inboxes"], "record_inboxes")
    for name, choices in (("dds", ("auto", "localhost", "profile")),
                          ("discovery_server", ("auto", "on", "off"))):
        if values[name] not in choices:
            raise ValueError(f"launch argument {name}: {', '.join(choices[:-1])} or "
                             f"{choices[-1]}, got {values[name]!r}")
    run_dir = fresh_run_dir(Path(values["out"]).expanduser().resolve(),
                            values["name"] or run_name(rc))
    plan = swarm_plan(rc, run_dir, SwarmOptions(
        robots_per_process=per, record=record, record_inboxes=record_inboxes,
        dds=values["dds"], discovery_server=values["discovery_server"],
        hosts=load_layout(values["hosts"]) if values.get("hosts") else None), base_env)
    plan.write_files()
    return plan


def node_action(p: NodeProcess) -> Node:
    """The ``launch_ros`` ``Node`` of process ``p``: ``ros2 run phd_swarm <executable>``.

    Its namespace and node name as ``launch_ros`` arguments (``-r __ns:=``, ``-r
    __node:=``), the parameter file and overrides as ROS arguments; on screen if ``p``
    shows progress, else in the launch log. It gets ``p.stop_grace`` s after SIGINT before
    it is killed. On another host (``hosts:=``) its command has the host's prefix and its
    environment the host's DDS profile.
    """
    half = f"{p.stop_grace / 2:g}"
    prefix = [*p.prefix, *(("nice", "-n", str(p.nice)) if p.nice else ())]
    return Node(package=PACKAGE, executable=p.executable, exec_name=p.name,
                name=p.node_name, namespace=p.namespace,
                ros_arguments=[*p.ros_prefix,
                               *(a for k, v in p.parameters for a in ("-p", f"{k}:={v}"))],
                arguments=list(p.arguments), output="screen" if p.echo else "log",
                prefix=shlex.join(prefix) if prefix else None,
                additional_env=dict(p.env) or None,
                sigterm_timeout=half, sigkill_timeout=half)


def env_actions(changes: Mapping[str, str], unset: list[str] = ()) -> list[Any]:
    """Actions that set ``changes`` and unset ``unset`` for the processes started after."""
    return ([SetEnvironmentVariable(k, v) for k, v in sorted(changes.items())]
            + [UnsetEnvironmentVariable(k) for k in unset])


class WhenUp:
    """Actions ``then``, once every process of ``waiting`` printed its up marker.

    Also when one of them exits first, or after ``timeout`` s (with a warning), as
    ``run_swarm`` does: a late observer does not stop the run. With ``required``, those
    two end the launch instead (a discovery server that is not up).
    """

    def __init__(self, waiting: Mapping[ExecuteProcess, str], then: list[Any],
                 timeout: float, what: str, required: bool = False) -> None:
        self.waiting = dict(waiting)
        self.then = then
        self.timeout = timeout
        self.what = what
        self.required = required
        self.fired = False
        self._up: set[int] = set()
        self._tail: dict[int, str] = {}

    def actions(self) -> list[Any]:
        """The event handlers and the timer that watch the processes."""
        out: list[Any] = []
        for action in self.waiting:
            def seen(event: Any, action: ExecuteProcess = action) -> list[Any] | None:
                return self.output_seen(action, event.text)

            out.append(RegisterEventHandler(OnProcessIO(target_action=action, on_stdout=seen,
                                                        on_stderr=seen)))
            out.append(RegisterEventHandler(OnProcessExit(
                target_action=action,
                on_exit=lambda event, context: self._fire(
                    f"{event.process_name} exited with code {event.returncode} before it "
                    f"was up"))))
        out.append(TimerAction(period=self.timeout, actions=[OpaqueFunction(
            function=lambda context: self._fire(f"not up after {self.timeout:g} s"))]))
        return out

    def output_seen(self, action: ExecuteProcess, text: bytes) -> list[Any] | None:
        """Note output ``text`` of ``action``: ``then`` if that makes every process up."""
        marker, key = self.waiting[action], id(action)
        # A marker may straddle two reads of the pipe: keep the end of the last one.
        seen = self._tail.get(key, "") + text.decode(errors="replace")
        self._tail[key] = seen[-len(marker):]
        if marker in seen:
            self._up.add(key)
        if len(self._up) == len(self.waiting):
            return self._fire(None)
        return None

    def start(self, context: LaunchContext) -> list[Any] | None:
        """``then``, unless the launch is shutting down (Ctrl-C before all were up)."""
        return None if context.is_shutdown else self.then

    def _fire(self, late: str | None) -> list[Any] | None:
        """:meth:`start`, the first time only.

        ``late`` says why not every process is up: then a warning first, or with
        ``required`` a shutdown instead.
        """
        if self.fired:
            return None
        self.fired = True
        if late is None:
            return [OpaqueFunction(function=self.start)]
        if self.required:
            return [LogInfo(msg=f"phd_swarm: error: {late}; cannot start {self.what}"),
                    EmitEvent(event=Shutdown(reason=late))]
        return [LogInfo(msg=f"phd_swarm: {late}; starting {self.what} anyway"),
                OpaqueFunction(function=self.start)]


def finish_run(run_dir: Path, rc: RunConfig) -> str:
    """Finish a launched run's files; returns a line that says how the run went.

    Writes rosbag2's metadata.yaml if the recorder could not, and adds the run's own fields
    to ``summary.json`` (:func:`~phd_swarm.tools.launch_plan.finish_summary`).
    """
    mcap = run_dir / "run.mcap"
    if mcap.exists() and not (run_dir / "metadata.yaml").exists():
        try:
            write_bag_metadata(mcap)
        except (LogError, OSError) as exc:
            return f"no metadata.yaml for {mcap}: {exc}"
    path = run_dir / "summary.json"
    if not path.exists():
        return f"no summary was written (see the launch log); results in {run_dir}/"
    summary = json.loads(path.read_text())
    if "controller" in summary:        # finished already
        return f"results in {run_dir}/"
    report = finish_summary(summary, rc, run_dir)
    path.write_text(json.dumps(summary, indent=2) + "\n")
    log = f"; log {report.describe()}" if report is not None else ""
    return (f"{summary['steps']}/{rc.scenario.steps} steps, final OSPA "
            f"{summary['ospa_final']} m, dead robots: {summary['dead_robots'] or 'none'}"
            f"{log}; results in {run_dir}/")


def _discovery_server(plan: SwarmPlan) -> tuple[ExecuteProcess, str]:
    """phd_swarm's discovery server and its address.

    On a free loopback port, or with ``hosts:=`` on the observers' host at the layout's
    address and port.
    """
    if plan.hosts is None:
        address, port, prefix = "127.0.0.1", free_udp_port(), ()
    else:
        host = plan.hosts.host(plan.hosts.observers)
        address, port, prefix = host.address, plan.hosts.server_port, host.run
    profile = plan.run_dir / "discovery_server.xml"
    profile.write_text(server_profile(port, address))
    server = ExecuteProcess(
        cmd=[*prefix, sys.executable, "-m", "phd_swarm.tools.discovery_server", "--profile",
             str(profile), "--port", str(port), "--address", address],
        name="discovery_server", env=server_env(plan.env, profile), output="log")
    return server, f"{address}:{port}"


def swarm_actions(plan: SwarmPlan, base_env: Mapping[str, str]) -> list[Any]:
    """Every action of a whole run of ``plan`` (the module docstring's order and end)."""
    s = plan.rc.scenario
    changes, unset = plan.env_changes(base_env)
    observers = [node_action(p) for p in plan.observers]
    robots = [node_action(p) for p in plan.robots]
    world = node_action(plan.world)
    by_name = dict(zip([p.name for p in plan.observers], observers, strict=True))
    monitor, recorder = by_name["monitor"], by_name.get("recorder")
    gate = WhenUp({a: p.up_marker for a, p in zip(observers, plan.observers, strict=True)},
                  [*robots, world], OBSERVERS_UP_TIMEOUT, "the robots")
    # The handlers before the processes they watch.
    start: list[Any] = [*gate.actions(), *observers]
    first = [*env_actions(changes, unset)]
    if plan.use_server:
        server, address = _discovery_server(plan)
        first.append(server)
        start = [SetEnvironmentVariable("ROS_DISCOVERY_SERVER", address), *start]
        start = WhenUp({server: SERVER_UP}, start, SERVER_UP_TIMEOUT,
                       "the run: its discovery server", required=True).actions()
    done = OpaqueFunction(function=lambda context: [
        LogInfo(msg=f"phd_swarm: {finish_run(plan.run_dir, plan.rc)}")])
    end_timeout = float(plan.rc.param("monitor", "end_timeout")) + 15.0

    def world_exited(event: Any, context: LaunchContext) -> list[Any] | None:
        if event.returncode == EXIT_NOT_READY:
            return [LogInfo(msg="phd_swarm: start-up failed: the team did not become ready "
                                "(see the world's log); nothing was run"),
                    EmitEvent(event=Shutdown(reason="the team did not come up"))]
        if context.is_shutdown:
            return None
        return [TimerAction(period=end_timeout, actions=[
            LogInfo(msg="phd_swarm: the monitor did not finish; stopping the run"),
            EmitEvent(event=Shutdown(reason="the monitor did not finish"))])]

    ends = [RegisterEventHandler(OnProcessExit(target_action=world, on_exit=world_exited)),
            RegisterEventHandler(OnProcessExit(target_action=monitor, on_exit=[
                *([] if recorder else [done]),
                EmitEvent(event=Shutdown(reason="the monitor wrote the summary"))]))]
    if recorder is not None:
        ends.append(RegisterEventHandler(OnProcessExit(target_action=recorder,
                                                       on_exit=[done])))
    header = LogInfo(msg=(
        f"phd_swarm: {s.name}, {s.robots} robots, {s.targets.count} targets, "
        f"{s.duration:g} s sim ({s.steps} steps), controller {s.system.label()}, seed "
        f"{s.seed}, {plan.rc.param('world', 'mode')} mode; ROS_DOMAIN_ID="
        f"{plan.env['ROS_DOMAIN_ID']}, ROS_AUTOMATIC_DISCOVERY_RANGE="
        f"{plan.env['ROS_AUTOMATIC_DISCOVERY_RANGE']}; results in {plan.run_dir}/"))
    return [header, *first, *ends, *start]


def single_node_actions(p: NodeProcess, config: str, context: LaunchContext) -> list[Any]:
    """Process ``p`` alone (``world.launch.py``, ``robot.launch.py``), as ``run_*.sh`` run it.

    The config is checked first (ValueError naming the file and the key); DDS stays on
    loopback and ``ROS_DOMAIN_ID`` is 42 unless the caller chose others
    (:func:`~phd_swarm.tools.launch_plan.node_env`).
    """
    rc = load_run_config(config)
    if rc.moved:
        raise ValueError(f"{config}: robot parameter(s) {', '.join(rc.moved)} moved to "
                         "scenario.system (python -m phd_swarm.tools.check_config)")
    env = dict(context.environment)
    changes = {k: v for k, v in node_env(env).items() if env.get(k) != v}
    return [*env_actions(changes), node_action(p)]


def swarm_launch(context: LaunchContext) -> list[Any]:
    """``swarm.launch.py``'s ``OpaqueFunction``: its arguments -> the run's actions."""
    from launch.substitutions import LaunchConfiguration

    values = {name: LaunchConfiguration(name).perform(context) for name in SWARM_ARGUMENTS}
    env = dict(context.environment)
    return swarm_actions(plan_from_arguments(values, env), env)
