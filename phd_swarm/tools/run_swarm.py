"""Run a whole swarm: world, monitor, recorder and the robots as separate processes.

``scripts/run_swarm.sh CONFIG [--robots N] [--targets M] [--duration S] [--seed K]
[--controller C] [--out DIR] [--name NAME] [--realtime] [--robots-per-process P]``

1. loads and validates CONFIG (:mod:`phd_swarm.config`), applies the overrides and writes the
   resolved parameter file to ``<out>/<name>/config.yaml``;
2. starts the recorder and the monitor, one process per robot (or per ``P`` robots with
   :mod:`phd_swarm.nodes.team`), then the world; every child runs on loopback with the
   caller's ROS_DOMAIN_ID, in its own process group, logging to ``logs/<node>.log``. The
   processes, their parameters and environment are the plan
   :func:`phd_swarm.tools.launch_plan.swarm_plan`, which ``launch/swarm.launch.py`` starts
   too;
3. shows the monitor's progress lines (sim time, steps per second, OSPA, estimated vs true
   number of targets) while the world runs;
4. when the world is done, lets the monitor write ``summary.json``, stops the recorder so
   that ``run.mcap`` is closed cleanly (it checks that every step message is in the log),
   stops the robots, adds the recorder's completeness report to ``summary.json``, and
   reports. Ctrl-C stops every child but the recorder at once (each flushes what it
   published), then the recorder, so the log keeps every message sent before the Ctrl-C;
   it is done within twice :data:`STOP_GRACE` s plus the clean-up of Fast DDS's shared
   memory, whatever the team size.

A robot process that dies mid-run does not stop the run: the world counts it dead after
``step_timeout`` and the summary lists it in ``dead_robots``. The world, the monitor or the
recorder dying does: the run stops at once, ``summary.json`` gives the ``failure`` and the
exit code is 4 (:mod:`phd_swarm.tools.run_failures`). A team that does not come up does not
make a run: the world gives up (naming the missing robots and the likely cause), no summary
is written and the exit code is 3. An output folder that cannot be written, or a disk
nearly full, is refused before anything starts (exit code 2).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from phd_swarm.config import RunConfig
from phd_swarm.logs.bag_metadata import write_bag_metadata
from phd_swarm.logs.mcap_log import LogError
from phd_swarm.nodes.world import DONE_LINE, EXIT_NOT_READY, READY_LINE
from phd_swarm.tools import view_run
from phd_swarm.tools.dds import (
    DDS_PROFILE,
    free_udp_port,
    server_env,
    server_profile,
)
from phd_swarm.tools.discovery_server import UP as SERVER_UP
from phd_swarm.tools.hosts import HostLayout, load_layout
from phd_swarm.tools.launch_plan import (
    AUTO_PROFILE_PROCESSES,
    AUTO_SERVER_PROCESSES,
    RECORDER_STOP_GRACE,
    STARTUP_S_PER_PROCESS,  # noqa: F401 (the plan's; re-exported under its old home)
    STOP_GRACE,
    NodeProcess,
    SwarmOptions,
    finish_summary,
    fresh_run_dir,
    ready_timeouts,  # noqa: F401 (the plan's; re-exported under its old home)
    resolve_config,
    run_name,
    swarm_plan,
)
from phd_swarm.tools.processes import (
    Stepping,
    Swarm,
    process_cpu_seconds,
    stop_process_group,
)
from phd_swarm.tools.run_failures import (
    EXIT_PROCESS_DIED,
    ProcessDied,
    check_output_dir,
    describe_exit,
    mark_failure,
    vital_failure,
)
from phd_swarm.tools.view_server import ViewServerError

PROG = "run_swarm"

#: How long the robots' start waits for the observers to be up [s].
OBSERVERS_UP_TIMEOUT = 60.0

#: Default niceness of the robot processes (``--robot-nice``). A higher one gives the world,
#: monitor and recorder, which talk to every robot, the CPU first: on one core, 50 robot
#: processes at fair shares left the recorder's discovery thread ~1 % of it, its receive
#: socket overflowed and it never matched the world; niced robots let it match in 16 s. On
#: 2 cores the same niceness slowed the robots' step 0 until peers timed out, so it is off
#: by default (docs/deployment.md, "Start-up of a large team").
ROBOT_NICE = 0

#: Robot processes starting at once (``--start-window``): the next one starts when one of
#: them is up (its nodes built), or after :data:`PROCESS_UP_TIMEOUT` s. 100 robot processes
#: started together kept ~100 processes in the run queue of 2 cores for two minutes and the
#: discovery server's receive socket dropped ~10,000 datagrams; with 8 at a time the load
#: stayed near 12 and nothing was dropped (docs/deployment.md, "Start-up of a large team").
START_WINDOW = max(4, 4 * (os.cpu_count() or 1))
PROCESS_UP_TIMEOUT = 60.0

#: How long run_swarm waits for its discovery server's up line [s].
SERVER_UP_TIMEOUT = 60.0

#: Wall-clock fields of summary.json: they differ between two runs of the same seed.
WALL_CLOCK_FIELDS = ("wall_duration_s", "stepping_wall_s", "real_time_factor", "run_dir",
                     "cpu_s", "cpu_s_per_robot", "peak_memory_mb", "startup_s",
                     "cpu_s_stepping")


def parse_args(argv: list[str]) -> argparse.Namespace:
    """Command-line options (see the module docstring)."""
    p = argparse.ArgumentParser(prog="scripts/run_swarm.sh",
                                description="Run world, monitor, recorder and one process "
                                            "per robot; results in runs/<name>/.")
    p.add_argument("config", help="config file (config/*.yaml)")
    p.add_argument("--robots", type=int, help="team size")
    p.add_argument("--targets", type=int, help="number of (initial) targets")
    p.add_argument("--duration", type=float, help="sim time [s]")
    p.add_argument("--seed", type=int, help="random seed")
    p.add_argument("--controller", help="the system's controller (scenario.system.controller: "
                   "phd, uniform, chen_p, chen_o or one a plugin registers)")
    p.add_argument("--out", default="runs", help="parent directory of the run (default runs)")
    p.add_argument("--name", help="run name (default <scenario>-<controller>-r<N>-s<seed>)")
    p.add_argument("--realtime", action="store_true", help="fixed-rate steps instead of "
                                                           "lockstep")
    p.add_argument("--robots-per-process", type=int, default=1, metavar="P",
                   help="host P robot nodes per process (default 1)")
    p.add_argument("--robot-nice", type=int, default=ROBOT_NICE, metavar="N",
                   help=f"niceness of the robot processes (default {ROBOT_NICE}): a higher "
                        "one gives the world, monitor and recorder, which talk to every "
                        "robot, the CPU first (docs/deployment.md)")
    p.add_argument("--start-window", type=int, default=START_WINDOW, metavar="N",
                   help=f"robot processes starting at once (default {START_WINDOW}, 4 per "
                        "core): the next starts when one is up. 0: all at once")
    p.add_argument("--no-fork-server", action="store_true",
                   help="start each robot process as python -m (by default they are forked "
                   "from a process that imported the robot modules once: ~1 CPU-s less "
                   "start-up per process, its pages shared)")
    p.add_argument("--discovery-server", choices=("auto", "on", "off"), default="auto",
                   help="run a Fast DDS discovery server on 127.0.0.1 (auto, the default: "
                        f"when more than {AUTO_SERVER_PROCESSES} processes)")
    p.add_argument("--dds", choices=("auto", "localhost", "profile"), default="auto",
                   help="DDS discovery on loopback: Jazzy's LOCALHOST range (at most 32 "
                        "processes find each other), the repository's Fast DDS profile "
                        "config/dds/loopback_udp.xml (UDP bound to 127.0.0.1, 160 ports), or "
                        f"auto: the profile above {AUTO_PROFILE_PROCESSES} processes")
    p.add_argument("--hosts", metavar="LAYOUT",
                   help="place the processes on several hosts: a layout file naming each "
                        "host's address, robots and how to run a command there "
                        "(docs/deployment.md, \"Several machines\")")
    p.add_argument("--drop", type=float, metavar="P",
                   help="fault injection: lose each protocol message with probability P")
    p.add_argument("--delay", type=float, metavar="P",
                   help="fault injection: hold back each protocol message not lost with "
                        "probability P, 1..--delay-rounds tick periods")
    p.add_argument("--delay-rounds", type=int, metavar="N", help="most tick periods a "
                   "delayed message is held back (default 1)")
    p.add_argument("--fault-seed", type=int, metavar="S", help="seed of the fault draws")
    p.add_argument("--no-record", action="store_true", help="do not write run.mcap")
    p.add_argument("--record-inboxes", action="store_true",
                   help="also record the protocol traffic (/robot_*/inbox) in run.mcap")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    view_run.add_options(p, "run")
    opts = p.parse_args(argv)
    if opts.start_window < 0:
        p.error(f"--start-window: a number of processes >= 0, got {opts.start_window}")
    return opts


def resolve(opts: argparse.Namespace) -> RunConfig:
    """The config with the command-line overrides applied (ValueError on bad values)."""
    robot: dict[str, Any] = {}
    for option, param in (("drop", "fault_drop"), ("delay", "fault_delay"),
                          ("delay_rounds", "fault_delay_rounds"), ("fault_seed", "fault_seed")):
        if getattr(opts, option) is not None:
            robot[param] = getattr(opts, option)
    return resolve_config(opts.config, robots=opts.robots, targets=opts.targets,
                          duration=opts.duration, seed=opts.seed, controller=opts.controller,
                          realtime=opts.realtime, robot=robot)


def _raise_interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def run(opts: argparse.Namespace) -> int:
    """Run the swarm described by ``opts``; returns the exit code."""
    rc = resolve(opts)
    s = rc.scenario
    controller = s.system.label()
    check_output_dir(Path(opts.out))
    run_dir = fresh_run_dir(Path(opts.out), opts.name or run_name(rc))
    record = not opts.no_record
    per = max(1, opts.robots_per_process)
    # With the world's markers the viewer is one of its observers: the view gets step 0.
    view_observes = bool(opts.view) and bool(rc.param("world", "publish_markers"))
    # The processes, their parameters and environment: the plan swarm.launch.py starts too.
    plan = swarm_plan(rc, run_dir, SwarmOptions(
        robots_per_process=per, record=record, record_inboxes=bool(opts.record_inboxes),
        dds=opts.dds, discovery_server=opts.discovery_server, robot_nice=opts.robot_nice,
        hosts=None if opts.hosts is None else load_layout(opts.hosts),
        view=view_observes))
    rc = plan.rc
    plan.write_files()
    use_server = plan.use_server
    env = dict(plan.env)
    # Its children get ``env`` as it is when each starts.
    swarm = Swarm(run_dir, env, opts.quiet, fork=not opts.no_fork_server)
    started = time.monotonic()
    stepping = Stepping(started, READY_LINE, DONE_LINE)
    interrupted = False
    failure: str | None = None
    code = 0
    server = None
    view_server = None
    if opts.view:
        try:
            view_server = view_run.start_server(run_dir / "logs" / "view_server.log", PROG)
        except ViewServerError as exc:
            print(f"{PROG}: {exc}", file=sys.stderr)
            return 1
    # SIGINT explicitly too: a shell that starts a job in the background (nohup, `cmd &` in
    # a script) makes it ignore SIGINT, and Python then installs no handler for it.
    previous = {sig: signal.signal(sig, _raise_interrupt)
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        if use_server:
            # Inside the try: the server is stopped like every other child, whatever
            # happens after it started.
            server, address = _start_discovery_server(run_dir, env, plan.hosts)
            # Plain clients: each learns only the endpoints on its own topics. A super
            # client (ROS_SUPER_CLIENT) learns everything, which is what made the server do
            # worse than simple discovery in the first slice of issue 21; only the
            # recorder's ``discover`` mode, which polls the whole graph, needs it.
            env["ROS_DISCOVERY_SERVER"] = address
        print(f"run_swarm: {s.name}, {s.robots} robots, {s.targets.count} targets, "
              f"{s.duration:g} s sim ({s.steps} steps), controller {controller}, seed "
              f"{s.seed}, {rc.param('world', 'mode')} mode; "
              f"ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}"
              + (f", discovery server {env['ROS_DISCOVERY_SERVER']}" if server else "")
              + (f", Fast DDS profile {DDS_PROFILE.name}"
                 if env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT"
                 and plan.hosts is None else "")
              + (f", hosts {_hosts_line(plan)}" if plan.hosts else ""),
              flush=True)
        print(f"run_swarm: results in {run_dir}/", flush=True)
        if view_server is not None:
            # A process of the run: its CPU is counted, it is stopped with the others. With
            # a discovery server it is a super client, to see the whole graph (as the
            # recorder's discover mode).
            swarm.start("viewer", "phd_swarm.nodes.viewer", view_run.viewer_ros_args(
                view_server.grpc_url, run_dir / "view.rrd", run_dir.name, view_observes),
                env={"ROS_SUPER_CLIENT": "TRUE"} if server else None)
        # The observers first, each up (its subscriptions made) before the robots start:
        # with tens of processes starting at once, a recorder making its ~14 subscriptions
        # per robot got a slice of the CPU and was up 85 s after the robots, which had
        # given up waiting for it (50 robot processes, docs/deployment.md).
        for p in plan.observers:
            extra_env = dict(p.env)
            if server and p.name == "recorder" and rc.param("recorder", "discover"):
                extra_env["ROS_SUPER_CLIENT"] = "TRUE"
            swarm.start(p.name, p.module, p.ros_args(), extra=p.arguments, echo=p.echo,
                        up_marker=p.up_marker, env=extra_env, prefix=p.prefix)
        late = swarm.wait_up([p.name for p in plan.observers], OBSERVERS_UP_TIMEOUT)
        if late:
            print(f"run_swarm: {' and '.join(late)} not up after {OBSERVERS_UP_TIMEOUT:g} s; "
                  "starting the robots anyway (see their logs)", file=sys.stderr)
        _start_robots(swarm, list(plan.robots), opts.start_window)
        world = swarm.start(plan.world.name, plan.world.module, plan.world.ros_args(),
                            extra=plan.world.arguments, echo=plan.world.echo,
                            env=dict(plan.world.env), prefix=plan.world.prefix,
                            marks=stepping.marks())
        while world.poll() is None:
            time.sleep(0.2)
            for n in swarm.procs:
                swarm.sample(n)
            swarm.sample_fork_server()
            stepping.note(swarm.cpu)
            died = vital_failure(swarm.procs, record)
            if died:
                raise ProcessDied(died)
        if world.returncode == EXIT_NOT_READY:
            _explain_start_failure(swarm, run_dir)
            code = EXIT_NOT_READY
        elif world.returncode != 0:
            raise ProcessDied(f"the world {describe_exit(world.returncode)}")
        if code != EXIT_NOT_READY:
            end_timeout = float(rc.param("monitor", "end_timeout")) + 15.0
            try:
                swarm.procs["monitor"].wait(timeout=end_timeout)
            except subprocess.TimeoutExpired:
                print("run_swarm: the monitor did not finish; stopping it", file=sys.stderr)
    except KeyboardInterrupt:
        interrupted = True
        print("\nrun_swarm: interrupted; stopping the swarm", flush=True)
    except ProcessDied as exc:
        failure = str(exc)
        print(f"run_swarm: {failure}; stopping the run (see {run_dir}/logs/)", file=sys.stderr,
              flush=True)
        code = EXIT_PROCESS_DIED
    except RuntimeError as exc:
        print(f"run_swarm: {exc}", file=sys.stderr)
        code = 1
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if interrupted or code == EXIT_NOT_READY:
            # The recorder last: it takes what the others flushed as they stopped, and it
            # gets as long as at a normal end (it may wait up to 10 s for late messages).
            swarm.stop_many([n for n in swarm.procs if n != "recorder"], STOP_GRACE)
            swarm.stop_many(["recorder"], RECORDER_STOP_GRACE)
            swarm.stop_all(STOP_GRACE)
        else:
            swarm.stop_many(["world", "monitor"], grace=10.0)
            if record:
                swarm.stop_many(["recorder"], RECORDER_STOP_GRACE)
            swarm.stop_many(["viewer"], view_run.VIEWER_STOP_GRACE)
            swarm.stop_all()
        if server is not None:
            stop_process_group(server, 5.0)
    wall = time.monotonic() - started
    _ensure_bag_metadata(run_dir / "run.mcap")
    if code == EXIT_NOT_READY:
        print(f"run_swarm: nothing was run; no summary written (logs in {run_dir}/logs/)",
              file=sys.stderr)
    else:
        if view_server is not None:
            # The view's server is part of what --view costs (docs/benchmarks.md).
            swarm.cpu["view_server"] = process_cpu_seconds(view_server.pid)
        if failure is not None:
            mark_failure(run_dir / "summary.json", failure, {
                "wall_duration_s": wall, "cpu_s": {k: round(v, 2) for k, v in
                                                   sorted(swarm.cpu.items())}})
        code = _report(run_dir, rc, wall, interrupted, swarm.cpu, swarm.memory,
                       stepping.figures(swarm.cpu)) or code
        if failure is not None:
            code = EXIT_PROCESS_DIED
    if view_server is not None:
        if not interrupted and code != EXIT_NOT_READY:
            view_run.hold(view_server, PROG, True if opts.view_hold else None)
        view_server.close()
    return code


def _start_robots(swarm: Swarm, processes: list[NodeProcess], window: int) -> None:
    """Start the robot ``processes``, at most ``window`` of them starting at a time (0: all).

    A process has started when its last robot logged that it is built (``robot <id>:
    system``); one that has not after :data:`PROCESS_UP_TIMEOUT` s, or exited, leaves the
    window. Prints progress (unless ``--quiet``) when the window is smaller than the team
    of processes; names the processes that did not come up on stderr.
    """
    t0 = time.monotonic()
    pending = list(processes)
    total = len(pending)
    window = window if window > 0 else total
    starting: dict[str, float] = {}
    up, late, reported = 0, [], 0
    while pending or starting:
        while pending and len(starting) < window:
            p = pending.pop(0)
            swarm.start(p.name, p.module, p.ros_args(), extra=p.arguments, nice=p.nice,
                        up_marker=p.up_marker, env=dict(p.env), prefix=p.prefix)
            starting[p.name] = time.monotonic()
        if window >= total:
            return
        time.sleep(0.05)
        now = time.monotonic()
        for name, since in list(starting.items()):
            if swarm.is_up(name):
                up += 1
            elif swarm.procs[name].poll() is not None or now - since > PROCESS_UP_TIMEOUT:
                late.append(name)
            else:
                continue
            del starting[name]
        if not swarm.quiet and (up - reported >= window or (not pending and not starting)):
            reported = up
            print(f"run_swarm: {up} of {total} robot processes up ({now - t0:.0f} s)",
                  flush=True)
    if late:
        print(f"run_swarm: not up within {PROCESS_UP_TIMEOUT:g} s or exited: {', '.join(late)}",
              file=sys.stderr, flush=True)


def _ensure_bag_metadata(mcap: Path) -> None:
    """Write rosbag2's metadata.yaml beside ``mcap`` if the recorder could not (killed)."""
    if not mcap.exists() or (mcap.parent / "metadata.yaml").exists():
        return
    try:
        write_bag_metadata(mcap)
    except (LogError, OSError) as exc:
        print(f"run_swarm: no metadata.yaml for {mcap}: {exc}", file=sys.stderr)


def _explain_start_failure(swarm: Swarm, run_dir: Path) -> None:
    """Say why the team did not come up: the world's verdict, and robot processes that died."""
    print(f"run_swarm: start-up failed: the team did not become ready (see "
          f"{run_dir}/logs/world.log)", file=sys.stderr)
    for name, rc in sorted(swarm.exited("robot").items()):
        print(f"run_swarm: {name} exited with code {rc} before the run; see "
              f"{run_dir}/logs/{name}.log", file=sys.stderr)


def _hosts_line(plan) -> str:
    """``base (10.0.0.1: world, monitor, recorder), field1 (10.0.0.2: 2 robot processes)``."""
    parts = []
    for h in plan.hosts.hosts:
        names = [p.name for p in plan.processes if p.host == h.name]
        robots = sum(1 for p in plan.robots if p.host == h.name)
        what = [n for n in names if not n.startswith("robot")]
        if robots:
            what.append(f"{robots} robot process{'es' if robots > 1 else ''}")
        parts.append(f"{h.name} ({h.address}: {', '.join(what) or 'nothing'})")
    return "; ".join(parts) + f"; discovery {plan.hosts.discovery}"


def _start_discovery_server(run_dir: Path, env: dict[str, str], hosts: HostLayout | None = None
                            ) -> tuple[subprocess.Popen, str]:
    """Start phd_swarm's discovery server; returns it and its address.

    On a free loopback port, or, with ``hosts``, on the observers' host at the layout's
    address and port. It waits (at most :data:`SERVER_UP_TIMEOUT` s) for the server's up
    line, so that no client starts before the server listens.
    """
    if hosts is None:
        address, port, prefix = "127.0.0.1", free_udp_port(), ()
    else:
        host = hosts.host(hosts.observers)
        address, port, prefix = host.address, hosts.server_port, host.run
    profile = run_dir / "discovery_server.xml"
    profile.write_text(server_profile(port, address))
    log_path = run_dir / "logs" / "discovery_server.log"
    log_path.parent.mkdir(exist_ok=True)
    log = open(log_path, "w")  # noqa: SIM115 (the child holds it)
    proc = subprocess.Popen([*prefix, sys.executable, "-m", "phd_swarm.tools.discovery_server",
                             "--profile", str(profile), "--port", str(port),
                             "--address", address],
                            env=server_env(env, profile), stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)
    log.close()
    deadline = time.monotonic() + SERVER_UP_TIMEOUT
    while SERVER_UP not in log_path.read_text():
        if proc.poll() is not None or time.monotonic() > deadline:
            stop_process_group(proc, 2.0)
            raise RuntimeError(f"the discovery server did not come up (exit code "
                               f"{proc.returncode}); see {log_path}")
        time.sleep(0.05)
    return proc, f"{address}:{port}"


def _report(run_dir: Path, rc: RunConfig, wall: float, interrupted: bool,
            cpu: dict[str, float], memory: dict[str, float],
            stepping_figures: dict[str, object]) -> int:
    path = run_dir / "summary.json"
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError) as exc:  # none, or cut short (a full disk)
        print(f"run_swarm: no summary was written (see {run_dir}/logs/)"
              + ("" if isinstance(exc, FileNotFoundError) else f": {exc}"), file=sys.stderr)
        return 130 if interrupted else 1
    if "failure" in summary and not summary.get("steps"):
        # The monitor wrote none: the summary is run_swarm's, the failure and what it knows.
        print(f"run_swarm: failed: {summary.get('failure')}; no step was summarised; what "
              f"was recorded: scripts/evaluate.sh {run_dir}/run.mcap", file=sys.stderr)
        return EXIT_PROCESS_DIED
    s = rc.scenario
    stepping = summary.pop("wall_duration_s")
    # The fork server's imports are the robot processes' start-up, done once for them all.
    robots_cpu = sum(v for k, v in cpu.items() if k.startswith("robot") or k == "fork_server")
    report = finish_summary(summary, rc, run_dir)
    summary.update({"wall_duration_s": wall,
                    "stepping_wall_s": stepping,
                    "real_time_factor": (summary["sim_duration_s"] / stepping
                                         if stepping else None),
                    "cpu_s": {k: round(v, 2) for k, v in sorted(cpu.items())},
                    "cpu_s_per_robot": robots_cpu / s.robots,
                    "peak_memory_mb": {k: round(v, 1) for k, v in sorted(memory.items())},
                    **stepping_figures})
    try:
        path.write_text(json.dumps(summary, indent=2) + "\n")
    except OSError as exc:  # a full disk: the monitor's summary stays as it was
        print(f"run_swarm: cannot complete {path}: {exc.strerror or exc}", file=sys.stderr)
    print(f"run_swarm: {summary['steps']}/{s.steps} steps, {summary['sim_duration_s']:g} s sim "
          f"in {stepping:.1f} s wall ({summary['real_time_factor'] or 0:.2f} x real time; "
          f"{wall:.1f} s with start-up and shut-down); final OSPA "
          f"{summary['ospa_final']} m, targets est {summary['cardinality_est_final']} / true "
          f"{summary['cardinality_true_final']}; dead robots: "
          f"{summary['dead_robots'] or 'none'}", flush=True)
    if report is not None:
        print(f"run_swarm: log {report.describe()}", flush=True,
              file=sys.stdout if report.complete else sys.stderr)
    elif (run_dir / "run.mcap").exists():
        print("run_swarm: the log has no completeness report (the recorder did not close "
              "it); check it with scripts/evaluate.sh", file=sys.stderr)
    files = "run.mcap, summary.json" if (run_dir / "run.mcap").exists() else "summary.json"
    print(f"run_swarm: results in {run_dir}/ ({files}, config.yaml, logs/)", flush=True)
    if "failure" in summary:
        print(f"run_swarm: failed: {summary['failure']}", file=sys.stderr, flush=True)
        return EXIT_PROCESS_DIED
    return 130 if interrupted else 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of scripts/run_swarm.sh."""
    opts = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        return run(opts)
    except ValueError as exc:
        print(f"run_swarm: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
