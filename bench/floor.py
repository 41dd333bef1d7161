"""Floor benchmark: a lockstep team's messages through DDS, a process per robot, no work done.

Run with ``scripts/bench.sh floor [--sizes 10,30,50,100] [--steps 60] [--contacts 16]
[--phases 3] [--envelope-bytes 1000] [--bundle-bytes 8000] [--quick]``. Issue 39: the CPU
per robot-step of the real robots (``scripts/bench.sh swarm``) is the floor measured here
(DDS, rclpy, the executor, the scheduler) plus our work. For each size N it starts a
stepper (the world), ``--observers`` observers (the monitor) and N robot processes
(``bench/floor_peer.py``, which describes the pattern: per step a team state and a
measurement set per robot; per robot ``--phases`` phases of one envelope to each of its
``--contacts`` ring neighbours on their inbox topics, each phase waiting for the
contacts' envelopes; a status and an outputs bundle; the real topics and QoS, raw CDR
bytes, the real executor; a ``/clock`` tick per step and sim time, ``--no-clock`` for
neither), waits until every writer has its readers, steps ``--steps`` times, and prints
one row per size:

- ``startup_s``: from the first process started to all of them matched;
- ``steps_per_s``: steps per wall second while stepping (step 0 published to the last
  step's statuses in);
- ``robot_cpu_ms_per_robot_step``: the robot processes' CPU (``/proc/PID/stat`` user +
  system, all threads) between those two moments, over N x steps; and the busiest robot's;
- ``stepper_cpu_ms_per_step``, ``observer_cpu_ms_per_step``: the same for the stepper and
  the observers (all of them, per step);
- ``robot_peak_rss_mb``: the largest peak resident memory (VmHWM) of a robot process;
- ``robots_completed``: the robots that did every step (and the observers' counts of
  statuses and bundles, against N x steps); ``exited``: the processes that exited by
  themselves at the end (the others' stacks are in ``stuck``).

DDS as ``run_swarm.sh`` has it for as many processes (N + 1 + observers): Jazzy's
LOCALHOST range, the repository's Fast DDS profile and phd_swarm's discovery server above
30 processes (``--dds``, ``--discovery-server``); each size on a ROS_DOMAIN_ID of its own
from ``--domain``. Every process is stopped by its process group whatever happens.
``--quick``: 4 robots, 10 steps, 2 contacts. Writes ``bench/results/floor-<date>.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from results_io import machine_meta, write_results

from phd_swarm.tools.dds import (
    DDS_PROFILE,
    dds_env,
    free_udp_port,
    server_env,
    server_profile,
)
from phd_swarm.tools.discovery_server import UP as SERVER_UP
from phd_swarm.tools.launch_plan import AUTO_PROFILE_PROCESSES, AUTO_SERVER_PROCESSES

PEER = Path(__file__).with_name("floor_peer.py")
#: Seconds the stepper may take per step before the run counts as stuck.
STEP_TIMEOUT_S = 30.0
#: Seconds the processes get to exit after the end.
EXIT_TIMEOUT_S = 30.0
_HWM = re.compile(r"VmHWM:\s+(\d+) kB")


@dataclass
class Child:
    """A started process, its JSON lines (read by a thread) and its stderr file."""

    name: str
    proc: subprocess.Popen
    err: Path
    lines: list[dict] = field(default_factory=list)
    reader: threading.Thread | None = None

    def last(self, key: str) -> object:
        """The value of ``key`` in the latest line that has it, or None."""
        return next((line[key] for line in reversed(self.lines) if key in line), None)

    def read(self) -> None:
        """Collect the child's JSON lines until its stdout closes (a thread's target)."""
        for text in self.proc.stdout:
            try:
                self.lines.append(json.loads(text))
            except json.JSONDecodeError:
                pass


def parse_args(argv: list[str]) -> argparse.Namespace:
    """The command line (see the module docstring)."""
    p = argparse.ArgumentParser(prog="scripts/bench.sh floor",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", default="10,30,50,100", help="robot processes, comma-separated")
    p.add_argument("--steps", type=int, default=60)
    p.add_argument("--contacts", type=int, default=16, help="per robot (even: r +- 1 .. r +- "
                   "contacts / 2 on a ring)")
    p.add_argument("--phases", type=int, default=3, help="protocol phases per step")
    p.add_argument("--envelope-bytes", type=int, default=1000)
    p.add_argument("--bundle-bytes", type=int, default=8000, help="each robot's outputs")
    p.add_argument("--world-bytes", type=int, default=1000,
                   help="the team state and each measurement set")
    p.add_argument("--status-bytes", type=int, default=200)
    p.add_argument("--observers", type=int, default=1, help="monitor-like readers of the "
                   "statuses and bundles (run_swarm: 1, 2 when recording)")
    p.add_argument("--no-clock", action="store_true", help="no /clock tick per step and no "
                   "sim time (the real runs have both)")
    p.add_argument("--send", choices=("inbox", "outbox"), default="inbox",
                   help="outbox: each phase's envelope once, on the robot's own outbox "
                   "topic that its contacts read (bench/floor_peer.py)")
    p.add_argument("--dds", choices=("auto", "localhost", "profile", "shm"), default="auto",
                   help="shm: the profile plus Fast DDS's shared memory for the samples")
    p.add_argument("--discovery-server", choices=("auto", "on", "off"), default="auto")
    p.add_argument("--ready-timeout", type=float, default=None,
                   help="seconds for every writer to match (default 120 + 3 s per process)")
    p.add_argument("--domain", type=int, default=222, help="ROS_DOMAIN_ID of the first size")
    p.add_argument("--quick", action="store_true", help="4 robots, 10 steps, 2 contacts")
    p.add_argument("--out", type=Path, default=Path(__file__).with_name("results"))
    opts = p.parse_args(argv)
    if opts.quick:
        opts.sizes, opts.steps, opts.contacts = "4", 10, 2
    try:
        opts.sizes = [int(s) for s in opts.sizes.split(",")]
    except ValueError:
        p.error(f"--sizes must be comma-separated process counts, got {opts.sizes!r}")
    if min(opts.sizes) < 2 or opts.steps < 1 or opts.contacts < 2 or opts.contacts % 2:
        p.error("need sizes >= 2, steps >= 1 and an even number of contacts >= 2")
    if not 0 <= opts.domain <= 232 - len(opts.sizes):
        p.error("--domain: each size takes the next id, all within 0..232")
    return opts


def dds_setup(processes: int, opts: argparse.Namespace, domain: int, work: Path
              ) -> tuple[dict[str, str], list[str] | None, dict[str, str] | None, str]:
    """DDS for ``processes`` processes as run_swarm's plan has it (the module docstring).

    Returns the processes' environment, the discovery server's command and environment
    (None without one) and the set-up in words.
    """
    server = opts.discovery_server == "on" or (opts.discovery_server == "auto"
                                               and processes > AUTO_SERVER_PROCESSES)
    shm = opts.dds == "shm"
    profile = server or shm or opts.dds == "profile" or (
        opts.dds == "auto" and processes > AUTO_PROFILE_PROCESSES)
    env = dds_env(os.environ, profile)
    if shm:
        xml = work / "loopback_shm.xml"
        xml.write_text(shm_profile(DDS_PROFILE.read_text()))
        env["FASTRTPS_DEFAULT_PROFILES_FILE"] = env["FASTDDS_DEFAULT_PROFILES_FILE"] = str(xml)
    env.update(ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED="1")
    for var in ("ROS_DISCOVERY_SERVER", "ROS_SUPER_CLIENT", "ROS_STATIC_PEERS"):
        env.pop(var, None)
    what = "shm" if shm else "profile" if profile else "localhost"
    if not server:
        return env, None, None, what
    port = free_udp_port()
    xml = work / "discovery_server.xml"
    xml.write_text(server_profile(port))
    cmd = [sys.executable, "-m", "phd_swarm.tools.discovery_server", "--profile", str(xml),
           "--port", str(port)]
    senv = server_env(env, xml)
    env["ROS_DISCOVERY_SERVER"] = f"127.0.0.1:{port}"
    return env, cmd, senv, what + "+server"


def shm_profile(udp: str) -> str:
    """The repository's UDP profile (``udp``, its text) with shared memory for the samples.

    Fast DDS's SHM transport is added before the UDP one, and the default unicast locators
    (UDP on 127.0.0.1) are dropped, so that Fast DDS announces one per transport and a
    writer reaches a reader on this host through shared memory; discovery (metatraffic)
    stays on UDP, 127.0.0.1. For ``--dds shm``, a measurement only (issue 39): run_swarm
    has no such option, since such a start never matched at 100 processes.
    """
    shm = ("      <transport_descriptor>\n        <transport_id>phd_swarm_shm</transport_id>\n"
           "        <type>SHM</type>\n      </transport_descriptor>\n"
           "    </transport_descriptors>")
    out = udp.replace("    </transport_descriptors>", shm, 1)
    out = out.replace("<userTransports>\n", "<userTransports>\n"
                      "          <transport_id>phd_swarm_shm</transport_id>\n", 1)
    out = re.sub(r"\s*<defaultUnicastLocatorList>.*?</defaultUnicastLocatorList>", "", out,
                 flags=re.S)
    if out.count("phd_swarm_shm") != 2 or "defaultUnicastLocatorList" in out:
        raise RuntimeError(f"{DDS_PROFILE} is not laid out as shm_profile expects")
    return out


def start_server(cmd: list[str], env: dict[str, str], timeout: float = 60.0
                 ) -> subprocess.Popen:
    """Start the discovery server and wait for its up line (rclpy logs to stderr)."""
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, start_new_session=True)
    deadline = time.monotonic() + timeout
    for line in proc.stdout:
        if SERVER_UP in line:
            return proc
        if time.monotonic() > deadline:
            break
    stop_all([], proc)
    raise RuntimeError(f"the discovery server did not come up (exit code {proc.returncode})")


def start(name: str, args: list[str], env: dict[str, str], work: Path,
          stdin: bool = False) -> Child:
    """Start ``floor_peer.py ARGS`` in a process group of its own, its lines read by a thread."""
    err = work / f"{name}.err"
    proc = subprocess.Popen([sys.executable, str(PEER), *args], env=env, text=True,
                            stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=err.open("w"),
                            start_new_session=True)
    child = Child(name, proc, err)
    child.reader = threading.Thread(target=child.read, daemon=True)
    child.reader.start()
    return child


def tell(child: Child, command: str) -> None:
    """Write one command line to a child's stdin."""
    child.proc.stdin.write(command + "\n")
    child.proc.stdin.flush()


def cpu_seconds(pids: list[int]) -> np.ndarray:
    """User + system CPU seconds of each process (all its threads), NaN if it is gone."""
    out = np.full(len(pids), np.nan)
    for i, pid in enumerate(pids):
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        out[i] = int(fields[11]) + int(fields[12])
    return out / os.sysconf("SC_CLK_TCK")


def peak_rss_mb(pids: list[int]) -> np.ndarray:
    """Peak resident memory (VmHWM) of each process [MB], NaN if it is gone."""
    out = np.full(len(pids), np.nan)
    for i, pid in enumerate(pids):
        try:
            found = _HWM.search(Path(f"/proc/{pid}/status").read_text())
        except OSError:
            continue
        if found:
            out[i] = int(found.group(1)) / 1024
    return out


def _failure(what: str, children: list[Child], key: str = "waiting") -> RuntimeError:
    """An error naming ``what`` failed and, for each child not there, its last word."""
    lines = []
    for c in children:
        code = c.proc.poll()
        if code is not None:
            lines.append(f"  {c.name}: exited ({code}): {c.err.read_text()[-600:].strip()}")
        else:
            lines.append(f"  {c.name}: {c.last(key) or 'nothing reported'}")
    return RuntimeError(f"{what}:\n" + "\n".join(lines[:20])
                        + (f"\n  ... and {len(lines) - 20} more" if len(lines) > 20 else ""))


def wait_ready(children: list[Child], timeout: float) -> None:
    """Wait until every child reported ready; RuntimeError naming what did not match."""
    deadline = time.monotonic() + timeout
    while True:
        late = [c for c in children if c.last("ready") is None]
        if not late:
            return
        if time.monotonic() > deadline or any(c.proc.poll() is not None for c in late):
            raise _failure(f"not ready within {timeout:.0f} s ({len(late)} of "
                           f"{len(children)} processes)", late)
        time.sleep(0.1)


def wait_line(child: Child, key: str, timeout: float, others: list[Child]) -> dict:
    """The first line of ``child`` with ``key``; RuntimeError (with its last word) if none."""
    deadline = time.monotonic() + timeout
    while True:
        line = next((line for line in child.lines if key in line), None)
        if line is not None:
            return line
        if time.monotonic() > deadline or child.proc.poll() is not None:
            raise _failure(f"no {key!r} from {child.name} within {timeout:.0f} s",
                           [child, *[c for c in others if c.proc.poll() is not None]])
        time.sleep(0.05)


def stop_all(children: list[Child], server: subprocess.Popen | None) -> None:
    """Kill every process group still alive and reap it."""
    for proc in [*(c.proc for c in children), server]:
        if proc is None:
            continue
        if proc.poll() is None:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        proc.wait()


def run(n: int, opts: argparse.Namespace, domain: int) -> dict[str, object]:
    """One size: start, match, step, stop; its row (see the module docstring)."""
    processes = n + 1 + opts.observers
    work = Path(tempfile.mkdtemp(prefix="phd_swarm_floor_"))
    env, server_cmd, server_env_, dds = dds_setup(processes, opts, domain, work)
    common = ["--robots", str(n), "--steps", str(opts.steps), "--contacts", str(opts.contacts),
              "--phases", str(opts.phases), "--envelope-bytes", str(opts.envelope_bytes),
              "--bundle-bytes", str(opts.bundle_bytes), "--world-bytes", str(opts.world_bytes),
              "--status-bytes", str(opts.status_bytes), "--observers", str(opts.observers),
              "--send", opts.send,
              *(["--no-clock"] if opts.no_clock else [])]
    server = None
    children: list[Child] = []
    timeout = opts.ready_timeout or 120.0 + 3.0 * processes
    failed = True
    try:
        if server_cmd is not None:
            server = start_server(server_cmd, server_env_)
        t0 = time.monotonic()
        # One by one into ``children``, so that whatever started is stopped.
        children.append(start("stepper", ["stepper", *common], env, work, stdin=True))
        for i in range(opts.observers):
            children.append(start(f"observer_{i}", ["observer", "--index", str(i), *common],
                                  env, work))
        for r in range(n):
            children.append(start(f"robot_{r}", ["robot", "--index", str(r), *common], env,
                                  work))
        stepper, observers = children[0], children[1:1 + opts.observers]
        robots = children[1 + opts.observers:]
        wait_ready(children, timeout)
        startup = time.monotonic() - t0
        pids = [c.proc.pid for c in children]
        cpu0 = cpu_seconds(pids)
        tell(stepper, "go")
        done = wait_line(stepper, "done", 60.0 + STEP_TIMEOUT_S * opts.steps, robots)
        cpu = cpu_seconds(pids) - cpu0
        rss = peak_rss_mb([c.proc.pid for c in robots])
        tell(stepper, "stop")
        stuck = wait_exit(children, EXIT_TIMEOUT_S)
        failed = False
    finally:
        stop_all(children, server)
        if failed:
            print(f"floor: the processes' stderr is kept in {work}", file=sys.stderr)
        else:
            shutil.rmtree(work, ignore_errors=True)
    row = figures(n, opts, dds, startup, done, cpu, rss, robots, observers)
    row.update(exited=sum(c.proc.returncode == 0 for c in children),
               processes=len(children), stuck=stuck)
    return row


def wait_exit(children: list[Child], timeout: float) -> dict[str, str]:
    """Wait for every child to exit and its last lines; the end of the stuck ones' stderr.

    A child still running after ``timeout`` s is asked for its stack (faulthandler on
    SIGUSR1, bench/floor_peer.py), which its stderr then ends with.
    """
    deadline = time.monotonic() + timeout
    stuck = []
    for c in children:
        try:
            c.proc.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            c.proc.send_signal(signal.SIGUSR1)
            stuck.append(c)
    if stuck:
        time.sleep(1.0)
    for c in children:
        if c.reader is not None:
            c.reader.join(timeout=1.0)
    return {c.name: c.err.read_text()[-4000:] for c in stuck}


def figures(n: int, opts: argparse.Namespace, dds: str, startup: float, done: dict,
            cpu: np.ndarray, rss: np.ndarray, robots: list[Child], observers: list[Child]
            ) -> dict[str, object]:
    """A size's row from the stepper's done line and the CPU over the stepping."""
    steps, wall = opts.steps, float(done["wall_s"])
    k = 1 + len(observers)
    robot_cpu = cpu[k:]
    step_ms = np.asarray(done["step_ms"])
    completed = sum(c.last("steps_done") == steps for c in robots)
    received = [{key: c.last(key) for key in ("statuses", "bundles")} for c in observers]
    return {"robots": n, "steps": steps, "contacts": int(min(opts.contacts, n - 1)),
            "phases": opts.phases, "send": opts.send, "envelope_bytes": opts.envelope_bytes,
            "bundle_bytes": opts.bundle_bytes, "world_bytes": opts.world_bytes,
            "status_bytes": opts.status_bytes, "observers": len(observers), "dds": dds,
            "startup_s": round(startup, 1), "stepping_wall_s": round(wall, 3),
            "steps_per_s": round(steps / wall, 2),
            "step_ms_median": round(float(np.median(step_ms)), 1),
            "step_ms_max": round(float(step_ms.max()), 1),
            "robot_cpu_ms_per_robot_step": round(float(np.nansum(robot_cpu)) / (n * steps)
                                                 * 1e3, 2),
            "robot_cpu_ms_per_step_busiest": round(float(np.nanmax(robot_cpu)) / steps * 1e3,
                                                   2),
            "stepper_cpu_ms_per_step": round(float(cpu[0]) / steps * 1e3, 2),
            "observer_cpu_ms_per_step": round(float(np.nansum(cpu[1:k])) / steps * 1e3, 2),
            "robot_peak_rss_mb": round(float(np.nanmax(rss)), 1),
            "robot_peak_rss_mb_median": round(float(np.nanmedian(rss)), 1),
            "robots_completed": int(completed), "observers_received": received,
            "inbox_messages_per_robot_step": int(min(opts.contacts, n - 1)) * opts.phases}


def print_header() -> None:
    """The table's head."""
    print(f"{'robots':>6} {'dds':>15} {'start s':>8} {'steps/s':>8} {'step ms med/max':>16} "
          f"{'robot CPU ms/robot-step':>24} {'stepper ms/step':>16} {'observer ms/step':>17} "
          f"{'peak RSS MB':>12} {'completed':>10}", flush=True)


def print_row(r: dict) -> None:
    """One size's line."""
    step = f"{r['step_ms_median']}/{r['step_ms_max']}"
    robot = f"{r['robot_cpu_ms_per_robot_step']} (max {r['robot_cpu_ms_per_step_busiest']})"
    done = f"{r['robots_completed']}/{r['robots']}"
    print(f"{r['robots']:>6} {r['dds']:>15} {r['startup_s']:>8} {r['steps_per_s']:>8} "
          f"{step:>16} {robot:>24} {r['stepper_cpu_ms_per_step']:>16} "
          f"{r['observer_cpu_ms_per_step']:>17} {r['robot_peak_rss_mb']:>12} {done:>10}",
          flush=True)


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Run every size, print the table and write the JSON."""
    opts = parse_args(sys.argv[1:] if argv is None else argv)
    # SIGTERM as Ctrl-C, so that the children are stopped (run's finally) then too.
    signal.signal(signal.SIGTERM, _interrupt)
    print_header()
    rows = []
    for i, n in enumerate(opts.sizes):
        try:
            rows.append(run(n, opts, opts.domain + i))
        except RuntimeError as exc:
            print(f"floor: {n} robots: {exc}", file=sys.stderr)
            return 1
        print_row(rows[-1])
    meta = machine_meta(steps=opts.steps, contacts=opts.contacts, phases=opts.phases,
                        send=opts.send,
                        envelope_bytes=opts.envelope_bytes, bundle_bytes=opts.bundle_bytes,
                        world_bytes=opts.world_bytes, status_bytes=opts.status_bytes,
                        observers=opts.observers, clock=not opts.no_clock,
                        executor=os.environ.get("PHD_SWARM_EXECUTOR", "events"))
    write_results(opts.out, "floor", meta, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
