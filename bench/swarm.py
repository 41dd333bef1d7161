"""ROS swarm benchmark: real-time factor, CPU per robot and messages per robot per step.

For each team size, runs ``scripts/run_swarm.sh`` (lockstep, Dames static targets at
constant density as in the comms benchmark, no recorder) twice: one process per robot, and
all robots in one process (:mod:`phd_swarm.nodes.team`). Prints and writes to
``bench/results/swarm-<date>.json``:

- real-time factor: sim seconds per wall second while stepping (start-up excluded), and
  over the whole run including start-up and shut-down;
- CPU per robot: CPU seconds of the robot processes per robot per sim second;
- messages received per robot per step (protocol traffic, from the robots' statuses).

``scripts/bench.sh swarm [--sizes 10,30,50] [--duration S] [--quick]``.
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
             out: Path, domain: int) -> dict[str, object]:
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
           name, "--no-record", "--quiet", "--robots-per-process", str(per_process)]
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL)
    s = json.loads((out / name / "summary.json").read_text())
    return {"robots": robots, "layout": "one process per robot" if per_process == 1
            else "all robots in one process",
            "steps": s["steps"], "sim_s": s["sim_duration_s"],
            "stepping_wall_s": round(s["stepping_wall_s"], 2),
            "total_wall_s": round(s["wall_duration_s"], 2),
            "real_time_factor": round(s["real_time_factor"], 3),
            "real_time_factor_total": round(s["sim_duration_s"] / s["wall_duration_s"], 3),
            "cpu_per_robot_per_sim_s": round(s["cpu_s_per_robot"] / s["sim_duration_s"], 4),
            "messages_per_robot_per_step": round(s["messages_per_robot_per_step"], 1),
            "dead_robots": s["dead_robots"]}


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10,30,50", help="team sizes, comma separated")
    parser.add_argument("--duration", type=float, default=60.0, help="sim seconds per run")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--layouts", default="processes,one",
                        help="processes (one per robot) and/or one (all in one process)")
    parser.add_argument("--quick", action="store_true", help="sizes 4,8 and 10 s of sim time")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    opts = parser.parse_args(argv)
    sizes = [4, 8] if opts.quick else [int(x) for x in opts.sizes.split(",")]
    duration = 10.0 if opts.quick else opts.duration
    domain = int(os.environ.get("ROS_DOMAIN_ID", "42"))
    rows = []
    print(f"{'robots':>6} {'layout':<26} {'RTF':>6} {'RTF all':>8} {'CPU/robot':>10} "
          f"{'msgs/robot':>10}  dead")
    with tempfile.TemporaryDirectory(prefix="phd-swarm-bench-") as tmp:
        for n in sizes:
            layouts = opts.layouts.split(",")
            for per in [p for p, name in ((1, "processes"), (n, "one")) if name in layouts]:
                r = run_once(n, per, duration, opts.seed, Path(tmp), domain)
                rows.append(r)
                print(f"{n:>6} {r['layout']:<26} {r['real_time_factor']:>6.2f} "
                      f"{r['real_time_factor_total']:>8.2f} "
                      f"{r['cpu_per_robot_per_sim_s']:>10.3f} "
                      f"{r['messages_per_robot_per_step']:>10.1f}  {r['dead_robots']}",
                      flush=True)
    write_results(opts.out, "swarm", machine_meta(duration_s=duration), rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
