"""Recorder benchmark: is the log complete, what does it cost, how fast do runs start and stop.

Runs ``scripts/run_swarm.sh`` on the demo's setting (``config/dames_static.yaml``, robots
crowded in the start box, one process per robot, lockstep, recorded) for each team size,
once without and once with the protocol inboxes recorded (``--record-inboxes``), and prints
and writes to ``bench/results/recorder-<date>.json``:

- steps and real-time factor while stepping;
- start-up: wall seconds from the world's start to "all robots ready" (its log);
- messages the recorder wrote, its CPU seconds, and CPU per message [ms];
- the log's completeness: step messages expected, recorded and missing (the recorder's
  report, :mod:`phd_swarm.nodes.completeness`);
- with ``--interrupt-after S``: a further run per size interrupted with SIGINT S wall
  seconds after stepping began, and how long ``run_swarm`` took to stop every process.

``scripts/bench.sh recorder [--sizes 20] [--duration 120] [--interrupt-after 20] [--quick]``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from results_io import machine_meta, write_results

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "dames_static.yaml"
_READY = re.compile(r"all (\d+) robots and \d+ observers ready after ([\d.]+) s")


def _env(domain: int) -> dict[str, str]:
    return dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")


def _argv(robots: int, duration: float, out: Path, name: str, extra: list[str]) -> list[str]:
    return [str(ROOT / "scripts" / "run_swarm.sh"), str(CONFIG), "--robots", str(robots),
            "--targets", "30", "--duration", str(duration), "--seed", "1", "--out", str(out),
            "--name", name, "--quiet", *extra]


def _startup_s(run: Path) -> float | None:
    """Seconds the world waited for the team, from its log (None before it is ready)."""
    log = run / "logs" / "world.log"
    match = _READY.search(log.read_text()) if log.exists() else None
    return float(match.group(2)) if match else None


def run_once(robots: int, duration: float, inboxes: bool, out: Path, domain: int
             ) -> dict[str, object]:
    """One recorded run; returns its figures."""
    name = f"r{robots}-{'inboxes' if inboxes else 'steps'}"
    extra = ["--record-inboxes"] if inboxes else []
    subprocess.run(_argv(robots, duration, out, name, extra), env=_env(domain), check=True,
                   stdout=subprocess.DEVNULL)
    run = out / name
    s = json.loads((run / "summary.json").read_text())
    wrote = re.search(r"wrote (\d+) messages", (run / "logs" / "recorder.log").read_text())
    messages = int(wrote.group(1)) if wrote else 0
    cpu = float(s["cpu_s"].get("recorder", 0.0))
    report = s["log_completeness"] or {}
    return {"robots": robots, "inboxes_recorded": inboxes, "steps": s["steps"],
            "real_time_factor": round(s["real_time_factor"], 3),
            "startup_s": _startup_s(run),
            "recorder_messages": messages, "recorder_cpu_s": round(cpu, 2),
            "recorder_ms_per_message": round(1000 * cpu / messages, 4) if messages else None,
            "robot_cpu_s_per_robot": round(s["cpu_s_per_robot"], 2),
            "step_messages_expected": report.get("expected"),
            "step_messages_recorded": report.get("recorded"),
            "step_messages_missing": report.get("missing"),
            "dead_robots": s["dead_robots"]}


def interrupt_once(robots: int, after: float, out: Path, domain: int) -> dict[str, object]:
    """A run interrupted ``after`` s into stepping; how long run_swarm takes to stop."""
    name = f"r{robots}-interrupted"
    proc = subprocess.Popen(_argv(robots, 3600.0, out, name, []), env=_env(domain),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    run = out / name
    try:
        deadline = time.monotonic() + 900.0
        while _startup_s(run) is None:
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"{name}: the team did not start")
            time.sleep(0.2)
        time.sleep(after)
        start = time.monotonic()
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=120.0)
        stop_s = time.monotonic() - start
    finally:
        if proc.poll() is None:  # run_swarm stops its children on SIGTERM
            proc.terminate()
            try:
                proc.wait(timeout=30.0)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                subprocess.run(["pkill", "-9", "-f", str(run)], check=False)
    left = subprocess.run(["pgrep", "-f", str(run)], capture_output=True, text=True).stdout
    return {"robots": robots, "interrupted_after_s": after, "stop_s": round(stop_s, 2),
            "exit_code": proc.returncode, "processes_left": len(left.split())}


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark (see the module docstring)."""
    p = argparse.ArgumentParser(prog="scripts/bench.sh recorder")
    p.add_argument("--sizes", default="20", help="team sizes, comma-separated")
    p.add_argument("--duration", type=float, default=120.0, help="sim seconds per run")
    p.add_argument("--interrupt-after", type=float, default=None, metavar="S",
                   help="also measure Ctrl-C S wall seconds into a run")
    p.add_argument("--no-inboxes", action="store_true", help="skip the runs with inboxes")
    p.add_argument("--quick", action="store_true", help="4 robots, 10 s: a smoke run")
    p.add_argument("--out", default=str(ROOT / "bench" / "results"))
    args = p.parse_args(argv)
    sizes = [4] if args.quick else [int(x) for x in args.sizes.split(",")]
    duration = 10.0 if args.quick else args.duration
    rows: list[dict[str, object]] = []
    stops: list[dict[str, object]] = []
    domain = 180 + os.getpid() % 40
    with tempfile.TemporaryDirectory(prefix="bench-recorder-") as tmp:
        out = Path(tmp)
        for robots in sizes:
            for inboxes in ([False] if args.no_inboxes else [False, True]):
                row = run_once(robots, duration, inboxes, out, domain)
                rows.append(row)
                print(json.dumps(row), flush=True)
            if args.interrupt_after is not None:
                stop = interrupt_once(robots, args.interrupt_after, out, domain)
                stops.append(stop)
                print(json.dumps(stop), flush=True)
    print("\n| robots | inboxes | steps | RTF | start-up [s] | recorder msgs | recorder CPU "
          "[s] | ms / msg | step msgs expected | missing |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['robots']} | {'yes' if r['inboxes_recorded'] else 'no'} | {r['steps']} | "
              f"{r['real_time_factor']} | {r['startup_s']} | {r['recorder_messages']} | "
              f"{r['recorder_cpu_s']} | {r['recorder_ms_per_message']} | "
              f"{r['step_messages_expected']} | {r['step_messages_missing']} |")
    for s in stops:
        print(f"Ctrl-C at {s['robots']} robots: stopped in {s['stop_s']} s, exit code "
              f"{s['exit_code']}, {s['processes_left']} processes left")
    write_results(Path(args.out), "recorder", machine_meta(duration_s=duration),
                  {"runs": rows, "interrupts": stops})
    return 0


if __name__ == "__main__":
    sys.exit(main())
