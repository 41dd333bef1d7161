"""ROS swarm benchmark: real-time factor, CPU per robot and messages per robot per step.

For each team size, runs ``scripts/run_swarm.sh`` (lockstep, Dames static targets at
constant density as in the comms benchmark) in each layout: one process per robot
(``processes``), ``--per-group`` robots per process (``grouped``, issue 21's 10), and all
robots in one process (``one``, :mod:`phd_swarm.nodes.team`). With ``--record`` the
recorder runs too (every step topic, no inboxes) and the row says whether the log is
complete. Prints and writes to ``bench/results/swarm-<date>.json``:

- real-time factor: sim seconds per wall second while stepping (start-up excluded), and
  over the whole run including start-up and shut-down;
- CPU per robot: CPU seconds of the robot processes per robot per sim second, and per
  robot-step [ms] (start-up included: short runs overstate it);
- messages received per robot per step (protocol traffic, from the robots' statuses);
- the largest peak resident memory of a process of the run [MB] (a forked robot
  process's counts the pages it shares with the fork server);
- CPU of the world, monitor, recorder and fork server per step [ms] (start-up included).

``scripts/bench.sh swarm [--sizes 10,30,50,100] [--layouts processes,grouped,one]
[--per-group 10] [--record] [--duration S] [--quick]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from results_io import machine_meta, write_results

ROOT = Path(__file__).resolve().parents[1]


def run_once(robots: int, per_process: int, duration: float, seed: int,
             out: Path, domain: int, record: bool = False) -> dict[str, object]:
    """One run_swarm run; returns its figures."""
    side = 100.0 * (robots / 30.0) ** 0.5
    config = out / f"bench-{robots}.yaml"
    config.write_text(
        "/**:\n  ros__parameters:\n    scenario:\n      preset: dames_static\n"
        f"      env: {{xmin: 0.0, ymin: 0.0, xmax: {side:.0f}.0, ymax: {side:.0f}.0}}\n"
        f"      robot_start_box: [0.0, 0.0, {side:.0f}.0, {side:.0f}.0]\n"
        f"      targets: {{count: {robots}, draw_box: [0.0, 0.0, {side:.0f}.0, "
        f"{side:.0f}.0]}}\n"
        "world:\n  ros__parameters: {step_timeout: 60.0, ready_timeout: 300.0}\n"
        "/**/robot:\n  ros__parameters: {ready_timeout: 300.0, tick_period: 5.0}\n")
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    name = f"r{robots}-p{per_process}"
    cmd = [str(ROOT / "scripts" / "run_swarm.sh"), str(config), "--robots", str(robots),
           "--duration", str(duration), "--seed", str(seed), "--out", str(out), "--name",
           name, "--quiet", "--robots-per-process", str(per_process)]
    if not record:
        cmd.append("--no-record")
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL)
    s = json.loads((out / name / "summary.json").read_text())
    layout = ("one process per robot" if per_process == 1 else "all robots in one process"
              if per_process >= robots else f"{per_process} robots per process")
    report = s.get("log_completeness")
    return {"robots": robots, "layout": layout, "processes": -(-robots // per_process),
            "recorded": record,
            "log_complete": None if not record or report is None else report["complete"],
            "cpu_ms_per_robot_step": round(1e3 * s["cpu_s_per_robot"] / max(s["steps"], 1),
                                           1),
            "peak_memory_mb_per_process": round(max(s["peak_memory_mb"].values()), 1),
            "steps": s["steps"], "sim_s": s["sim_duration_s"],
            "stepping_wall_s": round(s["stepping_wall_s"], 2),
            "total_wall_s": round(s["wall_duration_s"], 2),
            "real_time_factor": round(s["real_time_factor"], 3),
            "real_time_factor_total": round(s["sim_duration_s"] / s["wall_duration_s"], 3),
            "cpu_per_robot_per_sim_s": round(s["cpu_s_per_robot"] / s["sim_duration_s"], 4),
            "messages_per_robot_per_step": round(s["messages_per_robot_per_step"], 1),
            # The all-to-all part: CPU of the world, monitor and recorder per step [ms].
            "cpu_ms_per_step": {k: round(1e3 * s["cpu_s"][k] / max(s["steps"], 1), 1)
                                for k in ("world", "monitor", "recorder", "fork_server")
                                if k in s["cpu_s"]},
            "dead_robots": s["dead_robots"]}


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10,30,50", help="team sizes, comma separated")
    parser.add_argument("--duration", type=float, default=60.0, help="sim seconds per run")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--layouts", default="processes,grouped,one",
                        help="processes (one per robot), grouped (--per-group per process), "
                        "one (all in one process); comma separated")
    parser.add_argument("--per-group", type=int, default=10,
                        help="robots per process in the grouped layout")
    parser.add_argument("--record", action="store_true",
                        help="run the recorder too and report whether the log is complete")
    parser.add_argument("--quick", action="store_true",
                        help="size 4 (2 per group), 5 s of sim time, recorded")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    opts = parser.parse_args(argv)
    try:
        sizes = [4] if opts.quick else [int(x) for x in opts.sizes.split(",")]
    except ValueError:
        parser.error(f"--sizes: comma-separated integers, got {opts.sizes!r}")
    layouts = opts.layouts.split(",")
    unknown = set(layouts) - {"processes", "grouped", "one"}
    if unknown or opts.per_group < 1:
        parser.error(f"--layouts: processes, grouped, one; got {sorted(unknown)}"
                     if unknown else "--per-group must be at least 1")
    per_group = 2 if opts.quick else opts.per_group
    duration = 5.0 if opts.quick else opts.duration
    record = opts.record or opts.quick
    domain = int(os.environ.get("ROS_DOMAIN_ID", "42"))
    rows = []
    print(f"{'robots':>6} {'layout':<26} {'RTF':>6} {'RTF all':>8} {'CPU/robot':>10} "
          f"{'ms/step':>8} {'msgs/robot':>10} {'MB/proc':>8} {'log':>8} "
          f"{'world/mon/rec ms':>17}  dead")
    with tempfile.TemporaryDirectory(prefix="phd-swarm-bench-") as tmp:
        for n in sizes:
            pers = {"processes": 1, "grouped": min(per_group, n), "one": n}
            for per in dict.fromkeys(pers[name] for name in layouts):
                r = run_once(n, per, duration, opts.seed, Path(tmp), domain, record)
                rows.append(r)
                log = {None: "-", True: "complete", False: "GAPS"}[r["log_complete"]]
                observers = "/".join(str(r["cpu_ms_per_step"].get(k, "-"))
                                     for k in ("world", "monitor", "recorder"))
                print(f"{n:>6} {r['layout']:<26} {r['real_time_factor']:>6.2f} "
                      f"{r['real_time_factor_total']:>8.2f} "
                      f"{r['cpu_per_robot_per_sim_s']:>10.3f} "
                      f"{r['cpu_ms_per_robot_step']:>8.1f} "
                      f"{r['messages_per_robot_per_step']:>10.1f} "
                      f"{r['peak_memory_mb_per_process']:>8.0f} {log:>8} "
                      f"{observers:>17}  "
                      f"{r['dead_robots']}", flush=True)
    write_results(opts.out, "swarm", machine_meta(duration_s=duration), rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
