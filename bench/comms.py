"""Communication benchmark (issue 4): traffic per robot per step vs team size.

Run with ``scripts/bench.sh comms``. Teams of 10, 30 and 100 robots at constant robot
density (400 m^2 per robot: the square map's side grows as 20 m x sqrt(R)) and constant
target density (one moving target per 500 m^2, Dames moving-target models with births, so
that hand-overs, phantom mass and eta exchanges all occur). Robots start spread over the
whole map (uniform start box) so the figures describe the steady state rather than the
crowded start of the papers' runs. After a warm-up, the engine counts the messages and
estimated CDR bytes each robot *receives* per step, by type. If the algorithm is
distributed, the figures stay flat as the team grows (Dames Sec. III-C: constant
complexity in the team size). Also prints the engine's steps per second.

Writes ``bench/results/comms-<date>.json``.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter
from pathlib import Path

import numpy as np
from results_io import machine_meta, write_results

from phd_swarm.core.geometry.grid import Environment
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim import presets as sc
from phd_swarm.sim.scenario import Scenario

AREA_PER_ROBOT = 400.0  # [m^2]
AREA_PER_TARGET = 500.0  # [m^2]
INTERIOR_MARGIN = 30.0  # [m]


def team_scenario(robots: int, seed: int) -> Scenario:
    """Dames moving-target scenario scaled to ``robots`` at constant densities."""
    side = float(round(np.sqrt(robots * AREA_PER_ROBOT)))
    targets = max(1, int(round(side * side / AREA_PER_TARGET)))
    base = sc.dames_moving(robots=robots, targets=targets)
    return base.with_overrides(env=Environment(0.0, 0.0, side, side),
                               robot_start_box=(0.0, 0.0, side, side), seed=seed)


def measure(robots: int, warmup: int, steps: int, seed: int) -> dict[str, object]:
    """Run one team and summarise the traffic of the measured steps."""
    scenario = team_scenario(robots, seed)
    engine = DistributedEngine(scenario, "phd")
    engine.run(warmup)
    t0 = time.perf_counter()
    engine.run(steps)
    wall = time.perf_counter() - t0
    traffic = engine.traffic[warmup:]
    # Interior robots (>= 30 m from the boundary at the end) see the team's full density;
    # near the boundary a robot has fewer contacts, and the boundary's share of a team
    # shrinks as the map grows, which lifts the all-robot mean slightly with R.
    q = engine.world.robot_positions
    interior = scenario.env.distance_to_boundary(q) >= INTERIOR_MARGIN
    interior_ids = [int(r) for r in np.asarray(engine.world.robot_ids)[interior]]
    interior_msgs = np.array([[sum(t.messages[r].values()) for r in interior_ids]
                              for t in traffic], dtype=float)
    per_robot_msgs = np.array([[sum(t.messages[r].values()) for r in engine.robots]
                               for t in traffic], dtype=float)
    per_robot_bytes = np.array([[sum(t.bytes[r].values()) for r in engine.robots]
                                for t in traffic], dtype=float)
    by_type: Counter = Counter()
    for t in traffic:
        for counter in t.messages.values():
            by_type.update(counter)
    n = len(traffic) * robots
    return {
        "robots": robots, "map_side_m": scenario.env.width,
        "targets": scenario.targets.count, "steps": steps,
        "messages_per_robot_per_step": float(per_robot_msgs.mean()),
        "messages_per_robot_per_step_p95": float(np.percentile(per_robot_msgs, 95)),
        "bytes_per_robot_per_step": float(per_robot_bytes.mean()),
        "interior_robots": len(interior_ids),
        "interior_messages_per_robot_per_step": (float(interior_msgs.mean())
                                                 if interior_ids else None),
        "by_type_per_robot_per_step": {k: v / n for k, v in sorted(by_type.items())},
        "steps_per_second": steps / wall,
    }


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark, print the table and write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="10,30,100", help="team sizes, comma separated")
    parser.add_argument("--warmup", type=int, default=10)
    parser.add_argument("--steps", type=int, default=30)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--quick", action="store_true", help="3 warm-up and 5 measured steps")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args(argv)
    warmup, steps = (3, 5) if args.quick else (args.warmup, args.steps)
    sizes = [int(s) for s in args.sizes.split(",")]
    results = [measure(r, warmup, steps, args.seed) for r in sizes]
    meta = machine_meta(warmup=warmup, steps=steps)
    print(f"comms benchmark {meta['date']} ({meta['cpus']} cpus); received per robot per step")
    print(f"{'robots':>6} {'map m':>6} {'targets':>7} {'msgs':>7} {'msgs p95':>8} "
          f"{'interior':>13} {'kB':>7} {'steps/s':>8}")
    for r in results:
        inner = r["interior_messages_per_robot_per_step"]
        inner_s = f"{inner:.1f} (n={r['interior_robots']})" if inner is not None else "-"
        print(f"{r['robots']:>6} {r['map_side_m']:>6.0f} {r['targets']:>7} "
              f"{r['messages_per_robot_per_step']:>7.1f} "
              f"{r['messages_per_robot_per_step_p95']:>8.1f} {inner_s:>13} "
              f"{r['bytes_per_robot_per_step'] / 1e3:>7.2f} {r['steps_per_second']:>8.2f}")
    kinds = sorted({k for r in results for k in r["by_type_per_robot_per_step"]})
    print("by type (messages per robot per step): " + ", ".join(kinds))
    for r in results:
        row = r["by_type_per_robot_per_step"]
        print(f"{r['robots']:>6} " + " ".join(f"{row.get(k, 0.0):>7.2f}" for k in kinds))
    write_results(args.out, "comms", meta, results)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
