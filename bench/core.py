"""Core benchmark (issue 3): centralised team step, partitions, OSPA.

Run with ``scripts/bench.sh core``. Prints a table and writes the figures as JSON to
``bench/results/core-<date>.json``. Cases:

- team step: ``CentralPhdFilter.predict()`` then the update with 100 sensors' measurement
  sets (simulated from 50 targets with the paper's sensor model), 100 x 100 m map, at 1 m and
  at 0.1 m, for the Dames moving-target models (5x5 / 41x41 kernels) and Chen's (29x29 at
  0.1 m);
- partition + ownership for 100 robots: cells, neighbours and the owner of every bin;
- OSPA (c = 10, p = 1) between two sets of 50 points.

Figures are medians (and 90th percentiles) over repeated runs, in milliseconds.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from results_io import machine_meta, write_results

from phd_swarm.core.estimators.grid_phd.central import CentralPhdFilter
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.geometry.ownership import bin_owners
from phd_swarm.core.geometry.partition import partition
from phd_swarm.core.ospa import ospa
from phd_swarm.core.scan import Scan
from phd_swarm.core.sensors.disk import simulate_scan
from phd_swarm.sim.presets import PRESETS

ENV = Environment(0.0, 0.0, 100.0, 100.0)


def _timed(fn: Callable[[], object], repeats: int, warmup: int = 1) -> dict[str, float]:
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1e3)
    arr = np.array(times)
    return {"median_ms": float(np.median(arr)), "p90_ms": float(np.percentile(arr, 90)),
            "repeats": repeats}


def bench_team_step(resolution: float, preset: str, repeats: int) -> dict[str, object]:
    """Centralised predict + 100 sequential updates on a 100 x 100 m map."""
    rng = np.random.default_rng(7)
    models = PRESETS[preset]().models
    filt = CentralPhdFilter(Grid(ENV, resolution), models)
    targets = rng.uniform(0.0, 100.0, (50, 2))
    sensors = [rng.uniform(0.0, 100.0, (100, 2)) for _ in range(repeats + 1)]
    batches = [[Scan(robot_id=r, step=k, sensor=q, z=simulate_scan(rng, models, q, targets))
                for r, q in enumerate(qs)] for k, qs in enumerate(sensors)]
    it = iter(batches)
    stats = _timed(lambda: filt.step(next(it)), repeats)
    n_meas = float(np.mean([len(s.z) for b in batches for s in b]))
    return {"case": f"team step {preset} {resolution} m", "resolution_m": resolution,
            "preset": preset, "kernel": list(filt.kernel.shape), "sensors": 100,
            "mean_measurements_per_scan": n_meas, **stats}


def bench_partition(resolution: float, repeats: int) -> dict[str, object]:
    """Cells, neighbours and bin ownership for 100 robots."""
    rng = np.random.default_rng(3)
    grid = Grid(ENV, resolution)
    configs = [rng.uniform(0.0, 100.0, (100, 2)) for _ in range(repeats + 1)]
    it = iter(configs)

    def run() -> None:
        q = next(it)
        partition(ENV, q)
        bin_owners(grid, q)

    return {"case": f"partition + ownership 100 robots, {resolution} m bins",
            "resolution_m": resolution, "robots": 100, **_timed(run, repeats)}


def bench_ospa(repeats: int) -> dict[str, object]:
    """OSPA between two random 50-point sets."""
    rng = np.random.default_rng(11)
    pairs = [(rng.uniform(0, 100, (50, 2)), rng.uniform(0, 100, (50, 2)))
             for _ in range(repeats + 1)]
    it = iter(pairs)
    return {"case": "OSPA 50 x 50 points (c=10, p=1)",
            **_timed(lambda: ospa(*next(it), c=10.0, p=1.0), repeats)}


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark, print the table and write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (smoke run)")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args(argv)
    n = 3 if args.quick else 20
    results = [
        bench_team_step(1.0, "dames_moving", n),
        bench_team_step(0.1, "dames_moving", max(3, n // 2)),
        bench_team_step(0.1, "chen_clustered", max(3, n // 2)),
        bench_partition(1.0, n),
        bench_partition(0.1, max(3, n // 4)),
        bench_ospa(n * 10),
    ]
    meta = machine_meta()
    print(f"core benchmark {meta['date']} ({meta['cpus']} cpus, {meta['machine']})")
    print(f"{'case':<48} {'median ms':>10} {'p90 ms':>10}")
    for r in results:
        print(f"{r['case']:<48} {r['median_ms']:>10.2f} {r['p90_ms']:>10.2f}")
    write_results(args.out, "core", meta, results)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
