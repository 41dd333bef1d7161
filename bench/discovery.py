"""Discovery benchmark: how many processes on one host find each other, how fast, at what cost.

Run with ``scripts/bench.sh discovery [--sizes 32,50,100] [--modes localhost,profile,server]
[--duration 90] [--quick]``. For each mode and size N it starts N processes at once
(``bench/discovery_peer.py``: one node, one publisher and one subscription on a shared
topic), each printing every 0.5 s how many publishers of the topic it sees, and reports

- ``all_matched``: how many processes saw all N publishers at some time;
- ``matched_after_s``: the time from the start until the last of them did (None if not all);
- ``min_seen``, ``median_seen``: the most publishers a process saw at once, least and median;
- ``cpu_s``: the processes' CPU seconds (user + system) over the run, and per process;
- ``max_rss_mb``: the largest resident memory of a process.

Modes (every one on loopback, each with a ROS_DOMAIN_ID of its own):

- ``localhost``: ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, Jazzy's default for our
  scripts: rmw_fastrtps adds shared memory and a UDP transport that probes 32 ports;
- ``profile``: ``SYSTEM_DEFAULT`` with the repository's Fast DDS profile
  ``config/dds/loopback_udp.xml`` (UDP on 127.0.0.1 only, 160 ports probed, no shared
  memory);
- ``server``: ``LOCALHOST`` with phd_swarm's discovery server on 127.0.0.1
  (:mod:`phd_swarm.tools.discovery_server`, ``ROS_DISCOVERY_SERVER``);
- ``server_profile``: the profile's transport with the discovery server, as
  ``run_swarm.sh --discovery-server on`` runs it.

Processes are stopped by PID (their process group) whatever happens. Writes
``bench/results/discovery-<date>.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from results_io import machine_meta, write_results

from phd_swarm.tools.dds import dds_env, free_udp_port, server_env, server_profile
from phd_swarm.tools.discovery_server import UP as SERVER_UP

ROOT = Path(__file__).resolve().parents[1]
PEER = Path(__file__).with_name("discovery_peer.py")
MODES = ("localhost", "profile", "server", "server_profile")
#: The domain of the first mode's runs; each run takes the next one.
BASE_DOMAIN = 150


def mode_env(mode: str, domain: int, work: Path) -> tuple[dict[str, str],
                                                       tuple[list[str], dict[str, str]] | None]:
    """The environment of a mode's processes, and the server's command and environment.

    The server part is None in modes without one; its profile is written into ``work``.
    """
    env = dds_env(os.environ, profile=mode in ("profile", "server_profile"))
    env.update(ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED="1")
    for var in ("ROS_DISCOVERY_SERVER", "ROS_STATIC_PEERS"):
        env.pop(var, None)
    server = None
    if mode in ("server", "server_profile"):
        port = free_udp_port()
        profile = work / "discovery_server.xml"
        profile.write_text(server_profile(port))
        server = ([sys.executable, "-m", "phd_swarm.tools.discovery_server", "--profile",
                   str(profile), "--port", str(port)], server_env(env, profile))
        env["ROS_DISCOVERY_SERVER"] = f"127.0.0.1:{port}"
    return env, server


def run(mode: str, n: int, duration: float, domain: int,
        stop_when_matched: bool = False) -> dict[str, object]:
    """Start ``n`` peers in ``mode``; their discovery figures (see the module docstring).

    With ``stop_when_matched`` the peers are stopped (a stop file they poll, not a signal:
    ``bench/discovery_peer.py``) as soon as every one of them has seen all ``n``
    publishers, ``duration`` being only the cap.
    """
    work = Path(tempfile.mkdtemp(prefix="phd_swarm_discovery_"))
    stop_file = work / "stop"
    env, server_spec = mode_env(mode, domain, work)
    procs: list[subprocess.Popen] = []
    server = None
    lines: list[list[dict]] = [[] for _ in range(n)]
    usage: dict[int, tuple[float, float]] = {}
    stuck: dict[int, str] = {}

    def read(i: int, proc: subprocess.Popen) -> None:
        for line in proc.stdout:
            try:
                lines[i].append(json.loads(line))
            except json.JSONDecodeError:
                pass

    t0 = time.time()
    try:
        if server_spec is not None:
            server = subprocess.Popen(server_spec[0], env=server_spec[1],
                                      stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                      text=True, start_new_session=True)
            # Its up line (rclpy logs to stderr, merged here), so no peer starts before it.
            for line in server.stdout:
                if SERVER_UP in line:
                    break
            else:
                raise RuntimeError(f"the discovery server exited ({server.wait()})")
        t0 = time.time()
        threads = []
        for i in range(n):
            # Each peer's stderr goes to a file: a peer that does not exit is asked for
            # its stack (faulthandler on SIGUSR1), which the row then names.
            proc = subprocess.Popen([sys.executable, str(PEER), str(i), str(duration),
                                     str(stop_file)],
                                    env=env, stdout=subprocess.PIPE,
                                    stderr=(work / f"peer{i}.err").open("w"),
                                    text=True, start_new_session=True)
            procs.append(proc)
            th = threading.Thread(target=read, args=(i, proc), daemon=True)
            th.start()
            threads.append(th)
        deadline = time.time() + duration + 60.0
        if stop_when_matched:
            while (time.time() < t0 + duration
                   and not all(any(r["publishers"] >= n for r in reports)
                               for reports in lines)):
                time.sleep(0.2)
            stop_file.touch()
        for proc in procs:
            # wait4 gives this child's own rusage (CPU, peak memory).
            while True:
                pid, status, ru = os.wait4(proc.pid, os.WNOHANG)
                if pid:
                    proc.returncode = os.waitstatus_to_exitcode(status)
                    usage[proc.pid] = (ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024.0)
                    break
                if time.time() > deadline:
                    break
                time.sleep(0.1)
        for th in threads:
            th.join(timeout=5.0)
        stuck = _stacks_of_stuck(procs, usage, work)
    finally:
        for p in [*procs, server]:
            if p is not None and p.poll() is None and p.pid not in usage:
                try:
                    os.killpg(p.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                p.wait()
        shutil.rmtree(work, ignore_errors=True)
    matched_at = []
    for reports in lines:
        hit = [r["t"] - t0 for r in reports if r["publishers"] >= n]
        matched_at.append(min(hit) if hit else None)
    # The most publishers each process saw at once (near the end, peers exit one by one).
    peaks = [max((r["publishers"] for r in reports), default=0) for reports in lines]
    done = [t for t in matched_at if t is not None]
    cpu = sum(u[0] for u in usage.values())
    return {"mode": mode, "processes": n, "duration_s": duration,
            "all_matched": len(done),
            "matched_after_s": round(max(done), 1) if len(done) == n else None,
            "median_seen": sorted(peaks)[n // 2] if peaks else 0,
            "min_seen": min(peaks) if peaks else 0,
            "cpu_s": round(cpu, 1), "cpu_s_per_process": round(cpu / n, 2),
            "max_rss_mb": round(max((u[1] for u in usage.values()), default=0.0), 1),
            "exited": len(usage), "stuck": stuck}


def _stacks_of_stuck(procs: list[subprocess.Popen], usage: dict[int, tuple[float, float]],
                     work: Path) -> dict[int, str]:
    """Peers not reaped by the deadline: index -> the end of their stderr and stack dump."""
    stuck = {i: p for i, p in enumerate(procs) if p.pid not in usage and p.poll() is None}
    for p in stuck.values():
        p.send_signal(signal.SIGUSR1)
    if stuck:
        time.sleep(1.0)
    return {i: (work / f"peer{i}.err").read_text()[-4000:] for i in stuck}


def main(argv: list[str] | None = None) -> int:
    """Run every mode and size, print one line each and write the JSON."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", default="32,50,100", help="process counts, comma-separated")
    p.add_argument("--modes", default="localhost,profile,server",
                   help=f"comma-separated, of {', '.join(MODES)}")
    p.add_argument("--duration", type=float, default=90.0, help="seconds each peer runs")
    p.add_argument("--quick", action="store_true", help="10 processes, profile only, stopped "
                   "once all matched (at most 120 s)")
    p.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results")
    args = p.parse_args(argv)
    try:
        sizes = [10] if args.quick else [int(s) for s in args.sizes.split(",")]
    except ValueError:
        p.error(f"--sizes must be comma-separated process counts, got {args.sizes!r}")
    modes = ["profile"] if args.quick else args.modes.split(",")
    duration = 120.0 if args.quick else args.duration
    bad = [m for m in modes if m not in MODES]
    if bad:
        p.error(f"unknown mode(s) {bad}; choose from {MODES}")
    rows = []
    domain = BASE_DOMAIN
    for mode in modes:
        for n in sizes:
            row = run(mode, n, duration, domain, stop_when_matched=args.quick)
            domain += 1
            rows.append(row)
            print(f"{mode:>14} {n:4d} processes: {row['all_matched']:4d} saw all "
                  f"(after {row['matched_after_s']} s), most seen: min "
                  f"{row['min_seen']} median {row['median_seen']}; CPU "
                  f"{row['cpu_s']} s ({row['cpu_s_per_process']} s per process), "
                  f"max RSS {row['max_rss_mb']} MB", flush=True)
    write_results(args.out, "discovery", machine_meta(), rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
