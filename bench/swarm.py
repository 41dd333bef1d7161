"""ROS swarm benchmark: real-time factor, start-up, CPU of robots and observers per step.

For each team size and start, runs ``scripts/run_swarm.sh`` (lockstep at 2 Hz, Dames'
static targets) in each layout: one process per robot (``processes``), ``--per-group``
robots per process (``grouped``, issue 21's 10), and all robots in one process (``one``,
:mod:`phd_swarm.nodes.team`). Starts: ``spread``, the team spread over a map that grows
with it (side 100 m x sqrt(N / 30), a target per robot: constant density, as in the comms
benchmark); ``crowded``, Dames' crowded start (``config/dames_static.yaml``: 100 m map,
the team in its 20 x 10 m box, 30 targets). With ``--record`` the recorder runs too (every
step topic, no inboxes) and the row says whether the log is complete. Prints one table
and writes ``bench/results/swarm-<date>.json``; per row:

- real-time factor: sim seconds per wall second while stepping, and over the whole run
  with start-up and shut-down;
- start-up: from run_swarm's start to the world's "all robots and observers ready" line
  (every process up and matched) [s];
- CPU while stepping (from that line to the world's "done", ``summary.json``'s
  ``cpu_s_stepping``): of the robot processes per robot-step [ms], and of the world,
  monitor and recorder per step [ms] and their sum;
- CPU of the robot processes per robot-step with start-up, as earlier tables had it;
- protocol messages received per robot per step (from the robots' statuses);
- peak resident memory [MB]: the largest robot process, and the largest process of the
  run (a forked robot process counts the pages it shares with the fork server);
- log completeness and the robots counted dead.

``scripts/bench.sh swarm [--sizes 10,30,50,100] [--layouts processes,grouped,one]
[--starts spread,crowded] [--per-group 10] [--record] [--duration S] [--quick]``.
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


#: The observer processes whose CPU per step the table gives.
OBSERVERS = ("world", "monitor", "recorder")


def _config(robots: int, start: str, out: Path) -> Path:
    """The run config of a team of ``robots`` from ``start`` (see the module docstring)."""
    config = out / f"bench-{start}-{robots}.yaml"
    if start == "crowded":
        scenario = "      preset: dames_static\n"
    else:
        side = 100.0 * (robots / 30.0) ** 0.5
        scenario = (
            "      preset: dames_static\n"
            f"      env: {{xmin: 0.0, ymin: 0.0, xmax: {side:.0f}.0, ymax: {side:.0f}.0}}\n"
            f"      robot_start_box: [0.0, 0.0, {side:.0f}.0, {side:.0f}.0]\n"
            f"      targets: {{count: {robots}, draw_box: [0.0, 0.0, {side:.0f}.0, "
            f"{side:.0f}.0]}}\n")
    config.write_text(
        "/**:\n  ros__parameters:\n    scenario:\n" + scenario
        + "world:\n  ros__parameters: {step_timeout: 60.0, ready_timeout: 300.0}\n"
        "/**/robot:\n  ros__parameters: {ready_timeout: 300.0, tick_period: 5.0}\n")
    return config


def run_once(robots: int, per_process: int, duration: float, seed: int,
             out: Path, domain: int, record: bool = False, start: str = "spread"
             ) -> dict[str, object]:
    """One run_swarm run; returns its figures."""
    config = _config(robots, start, out)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    name = f"{start}-r{robots}-p{per_process}"
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
    steps = max(s["steps"], 1)
    stepping = s.get("cpu_s_stepping", {})
    robots_stepping = sum(v for k, v in stepping.items() if k.startswith("robot"))
    observers = {k: round(1e3 * stepping[k] / steps, 1) for k in OBSERVERS if k in stepping}
    robot_mb = [v for k, v in s["peak_memory_mb"].items() if k.startswith("robot")]
    return {"robots": robots, "start": start, "layout": layout,
            "processes": -(-robots // per_process), "recorded": record,
            "log_complete": None if not record or report is None else report["complete"],
            "startup_s": s.get("startup_s"),
            "robot_cpu_ms_per_robot_step_stepping": round(
                1e3 * robots_stepping / (robots * steps), 2),
            "observers_cpu_ms_per_step_stepping": observers,
            "observers_cpu_ms_per_step_stepping_sum": round(sum(observers.values()), 1),
            "cpu_ms_per_robot_step": round(1e3 * s["cpu_s_per_robot"] / steps, 1),
            "peak_memory_mb_robot_process": round(max(robot_mb, default=0.0), 1),
            "peak_memory_mb_per_process": round(max(s["peak_memory_mb"].values()), 1),
            "steps": s["steps"], "sim_s": s["sim_duration_s"],
            "stepping_wall_s": round(s["stepping_wall_s"], 2),
            "total_wall_s": round(s["wall_duration_s"], 2),
            "real_time_factor": round(s["real_time_factor"], 3),
            "real_time_factor_total": round(s["sim_duration_s"] / s["wall_duration_s"], 3),
            "cpu_per_robot_per_sim_s": round(s["cpu_s_per_robot"] / s["sim_duration_s"], 4),
            "messages_per_robot_per_step": round(s["messages_per_robot_per_step"], 1),
            # With start-up: CPU of the world, monitor, recorder, fork server per step [ms].
            "cpu_ms_per_step": {k: round(1e3 * s["cpu_s"][k] / steps, 1)
                                for k in (*OBSERVERS, "fork_server") if k in s["cpu_s"]},
            "dead_robots": s["dead_robots"]}


HEADER = (f"{'robots':>6} {'start':<7} {'layout':<26} {'RTF':>5} {'RTF all':>7} "
          f"{'start-up s':>10} {'robot ms':>8} {'obs ms':>6} {'world/mon/rec':>15} "
          f"{'msgs':>5} {'MB robot/max':>12} {'log':>8}  dead")


def table_line(r: dict[str, object]) -> str:
    """One row of the printed table (see the module docstring for the figures)."""
    log = {None: "-", True: "complete", False: "GAPS"}[r["log_complete"]]
    obs = r["observers_cpu_ms_per_step_stepping"]
    split = "/".join(f"{obs[k]:.0f}" if k in obs else "-" for k in OBSERVERS)
    startup = "-" if r["startup_s"] is None else f"{r['startup_s']:.1f}"
    return (f"{r['robots']:>6} {r['start']:<7} {r['layout']:<26} "
            f"{r['real_time_factor']:>5.2f} {r['real_time_factor_total']:>7.2f} "
            f"{startup:>10} {r['robot_cpu_ms_per_robot_step_stepping']:>8.1f} "
            f"{r['observers_cpu_ms_per_step_stepping_sum']:>6.0f} {split:>15} "
            f"{r['messages_per_robot_per_step']:>5.1f} "
            f"{r['peak_memory_mb_robot_process']:>5.0f}/{r['peak_memory_mb_per_process']:<6.0f} "
            f"{log:>8}  {r['dead_robots']}")


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
    parser.add_argument("--starts", default="spread",
                        help="spread (a map growing with the team), crowded (Dames' start "
                        "box); comma separated")
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
    starts = opts.starts.split(",")
    if set(starts) - {"spread", "crowded"}:
        parser.error(f"--starts: spread, crowded; got {opts.starts!r}")
    per_group = 2 if opts.quick else opts.per_group
    # 60 steps: the stepping window must span many of run_swarm's 0.2 s CPU samples (with
    # 10 steps it fit in one, and the observers' CPU while stepping read 0).
    duration = 30.0 if opts.quick else opts.duration
    record = opts.record or opts.quick
    domain = int(os.environ.get("ROS_DOMAIN_ID", "42"))
    rows = []
    print(HEADER, flush=True)
    with tempfile.TemporaryDirectory(prefix="phd-swarm-bench-") as tmp:
        for start in starts:
            for n in sizes:
                pers = {"processes": 1, "grouped": min(per_group, n), "one": n}
                for per in dict.fromkeys(pers[name] for name in layouts):
                    r = run_once(n, per, duration, opts.seed, Path(tmp), domain, record,
                                 start)
                    rows.append(r)
                    print(table_line(r), flush=True)
    write_results(opts.out, "swarm", machine_meta(duration_s=duration), rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
