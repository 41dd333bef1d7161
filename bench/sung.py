"""Sung & Tokekar benchmark: a whole 7,278-step trial in the in-memory engine, and the GP.

Run with ``scripts/bench.sh sung [--quick] [--repeats 3]``. Measures, on the distributed
engine (the only one for this system), CPU seconds of this process for one full trial of
``config/sweeps/sung_false_positives.yaml`` (lawn-mower, 10 % false positives, exact
belief, seed 0), of its moving-target twin with GP prediction
(``sung_moving.yaml``, method ``gp``), and of the per-step scoring the sweeps add (OSPA,
tracks, Mahalanobis distances). Then the GP prediction alone
(:func:`phd_swarm.core.estimators.sung.gp_motion.predict_tracks`) per confirmed track per step,
for 1, 10 and 50 tracks at the 100-point window of ``config/sung_moving.yaml``. Last, the
system as ROS nodes: ``run_swarm.sh config/sung_static.yaml --robots 1`` in lockstep
(world, monitor, recorder and the robot, one process each), its real-time factor while
stepping and the CPU of each process. The issue's targets: a trial in <= 10 s, the GP in
<= 1 ms per track per step, the ROS run >= 5x real time.

Writes ``bench/results/sung-<date>.json``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from results_io import machine_meta, run_swarm_figures, time_trial, write_results

from phd_swarm.config.sweep_spec import find_spec, load_spec
from phd_swarm.core.estimators.sung.gp_motion import GpHyperparameters, predict_tracks


def _trial(spec: str, method: str, steps: int | None):
    trial = next(t for t in load_spec(find_spec(spec)).trials_list()
                 if t.method == method and t.index == 0)
    sc = trial.scenario
    if steps is not None:
        sc = sc.with_overrides(duration=steps * sc.dt)
    return sc


def run_trial(sc, score: bool) -> tuple[float, float]:
    """CPU seconds of the engine's steps, and of the scoring (0 unless ``score``)."""
    return time_trial(sc, score)


def gp_cost(tracks: int, window: int, repeats: int = 200) -> float:
    """CPU milliseconds per track per step of the GP prediction on straight noisy tracks."""
    rng = np.random.default_rng(0)
    hp = GpHyperparameters(16.67, 472.0, 1.0, window)
    hist = [(np.arange(window, dtype=float),
             rng.uniform(0, 150, 2) + np.outer(np.arange(window), rng.normal(0, 0.05, 2))
             + rng.normal(0, 0.3, (window, 2))) for _ in range(tracks)]
    k = np.full(tracks, float(window))
    predict_tracks(hist, k, hp)
    t0 = time.process_time()
    for _ in range(repeats):
        predict_tracks(hist, k, hp)
    return 1000.0 * (time.process_time() - t0) / repeats / tracks


ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    """Time the two trials and the GP, print the figures and write them."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="600-step trials, one repeat")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results")
    args = p.parse_args()
    steps = 600 if args.quick else None
    repeats = 1 if args.quick else args.repeats
    results = []
    for label, spec, method in (("static, lawn-mower, 10 % false positives",
                                 "sung_false_positives", "fp10"),
                                ("moving targets, GP prediction", "sung_moving", "gp")):
        sc = _trial(spec, method, steps)
        runs = [run_trial(sc, score=(i == 0)) for i in range(repeats)]
        engine_s = float(np.median([r[0] for r in runs]))
        row = {"case": label, "steps": sc.steps, "engine_cpu_s": round(engine_s, 2),
               "engine_cpu_s_runs": [round(r[0], 2) for r in runs],
               "ms_per_step": round(1000 * engine_s / sc.steps, 3),
               "scoring_cpu_s": round(runs[0][1], 2)}
        results.append(row)
        print(f"{label}: {sc.steps} steps in {engine_s:.2f} s CPU (median of {repeats}; "
              f"{row['ms_per_step']} ms/step), scoring {row['scoring_cpu_s']} s")
    gp = {f"{n} tracks": round(gp_cost(n, 100), 4) for n in (1, 10, 50)}
    results.append({"case": "GP prediction, window 100, ms per track per step", **gp})
    print("GP prediction, window 100 [ms per track per step]: "
          + ", ".join(f"{k}: {v}" for k, v in gp.items()))
    ros = run_swarm_figures(ROOT / "config" / "sung_static.yaml", "--robots", "1",
                            *(["--duration", str(float(steps))] if steps else []))
    results.append(ros)
    print(f"ROS nodes (lockstep, recorded): {ros['steps']} steps in {ros['stepping_wall_s']} s "
          f"wall, {ros['real_time_factor']}x real time; CPU s per process {ros['cpu_s']}")
    write_results(args.out, "sung", machine_meta(), results)


if __name__ == "__main__":
    main()
