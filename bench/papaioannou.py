"""Papaioannou et al. benchmark: a 100-step trial, the 17-action Rényi reward, the ROS run.

Run with ``scripts/bench.sh papaioannou [--quick] [--repeats 3] [--no-ros]``. Measures

- **a trial**: CPU seconds of this process for one 100-step trial of Fig. 3's setting
  (``config/sweeps/papaioannou_fig3.yaml``, C_R = 50 m, 5 agents, 10 targets from the
  centre) in the distributed engine, the engine's steps and the sweeps' per-step scoring
  (OSPA of the team's estimates, the figures) apart; the issue's target is <= 5 s;
- **the tracking reward**: one evaluation of eq. 18 for the 17 moves of eq. 4
  (:meth:`phd_swarm.core.controllers.sat_search_track.tracking.RenyiTracking.choose`,
  vectorised over moves and
  particles) on a predicted particle cloud of N = 300, 1,200 and 6,000 particles around
  1, 2 and 4 estimates: median ms per evaluation and ns per (move x particle);
- **the ROS run** (unless ``--no-ros``): ``run_swarm.sh config/papaioannou_small.yaml``
  (world, monitor, recorder, 4 agent processes, lockstep, recorded): real-time factor,
  messages per agent per step and the system's figures.

Writes ``bench/results/papaioannou-<date>.json``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from results_io import machine_meta, run_swarm_figures, time_trial, write_results

from phd_swarm.config.sweep_spec import find_spec, load_spec
from phd_swarm.core import registry
from phd_swarm.core.controllers.sat_search_track.agent_moves import admissible_positions

ROOT = Path(__file__).resolve().parents[1]


def fig3_trial(agents: int, seed_index: int):
    """Fig. 3's cr50 trial with ``agents`` agents and the given seed index."""
    trials = [t for t in load_spec(find_spec("papaioannou_fig3")).trials_list()
              if t.method == "cr50" and t.robots == agents]
    return trials[seed_index]


def run_trial(agents: int, seed_index: int) -> tuple[float, float, int]:
    """CPU seconds of the engine's steps and of the scoring; steps."""
    sc = fig3_trial(agents, seed_index).scenario
    engine_s, score_s = time_trial(sc)
    return engine_s, score_s, sc.steps


def reward_timings(repeats: int) -> list[dict[str, object]]:
    """The 17-move Rényi evaluation's cost for a few particle and estimate counts."""
    sc = fig3_trial(5, 0).scenario
    part = registry.lookup("controller", "sat_search_track")
    setup = part.setup(sc, sc.system)
    rng = np.random.default_rng(0)
    agent = np.array([50.0, 50.0])
    positions, admissible = admissible_positions(agent, setup.offsets, setup.bounds)
    rows = []
    for n, k in ((300, 1), (1200, 2), (6000, 4)):
        estimates = agent + rng.uniform(-4.0, 4.0, (k, 2))
        centre = estimates[rng.integers(k, size=n)]
        states = np.concatenate([centre + rng.normal(0.0, 1.0, (n, 2)),
                                 rng.normal(0.0, 1.0, (n, 2))], axis=1)
        weights = np.full(n, k / n)
        setup.tracking.choose(states, weights, estimates, positions, admissible)   # warm
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            setup.tracking.choose(states, weights, estimates, positions, admissible)
            times.append(time.perf_counter() - t0)
        ms = 1000.0 * float(np.median(times))
        rows.append({"case": f"Rényi reward, 17 moves, {n} particles, {k} estimates",
                     "particles": n, "estimates": k, "moves": len(positions),
                     "median_ms": round(ms, 3),
                     "ns_per_move_particle": round(1e6 * ms / (n * len(positions)), 1)})
    return rows


def main() -> None:
    """Time the trial, the reward and the ROS run, print the figures and write them."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="one trial, fewer reward repeats")
    p.add_argument("--repeats", type=int, default=3, help="trials (different seeds)")
    p.add_argument("--no-ros", action="store_true", help="skip the ROS run")
    p.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results")
    args = p.parse_args()
    n = 1 if args.quick else args.repeats
    runs = [run_trial(5, i) for i in range(n)]
    engine_s = [r[0] for r in runs]
    total_s = [r[0] + r[1] for r in runs]
    trial = {"case": "Fig. 3 trial, 5 agents, 10 targets, 100 steps, in memory",
             "trials": n, "steps": runs[0][2],
             "engine_cpu_s_median": round(float(np.median(engine_s)), 2),
             "trial_cpu_s_median": round(float(np.median(total_s)), 2),
             "trial_cpu_s_max": round(float(np.max(total_s)), 2), "target_s": 5.0}
    print(f"Fig. 3 trial (5 agents, 100 steps), {n} seeds: engine "
          f"{trial['engine_cpu_s_median']:.2f} s, with scoring {trial['trial_cpu_s_median']:.2f}"
          f" s CPU (median; max {trial['trial_cpu_s_max']:.2f} s; target <= 5 s)")
    rewards = reward_timings(20 if args.quick else 200)
    for r in rewards:
        print(f"{r['case']}: {r['median_ms']:.3f} ms, {r['ns_per_move_particle']:.1f} ns per "
              f"move x particle")
    results: list[dict[str, object]] = [trial, *rewards]
    if not args.no_ros:
        ros = run_swarm_figures(ROOT / "config" / "papaioannou_small.yaml")
        print(f"ROS nodes (papaioannou_small, lockstep, recorded): {ros['steps']} steps, "
              f"{ros['real_time_factor']}x real time, "
              f"{ros['messages_per_robot_per_step']:.4f} messages per agent per step; "
              f"CPU s {ros['cpu_s']}")
        results.append(ros)
    write_results(args.out, "papaioannou", machine_meta(), results)


if __name__ == "__main__":
    main()
